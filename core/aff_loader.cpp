// BART's AFF scene files (the animated extension of Eric Haines' NFF): the scenes paper 002 measured on
// (BART museum, robots, kitchen). Only what shadows need is kept: triangles, transforms, the view and the
// point lights; materials, background and texture names are read past. See scene.h for the semantics.
#include <algorithm>
#include <array>
#include <cmath>
#include <filesystem>
#include <map>
#include <memory>
#include <optional>

#include <glm/gtc/matrix_transform.hpp>
#include <glm/gtc/quaternion.hpp>

#include "core/error.h"
#include "core/input_guard.h"
#include "core/scene.h"

namespace cs {

namespace fs = std::filesystem;

namespace {

constexpr int kMaxIncludeDepth = 32;
// Over a whole load, includes repeat: a file including the next twice, 30 levels deep, asks for 2^30
// parses. BART's kitchen reads 187 files, 5.7 MB in all.
constexpr size_t kMaxFilesRead = 4096;
constexpr uint64_t kMaxBytesRead = 256ull << 20;
constexpr size_t kMaxBlockDepth = 256;  // nested { } blocks: BART nests a dozen
constexpr uint32_t kConeSegments = 16;  // sides of a tessellated cone or cylinder
constexpr uint32_t kSphereRings = 8;     // a sphere: kSphereRings x 2·kSphereRings quads

// ---- tokens -----------------------------------------------------------------------------------------

struct Token {
  std::string text;
  uint32_t line = 0;
};

// Whitespace-separated tokens; '%' (anywhere) and '#' (at the start of a token) start a comment to the
// end of its line.
std::vector<Token> tokenize(const std::string& text) {
  std::vector<Token> out;
  uint32_t line = 1;
  size_t i = 0;
  while (i < text.size()) {
    const char c = text[i];
    if (c == '\n') {
      ++line, ++i;
    } else if (c == '%' || c == '#') {
      while (i < text.size() && text[i] != '\n') ++i;
    } else if (std::isspace(static_cast<unsigned char>(c))) {
      ++i;
    } else {
      size_t j = i;
      while (j < text.size() && !std::isspace(static_cast<unsigned char>(text[j])) && text[j] != '%') ++j;
      out.push_back({text.substr(i, j - i), line});
      i = j;
    }
  }
  return out;
}

// ---- what a file describes, before it is placed in time --------------------------------------------

struct Tri {
  std::array<glm::dvec3, 3> p;
  std::array<glm::dvec3, 3> n;  // zero where the file gives none (flat normal then)
};

// A triangle whose vertices and normals are keyed in time (tpa): linear between the keys.
struct AnimTri {
  std::vector<double> times;
  std::vector<Tri> keys;
};

struct Group {
  enum class Kind { Root, Static, Animated } kind = Kind::Root;
  glm::dmat4 local{1.0};  // Static
  std::string track;      // Animated: the keyframes' name
  std::string where;      // file:line of the transform, for errors
  std::vector<Tri> tris;
  std::vector<AnimTri> animTris;
  std::vector<std::unique_ptr<Group>> children;
};

// One key of a track: time, value (rotation: axis x, y, z and angle in degrees) and the Kochanek-Bartels
// tension, continuity and bias.
struct Key {
  double time = 0;
  glm::dvec4 value{0};
  double tension = 0, continuity = 0, bias = 0;
};

struct Track {
  std::vector<Key> transl, rot, scale;
  std::string where;
};

struct Parsed {
  Group root;
  std::map<std::string, Track> tracks;
  bool hasView = false;
  Camera view;
  std::vector<PointLight> lights;
  bool hasRange = false;
  double start = 0, end = 0;
  uint64_t skipped = 0;  // polygons with fewer than 3 vertices
  uint64_t redefined = 0;                // keyframe blocks whose name was defined before
  std::vector<std::string> unordered;    // tracks whose keys were not in time order
};

// ---- the parser -------------------------------------------------------------------------------------

class Parser {
 public:
  explicit Parser(Parsed& out) : out_(out) {}

