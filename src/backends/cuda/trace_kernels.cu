// The cuda traversal's kernels: one ray per thread, bvh_traverse.h as the CPU
// tests run it. Built without fast math: the triangle test must round as it
// does on the CPU, where it is checked against Embree.
#include "backends/cuda/trace_kernels.h"

#include <cstdlib>
#include <stdexcept>
#include <string>
#include <vector>

#include <cuda_runtime.h>

#include "backends/cuda/bvh_traverse.h"

namespace pn {
namespace {

void check(cudaError_t e, const char* what) {
  if (e != cudaSuccess)
    throw std::runtime_error(std::string("cuda traversal: ") + what + ": " + cudaGetErrorString(e));
}

__device__ __forceinline__ Ray load_ray(const TraceRay* rays, uint32_t i, float* tmax) {
  const float4* p = reinterpret_cast<const float4*>(rays + i);
  const float4 a = __ldg(p), b = __ldg(p + 1);
  *tmax = a.w;
  return Ray(Vec3(a.x, a.y, a.z), Vec3(b.x, b.y, b.z));
}

// kMinBlocks: the resident blocks an SM the launch bound asks for (GpuTuning::cuda_occ); 0 asks for none
// (registers as needed).
template <int kMinBlocks, int kForm>
__global__ void __launch_bounds__(cuda_trace_max_threads(kMinBlocks), kMinBlocks)
    closest_kernel(BvhView bvh, SceneView scene, const TraceRay* rays, uint32_t count, const uint32_t* device_count,
                   HitRecord* hits, const uint32_t* order) {
  const uint32_t i = blockIdx.x * blockDim.x + threadIdx.x;
  if (device_count) count = *device_count;
  if (i >= count) return;
  const uint32_t j = order ? order[i] : i;
  float tmax;
  const Ray ray = load_ray(rays, j, &tmax);
  HitRecord h;
  if (!bvh_trace<false, kForm>(bvh, &scene, ray, tmax, &h)) h.instance = kTraceMiss;
  hits[j] = h;
}

// Every thread of a warp reaches the ballot; its lane 0 writes the warp's word.
template <int kMinBlocks, int kForm>
__global__ void __launch_bounds__(cuda_trace_max_threads(kMinBlocks), kMinBlocks)
    shadow_kernel(BvhView bvh, SceneView scene, const TraceRay* rays, uint32_t count, const uint32_t* device_count,
                  uint32_t* bits) {
  const uint32_t i = blockIdx.x * blockDim.x + threadIdx.x;
  if (device_count) count = *device_count;
  if ((i & ~31u) >= count) return;  // a whole warp past the end: no word of its to write
  bool blocked = false;
  if (i < count) {
    float tmax;
    const Ray ray = load_ray(rays, i, &tmax);
    HitRecord unused;
    blocked = bvh_trace<true, kForm>(bvh, &scene, ray, tmax, &unused);
  }
  const uint32_t word = __ballot_sync(0xFFFFFFFFu, blocked);
  if ((threadIdx.x & 31u) == 0 && i < count) bits[i / 32u] = word;
}

template <class T>
T* upload(const std::vector<T>& v, void** slot, uint64_t* bytes) {
  if (v.empty()) return nullptr;
  check(cudaMalloc(slot, v.size() * sizeof(T)), "allocating the BVH");
  check(cudaMemcpy(*slot, v.data(), v.size() * sizeof(T), cudaMemcpyHostToDevice), "uploading the BVH");
  *bytes += v.size() * sizeof(T);
  return static_cast<T*>(*slot);
}

// The kernels as compiled for `shape.min_blocks` resident blocks an SM, in blocks of shape.block_size threads
// over `count` rays.
template <class... A>
void launch_closest(const CudaTraceShape& shape, uint32_t count, cudaStream_t s, int form, A... a) {
  const unsigned grid = unsigned((count + shape.block_size - 1) / shape.block_size);
  with_trace_min_blocks(shape.min_blocks, [&](auto b) {
    with_trace_form(form, [&](auto f) {
      closest_kernel<decltype(b)::value, decltype(f)::value><<<grid, shape.block_size, 0, s>>>(a...);
    });
  });
}
template <class... A>
void launch_shadow(const CudaTraceShape& shape, uint32_t count, cudaStream_t s, int form, A... a) {
  const unsigned grid = unsigned((count + shape.block_size - 1) / shape.block_size);
  with_trace_min_blocks(shape.min_blocks, [&](auto b) {
    with_trace_form(form, [&](auto f) {
      shadow_kernel<decltype(b)::value, decltype(f)::value><<<grid, shape.block_size, 0, s>>>(a...);
    });
  });
}

}  // namespace

// Resident blocks of 128 threads an SM the kernels are compiled for: 10 (48 registers, a few spilled), or
// cuda_occ = 0 (as many registers as they take, 64: 8 blocks) or 12 (40 registers). The traversal waits on
// dependent node loads, and more warps hide more of that: on the H200, Sponza 10.93 -> 10.69 ms a sample at 10
// blocks (10.70 at 12), cornell-sphere 1.934 -> 1.943 (1.99 at 12); random rays in Sponza 1.73 -> 1.67 ms closest,
// 1.76 -> 1.68 shadow. Threads a block: 128 unless cuda_block (32..256, a multiple of 32; with cuda_occ = 0 only,
// parse_gpu_tuning checks) says otherwise.
CudaTraceShape cuda_trace_shape(const GpuTuning& tuning) {
  CudaTraceShape shape;
  if (tuning.cuda_occ != 0 && tuning.cuda_occ != 10 && tuning.cuda_occ != 12)
    throw std::runtime_error("cuda_occ must be 0, 10 or 12 (resident blocks an SM), not " +
                             std::to_string(tuning.cuda_occ));
  shape.min_blocks = tuning.cuda_occ;
  const int b = tuning.cuda_block;
  if (b != 128 && !(b >= 32 && b <= cuda_trace_max_threads(0) && b % 32 == 0 && shape.min_blocks == 0))
    throw std::runtime_error("cuda_block=" + std::to_string(b) + " needs cuda_occ=0 and a multiple of 32 in 32.." +
                             std::to_string(cuda_trace_max_threads(0)));
  shape.block_size = b;
  return shape;
}

CudaTraversal::CudaTraversal(const BvhHost& bvh, const GpuTuning& tuning)
    : stats_(bvh.stats), shape_(cuda_trace_shape(tuning)) {  // a bad shape stops here, before any allocation
  view_ = bvh.view();
  forms_ = choose_trace_forms(view_.flat, stats_.sah_visits_per_ray, tuning);
  try {
    view_.nodes = upload(bvh.nodes, &buffers_[0], &bytes_);
    view_.triangles = upload(bvh.triangles, &buffers_[1], &bytes_);
    view_.instances = upload(bvh.instances, &buffers_[2], &bytes_);
    view_.items = upload(bvh.items, &buffers_[3], &bytes_);
    view_.spheres = upload(bvh.spheres, &buffers_[4], &bytes_);
  } catch (...) {
    for (void* b : buffers_) cudaFree(b);
    throw;
  }
}

CudaTraversal::~CudaTraversal() {
  for (void* b : buffers_) cudaFree(b);
}

void CudaTraversal::trace_closest(const TraceRay* rays, uint32_t count, HitRecord* hits, const SceneView& scene,
                                  void* stream) const {
  if (count == 0) return;
  cudaStream_t s = static_cast<cudaStream_t>(stream);
  launch_closest(shape_, count, s, forms_.closest, view_, scene, rays, count, nullptr, hits, nullptr);
  check(cudaGetLastError(), "launching the closest-hit kernel");
}

void CudaTraversal::trace_shadow(const TraceRay* rays, uint32_t count, uint32_t* blocked_bits,
                                 const SceneView& scene, void* stream) const {
  if (count == 0) return;
  cudaStream_t s = static_cast<cudaStream_t>(stream);
  launch_shadow(shape_, count, s, forms_.shadow, view_, scene, rays, count, nullptr, blocked_bits);
  check(cudaGetLastError(), "launching the shadow kernel");
}

void CudaTraversal::trace_closest(const TraceRay* rays, const uint32_t* device_count, uint32_t capacity,
                                  HitRecord* hits, const SceneView& scene, void* stream, const uint32_t* order) const {
  if (capacity == 0) return;
  cudaStream_t s = static_cast<cudaStream_t>(stream);
  launch_closest(shape_, capacity, s, forms_.closest, view_, scene, rays, capacity, device_count, hits, order);
  check(cudaGetLastError(), "launching the closest-hit kernel");
}

void CudaTraversal::trace_shadow(const TraceRay* rays, const uint32_t* device_count, uint32_t capacity,
                                 uint32_t* blocked_bits, const SceneView& scene, void* stream) const {
  if (capacity == 0) return;
  cudaStream_t s = static_cast<cudaStream_t>(stream);
  launch_shadow(shape_, capacity, s, forms_.shadow, view_, scene, rays, capacity, device_count, blocked_bits);
  check(cudaGetLastError(), "launching the shadow kernel");
}

}  // namespace pn
