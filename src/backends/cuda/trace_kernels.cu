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

int block_size() { return cuda_trace_block_size(); }

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

// kMinBlocks: the resident blocks an SM the launch bound asks for (cuda_trace_min_blocks); 0 asks for none
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

unsigned blocks(uint32_t count) { return unsigned((count + block_size() - 1) / block_size()); }

// The kernels as compiled for cuda_trace_min_blocks() resident blocks an SM.
template <class... A>
void launch_closest(unsigned grid, cudaStream_t s, int form, A... a) {
  with_trace_min_blocks([&](auto b) {
    with_trace_form(form, [&](auto f) {
      closest_kernel<decltype(b)::value, decltype(f)::value><<<grid, block_size(), 0, s>>>(a...);
    });
  });
}
template <class... A>
void launch_shadow(unsigned grid, cudaStream_t s, int form, A... a) {
  with_trace_min_blocks([&](auto b) {
    with_trace_form(form, [&](auto f) {
      shadow_kernel<decltype(b)::value, decltype(f)::value><<<grid, block_size(), 0, s>>>(a...);
    });
  });
}

}  // namespace

// Resident blocks of 128 threads an SM the kernels are compiled for: 10 (48 registers, a few spilled), or
// PENUMBRA_CUDA_OCC = 0 (as many registers as they take, 64: 8 blocks) or 12 (40 registers). The traversal waits on
// dependent node loads, and more warps hide more of that: on the H200, Sponza 10.93 -> 10.69 ms a sample at 10
// blocks (10.70 at 12), cornell-sphere 1.934 -> 1.943 (1.99 at 12); random rays in Sponza 1.73 -> 1.67 ms closest,
// 1.76 -> 1.68 shadow.
int cuda_trace_min_blocks() {
  static const int b = [] {
    const char* env = std::getenv("PENUMBRA_CUDA_OCC");
    if (!env) return 10;
    const std::string v = env;
    if (v == "0" || v == "10" || v == "12") return std::stoi(v);
    throw std::runtime_error("PENUMBRA_CUDA_OCC must be 0, 10 or 12 (resident blocks an SM), not '" + v + "'");
  }();
  return b;
}

// Threads per block: 128 unless PENUMBRA_CUDA_BLOCK (32..256, a multiple of 32) says otherwise (tuning; not with
// PENUMBRA_CUDA_OCC, whose kernels are compiled for 128).
int cuda_trace_block_size() {
  static const int b = [] {
    const char* env = std::getenv("PENUMBRA_CUDA_BLOCK");
    const int v = env ? std::atoi(env) : 128;
    return (v >= 32 && v <= cuda_trace_max_threads(0) && v % 32 == 0 && cuda_trace_min_blocks() == 0) ? v : 128;
  }();
  return b;
}

CudaTraversal::CudaTraversal(const BvhHost& bvh) : stats_(bvh.stats) {
  cuda_trace_block_size();  // reads PENUMBRA_CUDA_OCC and _BLOCK now: a bad value stops here, before any launch
  view_ = bvh.view();
  forms_ = choose_trace_forms(view_.flat, stats_.sah_visits_per_ray);
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
  launch_closest(blocks(count), s, forms_.closest, view_, scene, rays, count, nullptr, hits, nullptr);
  check(cudaGetLastError(), "launching the closest-hit kernel");
}

void CudaTraversal::trace_shadow(const TraceRay* rays, uint32_t count, uint32_t* blocked_bits,
                                 const SceneView& scene, void* stream) const {
  if (count == 0) return;
  cudaStream_t s = static_cast<cudaStream_t>(stream);
  launch_shadow(blocks(count), s, forms_.shadow, view_, scene, rays, count, nullptr, blocked_bits);
  check(cudaGetLastError(), "launching the shadow kernel");
}

void CudaTraversal::trace_closest(const TraceRay* rays, const uint32_t* device_count, uint32_t capacity,
                                  HitRecord* hits, const SceneView& scene, void* stream, const uint32_t* order) const {
  if (capacity == 0) return;
  cudaStream_t s = static_cast<cudaStream_t>(stream);
  launch_closest(blocks(capacity), s, forms_.closest, view_, scene, rays, capacity, device_count, hits, order);
  check(cudaGetLastError(), "launching the closest-hit kernel");
}

void CudaTraversal::trace_shadow(const TraceRay* rays, const uint32_t* device_count, uint32_t capacity,
                                 uint32_t* blocked_bits, const SceneView& scene, void* stream) const {
  if (capacity == 0) return;
  cudaStream_t s = static_cast<cudaStream_t>(stream);
  launch_shadow(blocks(capacity), s, forms_.shadow, view_, scene, rays, capacity, device_count, blocked_bits);
  check(cudaGetLastError(), "launching the shadow kernel");
}

}  // namespace pn
