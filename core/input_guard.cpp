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

// PLY: each element's count against the bytes after the header (ASCII: at least 2 a value; binary: the
// exact size of its scalar properties plus each list's count).
void checkPly(const std::string& path, std::string_view b) {
  const size_t end = b.find("end_header");
  // Without it assimp's PLY reader reads past the end of the file forever.
  if (end == std::string_view::npos) refuse(path, "the PLY header has no end_header line", "re-export it");
  const size_t bodyAt = b.find('\n', end);
  const size_t body = bodyAt == std::string_view::npos ? 0 : b.size() - bodyAt - 1;
  bool ascii = true;
  struct Element {
    std::string name;
    uint64_t count = 0;
    uint64_t bytes = 0;  // per element, at least
  };
  std::vector<Element> elements;
  auto size = [](std::string_view type) -> uint64_t {
    if (type == "char" || type == "uchar" || type == "int8" || type == "uint8") return 1;
    if (type == "short" || type == "ushort" || type == "int16" || type == "uint16") return 2;
    if (type == "double" || type == "float64") return 8;
    return 4;
  };
  checkNumberLengths(path, b.substr(0, end));
  for (std::string_view line : lines(b.substr(0, end))) {
    const auto w = words(line);
    if (w.empty()) continue;
    if (w[0] == "format" && w.size() > 1) ascii = w[1] == "ascii";
    if (w[0] == "element" && w.size() > 2) {
      uint64_t n = 0;
      if (!count(w[2], n))
        refuse(path, "PLY element " + quoteInput(w[1]) + " has count " + quoteInput(w[2]) + ", not a whole number below 10^19",
               "re-export it");
      elements.push_back({std::string(w[1]), n, 0});
    }
    if (w[0] == "property" && !elements.empty()) {
      Element& e = elements.back();
      if (ascii) e.bytes += 2;
      else if (w.size() > 2 && w[1] == "list") e.bytes += size(w[2]);
      else if (w.size() > 1) e.bytes += size(w[1]);
    }
  }
  long double needs = 0;
  for (const Element& e : elements) {
    needs += (long double)e.count * (long double)std::max<uint64_t>(e.bytes, 1);
    if (needs > (long double)body)
      tooMany(path, "PLY element " + quoteInput(e.name), e.count, needs, body);
  }
  if (ascii) checkNumberLengths(path, b);
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
  if (b.substr(0, 3) == "ply") return checkPly(path, b);
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
