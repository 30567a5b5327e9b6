// penumbra's EXR writer (src/io/exr_write.cpp): what it writes, tinyexr reads
// back bit for bit, compressed or not, on any size, with NaN, infinities,
// denormals and negative zero among the pixels; the parallel blocks give the
// same file as one thread; and a smooth image shrinks.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <cstring>
#include <limits>
#include <string>
#include <vector>

#include <tinyexr.h>

#include "io/exr_write.h"
#include "io/image.h"
#include "core/rng.h"

namespace pn {
namespace {

// Every float of an image: smooth ramps with noise, and the special values at fixed places.
std::vector<float> test_image(int w, int h, uint32_t seed) {
  Rng r(0, 0, seed);
  std::vector<float> rgb(size_t(w) * size_t(h) * 3);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x)
      for (int c = 0; c < 3; ++c)
        rgb[(size_t(y) * size_t(w) + size_t(x)) * 3 + size_t(c)] =
            float(x + 2 * y + c) / float(w + h) + 0.01f * r.uniform();
  const float special[] = {std::numeric_limits<float>::quiet_NaN(), std::numeric_limits<float>::infinity(),
                           -std::numeric_limits<float>::infinity(), -0.f, std::numeric_limits<float>::denorm_min(),
                           -1e30f, 3.4e38f};
  for (size_t i = 0; i < sizeof special / sizeof special[0] && i < rgb.size(); ++i) rgb[(i * 7919) % rgb.size()] = special[i];
  return rgb;
}

// tinyexr's reading of an EXR held in memory: RGB, interleaved.
std::vector<float> decode(const std::vector<uint8_t>& bytes, int* w, int* h) {
  float* data = nullptr;
  const char* err = nullptr;
  const int rc = LoadEXRFromMemory(&data, w, h, bytes.data(), bytes.size(), &err);
  if (rc != TINYEXR_SUCCESS) {
    const std::string msg = err ? err : "?";
    if (err) FreeEXRErrorMessage(err);
    ADD_FAILURE() << "tinyexr cannot read it: " << msg;
    return {};
  }
  std::vector<float> rgb(size_t(*w) * size_t(*h) * 3);
  for (size_t i = 0; i < size_t(*w) * size_t(*h); ++i)
    for (int c = 0; c < 3; ++c) rgb[3 * i + size_t(c)] = data[4 * i + size_t(c)];
  free(data);
  return rgb;
}

bool same_bits(float a, float b) { return std::memcmp(&a, &b, 4) == 0; }

TEST(ExrWrite, TinyexrReadsBackEveryFloatBitForBit) {
  for (const ExrCompression compression : {ExrCompression::Zip, ExrCompression::None})
    for (const auto& [w, h] : std::vector<std::pair<int, int>>{{1, 1}, {1, 17}, {33, 1}, {16, 16}, {37, 45}, {200, 33}}) {
      const std::vector<float> rgb = test_image(w, h, uint32_t(w * 1000 + h));
      ExrOptions options;
      options.compression = compression;
      int rw = 0, rh = 0;
      const std::vector<float> back = decode(encode_exr(w, h, rgb, options), &rw, &rh);
      ASSERT_EQ(rw, w);
      ASSERT_EQ(rh, h);
      ASSERT_EQ(back.size(), rgb.size());
      size_t differ = 0;
      for (size_t i = 0; i < rgb.size(); ++i) differ += !same_bits(back[i], rgb[i]) && !(std::isnan(back[i]) && std::isnan(rgb[i]));
      EXPECT_EQ(differ, 0u) << w << "x" << h << (compression == ExrCompression::Zip ? " zip" : " none");
    }
}

TEST(ExrWrite, ParallelBlocksMakeTheSameFileAsOneThread) {
  const std::vector<float> rgb = test_image(160, 90, 3);
  ExrOptions one, many;
  one.threads = 1;
  many.threads = 8;
  EXPECT_EQ(encode_exr(160, 90, rgb, one), encode_exr(160, 90, rgb, many));
}

TEST(ExrWrite, ZipShrinksASmoothImage) {
  std::vector<float> rgb(size_t(256) * 128 * 3);
  for (size_t i = 0; i < rgb.size(); ++i) rgb[i] = float(i % 768) / 768.f;
  ExrOptions none;
  none.compression = ExrCompression::None;
  const size_t zip_size = encode_exr(256, 128, rgb).size(), raw_size = encode_exr(256, 128, rgb, none).size();
  EXPECT_GT(raw_size, rgb.size() * 4);
  EXPECT_LT(zip_size * 4, raw_size) << "zip " << zip_size << " bytes, raw " << raw_size;
}

TEST(ExrWrite, WriteImageWritesWhatReadExrReads) {
  const std::string path = ::testing::TempDir() + "exr_write_test.exr";
  const std::vector<float> rgb = test_image(48, 20, 9);
  write_image(path, 48, 20, rgb);
  int w = 0, h = 0;
  const std::vector<float> back = read_exr(path, &w, &h);
  std::remove(path.c_str());
  ASSERT_EQ(w, 48);
  ASSERT_EQ(h, 20);
  for (size_t i = 0; i < rgb.size(); ++i)
    ASSERT_TRUE(same_bits(back[i], rgb[i]) || (std::isnan(back[i]) && std::isnan(rgb[i]))) << i;
}

}  // namespace
}  // namespace pn
