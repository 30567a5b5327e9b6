// Image files read as textures: PNG, TGA, BMP (stb_image, 8-bit), JPEG
// (libjpeg-turbo, 8-bit), Radiance .hdr (stb_image, float) and OpenEXR
// (tinyexr, float). Always RGBA, row 0 at
// the top of the image (no flipping).
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

namespace pn {

struct DecodedImage {
  int width = 0, height = 0;
  bool is_float = false;         // texels: RGBA float32 (16 bytes each) or RGBA8 (4 bytes each)
  std::vector<uint8_t> texels;
  // Float images: texels that had a NaN, infinite or negative channel, which
  // decoding set to 0 (the texel's other channels are kept). Texture lookups
  // and the environment's sampling distribution both see the repaired values.
  size_t repaired_texels = 0;
};

// Largest image accepted (texels): larger headers are rejected before allocating.
constexpr size_t kMaxImageTexels = size_t(1) << 28;

// Decodes a file. want_float: the result is RGBA float (8-bit images are
// converted from sRGB to linear); otherwise 8-bit images stay 8-bit and HDR
// images are rejected. Returns false with a one-line reason (no path) in *error.
bool decode_image_file(const std::string& path, bool want_float, DecodedImage* out, std::string* error);

// The same for an encoded image in memory (glTF's embedded images).
bool decode_image_memory(const uint8_t* data, size_t size, bool want_float, DecodedImage* out, std::string* error);

// The width and height a PNG, JPEG, TGA, BMP or HDR header declares, as the
// decoder will read them (headers only; false where it finds none). EXR: no.
bool image_dimensions(const uint8_t* data, size_t size, int* w, int* h);

// Whether tinyexr may parse this single-part OpenEXR header: Debian's tinyexr
// (1.0.x) aborts the process on an assert, instead of returning an error, for
// a "type" attribute that is not one of its four names or that contradicts the
// file's tiling, a "tiles" attribute that is not 9 bytes, or a tile level mode
// of 3 (found by fuzz_image), even in a header whose later attributes are
// broken (tinyexr converts what it read before failing); and it allocates an
// offset table of "chunkCount" 8-byte entries before reading them, so a count the
// file is too small to hold is refused too. Walks the attributes as tinyexr does;
// false with a one-line reason in *why for those.
bool exr_header_parsable(const uint8_t* data, size_t size, std::string* why);

// Whether the extension names a float (HDR) format: .hdr or .exr.
bool is_hdr_path(const std::string& path);

}  // namespace pn
