// restir's reuse and shading passes (core/restir.h) with the cuda traversal: plain CUDA kernels, one thread a
// pixel, that trace their shadow rays inline (bvh_traverse.h). Each pixel's rays depend on the neighbours it finds
// and on their samples, so they are traced where they are made, as the OptiX raygens of the same passes do.
// The primary pass before them is the wavefront's (backends/wavefront, RestirFrame).
// This header has no CUDA types, so any C++ code may include it.
#pragma once

#include <cstdint>

#include "core/integrator.h"
#include "core/reservoir.h"
#include "core/scene_view.h"

namespace pn {

class CudaTraversal;

// A frame's restir buffers in device memory, one entry a pixel.
struct RestirFrameBuffers {
  RestirPixel* pixels = nullptr;      // the primary pass's records (L: the path's radiance less x1's direct light)
  Reservoir* reservoirs[2] = {nullptr, nullptr};  // [0]: the primary pass's; the passes ping-pong between them
  RestirPixel* history_pixels = nullptr;  // temporal reuse (null without it): the previous sample's
  Reservoir* history = nullptr;
};

// After the primary pass of sample `sample`: temporal reuse (with s.restir.temporal), the spatial passes, then
// shading into the launch sums (float4 a pixel, as the megakernel's: sum.w already holds the primary pass's rays,
// to which the passes' shadow rays are added), keeping the history. Queued on `stream` (a cudaStream_t).
// `scene` is the device SceneView. Throws std::runtime_error with one line.
void cuda_restir_passes(const CudaTraversal& traversal, const SceneView& scene, const IntegratorSettings& s,
                        int width, int height, uint32_t sample, uint32_t seed, const RestirFrameBuffers& b,
                        void* sum, void* sum_sq, void* stream);

}  // namespace pn
