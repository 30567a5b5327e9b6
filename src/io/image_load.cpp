#include "io/image_load.h"

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <iterator>

#include <stb/stb_image.h>
#include <tinyexr.h>

#include "render/resources.h"

namespace pn {

namespace {

std::string lower_extension(const std::string& path) {
  auto slash = path.find_last_of("/\\");
  auto dot = path.find_last_of('.');
  if (dot == std::string::npos || (slash != std::string::npos && dot < slash)) return "";
  std::string ext = path.substr(dot + 1);
  std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return char(std::tolower(c)); });
  return ext;
}

bool size_ok(int w, int h, std::string* error) {
  if (w <= 0 || h <= 0) {
    *error = "image has no pixels";
    return false;
  }
  if (size_t(w) * size_t(h) > kMaxImageTexels) {
    *error = "image too large (" + std::to_string(w) + "x" + std::to_string(h) + ")";
    return false;
  }
  return true;
}

float srgb_decode(float c) { return c <= 0.04045f ? c / 12.92f : std::pow((c + 0.055f) / 1.055f, 2.4f); }

// Radiance is finite and never negative: channels that are not become 0.
// Returns how many texels had one.
size_t repair_float_texels(std::vector<uint8_t>& texels) {
  size_t repaired = 0;
  const size_t n = texels.size() / 16;
  for (size_t i = 0; i < n; ++i) {
    float c[4];
    std::memcpy(c, &texels[16 * i], sizeof c);
    bool bad = false;
    for (float& v : c)
      if (!(v >= 0.f) || !std::isfinite(v)) {  // NaN fails v >= 0
        v = 0.f;
        bad = true;
      }
    if (bad) {
      std::memcpy(&texels[16 * i], c, sizeof c);
      ++repaired;
    }
  }
  return repaired;
}

bool is_exr(const uint8_t* d, size_t n) { return n >= 4 && d[0] == 0x76 && d[1] == 0x2f && d[2] == 0x31 && d[3] == 0x01; }

// Whether decoding a w x h image fits in memory: ours, the decoder's own copy
// and (EXR) its per-channel planes. Checked from the header, before decoding.
bool memory_ok(int w, int h, bool is_float, std::string* error) {
  const uint64_t texels = uint64_t(w) * uint64_t(h);
  try {
    check_memory("decoding a " + std::to_string(w) + "x" + std::to_string(h) + " image",
                 {{"texels", texels * (is_float ? 16 : 4)}, {"the decoder's buffers", texels * (is_float ? 32 : 4)}});
  } catch (const std::exception& e) {
    *error = e.what();
    return false;
  }
  return true;
}

bool decode_exr(const uint8_t* data, size_t size, DecodedImage* out, std::string* error) {
  {  // the size, from the header
    EXRVersion version;
    EXRHeader header;
    InitEXRHeader(&header);
    const char* err = nullptr;
    if (ParseEXRVersionFromMemory(&version, data, size) != TINYEXR_SUCCESS) {
      *error = "cannot decode EXR: not an OpenEXR file";
      return false;
    }
    if (ParseEXRHeaderFromMemory(&header, &version, data, size, &err) != TINYEXR_SUCCESS) {
      *error = std::string("cannot decode EXR: ") + (err ? err : "invalid header");
      if (err) FreeEXRErrorMessage(err);
      return false;
    }
    const int64_t w = int64_t(header.data_window.max_x) - header.data_window.min_x + 1;
    const int64_t h = int64_t(header.data_window.max_y) - header.data_window.min_y + 1;
    FreeEXRHeader(&header);
    if (w <= 0 || h <= 0 || w > (int64_t(1) << 30) || h > (int64_t(1) << 30)) {
      *error = "cannot decode EXR: invalid data window";
      return false;
    }
    if (!size_ok(int(w), int(h), error) || !memory_ok(int(w), int(h), true, error)) return false;
  }
  float* rgba = nullptr;
  const char* err = nullptr;
  int w = 0, h = 0;
  int rc = LoadEXRFromMemory(&rgba, &w, &h, data, size, &err);
  if (rc != TINYEXR_SUCCESS) {
    *error = std::string("cannot decode EXR: ") + (err ? err : "unknown error");
    if (err) FreeEXRErrorMessage(err);
    if (rgba) free(rgba);
    return false;
  }
  if (!size_ok(w, h, error)) {
    free(rgba);
    return false;
  }
  out->width = w;
  out->height = h;
  out->is_float = true;
  out->texels.resize(size_t(w) * h * 16);
  std::memcpy(out->texels.data(), rgba, out->texels.size());
  free(rgba);
  out->repaired_texels = repair_float_texels(out->texels);
  return true;
}

}  // namespace

