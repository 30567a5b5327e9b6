// The display's tone-map of one pixel, shared by the host path (progressive.cpp)
// and the CUDA-OpenGL interop path (device_image_kernels.cu), so that both put
// exactly the bytes of a PNG screenshot on the screen: mean = float(sum x 1/n)
// as Film::mean() computes it, x 2^exposure as write_image does, then sRGB 8-bit
// by counting the thresholds of a 255-entry table (srgb8_thresholds() in
// progressive.h) instead of a pow(), so that host and device agree bit for bit.
#pragma once

#include "core/common.h"

namespace pn::viewer {

// to_srgb8(v) (io/image.h), given the table t: the number of thresholds <= v.
PN_HD inline unsigned char srgb8_by_thresholds(float v, const float* t) {
  if (!(v > 0.f)) return 0;  // also NaN
  int lo = 0, n = 255;       // upper_bound over t[0..254]
  while (n > 0) {
    const int half = n >> 1;
    if (t[lo + half] <= v) {
      lo += half + 1;
      n -= half + 1;
    } else {
      n = half;
    }
  }
  return (unsigned char)lo;
}

// One display pixel from its RGB sums: rgba[0..2] = sRGB8(float(sum * inv) * gain), rgba[3] = 255.
PN_HD inline void tone_map_pixel(const double* sum3, double inv, float gain, const float* t, unsigned char* rgba) {
  for (int c = 0; c < 3; ++c) rgba[c] = srgb8_by_thresholds(float(sum3[c] * inv) * gain, t);
  rgba[3] = 255;
}

// The same from a linear RGB value (a denoised image): rgba[0..2] = sRGB8(rgb * gain), as write_image writes a PNG.
PN_HD inline void tone_map_rgb(const float* rgb, float gain, const float* t, unsigned char* rgba) {
  for (int c = 0; c < 3; ++c) rgba[c] = srgb8_by_thresholds(rgb[c] * gain, t);
  rgba[3] = 255;
}

}  // namespace pn::viewer
