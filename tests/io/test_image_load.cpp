// Texture decoding (io/image_load.cpp). JPEG is decoded by libjpeg-turbo: the
// tests encode images with libjpeg, decode them with penumbra's loader, and
// compare with the original pixels and with stb_image's decoder of the same
// bytes; broken JPEGs (truncated, and an input on which stb reads out of bounds,
// found by fuzz_image) are refused with one line, as are the formats stb knows
// that are not textures.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <iterator>
#include <string>
#include <vector>

#include <jpeglib.h>
#include <stb/stb_image.h>

#include "io/image_load.h"

namespace pn {
namespace {

// A smooth test picture (JPEG's error is small on it): gradients and a disc.
std::vector<uint8_t> picture(int w, int h, int channels) {
  std::vector<uint8_t> p(size_t(w) * h * channels);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      const float dx = x - w * 0.5f, dy = y - h * 0.4f;
      const bool disc = dx * dx + dy * dy < 0.04f * w * w;
      const uint8_t rgb[3] = {uint8_t(40 + 180 * x / w), uint8_t(30 + 200 * y / h), uint8_t(disc ? 200 : 60)};
      for (int c = 0; c < channels; ++c) p[(size_t(y) * w + x) * channels + c] = channels == 1 ? rgb[1] : rgb[c];
    }
  return p;
}

std::vector<uint8_t> encode_jpeg(const std::vector<uint8_t>& pixels, int w, int h, int channels, bool progressive) {
  jpeg_compress_struct cinfo;
  jpeg_error_mgr err;
  cinfo.err = jpeg_std_error(&err);
  jpeg_create_compress(&cinfo);
  unsigned char* buffer = nullptr;
  unsigned long size = 0;
  jpeg_mem_dest(&cinfo, &buffer, &size);
  cinfo.image_width = JDIMENSION(w);
  cinfo.image_height = JDIMENSION(h);
  cinfo.input_components = channels;
  cinfo.in_color_space = channels == 1 ? JCS_GRAYSCALE : JCS_RGB;
  jpeg_set_defaults(&cinfo);
  jpeg_set_quality(&cinfo, 95, TRUE);
  if (progressive) jpeg_simple_progression(&cinfo);
  jpeg_start_compress(&cinfo, TRUE);
  while (cinfo.next_scanline < cinfo.image_height) {
    JSAMPROW row = const_cast<uint8_t*>(pixels.data()) + size_t(cinfo.next_scanline) * w * channels;
    jpeg_write_scanlines(&cinfo, &row, 1);
  }
  jpeg_finish_compress(&cinfo);
  jpeg_destroy_compress(&cinfo);
  std::vector<uint8_t> out(buffer, buffer + size);
  std::free(buffer);
  return out;
}

TEST(ImageLoad, JpegMatchesItsPixelsAndStbImage) {
  constexpr int w = 67, h = 45;  // not multiples of the 16 x 16 blocks
  for (int channels : {3, 1})
    for (bool progressive : {false, true}) {
      SCOPED_TRACE("channels " + std::to_string(channels) + (progressive ? ", progressive" : ", baseline"));
      const std::vector<uint8_t> original = picture(w, h, channels);
      const std::vector<uint8_t> jpeg = encode_jpeg(original, w, h, channels, progressive);
      int dw = 0, dh = 0;
      ASSERT_TRUE(image_dimensions(jpeg.data(), jpeg.size(), &dw, &dh));
      EXPECT_EQ(dw, w);
      EXPECT_EQ(dh, h);
      DecodedImage img;
      std::string error;
      ASSERT_TRUE(decode_image_memory(jpeg.data(), jpeg.size(), false, &img, &error)) << error;
      ASSERT_EQ(img.width, w);
      ASSERT_EQ(img.height, h);
      ASSERT_FALSE(img.is_float);
      ASSERT_EQ(img.texels.size(), size_t(w) * h * 4);
      int sw = 0, sh = 0, sc = 0;
      unsigned char* stb = stbi_load_from_memory(jpeg.data(), int(jpeg.size()), &sw, &sh, &sc, 4);
      ASSERT_NE(stb, nullptr);
      double err_original = 0, err_stb = 0;
      int max_stb = 0;
      for (size_t i = 0; i < size_t(w) * h; ++i) {
        EXPECT_EQ(img.texels[4 * i + 3], 255);
        for (int c = 0; c < 3; ++c) {
          const int v = img.texels[4 * i + c];
          err_original += std::abs(v - int(original[i * channels + (channels == 1 ? 0 : c)]));
          const int d = std::abs(v - int(stb[4 * i + c]));
          err_stb += d;
          max_stb = std::max(max_stb, d);
        }
      }
      stbi_image_free(stb);
      // Quality 95: about two levels from the original, most of it where the
      // colour is subsampled 2 x 2 (4:2:0) across the disc's sharp edge; a
      // swapped or shifted channel is tens of levels off. The two decoders
      // differ in their IDCT and chroma upsampling only.
      EXPECT_LT(err_original / (3.0 * w * h), 3.0);
      EXPECT_LT(err_stb / (3.0 * w * h), 1.0);
      EXPECT_LE(max_stb, 16);
      // As float: sRGB decoded exactly, alpha 1.
      DecodedImage f;
      ASSERT_TRUE(decode_image_memory(jpeg.data(), jpeg.size(), true, &f, &error)) << error;
      ASSERT_TRUE(f.is_float);
      ASSERT_EQ(f.texels.size(), size_t(w) * h * 16);
      const float* texel = reinterpret_cast<const float*>(f.texels.data());
      const float u = img.texels[0] / 255.f;
      const float linear = u <= 0.04045f ? u / 12.92f : std::pow((u + 0.055f) / 1.055f, 2.4f);
      EXPECT_NEAR(texel[0], linear, 1e-6f);
      EXPECT_EQ(texel[3], 1.f);
    }
}

TEST(ImageLoad, BrokenJpegsAreRefusedInOneLine) {
  const std::vector<uint8_t> jpeg = encode_jpeg(picture(64, 64, 3), 64, 64, 3, false);
  for (size_t keep : {size_t(3), size_t(200), jpeg.size() / 2, jpeg.size() - 2}) {
    SCOPED_TRACE("first " + std::to_string(keep) + " bytes");
    DecodedImage img;
    std::string error;
    EXPECT_FALSE(decode_image_memory(jpeg.data(), keep, false, &img, &error));
    EXPECT_NE(error.find("JPEG"), std::string::npos) << error;
    EXPECT_EQ(error.find('\n'), std::string::npos) << error;
    EXPECT_TRUE(img.texels.empty());
  }
  // A header that claims 60000 x 60000 pixels: refused before anything is allocated.
  std::vector<uint8_t> huge = jpeg;
  bool patched = false;
  for (size_t i = 0; i + 8 < huge.size() && !patched; ++i)
    if (huge[i] == 0xFF && huge[i + 1] == 0xC0) {  // SOF0: length (2), precision (1), height (2), width (2)
      huge[i + 5] = huge[i + 7] = 0xEA;
      huge[i + 6] = huge[i + 8] = 0x60;
      patched = true;
    }
  ASSERT_TRUE(patched);
  DecodedImage none;
  std::string why;
  EXPECT_FALSE(decode_image_memory(huge.data(), huge.size(), true, &none, &why));
  EXPECT_EQ(why, "image too large (60000x60000)");
  EXPECT_TRUE(none.texels.empty());
  // fuzz_image's input on which Debian's stb_image read out of bounds (ASan).
  const std::string path =
      std::string(PENUMBRA_TEST_DATA) + "/../fuzz/regressions/image/jpeg-stb-reads-out-of-bounds.jpg";
  std::ifstream in(path, std::ios::binary);
  ASSERT_TRUE(in) << path;
  const std::vector<uint8_t> bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  for (bool want_float : {false, true}) {
    DecodedImage img;
    std::string error;
    EXPECT_FALSE(decode_image_memory(bytes.data(), bytes.size(), want_float, &img, &error));
    EXPECT_EQ(error.rfind("cannot decode image: JPEG: ", 0), 0u) << error;
  }
}

// An EXR whose chunkCount (0x3f800000) no file of its size can hold: refused before tinyexr allocates its offset
// table of 8.5 GB (fuzz_image: libFuzzer's out-of-memory; outside the fuzzer, std::bad_alloc and an abort).
TEST(ImageLoad, ExrChunkCountBeyondTheFileIsRefused) {
  const std::string path =
      std::string(PENUMBRA_TEST_DATA) + "/../fuzz/regressions/image/exr-chunkcount-allocates-8gb.exr";
  std::ifstream in(path, std::ios::binary);
  ASSERT_TRUE(in) << path;
  const std::vector<uint8_t> bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  DecodedImage img;  // as float: an EXR as an 8-bit texture is refused before its header is read
  std::string error;
  EXPECT_FALSE(decode_image_memory(bytes.data(), bytes.size(), true, &img, &error));
  EXPECT_NE(error.find("a chunkCount of 1065353216 in a file of " + std::to_string(bytes.size()) + " bytes"),
            std::string::npos)
      << error;
}

// Formats stb_image knows but textures are not: refused before stb sees them.
TEST(ImageLoad, FormatsOtherThanTexturesAreRefused) {
  const std::string gif = "GIF89a\x01\x00\x01\x00\x80\x00\x00\xff\xff\xff\x00\x00\x00!\xf9\x04\x01\x00\x00"
                          "\x00\x00,\x00\x00\x00\x00\x01\x00\x01\x00\x00\x02\x02D\x01\x00;";
  const std::string pnm = "P6\n1 1\n255\n\x10\x20\x30";
  for (const std::string& file : {gif, pnm}) {
    const auto* data = reinterpret_cast<const uint8_t*>(file.data());
    int w = 0, h = 0;
    EXPECT_FALSE(image_dimensions(data, file.size(), &w, &h));
    DecodedImage img;
    std::string error;
    EXPECT_FALSE(decode_image_memory(data, file.size(), false, &img, &error));
    EXPECT_EQ(error.rfind("unsupported image format: ", 0), 0u) << error;
  }
  // stb decodes both (it would be asked, were they not refused first).
  int w = 0, h = 0, c = 0;
  EXPECT_TRUE(stbi_info_from_memory(reinterpret_cast<const uint8_t*>(gif.data()), int(gif.size()), &w, &h, &c));
  EXPECT_TRUE(stbi_info_from_memory(reinterpret_cast<const uint8_t*>(pnm.data()), int(pnm.size()), &w, &h, &c));
}

}  // namespace
}  // namespace pn
