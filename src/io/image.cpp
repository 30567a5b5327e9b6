#include "io/image.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <functional>
#include <stdexcept>

#include <stb/stb_image_write.h>
#include <tinyexr.h>

#include "io/output.h"

namespace pn {

namespace {
std::string extension(const std::string& path) {
  auto dot = path.find_last_of('.');
  if (dot == std::string::npos) return "";
  std::string ext = path.substr(dot + 1);
  std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return char(std::tolower(c)); });
  return ext;
}
}  // namespace

void check_image_path(const std::string& path) {
  std::string ext = extension(path);
  if (ext != "exr" && ext != "png")
    throw std::runtime_error(path + ": unknown image format '." + ext + "' (use .exr or .png)");
}

unsigned char to_srgb8(float v) {
  if (!(v > 0.f)) return 0;  // also maps NaN to 0
  float s = v <= 0.0031308f ? 12.92f * v : 1.055f * std::pow(v, 1.f / 2.4f) - 0.055f;
  return (unsigned char)std::lround(std::min(1.f, s) * 255.f);
}

std::vector<uint8_t> encode_png(const std::string& path, int width, int height, int channels, const uint8_t* pixels) {
  std::vector<uint8_t> out;
  auto append = [](void* ctx, void* data, int size) {
    auto* v = static_cast<std::vector<uint8_t>*>(ctx);
    const auto* b = static_cast<const uint8_t*>(data);
    v->insert(v->end(), b, b + size);
  };
  if (!stbi_write_png_to_func(append, &out, width, height, channels, pixels, width * channels) || out.empty())
    throw std::runtime_error(path + ": cannot encode PNG (" + std::to_string(width) + "x" + std::to_string(height) +
                             ")");
  return out;
}

namespace {

// tinyexr's SaveEXR, into memory: float32 RGB planes in the B, G, R order most
// readers expect, ZIP-compressed (uncompressed below 16x16, as SaveEXR does).
// `use` gets tinyexr's buffer, freed after it returns (a large image is not
// copied once more).
void with_exr(const std::string& path, int width, int height, const std::vector<float>& rgb,
              const std::function<void(const uint8_t*, size_t)>& use) {
  const size_t n = size_t(width) * size_t(height);
  std::vector<float> planes[3];
  for (int c = 0; c < 3; ++c) {
    planes[c].resize(n);
    for (size_t i = 0; i < n; ++i) planes[c][i] = rgb[3 * i + size_t(c)];
  }
  float* ptr[3] = {planes[2].data(), planes[1].data(), planes[0].data()};  // B, G, R
  EXRImage image;
  InitEXRImage(&image);
  image.num_channels = 3;
  image.images = reinterpret_cast<unsigned char**>(ptr);
  image.width = width;
  image.height = height;
  EXRHeader header;
  InitEXRHeader(&header);
  header.compression_type = (width < 16 && height < 16) ? TINYEXR_COMPRESSIONTYPE_NONE : TINYEXR_COMPRESSIONTYPE_ZIP;
  EXRChannelInfo channels[3] = {};
  int types[3] = {TINYEXR_PIXELTYPE_FLOAT, TINYEXR_PIXELTYPE_FLOAT, TINYEXR_PIXELTYPE_FLOAT};
  const char* names[3] = {"B", "G", "R"};
  for (int c = 0; c < 3; ++c) std::snprintf(channels[c].name, sizeof channels[c].name, "%s", names[c]);
  header.num_channels = 3;
  header.channels = channels;
  header.pixel_types = types;
  header.requested_pixel_types = types;
  unsigned char* mem = nullptr;
  const char* err = nullptr;
  size_t size = SaveEXRImageToMemory(&image, &header, &mem, &err);
  if (size == 0 || !mem) {
    std::string msg = err ? err : "unknown error";
    if (err) FreeEXRErrorMessage(err);
    if (mem) free(mem);
    throw std::runtime_error(path + ": cannot encode EXR: " + msg);
  }
  for (auto& p : planes) std::vector<float>().swap(p);  // not needed while the bytes are used
  struct Free {
    unsigned char* m;
    ~Free() { free(m); }
  } owned{mem};
  use(mem, size);
}

std::vector<uint8_t> png_of(const std::string& path, int width, int height, const std::vector<float>& rgb,
                            float exposure_stops) {
  const float scale = std::exp2(exposure_stops);
  std::vector<unsigned char> px(rgb.size());
  for (size_t i = 0; i < rgb.size(); ++i) px[i] = to_srgb8(rgb[i] * scale);
  return encode_png(path, width, height, 3, px.data());
}

}  // namespace

void write_image(const std::string& path, int width, int height, const std::vector<float>& rgb,
                 float exposure_stops) {
  const std::string ext = extension(path);
  if (rgb.size() != size_t(width) * height * 3) throw std::logic_error("write_image: buffer size mismatch");
  if (ext == "exr") {
    with_exr(path, width, height, rgb,
             [&](const uint8_t* bytes, size_t size) { write_file_atomic(path, bytes, size); });
  } else if (ext == "png") {
    const std::vector<uint8_t> bytes = png_of(path, width, height, rgb, exposure_stops);
    write_file_atomic(path, bytes.data(), bytes.size());
  } else {
    throw std::runtime_error(path + ": unknown image format '." + ext + "' (use .exr or .png)");
  }
}

std::vector<float> read_exr(const std::string& path, int* width, int* height) {
  float* data = nullptr;
  const char* err = nullptr;
  int rc = LoadEXR(&data, width, height, path.c_str(), &err);
  if (rc != TINYEXR_SUCCESS) {
    std::string msg = err ? err : "unknown error";
    if (err) FreeEXRErrorMessage(err);
    throw std::runtime_error(path + ": cannot read EXR: " + msg);
  }
  std::vector<float> rgb(size_t(*width) * *height * 3);
  for (size_t i = 0; i < size_t(*width) * *height; ++i)
    for (int c = 0; c < 3; ++c) rgb[3 * i + c] = data[4 * i + c];  // LoadEXR returns RGBA
  free(data);
  return rgb;
}

}  // namespace pn
