// The CPU reference backend: Embree 3 for ray queries, all cores, tiled.
#pragma once

#include <memory>

#include "render/backend.h"

namespace pn {

std::unique_ptr<Backend> make_cpu_backend(const Scene& scene, int threads);

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
