// OpenEXR output: a single-part scanline file of float32 B, G, R channels,
// ZIP-compressed in blocks of 16 scanlines, the blocks compressed in parallel.
//
// tinyexr's writer compresses the blocks one after another: a 1080p image took
// 0.4 s here and 0.7 s on the H200's host, longer than many renders. The format
// (OpenEXR's "Technical Introduction" and file layout) makes every block
// independent: its scanlines, each channel's row in turn (B, G, R: channels
// sorted by name), the bytes split into even and odd halves and delta-coded
// (OpenEXR's ZIP predictor), then deflated by zlib; a block that does not shrink
// is stored raw, which readers tell by its size. tinyexr reads them back
// (tests/io/test_exr_write.cpp checks every float bit for bit).
#include "io/exr_write.h"

#include <zlib.h>

#include <algorithm>
#include <atomic>
#include <cstring>
#include <stdexcept>
#include <thread>

namespace pn {

namespace {

constexpr int kZipScanlines = 16;  // OpenEXR's ZIP_COMPRESSION block height
constexpr int kZipLevel = 4;       // OpenEXR's default zlib level: near level 6's size, faster

void put_u8(std::vector<uint8_t>* out, uint8_t v) { out->push_back(v); }
void put_i32(std::vector<uint8_t>* out, int32_t v) {
  uint32_t u = uint32_t(v);
  for (int i = 0; i < 4; ++i) out->push_back(uint8_t(u >> (8 * i)));
}
void put_u64(std::vector<uint8_t>* out, uint64_t v) {
  for (int i = 0; i < 8; ++i) out->push_back(uint8_t(v >> (8 * i)));
}
void put_f32(std::vector<uint8_t>* out, float f) {
  uint32_t u;
  std::memcpy(&u, &f, 4);
  put_i32(out, int32_t(u));
}
void put_str(std::vector<uint8_t>* out, const char* s) {
  out->insert(out->end(), s, s + std::strlen(s) + 1);
}
// An attribute: name, type, size, value.
void put_attribute(std::vector<uint8_t>* out, const char* name, const char* type, const std::vector<uint8_t>& value) {
  put_str(out, name);
  put_str(out, type);
  put_i32(out, int32_t(value.size()));
  out->insert(out->end(), value.begin(), value.end());
}

std::vector<uint8_t> header(int width, int height, bool zip) {
  std::vector<uint8_t> h = {0x76, 0x2f, 0x31, 0x01, 2, 0, 0, 0};  // magic, version 2, single-part scanline
  std::vector<uint8_t> v;
  for (const char* c : {"B", "G", "R"}) {
    put_str(&v, c);
    put_i32(&v, 2);  // FLOAT
    put_u8(&v, 0);   // pLinear
    put_u8(&v, 0);
    put_u8(&v, 0);
    put_u8(&v, 0);   // reserved
    put_i32(&v, 1);  // x sampling
    put_i32(&v, 1);  // y sampling
  }
  put_u8(&v, 0);
  put_attribute(&h, "channels", "chlist", v);
  put_attribute(&h, "compression", "compression", {uint8_t(zip ? 3 : 0)});  // ZIP_COMPRESSION or NO_COMPRESSION
  v.clear();
  for (int32_t x : {0, 0, width - 1, height - 1}) put_i32(&v, x);
  put_attribute(&h, "dataWindow", "box2i", v);
  put_attribute(&h, "displayWindow", "box2i", v);
  put_attribute(&h, "lineOrder", "lineOrder", {0});  // INCREASING_Y
  v.clear();
  put_f32(&v, 1.f);
  put_attribute(&h, "pixelAspectRatio", "float", v);
  v.clear();
  put_f32(&v, 0.f);
  put_f32(&v, 0.f);
  put_attribute(&h, "screenWindowCenter", "v2f", v);
  v.clear();
  put_f32(&v, 1.f);
  put_attribute(&h, "screenWindowWidth", "float", v);
  put_u8(&h, 0);  // end of the header
  return h;
}

// Block b's bytes as the file stores them: raw scanlines (each channel's row in turn, little-endian floats), or
// their ZIP form where it is smaller.
std::vector<uint8_t> block_bytes(int width, int height, const std::vector<float>& rgb, int b, int lines, bool zip) {
  const int y0 = b * lines, y1 = std::min(height, y0 + lines);
  const size_t row = size_t(width) * 4;
  std::vector<uint8_t> raw(size_t(y1 - y0) * 3 * row);
  uint8_t* p = raw.data();
  for (int y = y0; y < y1; ++y)
    for (int c = 2; c >= 0; --c)  // B, G, R
      for (int x = 0; x < width; ++x, p += 4) {
        const float f = rgb[(size_t(y) * size_t(width) + size_t(x)) * 3 + size_t(c)];
        uint32_t u;
        std::memcpy(&u, &f, 4);
        p[0] = uint8_t(u), p[1] = uint8_t(u >> 8), p[2] = uint8_t(u >> 16), p[3] = uint8_t(u >> 24);
      }
  if (!zip) return raw;
  // OpenEXR's predictor: the even bytes then the odd ones, each byte replaced by its difference from the one before.
  const size_t n = raw.size();
  std::vector<uint8_t> t(n);
  size_t i1 = 0, i2 = (n + 1) / 2;
  for (size_t i = 0; i < n; ++i) t[(i & 1) ? i2++ : i1++] = raw[i];
  int prev = t[0];
  for (size_t i = 1; i < n; ++i) {
    const int d = int(t[i]) - prev + (128 + 256);
    prev = t[i];
    t[i] = uint8_t(d);
  }
  uLongf size = compressBound(uLong(n));
  std::vector<uint8_t> out(size);
  if (compress2(out.data(), &size, t.data(), uLong(n), kZipLevel) != Z_OK || size >= n) return raw;
  out.resize(size);
  return out;
}

}  // namespace

std::vector<uint8_t> encode_exr(int width, int height, const std::vector<float>& rgb, const ExrOptions& options) {
  if (width <= 0 || height <= 0 || rgb.size() != size_t(width) * size_t(height) * 3)
    throw std::logic_error("encode_exr: buffer size mismatch");
  const bool zip = options.compression == ExrCompression::Zip;
  const int lines = zip ? kZipScanlines : 1;  // NO_COMPRESSION stores one scanline a block
  const int blocks = (height + lines - 1) / lines;
  std::vector<std::vector<uint8_t>> data(static_cast<size_t>(blocks));
  unsigned threads = options.threads > 0 ? unsigned(options.threads) : std::max(1u, std::thread::hardware_concurrency());
  threads = std::min(threads, unsigned(blocks));
  std::atomic<int> next{0};
  auto work = [&] {
    for (int b; (b = next.fetch_add(1)) < blocks;) data[size_t(b)] = block_bytes(width, height, rgb, b, lines, zip);
  };
  std::vector<std::thread> pool;
  for (unsigned i = 1; i < threads; ++i) pool.emplace_back(work);
  work();
  for (std::thread& t : pool) t.join();

  std::vector<uint8_t> out = header(width, height, zip);
  uint64_t offset = out.size() + 8 * uint64_t(blocks);
  for (int b = 0; b < blocks; ++b) {
    put_u64(&out, offset);
    offset += 8 + data[size_t(b)].size();
  }
  out.reserve(size_t(offset));
  for (int b = 0; b < blocks; ++b) {
    put_i32(&out, b * lines);
    put_i32(&out, int32_t(data[size_t(b)].size()));
    out.insert(out.end(), data[size_t(b)].begin(), data[size_t(b)].end());
    std::vector<uint8_t>().swap(data[size_t(b)]);
  }
  return out;
}

}  // namespace pn
