// The GPU's launch sums (LaunchParams::sum / sum_sq, the wavefront's): per
// pixel, float4(sum of the samples, rays traced) and float4(sum of their
// squares, non-finite samples skipped), read by OptixBackend::launch_accumulate.
// Device code only: the megakernel's raygens and the wavefront's accumulation
// write them through these two functions.
#pragma once

#include <cuda_runtime.h>

#include "core/sample_sums.h"

namespace pn {

__device__ __forceinline__ SampleSums<float> load_launch_sums(const float4* sum, const float4* sum_sq, uint32_t pixel,
                                                              float* rays) {
  const float4 s = sum[pixel], q = sum_sq[pixel];
  SampleSums<float> a;
  a.sum[0] = s.x, a.sum[1] = s.y, a.sum[2] = s.z;
  a.sum_sq[0] = q.x, a.sum_sq[1] = q.y, a.sum_sq[2] = q.z;
  a.nonfinite = uint32_t(q.w);
  *rays = s.w;
  return a;
}

__device__ __forceinline__ void store_launch_sums(float4* sum, float4* sum_sq, uint32_t pixel,
                                                  const SampleSums<float>& a, float rays) {
  sum[pixel] = make_float4(a.sum[0], a.sum[1], a.sum[2], rays);
  sum_sq[pixel] = make_float4(a.sum_sq[0], a.sum_sq[1], a.sum_sq[2], float(a.nonfinite));
}

}  // namespace pn