  void parseFile(const fs::path& path, Group& into, int depth, const std::string& from) {
    if (depth > kMaxIncludeDepth)
      throw Error("includes nest deeper than " + std::to_string(kMaxIncludeDepth) + " files (a cycle?)", from);
    checkSceneInput(path.string(), from);
    // A file that includes itself (directly or through others) is refused at its first repeat, not after
    // kMaxIncludeDepth copies of everything it holds (a 60 KB file would fill gigabytes).
    for (const fs::path& open : reading_) {
      std::error_code ec;
      if (fs::equivalent(open, path, ec))
        throw Error("an include cycle: '" + path.string() + "' includes itself", from, "remove the include");
    }
    if (root_.empty()) root_ = path.string();
    if (++filesRead_ > kMaxFilesRead)
      throw Error("the scene reads more than " + std::to_string(kMaxFilesRead) + " files through its includes", root_,
                  "an include fan-out? each include is read again every time it is named");
    const std::string text = readSceneBytes(path.string(), from);
    bytesRead_ += text.size();
    if (bytesRead_ > kMaxBytesRead)
      throw Error("the scene's files pass " + std::to_string(kMaxBytesRead >> 20) +
                      " MiB in all (includes counted each time they are named)",
                  root_, "an include fan-out? BART's kitchen reads 5.7 MB");
    File f{path, tokenize(text), 0};
    std::vector<Group*> stack{&into};
    reading_.push_back(path);
    while (f.pos < f.tokens.size()) statement(f, stack, depth);
    if (stack.size() != 1) throw Error("a '{' block is not closed by the end of the file", f.name() + ":" + std::to_string(f.tokens.back().line));
    reading_.pop_back();
  }

 private:
  struct File {
    fs::path path;
    std::vector<Token> tokens;
    size_t pos = 0;
    std::string name() const { return path.string(); }
  };

  Parsed& out_;
  size_t depth_ = 0;  // open blocks over all the files being read (includes nest inside blocks)
  std::vector<fs::path> reading_;  // the files being read, the outermost first
  size_t filesRead_ = 0;           // over the whole load, includes counted each time
  std::string root_;               // the scene file the load began with
  uint64_t bytesRead_ = 0;

  static std::string at(const File& f, const Token& t) { return f.name() + ":" + std::to_string(t.line); }
  static std::string at(const File& f) {
    return f.name() + ":" + std::to_string(f.tokens.empty() ? 0 : f.tokens[std::min(f.pos, f.tokens.size() - 1)].line);
  }

  const Token& next(File& f, const char* what) {
    if (f.pos >= f.tokens.size()) throw Error(std::string("the file ends where ") + what + " was expected", at(f));
    return f.tokens[f.pos++];
  }
  double number(File& f, const char* what) {
    const Token& t = next(f, what);
    char* end = nullptr;
    const double v = std::strtod(t.text.c_str(), &end);
    if (end == t.text.c_str() || end != t.text.c_str() + t.text.size())
      throw Error(std::string("expected ") + what + ", got " + quoteInput(t.text), at(f, t));
    if (!std::isfinite(v)) throw Error(std::string(what) + " is not finite (" + quoteInput(t.text) + ")", at(f, t));
    return v;
  }
  uint32_t count(File& f, const char* what, uint32_t lo = 0, uint32_t hi = 1u << 26) {
    const Token& t = next(f, what);
    char* end = nullptr;
    const long long v = std::strtoll(t.text.c_str(), &end, 10);
    if (end == t.text.c_str() || end != t.text.c_str() + t.text.size() || v < lo || v > hi)
      throw Error(std::string("expected ") + what + " (a whole number in [" + std::to_string(lo) + ", " +
                      std::to_string(hi) + "]), got " + quoteInput(t.text),
                  at(f, t));
    return uint32_t(v);
  }
  glm::dvec3 vec3(File& f, const char* what) {
    glm::dvec3 v;
    for (int i = 0; i < 3; ++i) v[i] = number(f, what);
    return v;
  }
  // n vectors, storage growing with what the file holds: a count of 2^26 in a 30-byte file is a claim, not
  // 1.6 GB to allocate before the first vertex is missed.
  std::vector<glm::dvec3> vec3s(File& f, uint32_t n, const char* what) {
    std::vector<glm::dvec3> out;
    out.reserve(std::min<size_t>(n, (f.tokens.size() - f.pos) / 3));
    for (uint32_t i = 0; i < n; ++i) out.push_back(vec3(f, what));
    return out;
  }
  static bool looksNumeric(const std::string& s) {
    char* end = nullptr;
    std::strtod(s.c_str(), &end);
    return end != s.c_str() && end == s.c_str() + s.size();
  }
  void expect(File& f, const char* word) {
    const Token& t = next(f, word);
    if (t.text != word) throw Error(std::string("expected '") + word + "', got " + quoteInput(t.text), at(f, t));
  }
  void skipNumbers(File& f, int n, const char* what) {
    for (int i = 0; i < n; ++i) number(f, what);
  }

