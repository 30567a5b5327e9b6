#include "backends/probe_rays.h"

#include "core/rng.h"
#include "core/sampling.h"

namespace pn {

Bounds3 scene_bounds(const Scene& scene) {
  Bounds3 b;
  std::vector<Bounds3> mesh(scene.meshes.size());
  for (size_t i = 0; i < scene.meshes.size(); ++i)
    for (const Vec3& p : scene.meshes[i].positions) {
      mesh[i].lo = vmin(mesh[i].lo, p);
      mesh[i].hi = vmax(mesh[i].hi, p);
    }
  for (const Instance& inst : scene.instances) {
    const Bounds3& m = mesh.at(inst.mesh);
    if (m.empty() || scene.meshes[inst.mesh].indices.empty()) continue;
    for (int k = 0; k < 8; ++k) {
      const Vec3 corner(k & 1 ? m.hi.x : m.lo.x, k & 2 ? m.hi.y : m.lo.y, k & 4 ? m.hi.z : m.lo.z);
      const Vec3 p = inst.to_world.point(corner);
      b.lo = vmin(b.lo, p);
      b.hi = vmax(b.hi, p);
    }
  }
  for (const Sphere& s : scene.spheres) {
    b.lo = vmin(b.lo, s.center - Vec3(s.radius));
    b.hi = vmax(b.hi, s.center + Vec3(s.radius));
  }
  return b;
}

namespace {

Vec3 point_in(const Bounds3& b, Rng& rng) {
  const Vec3 e = b.hi - b.lo;
  return b.lo + Vec3(rng.uniform() * e.x, rng.uniform() * e.y, rng.uniform() * e.z);
}

}  // namespace

std::vector<TraceRay> probe_closest_rays(const Bounds3& b, uint32_t n, uint32_t seed) {
  std::vector<TraceRay> rays(n);
  Rng rng(0u, 0u, seed);
  for (TraceRay& r : rays) {
    r.o = point_in(b, rng);
    r.d = sample_uniform_sphere(rng.uniform2());
    r.tmax = kInf;
  }
  return rays;
}

std::vector<TraceRay> probe_shadow_rays(const Bounds3& b, uint32_t n, uint32_t seed) {
  std::vector<TraceRay> rays(n);
  Rng rng(1u, 0u, seed);
  for (TraceRay& r : rays) {
    r.o = point_in(b, rng);
    const Vec3 to = point_in(b, rng) - r.o;
    const float len = length(to);
    r.d = len > 0.f ? to / len : Vec3(0.f, 0.f, 1.f);
    r.tmax = len;
  }
  return rays;
}

}  // namespace pn
