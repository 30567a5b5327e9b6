// The trace stage's cuda implementation on the device: a BvhHost (bvh_build.h)
// uploaded as it is, and one-ray-per-thread kernels running bvh_traverse.h.
// This header has no CUDA types, so any C++ code may include it.
#pragma once

#include <cstdint>
#include <type_traits>

#include "backends/cuda/bvh_build.h"
#include "backends/cuda/trace_forms.h"
#include "backends/trace_stage.h"

namespace pn {

// The trace kernels' launch bound, threads a block, where they are compiled for `min_blocks` resident blocks an SM
// (GpuTuning::cuda_occ): 128 where that is above 0, else the most cuda_block may ask for.
constexpr int cuda_trace_max_threads(int min_blocks) { return min_blocks ? 128 : 256; }
// How the trace kernels launch, for kernels elsewhere that trace too: compiled for min_blocks resident blocks of
// 128 threads an SM (GpuTuning::cuda_occ: 10; 0, as many registers as they take, or 12), in blocks of block_size
// threads (GpuTuning::cuda_block: 128).
struct CudaTraceShape {
  int min_blocks = 10;
  int block_size = 128;
};
// The shape `tuning` asks for. Throws std::runtime_error with one line naming the key for one it cannot launch.
CudaTraceShape cuda_trace_shape(const GpuTuning& tuning);
// Calls f(std::integral_constant<int, B>()) for B = min_blocks (CudaTraceShape::min_blocks): a kernel template on B
// launched inside f (with CudaTraceShape::block_size threads, 128 for B > 0) is the variant the run asks for.
template <class F>
void with_trace_min_blocks(int min_blocks, F&& f) {
  switch (min_blocks) {
    case 10: f(std::integral_constant<int, 10>()); break;
    case 12: f(std::integral_constant<int, 12>()); break;
    default: f(std::integral_constant<int, 0>()); break;
  }
}

// Calls f(std::integral_constant<int, F>()) for F = form (0..7): a kernel template on F launched inside f.
template <class F>
void with_trace_form(int form, F&& f) {
  switch (form) {
    case 1: f(std::integral_constant<int, 1>()); break;
    case 2: f(std::integral_constant<int, 2>()); break;
    case 3: f(std::integral_constant<int, 3>()); break;
    case 4: f(std::integral_constant<int, 4>()); break;
    case 5: f(std::integral_constant<int, 5>()); break;
    case 6: f(std::integral_constant<int, 6>()); break;
    case 7: f(std::integral_constant<int, 7>()); break;
    default: f(std::integral_constant<int, 0>()); break;
  }
}

class CudaTraversal {
 public:
  // Uploads the BVH to the current device; its kernels launch as `tuning` says (cuda_occ, cuda_block; the forms:
  // cuda_loop, cuda_box, cuda_flat). Throws std::runtime_error with one line.
  CudaTraversal(const BvhHost& bvh, const GpuTuning& tuning);
  ~CudaTraversal();
  CudaTraversal(const CudaTraversal&) = delete;
  CudaTraversal& operator=(const CudaTraversal&) = delete;

  // Queued on `stream` (a cudaStream_t; null: the default stream). `rays`, `hits`
  // and `blocked_bits` are device memory; `scene` is the device SceneView
  // (OptixBackend::device_scene_view()), read only for alpha masks. Closest:
  // one HitRecord a ray, instance kTraceMiss for a miss. Shadow: bit i of the
  // trace_bit_words(count) words is 1 when ray i is blocked (every word written).
  void trace_closest(const TraceRay* rays, uint32_t count, HitRecord* hits, const SceneView& scene,
                     void* stream) const;
  void trace_shadow(const TraceRay* rays, uint32_t count, uint32_t* blocked_bits, const SceneView& scene,
                    void* stream) const;
  // The same over a queue whose length is in device memory (`device_count`, at most `capacity`): the launch's
  // size is fixed, so a CUDA graph can hold it (the wavefront, backends/wavefront); threads past the count exit.
  // With `order` (device memory, a permutation of the queue's positions), thread i traces ray order[i] and writes
  // its hit at order[i]: the same hits, traced in another order.
  void trace_closest(const TraceRay* rays, const uint32_t* device_count, uint32_t capacity, HitRecord* hits,
                     const SceneView& scene, void* stream, const uint32_t* order = nullptr) const;
  void trace_shadow(const TraceRay* rays, const uint32_t* device_count, uint32_t capacity, uint32_t* blocked_bits,
                    const SceneView& scene, void* stream) const;

  const BvhView& device_view() const { return view_; }  // the BVH in device memory, for kernels of other stages
  const CudaTraceForms& forms() const { return forms_; }  // how its kernels trace (for kernels of other stages)
  const CudaTraceShape& shape() const { return shape_; }  // how its kernels launch (for kernels of other stages)
  uint64_t device_bytes() const { return bytes_; }
  const BvhStats& stats() const { return stats_; }

 private:
  BvhView view_;  // device pointers
  void* buffers_[5] = {};
  uint64_t bytes_ = 0;
  BvhStats stats_;
  CudaTraceShape shape_;
  CudaTraceForms forms_;
};

}  // namespace pn
