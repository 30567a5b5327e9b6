// Random incoherent rays inside a scene's bounds, for `penumbra bench --probe` and
// the cuda traversal's tests: the limit of a trace stage on any scene, free of
// any path tracer's ray order. Deterministic for a seed.
#pragma once

#include <cstdint>
#include <vector>

#include "backends/trace_stage.h"
#include "scene/scene.h"

namespace pn {

struct Bounds3 {
  Vec3 lo{kInf}, hi{-kInf};
  bool empty() const { return !(lo.x <= hi.x && lo.y <= hi.y && lo.z <= hi.z); }
};

// The world-space box of everything a ray can hit (placed meshes, spheres).
Bounds3 scene_bounds(const Scene& scene);

// Closest-hit rays: origins uniform in the bounds, directions uniform on the
// sphere, tmax infinite.
std::vector<TraceRay> probe_closest_rays(const Bounds3& b, uint32_t n, uint32_t seed);

// Shadow rays: from a point uniform in the bounds to another, tmax their distance.
std::vector<TraceRay> probe_shadow_rays(const Bounds3& b, uint32_t n, uint32_t seed);

}  // namespace pn
