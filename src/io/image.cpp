#include "io/image.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include <stb/stb_image_write.h>
#include <tinyexr.h>

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

void write_image(const std::string& path, int width, int height, const std::vector<float>& rgb,
                 float exposure_stops) {
  std::string ext = extension(path);
  if (rgb.size() != size_t(width) * height * 3) throw std::logic_error("write_image: buffer size mismatch");
  if (ext == "exr") {
    const char* err = nullptr;
    int rc = SaveEXR(rgb.data(), width, height, 3, /*save_as_fp16=*/0, path.c_str(), &err);
    if (rc != TINYEXR_SUCCESS) {
      std::string msg = err ? err : "unknown error";
      if (err) FreeEXRErrorMessage(err);
      throw std::runtime_error(path + ": cannot write EXR: " + msg);
    }
    return;
  }
  if (ext == "png") {
    float scale = std::exp2(exposure_stops);
    std::vector<unsigned char> px(rgb.size());
    for (size_t i = 0; i < rgb.size(); ++i) px[i] = to_srgb8(rgb[i] * scale);
    if (!stbi_write_png(path.c_str(), width, height, 3, px.data(), width * 3))
      throw std::runtime_error(path + ": cannot write PNG (does the folder exist and is it writable?)");
    return;
  }
  throw std::runtime_error(path + ": unknown image format '." + ext + "' (use .exr or .png)");
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
