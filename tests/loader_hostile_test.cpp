// Hostile scene files, written by the tests: each must be refused quickly with one clear line naming the
// file and the problem (issue 48: crashes, hangs, blow-ups, silent misreads, messages), through every
// loader (glTF, GLB, BART, assimp) and the side files they open.
#include <sys/stat.h>
#include <unistd.h>

#include <chrono>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <future>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "core/error.h"
#include "core/input_guard.h"
#include "core/scene.h"

namespace cs {
namespace {

namespace fs = std::filesystem;
using json = nlohmann::json;

class LoaderHostile : public ::testing::Test {
 protected:
  fs::path dir;
  void SetUp() override {
    dir = fs::temp_directory_path() /
          ("coneshadow_hostile_" + std::to_string(::getpid()) + "_" +
           ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::remove_all(dir);
    fs::create_directories(dir);
  }
  void TearDown() override { fs::remove_all(dir); }

  std::string write(const std::string& name, const std::string& bytes) const {
    const fs::path p = dir / name;
    std::ofstream(p, std::ios::binary) << bytes;
    return p.string();
  }

  // Loads `path` expecting a cs::Error: one line of printable text naming the file and holding
  // `fragment`, short, no source path. Returns the message.
  static std::string refused(const std::string& path, const std::string& fragment, std::string named = {}) {
    if (named.empty()) named = fs::path(path).filename().string();
    std::ostringstream warn;
    try {
      (void)loadSceneFile(path, warn);
    } catch (const Error& e) {
      const std::string what = e.what();
      EXPECT_NE(what.find(fragment), std::string::npos) << what;
      EXPECT_NE(what.find(named), std::string::npos) << what;
      EXPECT_EQ(what.size(), std::strlen(e.what())) << "a NUL byte in the message";
      for (char c : what) EXPECT_TRUE(c >= 0x20 && c < 0x7f) << "byte " << int(c) << " in: " << what;
      EXPECT_LE(what.size(), 420u) << what;
      EXPECT_EQ(what.find(".cpp"), std::string::npos) << what;
      return what;
    }
    ADD_FAILURE() << path << " loaded; expected an error with '" << fragment << "'";
    return {};
  }
};

// ---- Collada ----------------------------------------------------------------------------------------

// One triangle in a Collada file, instanced by the innermost of `depth` nested nodes.
std::string collada(int depth, const std::string& floatCount = "9") {
  std::string nodes;
  for (int i = 0; i < depth; ++i) nodes += "<node id=\"n" + std::to_string(i) + "\">";
  nodes += "<instance_geometry url=\"#tri\"/>";
  for (int i = 0; i < depth; ++i) nodes += "</node>\n";
  return R"(<?xml version="1.0" encoding="utf-8"?>
<COLLADA xmlns="http://www.collada.org/2005/11/COLLADASchema" version="1.4.1">
<asset><up_axis>Y_UP</up_axis></asset>
<library_geometries><geometry id="tri" name="tri"><mesh>
<source id="tri-pos"><float_array id="tri-pos-array" count=")" +
         floatCount + R"(">0 0 0 1 0 0 0 1 0</float_array>
<technique_common><accessor source="#tri-pos-array" count="3" stride="3">
<param name="X" type="float"/><param name="Y" type="float"/><param name="Z" type="float"/>
</accessor></technique_common></source>
<vertices id="tri-vtx"><input semantic="POSITION" source="#tri-pos"/></vertices>
<triangles count="1"><input semantic="VERTEX" source="#tri-vtx" offset="0"/><p>0 1 2</p></triangles>
</mesh></geometry></library_geometries>
<library_visual_scenes><visual_scene id="scene">)" +
         nodes + R"(</visual_scene></library_visual_scenes>
<scene><instance_visual_scene url="#scene"/></scene>
</COLLADA>
)";
}

TEST_F(LoaderHostile, ColladaNestingIsBoundedBeforeAssimpRecurses) {
  std::ostringstream warn;
  const Scene ok = loadSceneFile(write("nested50.dae", collada(50)), warn);
  EXPECT_EQ(ok.indices.size(), 3u);
  const std::string deep = write("nested10000.dae", collada(10000));
  ASSERT_GT(fs::file_size(deep), 200000u);
  refused(deep, "nests more than 256 elements deep");
  EXPECT_EQ(xmlDepth("<a><!-- <b> --><c/><d x='>'><e></e></d></a>", 100), 3u);
  EXPECT_EQ(xmlDepth("<?xml?><![CDATA[<x><y>]]><a></a>", 100), 1u);
}

// ---- BART includes ----------------------------------------------------------------------------------

TEST_F(LoaderHostile, BartIncludeFanOutFailsFastWithOneLine) {
  for (int i = 0; i <= 30; ++i) {
    std::string name = "f", next = "f", text = "p 3 0 0 0 1 0 0 0 1 0\n";
    name.append(std::to_string(i)).append(".aff");
    next.append(std::to_string(i + 1)).append(".aff");
    if (i < 30) text = std::string("i 0 ").append(next).append("\ni 0 ").append(next).append("\n");
    write(name, text);
  }
  const auto start = std::chrono::steady_clock::now();
  refused((dir / "f0.aff").string(), "reads more than 4096 files through its includes");
  // Without the bound the includes read 2^31 files (hours); with it, 4096. Seconds under any load of the
  // machine (a one-second bound failed on a loaded 2-core host: this is a guard, not a benchmark).
  EXPECT_LT(std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count(), 30.0);
  // Bytes: a 9 MB file (comments) included 30 times passes 256 MiB.
  write("big.aff", "% " + std::string(9u << 20, 'x') + "\np 3 0 0 0 1 0 0 0 1 0\n");
  std::string includes;
  for (int i = 0; i < 30; ++i) includes += "i 0 big.aff\n";
  refused(write("many.aff", includes), "pass 256 MiB in all");
  // Five includes of it are fine.
  std::ostringstream warn;
  EXPECT_EQ(loadSceneFile(write("five.aff", "i 0 big.aff\ni 0 big.aff\ni 0 big.aff\ni 0 big.aff\ni 0 big.aff\n"), warn)
                .indices.size(),
            15u);
}

// ---- every file a loader opens ----------------------------------------------------------------------

// Runs the load in a thread and returns its error ("loaded" if none); a load that blocks (a FIFO opened
// for reading) is unblocked by opening the FIFO for writing, and fails the test.
std::string loadWithoutBlocking(const std::string& path, const std::string& fifo) {
  auto result = std::async(std::launch::async, [&] {
    std::ostringstream warn;
    try {
      (void)loadSceneFile(path, warn);
      return std::string("loaded");
    } catch (const Error& e) {
      return std::string(e.what());
    }
  });
  if (result.wait_for(std::chrono::seconds(10)) != std::future_status::ready) {
    ADD_FAILURE() << path << " blocked on " << fifo;
    std::ofstream unblock(fifo);
  }
  return result.get();
}

void expectNoBlock(const std::string& path, const std::string& fifo, const std::string& fragment) {
  const std::string what = loadWithoutBlocking(path, fifo);
  EXPECT_NE(what.find(fragment), std::string::npos) << what;
  EXPECT_NE(what.find(fs::path(path).filename().string()), std::string::npos) << what;
}

TEST_F(LoaderHostile, SideFilesMustBeRegularFiles) {
  const std::string fifo = (dir / "pipe.mtl").string();
  ASSERT_EQ(mkfifo(fifo.c_str(), 0600), 0);
  expectNoBlock(write("mtl.obj", "mtllib pipe.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n"), fifo, "a FIFO");
  fs::create_directories(dir / "folder.mtl");
  refused(write("mtlfolder.obj", "mtllib folder.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n"), "is a folder");
  // glTF: an external buffer, and an image (not read at all).
  const std::string bin = (dir / "pipe.bin").string();
  ASSERT_EQ(mkfifo(bin.c_str(), 0600), 0);
  json doc = json::parse(R"({"asset": {"version": "2.0"}, "buffers": [{"uri": "pipe.bin", "byteLength": 36}],
    "bufferViews": [{"buffer": 0, "byteLength": 36}],
    "accessors": [{"bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3"}],
    "meshes": [{"primitives": [{"attributes": {"POSITION": 0}}]}], "nodes": [{"mesh": 0}]})");
  expectNoBlock(write("buffer.gltf", doc.dump()), bin, "a FIFO");
  doc["buffers"][0]["uri"] = "folder.mtl";
  refused(write("bufferfolder.gltf", doc.dump()), "is a folder");
  const std::string png = (dir / "pipe.png").string();
  ASSERT_EQ(mkfifo(png.c_str(), 0600), 0);
  doc["buffers"][0]["uri"] = "data:application/octet-stream;base64," + std::string(48, 'A');
  doc["images"] = json::array({{{"uri", "pipe.png"}}});
  // External images are never opened (tinygltf is built with TINYGLTF_NO_EXTERNAL_IMAGE): no textures.
  EXPECT_EQ(loadWithoutBlocking(write("image.gltf", doc.dump()), png), "loaded");
}

