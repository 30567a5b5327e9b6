// Memory estimates of a render, checked before allocating (io/host_memory.h's
// check_memory): the film, the images written, the CPU backend's acceleration
// structures. (The GPU backend makes the same check against cudaMemGetInfo:
// backends/optix/optix_backend.cpp.)
#pragma once

#include <cstdint>
#include <string>
#include <utility>
#include <vector>


namespace pn {

struct Scene;

// Bytes of a Film of w x h pixels (per-pixel sums and sums of squares, double RGB).
uint64_t film_bytes(int width, int height);
// Peak bytes of writing one w x h image: the float image plus its encoding.
uint64_t image_write_bytes(int width, int height);
// The CPU backend's copy of the geometry and its Embree BVHs (measured on the
// built-in scenes: 40-135 bytes a triangle, about 330 an instance; this errs high),
// the light BVH, and restir's per-pixel buffers where the scene's settings use them.
uint64_t cpu_backend_bytes(const Scene& scene);

}  // namespace pn
