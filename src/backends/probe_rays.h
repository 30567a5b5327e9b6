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

// Rays that leave surfaces, as a path tracer's do: the origin a uniform point of
// a placed triangle (an instance chosen uniformly, then a triangle of its mesh by
// area), resolved as a hit there is (core/scene_view.h: the interpolated point,
// its error bound and clearance) and offset by offset_ray_origin on a random side
// of the surface. `closest`: a cosine-distributed direction on that side, tmax
// infinite (a bounce); `shadow`: towards another such surface point, stopping
// kShadowEpsilon short of it (light_shadow_ray), at least 3 degrees off both
// surfaces' planes. `origin_instance` and
// `origin_prim` name each closest ray's triangle: a ray leaving a planar
// triangle can never hit it again, so a hit there is a self-intersection.
struct SurfaceRays {
  std::vector<TraceRay> closest, shadow;
  std::vector<uint32_t> origin_instance, origin_prim;
};
SurfaceRays probe_surface_rays(const Scene& scene, uint32_t n, uint32_t seed);

}  // namespace pn