  void statement(File& f, std::vector<Group*>& stack, int depth) {
    const Token& t = next(f, "a keyword");
    const std::string& k = t.text;
    Group& g = *stack.back();
    if (k == "}") {
      if (stack.size() == 1) throw Error("'}' closes no block", at(f, t));
      stack.pop_back();
      depth_--;
    } else if (k == "v") {
      view(f);
    } else if (k == "l") {
      PointLight l;
      l.name = "light" + std::to_string(out_.lights.size());
      l.position = glm::vec3(vec3(f, "a light position"));
      // An optional colour follows: up to three more numbers on the light's line.
      uint32_t extra = 0;
      while (extra < 3 && f.pos < f.tokens.size() && f.tokens[f.pos].line == t.line) l.color[extra++] = float(number(f, "a light colour"));
      out_.lights.push_back(l);
    } else if (k == "b" || k == "am") {
      skipNumbers(f, 3, "a colour");
    } else if (k == "f") {
      skipNumbers(f, 8, "a material value");
    } else if (k == "fm") {
      skipNumbers(f, 12, "a material value");
    } else if (k == "a") {
      out_.start = number(f, "the animation's start time");
      out_.end = number(f, "the animation's end time");
      number(f, "the animation's frame count");
      out_.hasRange = true;
    } else if (k == "p" || k == "pp") {
      polygon(f, g, k == "pp");
    } else if (k == "tt") {
      next(f, "a texture name");
      Tri tri{};
      for (int i = 0; i < 3; ++i) {
        tri.p[i] = vec3(f, "a vertex");
        skipNumbers(f, 2, "a texture coordinate");
      }
      g.tris.push_back(tri);
    } else if (k == "tpa") {
      animatedTriangle(f, g);
    } else if (k == "c") {
      cone(f, g);
    } else if (k == "s") {
      sphere(f, g);
    } else if (k == "m") {
      mesh(f, g, t);
    } else if (k == "i") {
      count(f, "an include's detail level", 0, 1000);
      const Token& name = next(f, "an include's file name");
      // Only BART files: a system file's first line is never read and quoted back as a bad keyword.
      std::string ext = fs::path(name.text).extension().string();
      std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return char(std::tolower(c)); });
      if (ext != ".aff")
        throw Error("an include names " + quoteInput(name.text) + ", not a BART (.aff) file", at(f, name),
                    "includes name .aff files");
      const fs::path p = f.path.parent_path() / name.text;
      parseFile(p, g, depth + 1, at(f, name));
    } else if (k == "xs") {
      auto child = std::make_unique<Group>();
      child->kind = Group::Kind::Static;
      child->where = at(f, t);
      const glm::dvec3 s = vec3(f, "a scale");
      const glm::dvec3 axis = vec3(f, "a rotation axis");
      const double angle = number(f, "a rotation angle");
      const glm::dvec3 tr = vec3(f, "a translation");
      child->local = trs(tr, axis, angle, s);
      expect(f, "{");
      enter(f, stack, child.get());
      g.children.push_back(std::move(child));
    } else if (k == "x") {
      auto child = std::make_unique<Group>();
      child->kind = Group::Kind::Animated;
      child->where = at(f, t);
      child->track = next(f, "a transform name").text;
      expect(f, "{");
      enter(f, stack, child.get());
      g.children.push_back(std::move(child));
    } else if (k == "k") {
      keyframes(f, t);
    } else {
      const bool word = k.size() <= 24 && std::all_of(k.begin(), k.end(), [](char c) {
        return std::isalnum(static_cast<unsigned char>(c)) || c == '_' || c == '{' || c == '}';
      });
      throw Error(word ? "unknown keyword " + quoteInput(k) : "a token of " + std::to_string(k.size()) + " characters where a keyword was expected", at(f, t),
                  "AFF keywords read: v l b am f fm a p pp tt tpa c s m i xs x k { }");
    }
  }

  void enter(File& f, std::vector<Group*>& stack, Group* g) {
    depth_++;
    if (depth_ > kMaxBlockDepth)
      throw Error("blocks nest deeper than " + std::to_string(kMaxBlockDepth) + " levels", at(f));
    stack.push_back(g);
  }

