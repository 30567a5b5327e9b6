#include "io/npy.h"

#include <cstdint>
#include <cstring>
#include <stdexcept>

#include "io/output.h"

namespace pn {

void write_npy(const std::string& path, int height, int width, int channels, const float* data) {
  std::string header = "{'descr': '<f4', 'fortran_order': False, 'shape': (" + std::to_string(height) + ", " +
                       std::to_string(width) + ", " + std::to_string(channels) + "), }";
  // Magic (6) + version (2) + header length (2) + header, padded with spaces to a
  // multiple of 64 bytes and ended by a newline.
  size_t total = 10 + header.size() + 1;
  header.append((64 - total % 64) % 64, ' ');
  header.push_back('\n');
  const size_t payload = sizeof(float) * size_t(height) * width * channels;
  std::string bytes("\x93NUMPY\x01\x00", 8);
  uint16_t len = uint16_t(header.size());
  bytes.push_back(char(len & 0xff));
  bytes.push_back(char(len >> 8));
  bytes += header;
  const size_t at = bytes.size();
  bytes.resize(at + payload);
  std::memcpy(&bytes[at], data, payload);
  write_file_atomic(path, bytes);
}

}  // namespace pn
