// The cuda traversal's shadow stage fused with the wavefront's apply stage: one kernel traces every query of the
// shadow queue and hands its answer to apply_shadow_result at once, with no blocked bits between two kernels.
// Built apart from wavefront_gpu.cu, without fast math: its traversal must round as the trace kernels' do.
//
// This header has no CUDA types, so any C++ code may include it.
#pragma once

#include "backends/cuda/bvh_layout.h"
#include "backends/wavefront/wavefront.h"

namespace pn {

// Queued on `stream` (a cudaStream_t). `bvh` and `scene` are device views (scene: alpha masks); `view` points
// to the wavefront's WavefrontView in device memory (restir's primary pass sets its RestirFrame per render call,
// after a CUDA graph holding this launch is recorded); `capacity` bounds the shadow queue's device count.
// `ordered`: the queue's ShadowOrder holds this queue's order (wavefront.h); its queries are then traced in that
// order, each from the light's end back (reversed_shadow_ray) where ShadowOrder::reverse says so.
// `form`: the traversal's form for shadow rays (CudaTraversal::forms().shadow, bvh_traverse.h); `min_blocks` and
// `block_size`: how its trace kernels launch (CudaTraversal::shape(), trace_kernels.h), which this one follows.
void launch_shadow_apply(const BvhView& bvh, int form, int min_blocks, int block_size, const SceneView& scene,
                         const WavefrontView* view, uint32_t capacity, bool ordered, void* stream);

}  // namespace pn