TEST_F(LoaderHostile, CannotReadIsNotFileNotFoundAndSystemFilesAreNotScenes) {
  // /proc/self/mem exists and opens but fails to read at offset 0; /proc/self/environ says 0 bytes.
  fs::create_symlink("/proc/self/mem", dir / "mem.obj");
  refused((dir / "mem.obj").string(), "cannot read");
  fs::create_symlink("/proc/self/environ", dir / "env.aff");
  const std::string env = refused((dir / "env.aff").string(), "reads more than its size");
  EXPECT_EQ(env.find("PATH="), std::string::npos) << env;
  // An include may only name a BART file: never a system file's first line quoted back.
  const std::string passwd = refused(write("passwd.aff", "i 0 /etc/passwd\n"), "not a BART (.aff) file");
  EXPECT_EQ(passwd.find("root:"), std::string::npos) << passwd;
  fs::create_symlink("/etc/passwd", dir / "linked.aff");
  const std::string linked = refused(write("linkpasswd.aff", "i 0 linked.aff\n"), "where a keyword was expected", "linked.aff");
  EXPECT_EQ(linked.find("root:"), std::string::npos) << linked;
  fs::create_directories(dir / "scene.obj");
  refused((dir / "scene.obj").string(), "is a folder");
}

// ---- claimed counts ---------------------------------------------------------------------------------

