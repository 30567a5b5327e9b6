// NumPy .npy output (format version 1.0, little-endian float32), so that the
// Python report reads images with numpy.load and no EXR library.
#pragma once

#include <string>
#include <vector>

namespace pn {

// Writes an array of shape (height, width, channels). Throws std::runtime_error.
void write_npy(const std::string& path, int height, int width, int channels, const float* data);

}  // namespace pn