  void view(File& f) {
    Camera c;
    c.name = "view";
    for (const char* word : {"from", "at", "up", "angle", "hither", "resolution"}) {
      expect(f, word);
      const std::string w = word;
      if (w == "from") c.eye = glm::vec3(vec3(f, "the eye"));
      else if (w == "at") c.target = glm::vec3(vec3(f, "the target"));
      else if (w == "up") c.up = glm::vec3(vec3(f, "the up vector"));
      else if (w == "angle") {
        const std::string where = at(f);
        const double a = number(f, "the field of view in degrees");
        if (!(a > 0 && a < 180)) throw Error("field of view " + std::to_string(a) + " is not in (0, 180) degrees", where);
        c.yfov = float(glm::radians(a));
      } else if (w == "hither") {
        const std::string where = at(f);
        const double h = number(f, "the near distance");
        if (h < 0) throw Error("the view's hither (near distance) " + std::to_string(h) + " is negative", where);
        c.znear = float(h);  // 0: unset, chosen from the scene's size when placed
      } else {
        count(f, "a resolution", 1, 1u << 16);
        count(f, "a resolution", 1, 1u << 16);
      }
    }
    if (glm::length(c.eye - c.target) == 0.0f) throw Error("the view's eye and target coincide", at(f));
    out_.view = c;
    out_.hasView = true;
  }

  static glm::dmat4 trs(glm::dvec3 t, glm::dvec3 axis, double degrees, glm::dvec3 s) {
    glm::dmat4 m = glm::translate(glm::dmat4(1.0), t);
    if (glm::length(axis) > 0 && degrees != 0) m = glm::rotate(m, glm::radians(degrees), glm::normalize(axis));
    return glm::scale(m, s);
  }

  void polygon(File& f, Group& g, bool withNormals) {
    const uint32_t n = count(f, "a polygon's vertex count", 0, 1u << 20);
    std::vector<glm::dvec3> p(n), nr(n, glm::dvec3(0));
    for (uint32_t i = 0; i < n; ++i) {
      p[i] = vec3(f, "a vertex");
      if (withNormals) nr[i] = vec3(f, "a normal");
    }
    if (n < 3) {
      out_.skipped++;
      return;
    }
    for (uint32_t i = 1; i + 1 < n; ++i) g.tris.push_back(Tri{{p[0], p[i], p[i + 1]}, {nr[0], nr[i], nr[i + 1]}});
  }

  void animatedTriangle(File& f, Group& g) {
    const uint32_t keys = count(f, "an animated triangle's key count", 1, 1u << 16);
    AnimTri a;
    for (uint32_t k = 0; k < keys; ++k) {
      const Token& tt = f.tokens[std::min(f.pos, f.tokens.size() - 1)];
      const double time = number(f, "a key time");
      if (!a.times.empty() && time < a.times.back())
        throw Error("animated triangle keys are not in time order", at(f, tt));
      Tri tri{};
      for (int i = 0; i < 3; ++i) {
        tri.p[i] = vec3(f, "a vertex");
        tri.n[i] = vec3(f, "a normal");
      }
      a.times.push_back(time);
      a.keys.push_back(tri);
    }
    g.animTris.push_back(std::move(a));
  }

  // An open cone or cylinder (NFF): base centre and radius, apex centre and radius; side only, no caps.
  void cone(File& f, Group& g) {
    const glm::dvec3 base = vec3(f, "a cone's base");
    const double rb = number(f, "a cone's base radius");
    const glm::dvec3 apex = vec3(f, "a cone's apex");
    const double ra = number(f, "a cone's apex radius");
    glm::dvec3 axis = apex - base;
    if (glm::length(axis) == 0) return;
    axis = glm::normalize(axis);
    const glm::dvec3 ref = std::abs(axis.x) < 0.9 ? glm::dvec3(1, 0, 0) : glm::dvec3(0, 1, 0);
    const glm::dvec3 u = glm::normalize(glm::cross(axis, ref)), v = glm::cross(axis, u);
    const double slope = (rb - ra) / glm::length(apex - base);  // the side's normal leans along the axis
    for (uint32_t i = 0; i < kConeSegments; ++i) {
      const double a0 = 2 * M_PI * i / kConeSegments, a1 = 2 * M_PI * (i + 1) / kConeSegments;
      const glm::dvec3 d0 = std::cos(a0) * u + std::sin(a0) * v, d1 = std::cos(a1) * u + std::sin(a1) * v;
      const glm::dvec3 n0 = glm::normalize(d0 + slope * axis), n1 = glm::normalize(d1 + slope * axis);
      const glm::dvec3 b0 = base + std::abs(rb) * d0, b1 = base + std::abs(rb) * d1;
      const glm::dvec3 t0 = apex + std::abs(ra) * d0, t1 = apex + std::abs(ra) * d1;
      g.tris.push_back(Tri{{b0, b1, t1}, {n0, n1, n1}});
      g.tris.push_back(Tri{{b0, t1, t0}, {n0, n1, n0}});
    }
  }