TEST_F(LoaderHostile, HeaderCountsAreCheckedAgainstTheFileSize) {
  const std::string plyHead = "ply\nformat ascii 1.0\nelement vertex ";
  const std::string plyRest =
      "\nproperty float x\nproperty float y\nproperty float z\nelement face 1\nproperty list uchar int vertex_indices\n"
      "end_header\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n";
  std::ostringstream warn;
  EXPECT_EQ(loadSceneFile(write("ok.ply", plyHead + "3" + plyRest), warn).indices.size(), 3u);
  refused(write("billion.ply", plyHead + "1000000000" + plyRest), "claims 1000000000 elements");
  // No end_header: assimp read on past the end forever (found by the assimp fuzzer).
  refused(write("open.ply", plyHead + "3\nproperty float x\n0 0 0\n"), "no end_header line");
  std::string binary = "ply\nformat binary_little_endian 1.0\nelement vertex 4294967295\nproperty float x\n"
                       "property float y\nproperty float z\nend_header\n";
  binary += std::string(36, '\0');
  refused(write("binary.ply", binary), "claims 4294967295 elements");
  EXPECT_EQ(loadSceneFile(write("ok.off", "OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n"), warn).indices.size(), 3u);
  refused(write("billion.off", "OFF\n1000000000 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n"), "claims 1000000001 elements");
  refused(write("count.dae", collada(1, "1000000000")), "claims 1000000000 elements");
  // Binary STL: 2^31 + 1 triangles in a one-triangle file (50 * (2^31 + 1) + 84 wraps to its size in 32 bits).
  std::string stl(84 + 50, '\0');
  const uint32_t n = (1u << 31) + 1;
  std::memcpy(&stl[80], &n, 4);
  refused(write("wrap.stl", stl), "claims 2147483649 elements");
  for (const char* name : {"billion.ply", "binary.ply", "billion.off", "count.dae", "wrap.stl"})
    EXPECT_LT(fs::file_size(dir / name), 2000u) << name;
}

