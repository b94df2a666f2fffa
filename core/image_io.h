// Image and file output: PNG (stb_image_write), PFM and OpenEXR (float images, for dumps an independent
// tool reads back), written atomically — to a temporary name, then renamed — so a failure never leaves a
// partial file under the final name. Every failure is a cs::Error naming the path and the reason.
#pragma once
#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

namespace cs {

// A file-name component made from a name that comes from data (a camera's name in a glTF or BART file):
// names are data, never paths. Letters, digits and "-_.@,+" are kept, every other byte becomes '_', a
// leading '.' becomes '_' (no ".", "..", hidden files), at most 64 bytes; empty gives "unnamed".
std::string fileStem(const std::string& name);

// Writes `bytes` to `path` via `path.tmp.<pid>` + rename. Does not create directories.
void writeFileAtomic(const std::string& path, std::string_view bytes);

// 8-bit RGB, rows top to bottom (row 0 = top of the image, as in the G-buffer); rgb.size() == w*h*3.
void writePng(const std::string& path, uint32_t width, uint32_t height, const std::vector<uint8_t>& rgb);

// PFM ("PF" = 3 channels, "Pf" = 1 channel), little-endian (scale -1.0). `data` is given rows top to
// bottom (row 0 = top, as in the G-buffer), `channels` floats per pixel; the file stores the bottom row
// first, as the format requires, so readers that follow the PFM convention see the image upright.
void writePfm(const std::string& path, uint32_t width, uint32_t height, int channels, const std::vector<float>& data);

// OpenEXR, the same data as writePfm (1 channel "Y", 3 channels "R", "G", "B"; 32-bit float, ZIP), rows
// top to bottom as EXR stores them: what tev, OpenImageIO and Python's EXR readers open directly.
void writeExr(const std::string& path, uint32_t width, uint32_t height, int channels, const std::vector<float>& data);

struct PfmImage {
  uint32_t width = 0, height = 0;
  int channels = 0;
  std::vector<float> data;  // rows top to bottom (converted from the file's bottom-first order)
};
// Reads a PFM written by writePfm or any conforming writer (either endianness).
PfmImage readPfm(const std::string& path);

}  // namespace cs