  void sphere(File& f, Group& g) {
    const glm::dvec3 c = vec3(f, "a sphere's centre");
    const double r = number(f, "a sphere's radius");
    if (!(r > 0)) return;
    auto at = [&](uint32_t ring, uint32_t seg) {
      const double th = M_PI * ring / kSphereRings, ph = 2 * M_PI * seg / (2 * kSphereRings);
      return glm::dvec3(std::sin(th) * std::cos(ph), std::cos(th), std::sin(th) * std::sin(ph));
    };
    for (uint32_t i = 0; i < kSphereRings; ++i)
      for (uint32_t j = 0; j < 2 * kSphereRings; ++j) {
        const glm::dvec3 a = at(i, j), b = at(i + 1, j), d = at(i + 1, j + 1), e = at(i, j + 1);
        if (i > 0) g.tris.push_back(Tri{{c + r * a, c + r * e, c + r * d}, {a, e, d}});
        if (i + 1 < kSphereRings) g.tris.push_back(Tri{{c + r * a, c + r * d, c + r * b}, {a, d, b}});
      }
  }

  // m: "vertices N" positions, optional "normals N", optional "texturecoords N" (u v), then
  // "triangles N": per triangle three vertex indices, three normal indices when the mesh has normals,
  // three texture-coordinate indices when it has those.
  void mesh(File& f, Group& g, const Token& t) {
    expect(f, "vertices");
    const std::vector<glm::dvec3> p = vec3s(f, count(f, "a vertex count"), "a vertex");
    std::vector<glm::dvec3> n;
    uint32_t uvs = 0;
    bool hasUv = false;
    std::string word = next(f, "normals, texturecoords or triangles").text;
    if (word == "normals") {
      n = vec3s(f, count(f, "a normal count"), "a normal");
      word = next(f, "texturecoords or triangles").text;
    }
    if (word == "texturecoords") {
      hasUv = true;
      uvs = count(f, "a texture-coordinate count");
      // An optional texture file name may follow the count.
      if (f.pos < f.tokens.size() && !looksNumeric(f.tokens[f.pos].text)) f.pos++;
      skipNumbers(f, int(2 * uvs), "a texture coordinate");
      word = next(f, "triangles").text;
    }
    if (word != "triangles") throw Error("expected 'triangles' in a mesh, got " + quoteInput(word), at(f));
    const uint32_t tris = count(f, "a triangle count");
    const bool hasN = !n.empty();
    for (uint32_t i = 0; i < tris; ++i) {
      uint32_t vi[3], ni[3] = {0, 0, 0};
      for (auto& x : vi) x = index(f, uint32_t(p.size()), "a vertex index", t);
      if (hasN)
        for (auto& x : ni) x = index(f, uint32_t(n.size()), "a normal index", t);
      if (hasUv)
        for (int j = 0; j < 3; ++j) index(f, uvs, "a texture-coordinate index", t);
      Tri tri{};
      for (int j = 0; j < 3; ++j) {
        tri.p[j] = p[vi[j]];
        tri.n[j] = hasN ? n[ni[j]] : glm::dvec3(0);
      }
      g.tris.push_back(tri);
    }
  }

  uint32_t index(File& f, uint32_t size, const char* what, const Token& mesh) {
    const Token& t = f.tokens[std::min(f.pos, f.tokens.size() - 1)];
    const uint32_t i = count(f, what);
    if (i >= size)
      throw Error(std::string(what) + " " + std::to_string(i) + " is out of range (the mesh at line " +
                      std::to_string(mesh.line) + " has " + std::to_string(size) + ")",
                  at(f, t));
    return i;
  }