// ---- silent misreads through assimp -----------------------------------------------------------------

TEST_F(LoaderHostile, AssimpNaNVerticesBadIndicesAndHugeNumbersAreErrors) {
  // A NaN vertex in one of two objects: assimp's FindInvalidData dropped that object without a word.
  refused(write("nan.obj", "o a\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\no b\nv nan 0 0\nv 1 1 0\nv 2 2 0\nf 4 5 6\n"),
          "not a number at vertex");
  refused(write("inf.stl",
                "solid x\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\nvertex 1 0 0\nvertex inf 1 0\nendloop\nendfacet\n"
                "endsolid x\n"),
          "at infinity or not a number");
  // Out-of-range face indices: OFF's was clamped to the last vertex and drawn.
  refused(write("index.off", "OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 9\n"), "OFF face 0 names vertex 9 of 3");
  refused(write("index.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 99\n"), "index out of range");
  refused(write("index.ply",
                "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\n"
                "element face 1\nproperty list uchar int vertex_indices\nend_header\n0 0 0\n1 0 0\n0 1 0\n3 0 1 7\n"),
          "out of range");
  // A coordinate of a million digits was read as 0.
  const std::string digits = refused(write("digits.obj", "v 0 0 0\nv 1 0 0\nv 0 1 " + std::string(1000000, '1') + "\nf 1 2 3\n"),
                                     "has more than 400 digits");
  std::ostringstream warn;
  EXPECT_EQ(loadSceneFile(write("long.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0." + std::string(300, '1') + "\nf 1 2 3\n"), warn)
                .indices.size(),
            3u);
}

// ---- what slips past the checks and crashes assimp ---------------------------------------------------

// What assimp makes of `path` may change with its version: a scene with triangles, or one line naming the file.
void loadsOrIsOneLine(const std::string& path) {
  std::ostringstream warn;
  try {
    EXPECT_GT(loadSceneFile(path, warn).indices.size(), 0u);
  } catch (const Error& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find(fs::path(path).filename().string()), std::string::npos) << what;
    EXPECT_EQ(what.find('\n'), std::string::npos) << what;
  }
}

// A Collada file whose float_array says count="0" over three coordinates: assimp 5.2.5 dereferences a null
// pointer on it. Whatever assimp does with it, the caller gets a scene or one line, and lives on.
TEST_F(LoaderHostile, AFileThatCrashesAssimpIsOneLineAndTheCallerGoesOn) {
  const std::string path = write("crash.dae", collada(1, "0"));
  loadsOrIsOneLine(path);
  std::ostringstream warn;
  // The same loader, in the same process, reads a good file after it.
  EXPECT_EQ(loadSceneFile(write("good.dae", collada(1)), warn).indices.size(), 3u);
}

// A byte 0xff for the first index of the same file: assimp 5.2.5 allocated without end (12 GB over 100 s
// on this machine before it failed). The reader's memory follows the file's size: the caller is told
// within seconds.
TEST_F(LoaderHostile, AFileThatMakesAssimpAllocateWithoutEndIsOneLine) {
  std::string dae = collada(1);
  const size_t at = dae.find("<p>0 1 2</p>");
  ASSERT_NE(at, std::string::npos);
  dae[at + 3] = char(0xff);
  const std::string path = write("alloc.dae", dae);
  loadsOrIsOneLine(path);
}

