// The CPU reference backend: Embree 3 for ray queries, all cores, tiled.
#pragma once

#include <cstdint>
#include <memory>

#include "render/backend.h"

namespace pn {

// The order in which the CPU advances paths (core/integrator.h's step
// functions). Both give the same image, bit for bit.
enum class CpuSchedule {
  DepthFirst,    // one path at a time, to its end (trace_path): the default
  BreadthFirst,  // a pool of paths per tile, one step at a time, in a wavefront GPU's order (tests)
  Wavefront,     // the GPU wavefront's stages (backends/wavefront/wavefront.h) over a whole-frame pool (tests)
};

// wavefront_paths: the Wavefront schedule's pool (slots; 0: 2^20); a render call runs in waves of that many
// paths, the last one partial.
std::unique_ptr<Backend> make_cpu_backend(const Scene& scene, int threads,
                                          CpuSchedule schedule = CpuSchedule::DepthFirst,
                                          uint32_t wavefront_paths = 0);

// The backend's two ray queries alone, answered by its Embree scene: the
// reference the other traversals (backends/cuda) are tested against.
class RayQueries {
 public:
  virtual ~RayQueries() = default;
  virtual bool intersect(const Ray& ray, float tmax, HitRecord* hit) const = 0;
  virtual bool occluded(const Ray& ray, float tmax) const = 0;
};
std::unique_ptr<RayQueries> make_cpu_ray_queries(const Scene& scene);

}  // namespace pn
