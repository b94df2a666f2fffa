// PNG / PFM / EXR writers and the PFM reader; all files go out through writeFileAtomic.
#include "core/image_io.h"

#include <unistd.h>

#include <bit>
#include <cctype>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <sstream>

#include <stb_image_write.h>  // implementation compiled once, in core/tinygltf_impl.cpp
#include <tinyexr.h>          // declarations only; the implementation is Debian's libtinyexr

#include "core/error.h"

namespace cs {

std::string fileStem(const std::string& name) {
  std::string out;
  for (unsigned char c : name) {
    if (out.size() >= 64) break;
    const bool keep = std::isalnum(c) || c == '-' || c == '_' || c == '.' || c == '@' || c == ',' || c == '+';
    out += keep && c < 0x80 ? char(c) : '_';
  }
  if (out.empty()) return "unnamed";
  if (out[0] == '.') out[0] = '_';
  return out;
}

namespace {

std::string errnoText(int err) { return err ? std::strerror(err) : "unknown I/O error"; }

void checkImageSize(const std::string& path, uint32_t width, uint32_t height, size_t elements, size_t perPixel) {
  if (width == 0 || height == 0) throw Error("image has zero size", path);
  if (elements != size_t(width) * height * perPixel) {
    std::ostringstream os;
    os << "image data has " << elements << " values, " << width << "x" << height << "x" << perPixel
       << " expected";
    throw Error(os.str(), path);
  }
}

}  // namespace

void writeFileAtomic(const std::string& path, std::string_view bytes) {
  // The pid keeps two processes writing the same path from sharing a temporary.
  const std::string tmp = path + ".tmp." + std::to_string(::getpid());
  std::FILE* f = std::fopen(tmp.c_str(), "wb");
  if (!f) throw Error("cannot create file: " + errnoText(errno), path, "does the directory exist and is it writable?");
  size_t written = bytes.empty() ? 0 : std::fwrite(bytes.data(), 1, bytes.size(), f);
  int writeErr = (written != bytes.size() || std::fflush(f) != 0) ? errno : 0;
  bool failed = written != bytes.size() || writeErr != 0;
  if (std::fclose(f) != 0 && !failed) {
    failed = true;
    writeErr = errno;
  }
  if (failed) {
    std::remove(tmp.c_str());
    throw Error("cannot write file: " + errnoText(writeErr), path, "is the disk full?");
  }
  if (std::rename(tmp.c_str(), path.c_str()) != 0) {
    int err = errno;
    std::remove(tmp.c_str());
    throw Error("cannot rename " + tmp + " into place: " + errnoText(err), path);
  }
}

void writePng(const std::string& path, uint32_t width, uint32_t height, const std::vector<uint8_t>& rgb) {
  checkImageSize(path, width, height, rgb.size(), 3);
  // Encode in memory, then write ourselves: stb's own file writer cannot say why it failed.
  std::string encoded;
  auto append = [](void* context, void* data, int size) {
    static_cast<std::string*>(context)->append(static_cast<const char*>(data), size_t(size));
  };
  if (!stbi_write_png_to_func(append, &encoded, int(width), int(height), 3, rgb.data(), int(width) * 3))
    throw Error("PNG encoding failed", path);
  writeFileAtomic(path, encoded);
}

void writePfm(const std::string& path, uint32_t width, uint32_t height, int channels, const std::vector<float>& data) {
  if (channels != 1 && channels != 3) throw Error("PFM takes 1 or 3 channels, not " + std::to_string(channels), path);
  checkImageSize(path, width, height, data.size(), size_t(channels));
  static_assert(std::endian::native == std::endian::little, "scale -1.0 declares little-endian floats");
  std::string header = std::string(channels == 3 ? "PF" : "Pf") + "\n" + std::to_string(width) + " " +
                       std::to_string(height) + "\n-1.0\n";
  std::string bytes = header;
  const size_t rowFloats = size_t(width) * size_t(channels);
  bytes.resize(header.size() + data.size() * sizeof(float));
  char* dst = bytes.data() + header.size();
  // PFM's first stored row is the image's bottom row.
  for (uint32_t fileRow = 0; fileRow < height; ++fileRow) {
    const float* src = data.data() + size_t(height - 1 - fileRow) * rowFloats;
    std::memcpy(dst + size_t(fileRow) * rowFloats * sizeof(float), src, rowFloats * sizeof(float));
  }
  writeFileAtomic(path, bytes);
}

void writeExr(const std::string& path, uint32_t width, uint32_t height, int channels, const std::vector<float>& data) {
  if (channels != 1 && channels != 3) throw Error("EXR dumps take 1 or 3 channels, not " + std::to_string(channels), path);
  checkImageSize(path, width, height, data.size(), size_t(channels));
  // Planar, channels in the alphabetical order readers expect (B, G, R).
  const size_t pixels = size_t(width) * height;
  std::vector<std::vector<float>> planes(static_cast<size_t>(channels), std::vector<float>(pixels));
  for (size_t i = 0; i < pixels; ++i)
    for (int c = 0; c < channels; ++c) planes[size_t(channels - 1 - c)][i] = data[i * size_t(channels) + size_t(c)];
  std::vector<unsigned char*> planePointers;
  for (auto& p : planes) planePointers.push_back(reinterpret_cast<unsigned char*>(p.data()));
  std::vector<EXRChannelInfo> info(static_cast<size_t>(channels));
  const char* names3[] = {"B", "G", "R"};
  for (int c = 0; c < channels; ++c) {
    info[size_t(c)] = EXRChannelInfo{};
    std::snprintf(info[size_t(c)].name, sizeof(info[size_t(c)].name), "%s", channels == 1 ? "Y" : names3[c]);
  }
  std::vector<int> types(size_t(channels), TINYEXR_PIXELTYPE_FLOAT), requested(size_t(channels), TINYEXR_PIXELTYPE_FLOAT);
  EXRHeader header;
  InitEXRHeader(&header);
  header.num_channels = channels;
  header.channels = info.data();
  header.pixel_types = types.data();
  header.requested_pixel_types = requested.data();
  header.compression_type = TINYEXR_COMPRESSIONTYPE_ZIP;
  EXRImage image;
  InitEXRImage(&image);
  image.num_channels = channels;
  image.images = planePointers.data();
  image.width = int(width);
  image.height = int(height);
  unsigned char* memory = nullptr;
  const char* err = nullptr;
  const size_t size = SaveEXRImageToMemory(&image, &header, &memory, &err);
  if (size == 0 || !memory) {
    const std::string why = err ? err : "unknown reason";
    if (err) FreeEXRErrorMessage(err);
    std::free(memory);
    throw Error("cannot encode EXR: " + why, path);
  }
  const std::string bytes(reinterpret_cast<const char*>(memory), size);
  std::free(memory);
  writeFileAtomic(path, bytes);
}

PfmImage readPfm(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw Error("cannot open file: " + errnoText(errno), path);
  std::string magic;
  long long w = 0, h = 0;
  double scale = 0;
  in >> magic >> w >> h >> scale;
  if (!in || (magic != "PF" && magic != "Pf")) throw Error("not a PFM file (bad header)", path);
  if (w <= 0 || h <= 0 || w > (1 << 20) || h > (1 << 20) || scale == 0)
    throw Error("PFM header has an invalid size or scale", path);
  in.get();  // the single whitespace character that ends the header
  PfmImage img;
  img.width = uint32_t(w);
  img.height = uint32_t(h);
  img.channels = magic == "PF" ? 3 : 1;
  const size_t rowFloats = size_t(w) * size_t(img.channels);
  std::vector<float> file(rowFloats * size_t(h));
  in.read(reinterpret_cast<char*>(file.data()), std::streamsize(file.size() * sizeof(float)));
  if (size_t(in.gcount()) != file.size() * sizeof(float)) throw Error("PFM file is truncated", path);
  const bool fileLittle = scale < 0;
  if (fileLittle != (std::endian::native == std::endian::little))
    for (float& f : file) {
      uint32_t u;
      std::memcpy(&u, &f, 4);
      u = __builtin_bswap32(u);
      std::memcpy(&f, &u, 4);
    }
  img.data.resize(file.size());
  for (size_t row = 0; row < size_t(h); ++row)
    std::memcpy(img.data.data() + row * rowFloats, file.data() + (size_t(h) - 1 - row) * rowFloats,
                rowFloats * sizeof(float));
  return img;
}

}  // namespace cs