// A binary little-endian PLY's header and its 3 float vertices, for `faces` faces read by `listLine`.
std::string plyVertices(size_t faces, const std::string& listLine = "property list uchar int vertex_indices") {
  std::string s = "ply\nformat binary_little_endian 1.0\nelement vertex 3\nproperty float x\nproperty float y\n"
                  "property float z\nelement face " + std::to_string(faces) + "\n" + listLine + "\nend_header\n";
  const float v[9] = {0, 0, 0, 1, 0, 0, 0, 1, 0};
  return s.append(reinterpret_cast<const char*>(v), sizeof v);
}

// The same with its faces, each a uchar count and int indices.
std::string binaryPly(const std::vector<std::vector<int32_t>>& faces, const std::string& tail = {}) {
  std::string s = plyVertices(faces.size());
  for (const auto& f : faces) {
    s += char(uint8_t(f.size()));
    s.append(reinterpret_cast<const char*>(f.data()), f.size() * 4);
  }
  return s + tail;
}

TEST_F(LoaderHostile, PlyLayoutIsWalkedBeforeAssimp) {
  std::ostringstream warn;
  EXPECT_EQ(loadSceneFile(write("ok.ply", binaryPly({{0, 1, 2}})), warn).indices.size(), 3u);
  // A face of no indices: assimp 5.2.5 takes it for a polygon and its triangulation aborts the process on
  // an ai_assert (found by the assimp fuzzer), binary or ASCII.
  refused(write("empty.ply", binaryPly({{}})), "PLY face 0 has no vertex indices");
  refused(write("empty2.ply", binaryPly({{0, 1, 2}, {}})), "PLY face 1 has no vertex indices");
  refused(write("empty.ply", "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\n"
                             "element face 1\nproperty list uchar int vertex_indices\nend_header\n0 0 0\n1 0 0\n0 1 0\n0\n"),
          "PLY face 0 has no vertex indices");
  // The binary data must be exactly what the header describes.
  refused(write("tail.ply", binaryPly({{0, 1, 2}}, std::string(16, '\0'))), "its elements take 49");
  refused(write("short.ply", plyVertices(2) + "\3" + std::string(12, '\0')), "ends inside 'face' 1 of 2");
  refused(write("cut.ply", plyVertices(1) + "\3" + std::string(8, '\0')), "more than the 8 bytes left hold");
  // List counts assimp would allocate: past the data, negative.
  refused(write("long.ply", plyVertices(1, "property list uint int vertex_indices") + std::string("\xff\xff\xff\x7f", 4) +
                                std::string(12, '\0')),
          "of 2147483647 values, more than the 12 bytes left hold");
  refused(write("negative.ply", plyVertices(1, "property list char int vertex_indices") + std::string("\xff", 1) +
                                    std::string(12, '\0')),
          "a negative count");
  refused(write("ascii.ply", "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\n"
                             "element face 1\nproperty list uint int vertex_indices\nend_header\n0 0 0\n1 0 0\n0 1 0\n4000000000 0 1 2\n"),
          "more than its line holds");
  // Header lines assimp would misread: unknown types, float list counts, properties cut off from their element,
  // a second vertex element (assimp writes it past the first's), triangle strips.
  refused(write("type.ply", plyVertices(1, "property list uchar int128 vertex_indices") + std::string(13, '\3')), "unknown type 'int128'");
  refused(write("fcount.ply", plyVertices(1, "property list float int vertex_indices") + std::string(16, '\0')), "not an integer type");
  std::string comment = binaryPly({{0, 1, 2}});
  comment.insert(comment.find("property float y"), "comment here\n");
  refused(write("comment.ply", comment), "'comment' after an element");
  std::string twice = binaryPly({{0, 1, 2}});
  twice.insert(twice.find("element face"), "element vertex 0\nproperty float x\n");
  refused(write("twice.ply", twice), "a second element 'vertex'");
  refused(write("strips.ply", "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\n"
                              "element tristrips 1\nproperty list int int vertex_indices\nend_header\n0 0 0\n1 0 0\n0 1 0\n2 0 1\n"),
          "tristrips");
  refused(write("nul.ply", std::string("ply\nformat ascii 1.0\nelement vertex 3\0\nend_header\n", 50)), "control byte (0)");
  // assimp's own PLY test models that it reads still load.
  for (const char* name : {"cube.ply", "cube_binary.ply", "cube_uv.ply", "Wuson.ply", "float-color.ply"}) {
    const std::string model = std::string("/usr/share/assimp/models/PLY/") + name;
    if (fs::exists(model)) EXPECT_GT(loadSceneFile(model, warn).indices.size(), 0u) << name;
  }
}

