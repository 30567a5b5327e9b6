// Plain CUDA kernels of the GPU backend (accumulation and tone-mapping), with
// host-side launchers. Each launcher returns the launch's error status.
#pragma once

#include <cstddef>

#include <cuda_runtime.h>

namespace pn {
namespace optix {

// Adds one launch's per-pixel sums (sum.xyz, sum_sq.xyz) into the progressive
// double sums, laid out like Film (3 doubles a pixel, RGB), and adds the
// launch's rays (sum.w) and non-finite samples (sum_sq.w) into counters[0] and
// counters[1], and the non-finite samples of each pixel into bad_pixels (one
// count a pixel, so that the host can say which pixels had them). If rgba is
// not null, also tone-maps the new accumulation with scale = 2^exposure /
// samples accumulated (see tonemap below).
cudaError_t launch_accumulate(const float4* sum, const float4* sum_sq, size_t pixels, double* acc_sum,
                              double* acc_sum_sq, unsigned long long* counters, unsigned* bad_pixels, uchar4* rgba,
                              float scale, int num_sms, cudaStream_t stream);

// rgba = sRGB8(acc_sum * scale), alpha 255; the transfer function of
// io/image.cpp's to_srgb8 (clamped to [0, 1], NaN to 0).
cudaError_t launch_tonemap(const double* acc_sum, size_t pixels, float scale, uchar4* rgba, int num_sms,
                           cudaStream_t stream);

}  // namespace optix
}  // namespace pn
