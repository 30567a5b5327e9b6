// The GPU backend's accumulation kernel.
#include "backends/optix/kernels.h"

#include "backends/gpu/launch_sums.h"

namespace pn {
namespace optix {
namespace {

constexpr int kBlock = 256;

// Grid-stride over pixels; per-block reduction of the two counters so that only
// a few hundred atomics reach the same address per launch.
__global__ void __launch_bounds__(kBlock) accumulate_kernel(const float4* __restrict__ sum,
                                                            const float4* __restrict__ sum_sq, size_t pixels,
                                                            DeviceFilm film) {
  unsigned long long rays = 0, bad = 0;
  for (size_t i = size_t(blockIdx.x) * kBlock + threadIdx.x; i < pixels; i += size_t(gridDim.x) * kBlock)
    film_add(film, i, sum[i], sum_sq[i], &rays, &bad);
  add_block_counters<kBlock>(film, rays, bad);
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
  DeviceFilm film;
  film.sum = acc_sum;
  film.sum_sq = acc_sum_sq;
  film.counters = counters;
  film.bad_pixels = bad_pixels;
  accumulate_kernel<<<grid_for(pixels, num_sms), kBlock, 0, stream>>>(sum, sum_sq, pixels, film);
  return cudaGetLastError();
}

}  // namespace optix
}  // namespace pn
