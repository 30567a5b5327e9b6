// Fuzz target: the image loaders of textures and environments: PNG, BMP, TGA,
// Radiance HDR (stb_image), JPEG (libjpeg-turbo) and OpenEXR (tinyexr), as
// 8-bit and as float.
#include <cstdint>
#include <string>

#include <tinyexr.h>

#include "io/image_load.h"

namespace {

// Images up to kMaxImageTexels (2^28) are accepted, up to 4 GiB as floats:
// decoding a header that claims that much is correct, and slow, and beyond
// libFuzzer's memory limit. The harness leaves out headers of more than 2^18
// texels (512 x 512): the decoders take the same paths for smaller images, and
// each input then takes milliseconds, not tenths of a second.
constexpr int64_t kMaxFuzzTexels = int64_t(1) << 18;

bool too_large(const uint8_t* data, size_t size) {
  int w = 0, h = 0;
  if (pn::image_dimensions(data, size, &w, &h)) return int64_t(w) * h > kMaxFuzzTexels;
  EXRVersion version;
  if (ParseEXRVersionFromMemory(&version, data, size) != TINYEXR_SUCCESS) return false;
  std::string why;
  if (!pn::exr_header_parsable(data, size, &why)) return false;  // tinyexr would abort on it (the loader refuses it)
  EXRHeader header;
  InitEXRHeader(&header);
  const char* err = nullptr;
  if (ParseEXRHeaderFromMemory(&header, &version, data, size, &err) != TINYEXR_SUCCESS) {
    if (err) FreeEXRErrorMessage(err);
    FreeEXRHeader(&header);
    return false;
  }
  const int64_t ew = int64_t(header.data_window.max_x) - header.data_window.min_x + 1;
  const int64_t eh = int64_t(header.data_window.max_y) - header.data_window.min_y + 1;
  FreeEXRHeader(&header);
  return ew * eh > kMaxFuzzTexels || ew > (int64_t(1) << 24) || eh > (int64_t(1) << 24);
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  if (size > (size_t(1) << 24) || too_large(data, size)) return 0;
  for (bool want_float : {false, true}) {
    pn::DecodedImage img;
    std::string error;
    if (pn::decode_image_memory(data, size, want_float, &img, &error)) {
      const size_t texel = img.is_float ? 16 : 4;
      if (img.width <= 0 || img.height <= 0 || img.texels.size() != size_t(img.width) * img.height * texel)
        __builtin_trap();  // a decoded image must hold exactly its texels
    }
  }
  return 0;
}
