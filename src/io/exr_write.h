// OpenEXR output (src/io/exr_write.cpp): float32 RGB, ZIP blocks compressed in parallel.
#pragma once

#include <cstdint>
#include <vector>

namespace pn {

enum class ExrCompression { Zip, None };

struct ExrOptions {
  ExrCompression compression = ExrCompression::Zip;
  int threads = 0;  // 0: every hardware thread
};

// The bytes of an EXR file of the width x height image `rgb` (interleaved R, G, B floats, top row first).
std::vector<uint8_t> encode_exr(int width, int height, const std::vector<float>& rgb, const ExrOptions& options = {});

}  // namespace pn
