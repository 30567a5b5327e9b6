// Image files. The format follows the file extension:
//   .exr  linear RGB, float32 (io/exr_write.h: ZIP-compressed on every core, or uncompressed)
//   .png  sRGB 8-bit, after exposure (x 2^stops) and clamping (stb_image_write)
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "io/exr_write.h"

namespace pn {

// rgb: width*height*3 floats, row 0 at the top. Written atomically
// (io/output.h): a failure leaves an existing file as it was. Throws
// std::runtime_error with one line naming the path on failure or on an unknown
// extension.
void write_image(const std::string& path, int width, int height, const std::vector<float>& rgb,
                 float exposure_stops = 0.f, const ExrOptions& exr = {});

// A PNG of 8-bit pixels (channels 1..4, rows top first); `path` names it in errors.
std::vector<uint8_t> encode_png(const std::string& path, int width, int height, int channels, const uint8_t* pixels);

// Throws the same one-line error write_image would for an unsupported extension.
void check_image_path(const std::string& path);

// Reads a linear float RGB EXR written by write_image (or any RGB(A) EXR).
std::vector<float> read_exr(const std::string& path, int* width, int* height);

// Linear -> sRGB-encoded 8-bit value.
unsigned char to_srgb8(float linear);

}  // namespace pn
