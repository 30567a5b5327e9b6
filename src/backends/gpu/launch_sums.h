// The GPU's launch sums (LaunchParams::sum / sum_sq, the wavefront's): per
// pixel, float4(sum of the samples, rays traced) and float4(sum of their
// squares, non-finite samples skipped), read by OptixBackend::launch_accumulate;
// and the film they are added to (film_add), by that kernel or by the wavefront's
// accumulation where one wave holds the whole launch.
// Device code only: the megakernel's raygens and the wavefront's accumulation
// write them through these two functions.
#pragma once

#include <cuda_runtime.h>

#include "backends/gpu/device_film.h"
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

// A pixel's sums as its two launch-sum words.
__device__ __forceinline__ void launch_sums_words(const SampleSums<float>& a, float rays, float4* sum,
                                                  float4* sum_sq) {
  *sum = make_float4(a.sum[0], a.sum[1], a.sum[2], rays);
  *sum_sq = make_float4(a.sum_sq[0], a.sum_sq[1], a.sum_sq[2], float(a.nonfinite));
}

__device__ __forceinline__ void store_launch_sums(float4* sum, float4* sum_sq, uint32_t pixel,
                                                  const SampleSums<float>& a, float rays) {
  launch_sums_words(a, rays, sum + pixel, sum_sq + pixel);
}

// A pixel's launch sums into the film (the pixel's own doubles; the counts into rays and bad, for
// add_block_counters).
__device__ __forceinline__ void film_add(const DeviceFilm& film, size_t pixel, const float4& s, const float4& q,
                                         unsigned long long* rays, unsigned long long* bad) {
  double* a = film.sum + 3 * pixel;
  double* b = film.sum_sq + 3 * pixel;
  a[0] += double(s.x);
  a[1] += double(s.y);
  a[2] += double(s.z);
  b[0] += double(q.x);
  b[1] += double(q.y);
  b[2] += double(q.z);
  *rays += (unsigned long long)s.w;
  *bad += (unsigned long long)q.w;
  if (q.w > 0.f) film.bad_pixels[pixel] += unsigned(q.w);
}

// The block's counts into the film's counters: one atomic a counter a block. Every thread of the block calls it,
// with blockDim.x == kBlock.
template <int kBlock>
__device__ __forceinline__ void add_block_counters(const DeviceFilm& film, unsigned long long rays,
                                                   unsigned long long bad) {
  for (int o = 16; o > 0; o >>= 1) {
    rays += __shfl_down_sync(0xffffffffu, rays, o);
    bad += __shfl_down_sync(0xffffffffu, bad, o);
  }
  __shared__ unsigned long long warp_rays[kBlock / 32], warp_bad[kBlock / 32];
  const int lane = threadIdx.x & 31, warp = threadIdx.x >> 5;
  if (lane == 0) {
    warp_rays[warp] = rays;
    warp_bad[warp] = bad;
  }
  __syncthreads();
  if (threadIdx.x == 0) {
    unsigned long long r = 0, b = 0;
    for (int w = 0; w < kBlock / 32; ++w) {
      r += warp_rays[w];
      b += warp_bad[w];
    }
    if (r) atomicAdd(&film.counters[0], r);
    if (b) atomicAdd(&film.counters[1], b);
  }
}

}  // namespace pn
