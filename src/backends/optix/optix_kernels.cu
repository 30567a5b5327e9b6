// Accumulation and tone-mapping kernels of the GPU backend.
#include "backends/optix/kernels.h"

namespace pn {
namespace optix {
namespace {

constexpr int kBlock = 256;

__device__ __forceinline__ unsigned char srgb8(float v) {
  if (!(v > 0.f)) return 0;  // also maps NaN to 0
  float s = v <= 0.0031308f ? 12.92f * v : 1.055f * powf(v, 1.f / 2.4f) - 0.055f;
  return (unsigned char)lrintf(fminf(1.f, s) * 255.f);
}

__device__ __forceinline__ uchar4 tonemap_pixel(double r, double g, double b, float scale) {
  return make_uchar4(srgb8(float(r) * scale), srgb8(float(g) * scale), srgb8(float(b) * scale), 255);
}

// Grid-stride over pixels; per-block reduction of the two counters so that only
// a few hundred atomics reach the same address per launch.
__global__ void __launch_bounds__(kBlock) accumulate_kernel(const float4* __restrict__ sum,
                                                            const float4* __restrict__ sum_sq, size_t pixels,
                                                            double* __restrict__ acc_sum,
                                                            double* __restrict__ acc_sum_sq,
                                                            unsigned long long* counters,
                                                            unsigned* __restrict__ bad_pixels, uchar4* rgba,
                                                            float scale) {
  unsigned long long rays = 0, bad = 0;
  for (size_t i = size_t(blockIdx.x) * kBlock + threadIdx.x; i < pixels; i += size_t(gridDim.x) * kBlock) {
    const float4 s = sum[i], q = sum_sq[i];
    double* a = acc_sum + 3 * i;
    double* b = acc_sum_sq + 3 * i;
    const double r = a[0] + s.x, g = a[1] + s.y, bl = a[2] + s.z;
    a[0] = r;
    a[1] = g;
    a[2] = bl;
    b[0] += double(q.x);
    b[1] += double(q.y);
    b[2] += double(q.z);
    rays += (unsigned long long)s.w;
    bad += (unsigned long long)q.w;
    if (q.w > 0.f) bad_pixels[i] += unsigned(q.w);
    if (rgba) rgba[i] = tonemap_pixel(r, g, bl, scale);
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

__global__ void __launch_bounds__(kBlock) tonemap_kernel(const double* __restrict__ acc_sum, size_t pixels,
                                                         float scale, uchar4* __restrict__ rgba) {
  for (size_t i = size_t(blockIdx.x) * kBlock + threadIdx.x; i < pixels; i += size_t(gridDim.x) * kBlock) {
    const double* a = acc_sum + 3 * i;
    rgba[i] = tonemap_pixel(a[0], a[1], a[2], scale);
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
                              double* acc_sum_sq, unsigned long long* counters, unsigned* bad_pixels, uchar4* rgba,
                              float scale, int num_sms, cudaStream_t stream) {
  accumulate_kernel<<<grid_for(pixels, num_sms), kBlock, 0, stream>>>(sum, sum_sq, pixels, acc_sum, acc_sum_sq,
                                                                     counters, bad_pixels, rgba, scale);
  return cudaGetLastError();
}

cudaError_t launch_tonemap(const double* acc_sum, size_t pixels, float scale, uchar4* rgba, int num_sms,
                           cudaStream_t stream) {
  tonemap_kernel<<<grid_for(pixels, num_sms), kBlock, 0, stream>>>(acc_sum, pixels, scale, rgba);
  return cudaGetLastError();
}

}  // namespace optix
}  // namespace pn