// ---- glTF -------------------------------------------------------------------------------------------

json oneTriangle() {
  // (0,0,0) (1,0,0) (0,1,0) as a base64 buffer of 36 bytes.
  return json::parse(R"({"asset": {"version": "2.0"}, "scene": 0, "scenes": [{"nodes": [0]}],
    "buffers": [{"uri": "data:application/octet-stream;base64,AAAAAAAAAAAAAAAAAACAPwAAAAAAAAAAAAAAAAAAgD8AAAAA", "byteLength": 36}],
    "bufferViews": [{"buffer": 0, "byteLength": 36}],
    "accessors": [{"bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3"}],
    "meshes": [{"primitives": [{"attributes": {"POSITION": 0}}]}],
    "nodes": [{"mesh": 0, "name": "tri"}],
    "cameras": [{"type": "perspective", "perspective": {"yfov": 0.8, "znear": 0.1, "zfar": 100}}]})");
}

TEST_F(LoaderHostile, GltfMatricesRootsVersionsAndContainers) {
  std::ostringstream warn;
  EXPECT_EQ(loadSceneFile(write("ok.gltf", oneTriangle().dump()), warn).indices.size(), 3u);
  json doc = oneTriangle();
  doc["nodes"][0]["matrix"] = {1, 0, 0, 0.5, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1};
  refused(write("projective.gltf", doc.dump()), "node 0 ('tri') has a matrix whose last row is (0.5, 0, 0, 1)");
  doc["nodes"][0]["matrix"] = {1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 0};
  refused(write("w0.gltf", doc.dump()), "last row is (0, 0, 0, 0)");
  doc = oneTriangle();
  doc["scenes"][0]["nodes"] = {0, 0};
  refused(write("twice.gltf", doc.dump()), "scene 0 lists node 0 ('tri') twice among its roots");
  doc = oneTriangle();
  doc["asset"]["minVersion"] = "2.5";
  refused(write("min.gltf", doc.dump()), "asset.minVersion is '2.5'");
  doc["asset"]["minVersion"] = "2.0";
  EXPECT_EQ(loadSceneFile(write("min20.gltf", doc.dump()), warn).indices.size(), 3u);

  // GLB: the header's length must be the file's, neither shorter nor longer.
  std::string text = oneTriangle().dump();
  while (text.size() % 4) text += ' ';
  auto glb = [&](int64_t lengthDelta, size_t trailing) {
    std::string out = "glTF";
    auto u32 = [&](uint32_t v) {
      for (int k = 0; k < 4; ++k) out += char(v >> (8 * k));
    };
    u32(2);
    u32(uint32_t(int64_t(20 + text.size() + trailing) + lengthDelta));
    u32(uint32_t(text.size()));
    out += "JSON" + text + std::string(trailing, ' ');
    return out;
  };
  EXPECT_EQ(loadSceneFile(write("ok.glb", glb(0, 0)), warn).indices.size(), 3u);
  refused(write("short.glb", glb(-8, 8)), "GLB header length says");
  refused(write("long.glb", glb(8, 0)), "GLB header length says");
}

