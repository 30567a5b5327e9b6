// The GPU backend's accumulation kernel.
#include "backends/optix/kernels.h"

namespace pn {
namespace optix {
namespace {

constexpr int kBlock = 256;

// Grid-stride over pixels; per-block reduction of the two counters so that only
// a few hundred atomics reach the same address per launch.
__global__ void __launch_bounds__(kBlock) accumulate_kernel(const float4* __restrict__ sum,
                                                            const float4* __restrict__ sum_sq, size_t pixels,
                                                            double* __restrict__ acc_sum,
                                                            double* __restrict__ acc_sum_sq,
                                                            unsigned long long* counters,
                                                            unsigned* __restrict__ bad_pixels) {
  unsigned long long rays = 0, bad = 0;
  for (size_t i = size_t(blockIdx.x) * kBlock + threadIdx.x; i < pixels; i += size_t(gridDim.x) * kBlock) {
    const float4 s = sum[i], q = sum_sq[i];
    double* a = acc_sum + 3 * i;
    double* b = acc_sum_sq + 3 * i;
    a[0] += double(s.x);
    a[1] += double(s.y);
    a[2] += double(s.z);
    b[0] += double(q.x);
    b[1] += double(q.y);
    b[2] += double(q.z);
    rays += (unsigned long long)s.w;
    bad += (unsigned long long)q.w;
    if (q.w > 0.f) bad_pixels[i] += unsigned(q.w);
  }
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
    if (r) atomicAdd(&counters[0], r);
    if (b) atomicAdd(&counters[1], b);
  }
}

unsigned grid_for(size_t pixels, int num_sms) {
  size_t blocks = (pixels + kBlock - 1) / kBlock;
  size_t cap = size_t(num_sms > 0 ? num_sms : 1) * 8;  // a few waves of resident blocks
  if (blocks > cap) blocks = cap;
  return unsigned(blocks > 0 ? blocks : 1);
}

}  // namespace

cudaError_t launch_accumulate(const float4* sum, const float4* sum_sq, size_t pixels, double* acc_sum,
                              double* acc_sum_sq, unsigned long long* counters, unsigned* bad_pixels, int num_sms,
                              cudaStream_t stream) {
  accumulate_kernel<<<grid_for(pixels, num_sms), kBlock, 0, stream>>>(sum, sum_sq, pixels, acc_sum, acc_sum_sq,
                                                                     counters, bad_pixels);
  return cudaGetLastError();
}

}  // namespace optix
}  // namespace pn
