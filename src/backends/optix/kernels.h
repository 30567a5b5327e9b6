// The GPU backend's accumulation kernel, with its host-side launcher, which
// returns the launch's error status.
#pragma once

#include <cstddef>

#include <cuda_runtime.h>

namespace pn {
namespace optix {

// Adds one launch's per-pixel sums (sum.xyz, sum_sq.xyz) into the progressive
// double sums, laid out like Film (3 doubles a pixel, RGB), and adds the
// launch's rays (sum.w) and non-finite samples (sum_sq.w) into counters[0] and
// counters[1], and the non-finite samples of each pixel into bad_pixels (one
// count a pixel, so that the host can say which pixels had them).
cudaError_t launch_accumulate(const float4* sum, const float4* sum_sq, size_t pixels, double* acc_sum,
                              double* acc_sum_sq, unsigned long long* counters, unsigned* bad_pixels, int num_sms,
                              cudaStream_t stream);

}  // namespace optix
}  // namespace pn