  void keyframes(File& f, const Token& t) {
    const std::string name = next(f, "a transform name").text;
    Track tr;
    tr.where = at(f, t);
    expect(f, "{");
    for (;;) {
      const Token& w = next(f, "transl, rot, scale or '}'");
      if (w.text == "}") break;
      std::vector<Key>* keys = w.text == "transl" ? &tr.transl : w.text == "rot" ? &tr.rot : w.text == "scale" ? &tr.scale : nullptr;
      if (!keys)
        throw Error("expected transl, rot, scale or '}' in keyframes " + quoteInput(name) + ", got " + quoteInput(w.text), at(f, w));
      if (!keys->empty()) throw Error(w.text + " keys of " + quoteInput(name) + " are given twice", at(f, w));
      const uint32_t n = count(f, "a key count", 1, 1u << 20);
      for (uint32_t i = 0; i < n; ++i) {
        Key k;
        k.time = number(f, "a key time");
        for (int c = 0; c < (keys == &tr.rot ? 4 : 3); ++c) k.value[c] = number(f, "a key value");
        k.tension = number(f, "a key's tension");
        k.continuity = number(f, "a key's continuity");
        k.bias = number(f, "a key's bias");
        keys->push_back(k);
      }
      // BART's own files have a few keys out of time order (the robots' gun rotations repeat a stretch):
      // taken in time order, with a warning.
      if (!std::is_sorted(keys->begin(), keys->end(), [](const Key& a, const Key& b) { return a.time < b.time; })) {
        std::stable_sort(keys->begin(), keys->end(), [](const Key& a, const Key& b) { return a.time < b.time; });
        out_.unordered.push_back(name + " (" + w.text + ", " + at(f, w) + ")");
      }
    }
    // A file included twice defines its keyframes twice: the first definition stands.
    if (!out_.tracks.emplace(name, std::move(tr)).second) out_.redefined++;
  }
};

// ---- placing the scene in time ----------------------------------------------------------------------

// The segment [i, i + 1] of keys holding time t (clamped to the ends) and the parameter u in it.
size_t segment(const std::vector<Key>& keys, double t, double& u) {
  u = 0;
  if (t <= keys.front().time) return 0;
  for (size_t i = 0; i + 1 < keys.size(); ++i)
    if (t < keys[i + 1].time) {
      const double span = keys[i + 1].time - keys[i].time;
      u = span > 0 ? (t - keys[i].time) / span : 0;
      return i;
    }
  u = 1;
  return keys.size() - 1;
}

// Kochanek-Bartels spline through the keys' values (positions, scales): Hermite segments with each key's
// incoming and outgoing tangents from its tension, continuity and bias, scaled for uneven key spacing;
// the ends use one-sided differences.
glm::dvec3 kbSpline(const std::vector<Key>& keys, double t) {
  if (keys.size() == 1) return glm::dvec3(keys[0].value);
  double u;
  const size_t i = segment(keys, t, u);
  if (i + 1 >= keys.size()) return glm::dvec3(keys.back().value);
  auto value = [&](size_t k) { return glm::dvec3(keys[k].value); };
  // Outgoing tangent at key k (towards k + 1) and incoming tangent at key k (from k - 1).
  auto tangents = [&](size_t k, glm::dvec3& in, glm::dvec3& out) {
    const Key& K = keys[k];
    const glm::dvec3 prev = k > 0 ? value(k) - value(k - 1) : value(k + 1 < keys.size() ? k + 1 : k) - value(k);
    const glm::dvec3 next = k + 1 < keys.size() ? value(k + 1) - value(k) : prev;
    const double a = (1 - K.tension) * (1 + K.continuity) * (1 + K.bias) / 2;
    const double b = (1 - K.tension) * (1 - K.continuity) * (1 - K.bias) / 2;
    const double c = (1 - K.tension) * (1 - K.continuity) * (1 + K.bias) / 2;
    const double d = (1 - K.tension) * (1 + K.continuity) * (1 - K.bias) / 2;
    out = a * prev + b * next;
    in = c * prev + d * next;
    const double dPrev = k > 0 ? K.time - keys[k - 1].time : 0, dNext = k + 1 < keys.size() ? keys[k + 1].time - K.time : 0;
    if (dPrev > 0 && dNext > 0) {
      out *= 2 * dNext / (dPrev + dNext);
      in *= 2 * dPrev / (dPrev + dNext);
    }
  };
  glm::dvec3 in0, out0, in1, out1;
  tangents(i, in0, out0);
  tangents(i + 1, in1, out1);
  const double u2 = u * u, u3 = u2 * u;
  return (2 * u3 - 3 * u2 + 1) * value(i) + (u3 - 2 * u2 + u) * out0 + (-2 * u3 + 3 * u2) * value(i + 1) +
         (u3 - u2) * in1;
}

glm::dquat keyRotation(const Key& k) {
  const glm::dvec3 axis(k.value);
  if (glm::length(axis) == 0 || k.value.w == 0) return glm::dquat(1, 0, 0, 0);
  return glm::angleAxis(glm::radians(k.value.w), glm::normalize(axis));
}

// Rotations: each key an orientation (axis, angle); spherical-linear between the two keys around t.
glm::dquat rotationAt(const std::vector<Key>& keys, double t) {
  double u;
  const size_t i = segment(keys, t, u);
  if (i + 1 >= keys.size()) return keyRotation(keys.back());
  return glm::slerp(keyRotation(keys[i]), keyRotation(keys[i + 1]), u);
}