bool is_hdr_path(const std::string& path) {
  std::string e = lower_extension(path);
  return e == "hdr" || e == "exr";
}

bool decode_image_memory(const uint8_t* data, size_t size, bool want_float, DecodedImage* out, std::string* error) {
  *out = DecodedImage();
  if (data == nullptr || size == 0) {
    *error = "empty image data";
    return false;
  }
  if (size > size_t(1) << 31) {
    *error = "image data too large";
    return false;
  }
  if (is_exr(data, size)) {
    if (!want_float) {
      *error = "an EXR (float) image cannot be a colour or data texture";
      return false;
    }
    return decode_exr(data, size, out, error);
  }
  int w = 0, h = 0, comp = 0;
  if (!stbi_info_from_memory(data, int(size), &w, &h, &comp)) {
    const char* why = stbi_failure_reason();
    *error = std::string("cannot decode image: ") + (why ? why : "unknown format");
    return false;
  }
  if (!size_ok(w, h, error)) return false;
  const bool hdr = stbi_is_hdr_from_memory(data, int(size)) != 0;
  if (!memory_ok(w, h, want_float, error)) return false;
  if (want_float) {
    // stbi_loadf would linearize 8-bit images with gamma 2.2; decode sRGB exactly instead.
    if (hdr) {
      float* f = stbi_loadf_from_memory(data, int(size), &w, &h, &comp, 4);
      if (!f) {
        const char* why = stbi_failure_reason();
        *error = std::string("cannot decode image: ") + (why ? why : "unknown error");
        return false;
      }
      out->texels.resize(size_t(w) * h * 16);
      std::memcpy(out->texels.data(), f, out->texels.size());
      stbi_image_free(f);
      out->repaired_texels = repair_float_texels(out->texels);
    } else {
      unsigned char* p = stbi_load_from_memory(data, int(size), &w, &h, &comp, 4);
      if (!p) {
        const char* why = stbi_failure_reason();
        *error = std::string("cannot decode image: ") + (why ? why : "unknown error");
        return false;
      }
      out->texels.resize(size_t(w) * h * 16);
      float* f = reinterpret_cast<float*>(out->texels.data());
      for (size_t i = 0; i < size_t(w) * h * 4; ++i)
        f[i] = (i % 4 == 3) ? p[i] / 255.f : srgb_decode(p[i] / 255.f);
      stbi_image_free(p);
    }
    out->width = w;
    out->height = h;
    out->is_float = true;
    return true;
  }
  if (hdr) {
    *error = "an HDR (float) image cannot be a colour or data texture";
    return false;
  }
  unsigned char* p = stbi_load_from_memory(data, int(size), &w, &h, &comp, 4);
  if (!p) {
    const char* why = stbi_failure_reason();
    *error = std::string("cannot decode image: ") + (why ? why : "unknown error");
    return false;
  }
  out->width = w;
  out->height = h;
  out->is_float = false;
  out->texels.assign(p, p + size_t(w) * h * 4);
  stbi_image_free(p);
  return true;
}

bool decode_image_file(const std::string& path, bool want_float, DecodedImage* out, std::string* error) {
  std::ifstream in(path, std::ios::binary);
  if (!in) {
    *error = "cannot open the file";
    return false;
  }
  in.seekg(0, std::ios::end);
  std::streamoff n = in.tellg();
  if (n <= 0) {
    *error = "the file is empty";
    return false;
  }
  if (n > (std::streamoff(1) << 31)) {
    *error = "the file is too large";
    return false;
  }
  in.seekg(0);
  std::vector<uint8_t> bytes(static_cast<size_t>(n));
  if (!in.read(reinterpret_cast<char*>(bytes.data()), n)) {
    *error = "cannot read the file";
    return false;
  }
  return decode_image_memory(bytes.data(), bytes.size(), want_float, out, error);
}

}  // namespace pn
