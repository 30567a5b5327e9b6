#include "io/npy.h"

#include <cstdint>
#include <fstream>
#include <stdexcept>

namespace pn {

void write_npy(const std::string& path, int height, int width, int channels, const float* data) {
  std::string header = "{'descr': '<f4', 'fortran_order': False, 'shape': (" + std::to_string(height) + ", " +
                       std::to_string(width) + ", " + std::to_string(channels) + "), }";
  // Magic (6) + version (2) + header length (2) + header, padded with spaces to a
  // multiple of 64 bytes and ended by a newline.
  size_t total = 10 + header.size() + 1;
  header.append((64 - total % 64) % 64, ' ');
  header.push_back('\n');
  std::ofstream out(path, std::ios::binary);
  if (!out) throw std::runtime_error(path + ": cannot write");
  out.write("\x93NUMPY\x01\x00", 8);
  uint16_t len = uint16_t(header.size());
  char len_le[2] = {char(len & 0xff), char(len >> 8)};
  out.write(len_le, 2);
  out << header;
  out.write(reinterpret_cast<const char*>(data), std::streamsize(sizeof(float) * size_t(height) * width * channels));
  if (!out) throw std::runtime_error(path + ": write failed");
}

}  // namespace pn
