#include "io/image.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <functional>
#include <stdexcept>

#include <stb/stb_image_write.h>
#include <tinyexr.h>

#include "io/exr_write.h"
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

std::vector<uint8_t> png_of(const std::string& path, int width, int height, const std::vector<float>& rgb,
                            float exposure_stops) {
  const float scale = std::exp2(exposure_stops);
  std::vector<unsigned char> px(rgb.size());
  for (size_t i = 0; i < rgb.size(); ++i) px[i] = to_srgb8(rgb[i] * scale);
  return encode_png(path, width, height, 3, px.data());
}

}  // namespace

void write_image(const std::string& path, int width, int height, const std::vector<float>& rgb,
                 float exposure_stops, const ExrOptions& exr) {
  const std::string ext = extension(path);
  if (rgb.size() != size_t(width) * height * 3) throw std::logic_error("write_image: buffer size mismatch");
  if (ext == "exr") {
    const std::vector<uint8_t> bytes = encode_exr(width, height, rgb, exr);
    write_file_atomic(path, bytes.data(), bytes.size());
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
