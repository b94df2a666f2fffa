// The loaders' shared guards (input_guard.h): bounded reads of regular files, quoting input in messages,
// and the cheap scans that refuse what assimp would crash on, hang on or silently misread.
#include "core/input_guard.h"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cctype>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <limits>
#include <vector>

#include <glm/gtc/constants.hpp>

#include "core/error.h"

namespace cs {

namespace {

char printable(char c) {
  const auto u = static_cast<unsigned char>(c);
  return u >= 0x20 && u < 0x7f ? c : '?';
}

std::string lowerExtension(const std::string& path) {
  std::string e = std::filesystem::path(path).extension().string();
  std::transform(e.begin(), e.end(), e.begin(), [](unsigned char c) { return char(std::tolower(c)); });
  return e;
}

std::string shown(const std::string& path) { return quoteInput(path, 160); }

}  // namespace

std::string clipInput(std::string_view text, size_t max) {
  std::string out;
  for (size_t i = 0; i < text.size() && i < max; ++i) out += printable(text[i]);
  if (text.size() > max) out += "... (" + std::to_string(text.size()) + " characters)";
  return out;
}

std::string quoteInput(std::string_view text, size_t max) {
  std::string out = "'";
  for (size_t i = 0; i < text.size() && i < max; ++i) out += printable(text[i]);
  out += "'";
  if (text.size() > max) out += "... (" + std::to_string(text.size()) + " characters)";
  return out;
}

std::string oneLineClipped(std::string_view text, size_t max) {
  std::string out;
  bool lineBreak = false;
  for (char c : text) {
    if (c == '\n' || c == '\r') {
      lineBreak = true;
      continue;
    }
    if (lineBreak && !out.empty()) {
      while (!out.empty() && out.back() == ' ') out.pop_back();
      if (!out.empty() && out.back() != ';') out += ';';
      out += ' ';
    }
    lineBreak = false;
    if (c == ' ' && !out.empty() && out.back() == ' ') continue;
    out += c == '\t' ? ' ' : printable(c);
  }
  while (!out.empty() && (out.back() == ' ' || out.back() == ';')) out.pop_back();
  if (out.size() > max) out = out.substr(0, max - 3) + "...";
  return out;
}

std::string readSceneBytes(const std::string& path, const std::string& from, uint64_t maxBytes) {
  checkSceneInput(path, from);
  const std::string where = from.empty() ? path : from;
  const int fd = ::open(path.c_str(), O_RDONLY | O_NONBLOCK | O_CLOEXEC);
  if (fd < 0) {
    const int e = errno;
    throw Error("cannot read " + shown(path) + ": " + std::strerror(e), where,
                e == EACCES ? "check its permissions" : "check the file");
  }
  struct Closer {
    int fd;
    ~Closer() { ::close(fd); }
  } closer{fd};
  struct stat st {};
  if (::fstat(fd, &st) != 0 || !S_ISREG(st.st_mode))
    throw Error(shown(path) + " is not a regular file", where, "give the scene file itself");
  const uint64_t size = uint64_t(st.st_size);
  if (size > maxBytes)
    throw Error(shown(path) + " is " + std::to_string(size) + " bytes, over the " + std::to_string(maxBytes) +
                    " this load may read",
                where, "split the scene or decimate it");
  std::string out(size, '\0');
  size_t got = 0;
  while (got < size) {
    const ssize_t n = ::read(fd, out.data() + got, size - got);
    if (n < 0 && errno == EINTR) continue;
    if (n < 0) throw Error("cannot read " + shown(path) + ": " + std::strerror(errno), where, "check the file");
    if (n == 0) throw Error(shown(path) + " ended before its size of " + std::to_string(size) + " bytes (it changed while read)", where);
    got += size_t(n);
  }
  // /proc and /sys files say 0 bytes and read more: not scene files.
  char extra;
  ssize_t n;
  do n = ::read(fd, &extra, 1);
  while (n < 0 && errno == EINTR);
  if (n < 0) throw Error("cannot read " + shown(path) + ": " + std::strerror(errno), where, "check the file");
  if (n != 0)
    throw Error(shown(path) + " reads more than its size of " + std::to_string(size) +
                    " bytes (a system or special file, not a scene)",
                where, "give a scene file");
  return out;
}

// ---- XML nesting ------------------------------------------------------------------------------------

size_t xmlDepth(std::string_view t, size_t limit) {
  size_t depth = 0, deepest = 0;
  size_t i = 0;
  auto skipPast = [&](std::string_view end) {
    const size_t at = t.find(end, i);
    i = at == std::string_view::npos ? t.size() : at + end.size();
  };
  while (i < t.size()) {
    const size_t lt = t.find('<', i);
    if (lt == std::string_view::npos) break;
    i = lt + 1;
    if (t.substr(lt, 4) == "<!--") {
      skipPast("-->");
    } else if (t.substr(lt, 9) == "<![CDATA[") {
      skipPast("]]>");
    } else if (i < t.size() && (t[i] == '?' || t[i] == '!')) {
      skipPast(">");
    } else if (i < t.size() && t[i] == '/') {
      if (depth > 0) --depth;
      skipPast(">");
    } else {
      // An element's start tag: quoted attribute values may hold '>'.
      char quote = 0;
      bool selfClosing = false;
      for (; i < t.size(); ++i) {
        const char c = t[i];
        if (quote) {
          if (c == quote) quote = 0;
        } else if (c == '"' || c == '\'') {
          quote = c;
        } else if (c == '>') {
          selfClosing = i > lt + 1 && t[i - 1] == '/';
          ++i;
          break;
        }
      }
      if (!selfClosing) {
        deepest = std::max(deepest, ++depth);
        if (deepest > limit) return deepest;
      }
    }
  }
  return deepest;
}

namespace {

// ---- the scans before assimp ------------------------------------------------------------------------

[[noreturn]] void refuse(const std::string& path, const std::string& what, const std::string& hint) {
  throw Error(what, path, hint);
}

bool looksText(std::string_view b) {
  return std::find(b.begin(), b.begin() + std::min<size_t>(b.size(), 4096), '\0') == b.begin() + std::min<size_t>(b.size(), 4096);
}

void checkNumberLengths(const std::string& path, std::string_view text) {
  size_t run = 0;
  for (size_t i = 0; i < text.size(); ++i) {
    const char c = text[i];
    if ((c >= '0' && c <= '9') || c == '.') {
      if (++run > kMaxNumberDigits)
        refuse(path,
               "a number at byte " + std::to_string(i + 1 - run) + " has more than " + std::to_string(kMaxNumberDigits) +
                   " digits (it would be read as a wrong value)",
               "write coordinates with at most 17 significant digits");
    } else {
      run = 0;
    }
  }
}

// Lines of `text` split at '\n' (a '\r' before it dropped).
std::vector<std::string_view> lines(std::string_view text, size_t maxLines = std::numeric_limits<size_t>::max()) {
  std::vector<std::string_view> out;
  size_t at = 0;
  while (at < text.size() && out.size() < maxLines) {
    size_t end = text.find('\n', at);
    if (end == std::string_view::npos) end = text.size();
    std::string_view line = text.substr(at, end - at);
    if (!line.empty() && line.back() == '\r') line.remove_suffix(1);
    out.push_back(line);
    at = end + 1;
  }
  return out;
}

std::vector<std::string_view> words(std::string_view line) {
  std::vector<std::string_view> out;
  size_t i = 0;
  while (i < line.size()) {
    while (i < line.size() && std::isspace(static_cast<unsigned char>(line[i]))) ++i;
    size_t j = i;
    while (j < line.size() && !std::isspace(static_cast<unsigned char>(line[j]))) ++j;
    if (j > i) out.push_back(line.substr(i, j - i));
    i = j;
  }
  return out;
}

// A whole number of at most 20 digits, or nothing.
bool count(std::string_view w, uint64_t& v) {
  if (w.empty() || w.size() > 19) return false;
  v = 0;
  for (char c : w) {
    if (c < '0' || c > '9') return false;
    v = v * 10 + uint64_t(c - '0');
  }
  return true;
}

[[noreturn]] void tooMany(const std::string& path, const std::string& what, uint64_t claimed, long double needs,
                          size_t bytes) {
  refuse(path,
         what + " claims " + std::to_string(claimed) + " elements, which need at least " +
             std::to_string(uint64_t(std::min<long double>(needs, 1e19L))) + " bytes; the file has " +
             std::to_string(bytes),
         "the header is wrong or the file is cut short; re-export it");
}

// PLY, as assimp 5.2.5 reads it (code/AssetLib/Ply). The header must be lines of text (LF or CRLF, no
// empty lines, no other control bytes) whose second line names a known format, with every property of an
// element right below its element line: assimp ends an element's properties at the first other line and
// then drops the properties after it (and a comment there makes it parse stale bytes as a property), so the
// data would be read at the wrong offsets. Types must be ones assimp knows (an unknown one ends the
// properties the same way) and a list's count type an integer. Then the data is walked element by element:
// each element's count against the bytes that could hold it; every list count non-negative and within the
// data (assimp allocates what it claims); every face with at least one vertex index (assimp makes a face of
// none, which its triangulation aborts the process on) and as many as its texcoord list needs (assimp reads
// the indices at half the texcoord positions); a binary body exactly as long as its elements, an ASCII one
// an element a line. At most one vertex and one face element (assimp sizes its arrays by the first and
// writes the second past them), and no tristrips (assimp keeps one triangle of each strip, leaves the other
// faces empty and aborts on them).
struct PlyType {
  uint8_t bytes = 0;  // 0: unknown
  bool isInteger = false, isSigned = false;
};

PlyType plyType(std::string_view t) {
  if (t == "char" || t == "int8") return {1, true, true};
  if (t == "uchar" || t == "uint8") return {1, true, false};
  if (t == "short" || t == "int16") return {2, true, true};
  if (t == "ushort" || t == "uint16") return {2, true, false};
  if (t == "int" || t == "int32") return {4, true, true};
  if (t == "uint" || t == "uint32") return {4, true, false};
  if (t == "float" || t == "float32") return {4, false, false};
  if (t == "double" || t == "float64" || t == "double64") return {8, false, false};
  return {};
}

struct PlyProperty {
  std::string name;
  bool list = false;
  PlyType countType, type;
};

struct PlyElement {
  std::string name;
  uint64_t count = 0;
  std::vector<PlyProperty> properties;
  int vertexIndices = -1, texcoords = -1;  // the list properties assimp reads a face's from (the last)
  uint64_t minBytes() const {  // one instance, its lists empty (binary) or a value each (ASCII: 2 bytes)
    uint64_t n = 0;
    for (const PlyProperty& p : properties) n += p.list ? p.countType.bytes : p.type.bytes;
    return n;
  }
};

void checkPly(const std::string& path, std::string_view b) {
  const char* const fix = "re-export it";
  // The header's lines, each with where it starts.
  std::vector<std::pair<std::string_view, size_t>> header;
  size_t bodyAt = std::string_view::npos;
  for (size_t at = 0; at < b.size();) {
    size_t end = at;
    while (end < b.size() && b[end] != '\n') {
      const auto c = static_cast<unsigned char>(b[end]);
      if ((c < 0x20 && c != '\t' && !(c == '\r' && end + 1 < b.size() && b[end + 1] == '\n')))
        refuse(path, "the PLY header has a control byte (" + std::to_string(int(c)) + ") at byte " + std::to_string(end),
               "a PLY header is lines of text; re-export it");
      ++end;
    }
    std::string_view line = b.substr(at, end - at);
    if (!line.empty() && line.back() == '\r') line.remove_suffix(1);
    const auto w = words(line);
    if (w.empty())
      refuse(path, "the PLY header has an empty line at byte " + std::to_string(at), "assimp misreads the header after it; " + std::string(fix));
    header.emplace_back(line, at);
    if (w[0] == "end_header") {
      bodyAt = std::min(end + 1, b.size());
      break;
    }
    at = end + 1;
  }
  // Without it assimp's PLY reader reads past the end of the file forever.
  if (bodyAt == std::string_view::npos) refuse(path, "the PLY header has no end_header line", fix);
  checkNumberLengths(path, b.substr(0, bodyAt));
  if (header.size() < 2 || words(header[1].first)[0] != "format" || words(header[1].first).size() < 2)
    refuse(path, "the PLY header's second line is not its format line", fix);
  const std::string_view format = words(header[1].first)[1];
  const bool ascii = format == "ascii";
  const bool bigEndian = format == "binary_big_endian";
  if (!ascii && !bigEndian && format != "binary_little_endian")
    refuse(path, "the PLY format " + quoteInput(format) + " is not ascii, binary_little_endian or binary_big_endian", fix);

  std::vector<PlyElement> elements;
  bool inProperties = false;  // the line before was an element or property line
  int vertexElements = 0, faceElements = 0;
  for (size_t i = 2; i + 1 < header.size(); ++i) {
    const auto w = words(header[i].first);
    const std::string where = " (header line " + std::to_string(i + 1) + ")";
    if (w[0] == "element") {
      uint64_t n = 0;
      if (w.size() != 3) refuse(path, "a PLY element line is not 'element NAME COUNT'" + where, fix);
      if (!count(w[2], n) || n > std::numeric_limits<uint32_t>::max())
        refuse(path, "PLY element " + quoteInput(w[1]) + " has count " + quoteInput(w[2]) + ", not a whole number below 2^32",
               fix);
      if (w[1] == "tristrips")
        refuse(path, "PLY element 'tristrips': assimp 5.2.5 reads one triangle of each strip and aborts on the rest",
               "write the triangles as an element 'face'");
      if (w[1] == "vertex" && ++vertexElements > 1)
        refuse(path, "the PLY header has a second element 'vertex'" + where + " (assimp writes it past the first one's)", fix);
      if (w[1] == "face" && ++faceElements > 1)
        refuse(path, "the PLY header has a second element 'face'" + where + " (assimp writes it past the first one's)", fix);
      elements.push_back({std::string(w[1]), n, {}});
      inProperties = true;
    } else if (w[0] == "property") {
      if (!inProperties)
        refuse(path,
               "a PLY property line is not right below its element line or another property" + where +
                   " (assimp drops it and misreads the data)",
               "keep an element's properties together, comments above the first element; " + std::string(fix));
      PlyProperty p;
      const bool list = w.size() > 1 && w[1] == "list";
      if (w.size() != (list ? 5u : 3u))
        refuse(path, "a PLY property line is not 'property TYPE NAME' or 'property list COUNTTYPE TYPE NAME'" + where, fix);
      p.list = list;
      p.name = std::string(w.back());
      p.type = plyType(w[list ? 3 : 1]);
      if (list) p.countType = plyType(w[2]);
      for (const std::string_view t : list ? std::vector{w[2], w[3]} : std::vector{w[1]})
        if (plyType(t).bytes == 0)
          refuse(path, "PLY property " + quoteInput(p.name) + " has the unknown type " + quoteInput(t) + where, fix);
      if (list && !p.countType.isInteger)
        refuse(path, "PLY list " + quoteInput(p.name) + " has a count of type " + quoteInput(w[2]) + ", not an integer type", fix);
      PlyElement& e = elements.back();
      if (e.name == "face" && list && (p.name == "vertex_indices" || p.name == "vertex_index"))
        e.vertexIndices = int(e.properties.size());
      if (e.name == "face" && list && p.name == "texcoord") e.texcoords = int(e.properties.size());
      e.properties.push_back(std::move(p));
    } else {
      // comment, obj_info and lines assimp does not know: it ignores them, but between properties they end the
      // element's (and a comment there makes it parse stale bytes), so none after the first element.
      if (!elements.empty())
        refuse(path, "the PLY header has " + quoteInput(w[0]) + " after an element" + where +
                         " (assimp misreads the properties around it)",
               "move comments above the first element line; " + std::string(fix));
      inProperties = false;
    }
  }
  for (const PlyElement& e : elements)
    if (e.name == "face" && e.count > 0 && e.vertexIndices < 0)
      refuse(path, "PLY element 'face' has no list property 'vertex_indices'", fix);

  // Counts against the bytes (ASCII: at least 2 a value).
  const size_t body = bodyAt <= b.size() ? b.size() - bodyAt : 0;
  long double needs = 0;
  for (const PlyElement& e : elements) {
    const uint64_t each = ascii ? 2 * e.properties.size() : e.minBytes();
    needs += (long double)e.count * (long double)std::max<uint64_t>(each, 1);
    if (needs > (long double)body) tooMany(path, "PLY element " + quoteInput(e.name), e.count, needs, body);
  }
  if (ascii) checkNumberLengths(path, b);

  // A face's vertex index and texcoord list counts: at least one index, and more than half the last texcoord
  // position assimp reads when it reads them (6 to 8 texcoords).
  auto checkFace = [&](uint64_t face, uint64_t indices, uint64_t texcoords) {
    if (indices == 0)
      refuse(path, "PLY face " + std::to_string(face) + " has no vertex indices (assimp 5.2.5 aborts on it)", fix);
    if (texcoords >= 6 && texcoords <= 8 && indices <= (texcoords - 1) / 2)
      refuse(path,
             "PLY face " + std::to_string(face) + " has " + std::to_string(texcoords) + " texcoords for " +
                 std::to_string(indices) + " vertex indices (assimp reads past them)",
             fix);
  };
  auto listTooLong = [&](const PlyElement& e, uint64_t i, const PlyProperty& p, const std::string& n, const std::string& room) {
    refuse(path,
           "PLY " + quoteInput(e.name) + " " + std::to_string(i) + " has a list " + quoteInput(p.name) + " of " + n +
               " values, " + room,
           fix);
  };

  if (!ascii) {
    // assimp drops one '\n' right after the end_header line's (for CRLF headers).
    size_t at = bodyAt < b.size() && b[bodyAt] == '\n' ? bodyAt + 1 : bodyAt;
    auto read = [&](const PlyType& t) -> int64_t {
      uint64_t v = 0;
      for (unsigned k = 0; k < t.bytes; ++k) {
        const uint64_t byte = static_cast<unsigned char>(b[at + (bigEndian ? t.bytes - 1 - k : k)]);
        v |= byte << (8 * k);
      }
      at += t.bytes;
      if (t.isSigned && t.bytes < 8 && (v >> (8 * t.bytes - 1)) & 1) return int64_t(v) - (int64_t(1) << (8 * t.bytes));
      return int64_t(v);
    };
    for (const PlyElement& e : elements) {
      if (e.count > 0 && e.properties.empty())
        refuse(path, "PLY element " + quoteInput(e.name) + " has " + std::to_string(e.count) + " instances and no properties",
               fix);
      for (uint64_t i = 0; i < e.count; ++i) {
        uint64_t indices = 0, texcoords = 0;
        for (size_t k = 0; k < e.properties.size(); ++k) {
          const PlyProperty& p = e.properties[k];
          if (b.size() - at < (p.list ? p.countType.bytes : p.type.bytes))
            refuse(path, "the binary PLY data ends inside " + quoteInput(e.name) + " " + std::to_string(i) + " of " +
                             std::to_string(e.count),
                   "the file is cut short or its header is wrong; " + std::string(fix));
          if (!p.list) {
            at += p.type.bytes;
            continue;
          }
          const int64_t n = read(p.countType);
          if (n < 0) listTooLong(e, i, p, std::to_string(n), "a negative count");
          if (uint64_t(n) * p.type.bytes > b.size() - at)
            listTooLong(e, i, p, std::to_string(n), "more than the " + std::to_string(b.size() - at) + " bytes left hold");
          at += uint64_t(n) * p.type.bytes;
          if (int(k) == e.vertexIndices) indices = uint64_t(n);
          if (int(k) == e.texcoords) texcoords = uint64_t(n);
        }
        if (e.name == "face") checkFace(i, indices, texcoords);
      }
    }
    if (at != b.size())
      refuse(path,
             "the binary PLY data is " + std::to_string(b.size() - bodyAt) + " bytes, but its elements take " +
                 std::to_string(at - bodyAt),
             "the header does not describe the data; " + std::string(fix));
    return;
  }

  // ASCII: an instance a line (assimp reads one a line and an empty line as an instance of default values),
  // its values separated by blanks, each list's count a whole number with that many values after it.
  size_t at = bodyAt;
  for (const PlyElement& e : elements) {
    for (uint64_t i = 0; i < e.count; ++i) {
      if (at >= b.size())
        refuse(path, "the PLY data ends before " + quoteInput(e.name) + " " + std::to_string(i) + " of " + std::to_string(e.count),
               "the file is cut short or its header is wrong; " + std::string(fix));
      size_t end = b.find('\n', at);
      if (end == std::string_view::npos) end = b.size();
      std::string_view line = b.substr(at, end - at);
      if (!line.empty() && line.back() == '\r') line.remove_suffix(1);
      for (const char c : line)
        if (static_cast<unsigned char>(c) < 0x20 && c != '\t')
          refuse(path, "the PLY data has a control byte (" + std::to_string(int(c)) + ") in " + quoteInput(e.name) + " " +
                           std::to_string(i), fix);
      const auto w = words(line);
      if (w.empty())
        refuse(path, "the PLY data has an empty line where " + quoteInput(e.name) + " " + std::to_string(i) + " should be",
               "one line an element; " + std::string(fix));
      size_t next = 0;
      uint64_t indices = 0, texcoords = 0;
      for (size_t k = 0; k < e.properties.size(); ++k) {
        const PlyProperty& p = e.properties[k];
        if (!p.list) {
          ++next;
          continue;
        }
        uint64_t n = 0;
        if (next >= w.size())
          refuse(path, "PLY " + quoteInput(e.name) + " " + std::to_string(i) + " has no count for its list " + quoteInput(p.name),
                 fix);
        if (!count(w[next], n)) listTooLong(e, i, p, quoteInput(w[next]), "not a whole number");
        ++next;
        if (n > w.size() - std::min(next, w.size()))
          listTooLong(e, i, p, std::to_string(n), "more than its line holds");
        next += n;
        if (int(k) == e.vertexIndices) indices = n;
        if (int(k) == e.texcoords) texcoords = n;
      }
      if (next > w.size())
        refuse(path, "PLY " + quoteInput(e.name) + " " + std::to_string(i) + " has " + std::to_string(w.size()) +
                         " values, fewer than its " + std::to_string(next) + " properties", fix);
      if (e.name == "face") checkFace(i, indices, texcoords);
      at = end + 1;
    }
  }
}

// OFF: the counts against the file (a vertex needs at least 6 bytes, a face 2), then every face's indices
// against the vertex count: assimp clamps one out of range to the last vertex and draws it.
void checkOff(const std::string& path, std::string_view b) {
  std::vector<std::vector<std::string_view>> rows;
  for (std::string_view line : lines(b)) {
    const size_t hash = line.find('#');
    if (hash != std::string_view::npos) line = line.substr(0, hash);
    auto w = words(line);
    if (!w.empty()) rows.push_back(std::move(w));
  }
  if (rows.empty()) return;
  std::vector<std::string_view> head = rows[0];
  size_t next = 1;
  if (!head.empty() && head[0].size() >= 3 && head[0].substr(head[0].size() - 3) == "OFF") head.erase(head.begin());
  if (head.empty()) {
    if (rows.size() < 2) return;
    head = rows[1];
    next = 2;
  }
  uint64_t nv = 0, nf = 0;
  if (head.size() < 2 || !count(head[0], nv) || !count(head[1], nf))
    refuse(path, "the OFF header's counts are not whole numbers", "re-export it");
  const long double needs = (long double)nv * 6 + (long double)nf * 2;
  if (needs > (long double)b.size()) tooMany(path, "the OFF header", nv + nf, needs, b.size());
  if (rows.size() < next + nv) return;  // assimp reports the file cut short
  for (uint64_t f = 0; f < nf && next + nv + f < rows.size(); ++f) {
    const auto& row = rows[next + nv + f];
    uint64_t k = 0;
    if (!count(row[0], k)) continue;
    for (uint64_t i = 1; i <= k && i < row.size(); ++i) {
      uint64_t index = 0;
      if (count(row[i], index) && index >= nv)
        refuse(path,
               "OFF face " + std::to_string(f) + " names vertex " + std::to_string(index) + " of " + std::to_string(nv),
               "every index must name a vertex; re-export it");
    }
  }
}

// Binary STL: 84 bytes of header and count, 50 a triangle, exactly. assimp compares the sizes in 32 bits,
// so a count of 2^31 + 1 passes for a one-triangle file and allocates 2^31 triangles.
void checkStl(const std::string& path, std::string_view b) {
  if (b.size() < 84) return;
  uint32_t n;
  std::memcpy(&n, b.data() + 80, 4);
  const uint64_t exact = 84 + 50 * uint64_t(n);
  if (exact != b.size() && uint32_t(exact) == uint32_t(b.size()))
    tooMany(path, "the binary STL header", n, (long double)exact, b.size());
  if (b.substr(0, 5) == "solid" && exact != b.size() && looksText(b)) checkNumberLengths(path, b);
}

// Collada (and any XML): nesting, and every count="N" (times its stride="S") against the file's bytes at 2
// a value: the parser reserves what the attribute claims.
void checkXml(const std::string& path, std::string_view b) {
  if (xmlDepth(b, kMaxXmlDepth) > kMaxXmlDepth)
    refuse(path, "the XML nests more than " + std::to_string(kMaxXmlDepth) + " elements deep",
           "a scene needs a few dozen levels; flatten the node hierarchy");
  checkNumberLengths(path, b);
  size_t at = 0;
  while ((at = b.find("count=", at)) != std::string_view::npos) {
    const size_t tagStart = b.rfind('<', at);
    const size_t tagEnd = b.find('>', at);
    at += 6;
    if (at >= b.size() || (b[at] != '"' && b[at] != '\'')) continue;
    const size_t close = b.find(b[at], at + 1);
    if (close == std::string_view::npos) break;
    uint64_t n = 0;
    const std::string_view value = b.substr(at + 1, close - at - 1);
    if (!count(value, n)) {
      if (!value.empty() && value[0] != '-' && std::all_of(value.begin(), value.end(), [](char c) { return c >= '0' && c <= '9'; }))
        tooMany(path, "a count attribute", std::numeric_limits<uint64_t>::max(), 1e19L, b.size());
      continue;
    }
    uint64_t stride = 1;
    if (tagStart != std::string_view::npos && tagEnd != std::string_view::npos) {
      const std::string_view tag = b.substr(tagStart, tagEnd - tagStart);
      const size_t s = tag.find("stride=\"");
      if (s != std::string_view::npos) {
        const size_t q = tag.find('"', s + 8);
        uint64_t v = 0;
        if (q != std::string_view::npos && count(tag.substr(s + 8, q - s - 8), v) && v > 0) stride = v;
      }
    }
    const long double needs = (long double)n * (long double)stride * 2;
    if (needs > (long double)b.size()) tooMany(path, "a count attribute", n, needs, b.size());
  }
}

}  // namespace

void checkAssimpInput(const std::string& path, std::string_view b) {
  const std::string ext = lowerExtension(path);
  if (b.size() >= 3 && std::tolower(static_cast<unsigned char>(b[0])) == 'p' &&
      std::tolower(static_cast<unsigned char>(b[1])) == 'l' && std::tolower(static_cast<unsigned char>(b[2])) == 'y')
    return checkPly(path, b);  // assimp takes any case
  if (ext == ".off") return checkOff(path, b);
  if (ext == ".stl") return checkStl(path, b);
  if (!looksText(b)) return;
  size_t first = 0;
  if (b.substr(0, 3) == "\xEF\xBB\xBF") first = 3;
  while (first < b.size() && std::isspace(static_cast<unsigned char>(b[first]))) ++first;
  if (first < b.size() && b[first] == '<') return checkXml(path, b);
  checkNumberLengths(path, b);
}

Error clippedError(const Error& e) {
  std::string what = e.what();
  const std::string prefix = e.where.empty() ? "" : e.where + ": ";
  const std::string suffix = e.hint.empty() ? "" : " (" + e.hint + ")";
  if (what.rfind(prefix, 0) == 0) what = what.substr(prefix.size());
  if (what.size() >= suffix.size() && what.compare(what.size() - suffix.size(), suffix.size(), suffix) == 0)
    what.resize(what.size() - suffix.size());
  const std::string where = oneLineClipped(e.where, 160), hint = oneLineClipped(e.hint, 400);  // hints are ours
  const size_t room = kMaxMessage > where.size() + hint.size() + 8 ? kMaxMessage - where.size() - hint.size() - 8 : 60;
  return Error(oneLineClipped(what, room), where, hint);
}

void checkFileCamera(const Camera& c, const std::string& file, const std::string& what, double reach) {
  auto finite = [](const glm::vec3& v) { return std::isfinite(v.x) && std::isfinite(v.y) && std::isfinite(v.z); };
  const char* fix = "fix the camera in the file, or choose another with --camera";
  if (!finite(c.eye)) throw Error(what + " has a position at infinity or not a number", file, fix);
  if (!finite(c.target) || c.target == c.eye)
    throw Error(what + " has no usable view direction (its target is not finite or is its position)", file, fix);
  if (!(c.yfov > 0 && c.yfov < glm::pi<float>()))
    throw Error(what + " has a field of view (yfov) of " + std::to_string(c.yfov) + " radians, outside (0, pi)", file, fix);
  if (!(c.znear > 0) || !std::isfinite(c.znear))
    throw Error(what + " has a near plane (znear) of " + std::to_string(c.znear) + ", not above 0 in float", file, fix);
  if (!(c.zfar > c.znear) || !std::isfinite(c.zfar))
    throw Error(what + " has a far plane (zfar) of " + std::to_string(c.zfar) + ", not beyond its near plane " +
                    std::to_string(c.znear),
                file, fix);
  const double far = std::min(double(c.zfar), reach);
  if (far / double(c.znear) > kMaxDepthRatio) {
    char ratio[32];
    std::snprintf(ratio, sizeof ratio, "%.3g", far / double(c.znear));
    throw Error(what + " has zfar / znear = " + ratio + (far < c.zfar ? " (zfar taken at the scene's far side)" : "") +
                    ", over the 1e7 at which depth precision drops samples",
                file, "raise znear");
  }
}

}  // namespace cs
