// `coneshadow visibility SCENE --samples FILE`: the exact shadow visibility of samples of the caller's own
// (a text file, one sample a line: x y z nx ny nz) from the scene's lights or --light, through the cone
// engine (harness/samples.h), and with --reference Embree's answer and the ambiguity band beside it.
// Writes a CSV, one row a sample: facing_<l> and visible_<l> per light (then embree_<l>, band_<l>).
#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <sstream>

#include "app/commands.h"
#include "app/frame_runner.h"
#include "core/image_io.h"
#include "harness/samples.h"

namespace fs = std::filesystem;

namespace cs {

namespace {

constexpr const char* kHeader = "# coneshadow visibility";  // an output's first line: only such a file is replaced
constexpr size_t kMaxSamples = size_t(1) << 26;

// The samples of `path`: a line each, six numbers separated by spaces, tabs or commas; blank lines and
// lines starting with # are skipped. Any other line is an error naming the file and line.
void readSamples(const std::string& path, std::vector<glm::vec3>& points, std::vector<glm::vec3>& normals) {
  std::ifstream in(path);
  if (!in) throw Error("cannot open the samples file", path, "give a text file, a sample a line: x y z nx ny nz");
  std::string line;
  for (size_t number = 1; std::getline(in, line); ++number) {
    const size_t first = line.find_first_not_of(" \t\r");
    if (first == std::string::npos || line[first] == '#') continue;
    // Six fields separated by spaces, tabs or commas, each a whole finite number.
    std::vector<std::string> fields;
    std::string field;
    for (char c : line + " ") {
      if (c == ' ' || c == '\t' || c == ',' || c == '\r') {
        if (!field.empty()) fields.push_back(field);
        field.clear();
      } else {
        field += c;
      }
    }
    float v[6] = {};
    bool ok = fields.size() == 6;
    for (size_t k = 0; ok && k < 6; ++k) {
      char* end = nullptr;
      errno = 0;
      v[k] = std::strtof(fields[k].c_str(), &end);
      // ERANGE with a finite result is an underflow to a denormal or zero: a finite number all the same.
      ok = *end == '\0' && (!errno || errno == ERANGE) && std::isfinite(v[k]);
    }
    const glm::vec3 x(v[0], v[1], v[2]), nv(v[3], v[4], v[5]);
    if (!ok)
      throw Error("expected six finite numbers x y z nx ny nz, got '" + line.substr(0, 80) + "'",
                  path + ":" + std::to_string(number), "a sample a line; # starts a comment");
    const float len = glm::length(nv);
    if (!std::isfinite(len) || !(len > 0))
      throw Error("the normal is zero or too large", path + ":" + std::to_string(number), "give a non-zero normal");
    if (points.size() == kMaxSamples)
      throw Error("more than 2^26 samples", path, "split the samples into several files");
    points.push_back(x);
    normals.push_back(nv);
  }
  if (in.bad()) throw Error("cannot read the samples file", path);
  if (points.empty()) throw Error("no sample in the file", path, "a sample a line: x y z nx ny nz");
}

}  // namespace

int runVisibility(const Options& o) {
  std::error_code ec;
  if (!o.samplesOut.empty() && o.samplesOut != "-") {
    if (fs::exists(o.samplesOut, ec) && fs::equivalent(o.samplesOut, o.samples, ec))
      throw UsageError("--out " + o.samplesOut + " is the samples file: give another file");
    if (fs::exists(o.samplesOut, ec)) {
      std::ifstream old(o.samplesOut);
      std::string first;
      std::getline(old, first);
      if (!fs::is_regular_file(o.samplesOut, ec) || first.rfind(kHeader, 0) != 0)
        throw Error("it exists and was not written by coneshadow visibility: it is left as it is", "--out " + o.samplesOut,
                    "give a new file name");
    }
  }
  std::vector<glm::vec3> points, normals;
  readSamples(o.samples, points, normals);
  Scene scene = loadSceneArg(o, std::cerr);
  const std::vector<glm::vec3> lights = chooseLights(scene, o);
  auto ctx = commandContext(o);
  SampleEngine engine;
  const SampleAnswers a = sampleVisibility(*ctx, engine, scene, sampleGrid(points, normals), lights, o.reference);

  std::ostringstream csv;
  csv << kHeader << ": " << scene.name << ", " << a.count << " samples of " << o.samples << ", " << a.lights
      << (a.lights == 1 ? " light" : " lights");
  for (const glm::vec3& l : lights) csv << " (" << l.x << "," << l.y << "," << l.z << ")";
  csv << "\n";
  const char* columns[] = {"facing", "visible", "embree", "band"};
  const std::vector<uint8_t>* answers[] = {&a.facing, &a.visible, &a.reference, &a.band};
  const int kinds = o.reference ? 4 : 2;
  for (int k = 0; k < kinds; ++k)
    for (size_t l = 0; l < a.lights; ++l) csv << (k || l ? "," : "") << columns[k] << "_" << l;
  csv << "\n";
  for (size_t i = 0; i < a.count; ++i) {
    for (int k = 0; k < kinds; ++k)
      for (size_t l = 0; l < a.lights; ++l) csv << (k || l ? "," : "") << int((*answers[k])[l * a.count + i]);
    csv << "\n";
  }
  if (o.samplesOut.empty() || o.samplesOut == "-")
    std::cout << csv.str() << std::flush;
  else
    writeFileAtomic(o.samplesOut, csv.str());

  // The summary: per light, the visible samples and, with the reference, the disagreements outside the band.
  for (size_t l = 0; l < a.lights; ++l) {
    size_t visible = 0, wrong = 0, band = 0;
    for (size_t i = 0; i < a.count; ++i) {
      visible += a.visible[l * a.count + i];
      if (!o.reference) continue;
      band += a.band[l * a.count + i];
      wrong += !a.band[l * a.count + i] && a.visible[l * a.count + i] != a.reference[l * a.count + i];
    }
    std::cerr << "visibility: light " << l << ": " << visible << " of " << a.count << " samples visible";
    if (o.reference) std::cerr << "; against Embree " << wrong << " wrong outside the band of " << band << " samples";
    std::cerr << "\n";
  }
  return kExitOk;
}

}  // namespace cs
