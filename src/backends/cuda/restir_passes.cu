// restir's reuse and shading passes with the cuda traversal traced inline (restir_passes.h). Built, as the trace
// kernels, without fast math: the triangle test rounds as on the CPU.
#include "backends/cuda/restir_passes.h"

#include <stdexcept>
#include <string>

#include <cuda_runtime.h>

#include "backends/cuda/bvh_traverse.h"
#include "backends/cuda/trace_kernels.h"
#include "backends/optix/launch_sums.h"
#include "core/restir.h"

namespace pn {
namespace {

constexpr int kBlock = 128;

void check(cudaError_t e, const char* what) {
  if (e != cudaSuccess)
    throw std::runtime_error(std::string("restir passes (cuda traversal): ") + what + ": " + cudaGetErrorString(e));
}

// The core's Tracer over the BVH, counting rays for the launch sums (the passes only ask for visibility).
struct InlineTracer {
  const BvhView* bvh;
  const SceneView* scene;
  mutable uint32_t rays = 0;
  __device__ bool occluded(const Ray& ray, float tmax) const {
    ++rays;
    return bvh_occluded(*bvh, scene, ray, tmax);
  }
};

// What both kernels read.
struct PassParams {
  BvhView bvh;
  SceneView scene;
  IntegratorSettings s;
  RestirFrameBuffers b;
  float4* sum = nullptr;
  float4* sum_sq = nullptr;
  int width = 0, height = 0;
  uint32_t sample = 0, seed = 0;
};

// Pass `pass` (kRestirTemporalPass: temporal reuse) from `in` into `out`.
__global__ void __launch_bounds__(kBlock) reuse_kernel(const PassParams p, const Reservoir* in, Reservoir* out,
                                                      uint32_t pass) {
  const uint32_t pixels = uint32_t(p.width) * uint32_t(p.height);
  const uint32_t pixel = blockIdx.x * blockDim.x + threadIdx.x;
  if (pixel >= pixels) return;
  const InlineTracer tracer{&p.bvh, &p.scene};
  if (pass == kRestirTemporalPass)
    out[pixel] = restir_temporal_reuse(tracer, p.scene, p.s.restir, p.b.pixels[pixel], in[pixel],
                                       p.b.history_pixels[pixel], p.b.history[pixel], pixel, p.sample, p.seed);
  else
    out[pixel] = restir_spatial_reuse(tracer, p.scene, p.s.restir, p.b.pixels, in, p.width, p.height,
                                      int(pixel % uint32_t(p.width)), int(pixel / uint32_t(p.width)), p.sample,
                                      p.seed, pass);
  p.sum[pixel].w += float(tracer.rays);
}

// The final reservoirs shaded (restir_shade) into this sample's launch sums; the next sample's history kept.
__global__ void __launch_bounds__(kBlock) shade_kernel(const PassParams p, const Reservoir* final_reservoirs) {
  const uint32_t pixels = uint32_t(p.width) * uint32_t(p.height);
  const uint32_t pixel = blockIdx.x * blockDim.x + threadIdx.x;
  if (pixel >= pixels) return;
  const InlineTracer tracer{&p.bvh, &p.scene};
  const RestirPixel& q = p.b.pixels[pixel];
  const Vec3 L = q.L + restir_shade(tracer, p.scene, p.s, q, final_reservoirs[pixel]);
  if (p.b.history) {
    p.b.history_pixels[pixel] = q;
    p.b.history[pixel] = final_reservoirs[pixel];
  }
  SampleSums<float> sums;  // this frame's one sample
  sums.add(L);
  store_launch_sums(p.sum, p.sum_sq, pixel, sums, p.sum[pixel].w + float(tracer.rays));
}

}  // namespace

void cuda_restir_passes(const CudaTraversal& traversal, const SceneView& scene, const IntegratorSettings& s,
                        int width, int height, uint32_t sample, uint32_t seed, const RestirFrameBuffers& b,
                        void* sum, void* sum_sq, void* stream_ptr) {
  cudaStream_t stream = static_cast<cudaStream_t>(stream_ptr);
  PassParams p;
  p.bvh = traversal.view();
  p.scene = scene;
  p.s = s;
  p.b = b;
  p.sum = static_cast<float4*>(sum);
  p.sum_sq = static_cast<float4*>(sum_sq);
  p.width = width;
  p.height = height;
  p.sample = sample;
  p.seed = seed;
  const uint32_t pixels = uint32_t(width) * uint32_t(height);
  const unsigned grid = (pixels + kBlock - 1) / kBlock;
  if (grid == 0) return;
  int cur = 0;  // reservoirs[cur]: the latest
  if (s.restir.temporal) {
    reuse_kernel<<<grid, kBlock, 0, stream>>>(p, b.reservoirs[cur], b.reservoirs[cur ^ 1], kRestirTemporalPass);
    cur ^= 1;
  }
  for (uint32_t pass = 0; pass < s.restir.spatial_passes; ++pass) {
    reuse_kernel<<<grid, kBlock, 0, stream>>>(p, b.reservoirs[cur], b.reservoirs[cur ^ 1], pass);
    cur ^= 1;
  }
  check(cudaGetLastError(), "launching the reuse kernels");
  shade_kernel<<<grid, kBlock, 0, stream>>>(p, b.reservoirs[cur]);
  check(cudaGetLastError(), "launching the shading kernel");
}

}  // namespace pn