glm::dmat4 trackMatrix(const Track& tr, double t) {
  glm::dmat4 m(1.0);
  if (!tr.transl.empty()) m = glm::translate(m, kbSpline(tr.transl, t));
  if (!tr.rot.empty()) m = m * glm::mat4_cast(rotationAt(tr.rot, t));
  if (!tr.scale.empty()) m = glm::scale(m, kbSpline(tr.scale, t));
  return m;
}

Tri animTriAt(const AnimTri& a, double t) {
  if (t <= a.times.front()) return a.keys.front();
  for (size_t i = 0; i + 1 < a.times.size(); ++i)
    if (t < a.times[i + 1]) {
      const double span = a.times[i + 1] - a.times[i];
      const double u = span > 0 ? (t - a.times[i]) / span : 0;
      Tri r;
      for (int j = 0; j < 3; ++j) {
        r.p[j] = glm::mix(a.keys[i].p[j], a.keys[i + 1].p[j], u);
        r.n[j] = glm::mix(a.keys[i].n[j], a.keys[i + 1].n[j], u);
      }
      return r;
    }
  return a.keys.back();
}

struct Flattener {
  const Parsed& parsed;
  double time;
  Scene& scene;
  std::vector<std::string> undriven;  // x NAME blocks without keyframes NAME

  void add(const Tri& tri, const glm::dmat4& m, const glm::dmat3& normalMatrix) {
    glm::dvec3 p[3];
    for (int j = 0; j < 3; ++j) p[j] = glm::dvec3(m * glm::dvec4(tri.p[j], 1.0));
    glm::dvec3 flat = glm::cross(p[1] - p[0], p[2] - p[0]);
    const double len = glm::length(flat);
    flat = len > 0 && std::isfinite(len) ? flat / len : glm::dvec3(0, 1, 0);
    const uint32_t base = uint32_t(scene.positions.size());
    for (int j = 0; j < 3; ++j) {
      glm::dvec3 n = normalMatrix * tri.n[j];
      const double nl = glm::length(n);
      n = nl > 0 && std::isfinite(nl) ? n / nl : flat;
      scene.positions.push_back(glm::vec3(p[j]));
      scene.normals.push_back(glm::vec3(n));
      scene.indices.push_back(base + uint32_t(j));
    }
  }

  void walk(const Group& g, const glm::dmat4& parent) {
    glm::dmat4 m = parent;
    if (g.kind == Group::Kind::Static) m = parent * g.local;
    if (g.kind == Group::Kind::Animated) {
      // BART's robots name a few transforms that no keyframes drive: those stay put (identity).
      auto it = parsed.tracks.find(g.track);
      if (it != parsed.tracks.end()) m = parent * trackMatrix(it->second, time);
      else if (std::find(undriven.begin(), undriven.end(), g.track) == undriven.end()) undriven.push_back(g.track);
    }
    const glm::dmat3 normalMatrix = glm::transpose(glm::inverse(glm::dmat3(m)));
    for (const Tri& t : g.tris) add(t, m, normalMatrix);
    for (const AnimTri& a : g.animTris) add(animTriAt(a, time), m, normalMatrix);
    for (auto& c : g.children) walk(*c, m);
  }
};

}  // namespace

struct AffAnimation::Data {
  std::string name;  // file name, for the scene and the warnings
  Parsed parsed;
  bool animated = false;
  double start = 0, end = 0;
};

