#include "backends/probe_rays.h"

#include <algorithm>
#include <cmath>

#include "core/geometry.h"
#include "core/reservoir.h"

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

namespace {

// A uniform point on the scene's placed triangles (an instance uniformly, then a
// triangle of its mesh by area), with its bound and normal as a hit there has.
struct SurfacePicker {
  const Scene& scene;
  std::vector<uint32_t> instances;           // placed instances with triangles
  std::vector<std::vector<double>> mesh_cdf;  // per mesh: cumulative triangle areas (object space)

  explicit SurfacePicker(const Scene& s) : scene(s), mesh_cdf(s.meshes.size()) {
    for (uint32_t i = 0; i < s.instances.size(); ++i) {
      const uint32_t m = s.instances[i].mesh;
      if (s.meshes[m].indices.empty()) continue;
      instances.push_back(i);
      std::vector<double>& cdf = mesh_cdf[m];
      if (!cdf.empty()) continue;
      double sum = 0;
      for (const auto& t : s.meshes[m].indices) {
        const Vec3& a = s.meshes[m].positions[t[0]];
        sum += 0.5 * double(length(cross(s.meshes[m].positions[t[1]] - a, s.meshes[m].positions[t[2]] - a)));
        cdf.push_back(sum);
      }
    }
  }

  // Point, its bound and the unit normal (flipped to a random side); false where the triangle is degenerate.
  bool pick(Rng& rng, Vec3* p, PointBound* bound, Vec3* n, uint32_t* instance, uint32_t* prim) const {
    *instance = instances[std::min(size_t(rng.uniform() * float(instances.size())), instances.size() - 1)];
    const Instance& inst = scene.instances[*instance];
    const TriangleMesh& mesh = scene.meshes[inst.mesh];
    const std::vector<double>& cdf = mesh_cdf[inst.mesh];
    const double u = double(rng.uniform()) * cdf.back();
    *prim = uint32_t(std::min(size_t(std::upper_bound(cdf.begin(), cdf.end(), u) - cdf.begin()), cdf.size() - 1));
    const auto& t = mesh.indices[*prim];
    const Vec3 p0 = mesh.positions[t[0]], p1 = mesh.positions[t[1]], p2 = mesh.positions[t[2]];
    if (!(length(cross(p1 - p0, p2 - p0)) > 0.f)) return false;
    Vec2 b = rng.uniform2();
    if (b.x + b.y > 1.f) b = Vec2(1.f - b.x, 1.f - b.y);
    Vec3 error;
    float clearance;
    triangle_hit(p0, p1, p2, b.x, b.y, p, &error, n, &clearance);
    instance_to_world(inst.to_world, inst.to_object, p, &error, n, &clearance);
    *bound = PointBound(error_along(error, *n), clearance);
    if (rng.uniform() < 0.5f) *n = -*n;
    return true;
  }
};

}  // namespace

SurfaceRays probe_surface_rays(const Scene& scene, uint32_t n, uint32_t seed) {
  constexpr float kMinSurfaceCos = 0.05f;
  SurfaceRays r;
  const SurfacePicker picker(scene);
  if (picker.instances.empty()) return r;
  Rng rng(2u, 0u, seed);
  r.closest.reserve(n), r.shadow.reserve(n), r.origin_instance.reserve(n), r.origin_prim.reserve(n);
  while (r.closest.size() < n) {
    Vec3 p, ng, q, nq;
    PointBound bp, bq;
    uint32_t inst, prim, inst_q, prim_q;
    if (!picker.pick(rng, &p, &bp, &ng, &inst, &prim) || !picker.pick(rng, &q, &bq, &nq, &inst_q, &prim_q)) continue;
    const Vec3 w = Frame::from_z(ng).to_world(sample_cosine_hemisphere(rng.uniform2()));
    if (!(dot(w, ng) > 0.f)) continue;
    TraceRay c;
    c.o = offset_ray_origin(p, ng, bp, w);
    c.d = w;
    c.tmax = kInf;
    // The shadow ray from p to q, leaving p on the side facing q (a ray into the surface is none a path makes).
    const Vec3 to_q = q - p;
    const float dist = length(to_q);
    if (!(dist > 0.f)) continue;
    const Vec3 wq = to_q / dist;
    // Not along either surface: a light point seen at a grazing angle contributes nothing, and where the ray runs
    // in a plane (p and q on one wall) where it crosses it is ill-conditioned.
    if (std::fabs(dot(wq, ng)) < kMinSurfaceCos || std::fabs(dot(wq, nq)) < kMinSurfaceCos) continue;
    const Vec3 side = dot(wq, ng) >= 0.f ? ng : -ng;
    const ShadowRay sr = light_shadow_ray(p, bp, side, wq, q, false);
    TraceRay s;
    s.o = sr.ray.o;
    s.d = sr.ray.d;
    s.tmax = sr.tmax;
    r.closest.push_back(c);
    r.shadow.push_back(s);
    r.origin_instance.push_back(inst);
    r.origin_prim.push_back(prim);
  }
  return r;
}

}  // namespace pn