TEST_F(LoaderHostile, CamerasFromFilesAreChecked) {
  std::ostringstream warn;
  auto camera = [&](const char* name, auto edit, const std::string& fragment) {
    json doc = oneTriangle();
    doc["nodes"].push_back({{"camera", 0}, {"translation", {0, 0, 5}}});
    doc["scenes"][0]["nodes"].push_back(1);
    edit(doc);
    refused(write(name, doc.dump()), fragment);
  };
  camera("fov.gltf", [](json& d) { d["cameras"][0]["perspective"]["yfov"] = 3.2; }, "yfov");
  camera("near.gltf", [](json& d) { d["cameras"][0]["perspective"]["znear"] = 0; }, "znear");
  camera("far.gltf", [](json& d) { d["cameras"][0]["perspective"]["zfar"] = 0.05; }, "zfar");
  // The ratio counts up to the scene's far side (about 5.2 from this camera), not to a zfar far beyond it.
  camera("ratio.gltf", [](json& d) { d["cameras"][0]["perspective"]["znear"] = 1e-7; },
         "zfar / znear = 5.2e+07 (zfar taken at the scene's far side)");
  {
    json doc = oneTriangle();
    doc["nodes"].push_back({{"camera", 0}, {"translation", {0, 0, 5}}});
    doc["scenes"][0]["nodes"].push_back(1);
    doc["cameras"][0]["perspective"]["zfar"] = 1e9;
    doc["cameras"][0]["perspective"]["znear"] = 1;
    EXPECT_EQ(loadSceneFile(write("deep.gltf", doc.dump()), warn).cameras.size(), 1u);
  }
  camera("infinite.gltf", [](json& d) { d["nodes"][1]["translation"] = {1e39, 0, 0}; }, "at infinity");
  camera("tiny.gltf", [](json& d) { d["cameras"][0]["perspective"]["znear"] = 1e-50; }, "znear");
  // BART: the view's position, near plane and ratio.
  const std::string tri = "p 3 0 0 0 1 0 0 0 1 0\n";
  auto view = [](const std::string& from, const std::string& hither) {
    return "v\nfrom " + from + "\nat 0 0 0\nup 0 1 0\nangle 45\nhither " + hither + "\nresolution 64 64\n";
  };
  EXPECT_EQ(loadSceneFile(write("ok.aff", view("0 0 5", "0.01") + tri), warn).cameras.size(), 1u);
  EXPECT_EQ(loadSceneFile(write("unset.aff", view("0 0 5", "0") + tri), warn).cameras.size(), 1u);
  refused(write("far.aff", view("1e39 0 0", "1") + tri), "the view (v) has a position at infinity");
  refused(write("neg.aff", view("0 0 5", "-1") + tri), "hither");
  refused(write("ratio.aff", view("0 0 5", "1e-9") + tri), "zfar / znear");
}

// ---- messages ---------------------------------------------------------------------------------------

TEST_F(LoaderHostile, MessagesQuoteLittleOfTheInput) {
  json doc = oneTriangle();
  doc["scene"] = std::string(1 << 20, 'Q');  // a 1 MB string where an index belongs
  const std::string big = refused(write("token.gltf", doc.dump()), "scene must be a non-negative integer");
  EXPECT_EQ(big.find(std::string(61, 'Q')), std::string::npos) << big.size();
  std::string nul = "p 3 0 0 0 1 0 0 0 1 ";
  nul += std::string("1\0zz", 4) + "\n";
  const std::string cut = refused(write("nul.aff", nul), "expected a vertex, got '1?zz'");
  refused(write("long.aff", "p 3 0 0 0 1 0 0 0 1 " + std::string(100000, '7') + "x\n"), "characters)");
  EXPECT_EQ(quoteInput(std::string("a\nb\0c", 5)), "'a?b?c'");
  std::string clipped(1, '\'');
  clipped.append(60, 'x').append("'... (100 characters)");
  EXPECT_EQ(quoteInput(std::string(100, 'x')), clipped);
  EXPECT_EQ(oneLineClipped("one\ntwo\r\nthree"), "one; two; three");
}

}  // namespace
}  // namespace cs