AffAnimation::AffAnimation(const std::string& path, std::ostream& warn) : d_(std::make_unique<Data>()) {
  Data& d = *d_;
  d.name = fs::path(path).filename().string();
  Parser parser(d.parsed);
  try {
    parser.parseFile(fs::path(path), d.parsed.root, 0, "");
  } catch (const Error& e) {
    throw clippedError(e);
  }
  const Parsed& parsed = d.parsed;
  if (!parsed.unordered.empty()) {
    warn << d.name << ": keys not in time order, sorted by time in " << parsed.unordered.size() << " track(s):";
    for (size_t i = 0; i < parsed.unordered.size() && i < 3; ++i) warn << " " << parsed.unordered[i];
    warn << (parsed.unordered.size() > 3 ? " ...\n" : "\n");
  }
  if (parsed.skipped) warn << d.name << ": " << parsed.skipped << " polygon(s) with fewer than 3 vertices skipped\n";
  // Animated: an x block driven by keyframes, or a tpa triangle with two keys or more.
  double lo = 1e300, hi = -1e300;
  auto visit = [&](auto&& self, const Group& g) -> void {
    if (g.kind == Group::Kind::Animated) {
      auto it = parsed.tracks.find(g.track);
      if (it != parsed.tracks.end()) {
        for (const std::vector<Key>* keys : {&it->second.transl, &it->second.rot, &it->second.scale})
          if (keys->size() > 1) {
            d.animated = true;
            lo = std::min(lo, keys->front().time);
            hi = std::max(hi, keys->back().time);
          }
      }
    }
    for (const AnimTri& a : g.animTris)
      if (a.times.size() > 1) {
        d.animated = true;
        lo = std::min(lo, a.times.front());
        hi = std::max(hi, a.times.back());
      }
    for (auto& c : g.children) self(self, *c);
  };
  visit(visit, parsed.root);
  if (parsed.hasRange) {
    d.start = parsed.start;
    d.end = std::max(parsed.start, parsed.end);
  } else if (d.animated) {
    d.start = lo;
    d.end = hi;
  }
  // The first placement checks what every placement shares: triangles, finite vertices.
  sceneAt(d.start, &warn);
}

AffAnimation::~AffAnimation() = default;
AffAnimation::AffAnimation(AffAnimation&&) noexcept = default;
AffAnimation& AffAnimation::operator=(AffAnimation&&) noexcept = default;

double AffAnimation::start() const { return d_->start; }
double AffAnimation::end() const { return d_->end; }
bool AffAnimation::animated() const { return d_->animated; }

Scene AffAnimation::sceneAt(double t, std::ostream* warn) const {
  const Parsed& parsed = d_->parsed;
  if (!std::isfinite(t)) throw Error("the scene time is not finite", d_->name);
  Scene scene;
  scene.name = d_->name;
  Flattener flat{parsed, t, scene, {}};
  flat.walk(parsed.root, glm::dmat4(1.0));
  if (warn && !flat.undriven.empty()) {
    *warn << scene.name << ": " << flat.undriven.size() << " animated transform(s) without keyframes, left in place:";
    for (size_t i = 0; i < flat.undriven.size() && i < 3; ++i) *warn << " " << flat.undriven[i];
    *warn << (flat.undriven.size() > 3 ? " ...\n" : "\n");
  }
  if (scene.indices.empty()) throw Error("the scene has no triangles", d_->name);
  for (const glm::vec3& p : scene.positions)
    if (!std::isfinite(p.x) || !std::isfinite(p.y) || !std::isfinite(p.z))
      throw Error("a transformed vertex is not finite (a transform overflows float)", d_->name);
  scene.computeBounds();
  const float diag = scene.diagonal() > 0 ? scene.diagonal() : 1.0f;
  if (parsed.hasView) {
    Camera c = parsed.view;
    c.zfar = glm::length(c.eye - 0.5f * (scene.boundsMin + scene.boundsMax)) + diag;
    c.znear = std::min(c.znear > 0 ? c.znear : 1e-4f * c.zfar, 0.5f * c.zfar);
    checkFileCamera(c, d_->name, "the view (v)");
    scene.cameras.push_back(c);
  }
  // BART's camera track: the camera at the origin looking down -z with +y up, moved by the track.
  auto cam = parsed.tracks.find("camera");
  if (cam != parsed.tracks.end()) {
    const glm::dmat4 m = trackMatrix(cam->second, t);
    Camera c = parsed.hasView ? parsed.view : Camera{};
    c.name = "animated";
    c.eye = glm::vec3(m * glm::dvec4(0, 0, 0, 1));
    c.target = glm::vec3(m * glm::dvec4(0, 0, -1, 1));
    c.up = glm::vec3(glm::normalize(glm::dvec3(m * glm::dvec4(0, 1, 0, 0))));
    c.zfar = glm::length(c.eye - 0.5f * (scene.boundsMin + scene.boundsMax)) + diag;
    const float hither = parsed.hasView ? parsed.view.znear : 0.0f;
    c.znear = std::min(hither > 0 ? hither : 1e-4f * c.zfar, 0.5f * c.zfar);
    checkFileCamera(c, d_->name, "the animated camera (k camera)");
    scene.cameras.push_back(c);
  }
  scene.lights = parsed.lights;
  return scene;
}

Scene loadAff(const std::string& path, std::ostream& warn, std::optional<double> time) {
  AffAnimation a(path, warn);
  return time ? a.sceneAt(*time) : a.sceneAt(a.start());
}

}  // namespace cs
