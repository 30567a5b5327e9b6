// wavefront_shadow.h's kernel: the shadow queue traced by the cuda traversal and applied in one pass.
#include "backends/wavefront/wavefront_shadow.h"

#include <stdexcept>
#include <string>

#include <cuda_runtime.h>

#include "backends/cuda/bvh_traverse.h"
#include "backends/cuda/trace_kernels.h"

namespace pn {
namespace {

template <int kMinBlocks, int kForm>
__global__ void __launch_bounds__(cuda_trace_max_threads(kMinBlocks), kMinBlocks)
    shadow_apply_kernel(BvhView bvh, SceneView scene, const WavefrontView* view, bool ordered) {
  const WavefrontView& w = *view;
  const uint32_t i = blockIdx.x * blockDim.x + threadIdx.x;
  if (i >= *w.shadow.count) return;
  const uint32_t j = ordered ? w.shadow_order.order[i] : i;  // wavefront.h's ShadowOrder
  float tmax;
  Ray ray = load_trace_ray(w.shadow.rays + j, &tmax);
  if (ordered && w.shadow_order.reverse) ray = reversed_shadow_ray(ray, &tmax);
  HitRecord unused;
  apply_shadow_result(j, w, bvh_trace<true, kForm>(bvh, &scene, ray, tmax, &unused));
}

}  // namespace

void launch_shadow_apply(const BvhView& bvh, int form, int min_blocks, int block_size, const SceneView& scene,
                         const WavefrontView* view, uint32_t capacity, bool ordered, void* stream) {
  // One thread a slot, as the trace kernels (grids held to a few waves of resident blocks were measured on the
  // H200: Sponza 11.65 -> 11.85 ms a sample at four waves, 12.6 at one; the tail of long rays then waits).
  const unsigned threads = unsigned(block_size);
  const unsigned blocks = (capacity + threads - 1) / threads;
  if (blocks == 0) return;
  cudaStream_t s = static_cast<cudaStream_t>(stream);
  // Compiled for the trace kernels' occupancy (trace_kernels.h).
  with_trace_min_blocks(min_blocks, [&](auto b) {
    with_trace_form(form, [&](auto f) {
      shadow_apply_kernel<decltype(b)::value, decltype(f)::value><<<blocks, threads, 0, s>>>(bvh, scene, view,
                                                                                            ordered);
    });
  });
  const cudaError_t e = cudaGetLastError();
  if (e != cudaSuccess)
    throw std::runtime_error(std::string("wavefront: the shadow + apply kernel: ") + cudaGetErrorString(e));
}

}  // namespace pn
