// The scene as the integrator sees it: flat arrays behind plain pointers (host
// memory on the CPU, device memory on the GPU), and the code that turns what a
// ray-tracing backend reports (instance, primitive, barycentrics, t) into a
// shading point. Both backends report the same HitRecord and the same function
// rebuilds the hit, so CPU and GPU shade bit-identical points.
#pragma once

#include "common.h"
#include "environment.h"
#include "features.h"
#include "geometry.h"
#include "light_selection.h"
#include "lights.h"
#include "material.h"
#include "texture.h"
#include "transform.h"
#include "vec.h"

namespace pn {

// A triangle mesh in object space. Optional arrays are null when absent.
struct MeshView {
  const Vec3* positions = nullptr;
  const uint32_t* indices = nullptr;        // 3 per triangle
  const Vec3* normals = nullptr;            // per vertex (smooth shading), or null
  const Vec2* uvs = nullptr;                // per vertex, image convention, or null
  const uint32_t* face_materials = nullptr; // per triangle, or null: the instance's material
  const int32_t* face_lights = nullptr;     // per triangle: rank among the mesh's emissive triangles, or -1
  uint32_t num_triangles = 0;
};

// One placement of a mesh in the world.
struct InstanceView {
  Affine to_world;
  Affine to_object;
  MeshView mesh;
  uint32_t material = 0;    // when the mesh has no per-face materials
  int32_t light = -1;       // >= 0: every triangle belongs to this light (quad lights)
  int32_t light_base = -1;  // >= 0: triangle t is light light_base + face_lights[t]
};

struct SphereView {
  Vec3 center;
  float radius = 1.f;
  uint32_t material = 0;
  int32_t light = -1;
};

// What a backend's closest-hit query reports.
constexpr uint32_t kSphereInstance = 0xFFFFFFFEu;  // `instance` of a hit on a sphere
struct HitRecord {
  float t = kInf;
  uint32_t instance = 0;  // index into SceneView::instances, or kSphereInstance
  uint32_t prim = 0;      // triangle of the instance's mesh, or sphere index
  float b1 = 0.f, b2 = 0.f;  // barycentrics of vertices 1 and 2 (triangles)
};

// A shading point, world space.
struct SurfaceHit {
  float t = kInf;
  Vec3 p;          // hit point: where the ray hit, to rounding
  PointBound p_bound;  // p's error bound along n and its clearance from its primitive's edges: offset_ray_origin's
  Vec3 n;          // unit geometric normal, as modelled (not flipped towards the ray)
  Vec3 ns;         // unit shading normal (interpolated vertex normals), same side as n
  Vec2 uv;         // texture coordinates (0 without)
  Vec3 dpdu;       // tangent along u (0 without texture coordinates)
  float bitangent_sign = 1.f;  // normal maps: bitangent = sign * cross(ns, tangent)
  uint32_t material = 0;
  int32_t light = -1;  // index into SceneView::lights if the surface emits, else -1
};

struct SceneView {
  const Light* lights = nullptr;
  uint32_t num_lights = 0;
  LightSelectionView selection;  // the power CDF
  const Material* materials = nullptr;
  uint32_t num_materials = 0;
  const TextureView* textures = nullptr;
  uint32_t num_textures = 0;
  const InstanceView* instances = nullptr;
  uint32_t num_instances = 0;
  const SphereView* spheres = nullptr;
  uint32_t num_spheres = 0;
  EnvironmentView environment;  // present() when the scene has an environment map
  int32_t environment_light = -1;  // its index in `lights`
  Vec3 background;  // radiance of rays that escape when there is no environment map
};

// --- Features: core/features.h ----------------------------------------------------

// --- Hits ----------------------------------------------------------------------

PN_FN Vec2 lerp_uv(Vec2 a, Vec2 b, Vec2 c, float b1, float b2) {
  float b0 = 1.f - b1 - b2;
  return Vec2(a.x * b0 + b.x * b1 + c.x * b2, a.y * b0 + b.y * b1 + c.y * b2);
}

PN_FN uint32_t triangle_material(const InstanceView& inst, uint32_t tri) {
  return inst.mesh.face_materials ? inst.mesh.face_materials[tri] : inst.material;
}

// A triangle hit of an instance: interpolated point, geometric normal from the
// winding, interpolated shading normal, uv and tangent, moved to world space.
template <uint32_t kFeatures = kAllFeatures>
PN_FN void resolve_triangle_hit(const InstanceView& inst, uint32_t tri, float b1, float b2, SurfaceHit* hit) {
  constexpr bool kShading = (kFeatures & kFeatureShading) != 0;
  const MeshView& m = inst.mesh;
  const uint32_t i0 = m.indices[3 * tri], i1 = m.indices[3 * tri + 1], i2 = m.indices[3 * tri + 2];
  const Vec3 p0 = m.positions[i0], p1 = m.positions[i1], p2 = m.positions[i2];
  Vec3 p, p_error, n;
  float clearance;
  triangle_hit(p0, p1, p2, b1, b2, &p, &p_error, &n, &clearance);
  Vec3 ns = n;
  if (kShading && m.normals) {
    const float b0 = 1.f - b1 - b2;
    Vec3 s = m.normals[i0] * b0 + m.normals[i1] * b1 + m.normals[i2] * b2;
    float len = length(s);
    if (len > 1e-12f) ns = s / len;
    if (dot(ns, n) < 0.f) ns = -ns;  // vertex normals disagreeing with the winding: trust the winding
  }
  Vec2 uv;
  Vec3 dpdu(0.f);
  float sign = 1.f;
  if (kShading && m.uvs) {
    const Vec2 t0 = m.uvs[i0], t1 = m.uvs[i1], t2 = m.uvs[i2];
    uv = lerp_uv(t0, t1, t2, b1, b2);
    const float du1 = t1.x - t0.x, dv1 = t1.y - t0.y, du2 = t2.x - t0.x, dv2 = t2.y - t0.y;
    const float det = du1 * dv2 - dv1 * du2;
    if (std::fabs(det) > 1e-20f) {
      const Vec3 e1 = p1 - p0, e2 = p2 - p0;
      const float inv = 1.f / det;
      dpdu = (e1 * dv2 - e2 * dv1) * inv;
      const Vec3 dpdv = (e2 * du1 - e1 * du2) * inv;
      // Tangent-space +Y points along decreasing image v (glTF/OpenGL normal maps);
      // a mirroring instance transform flips cross products, hence the sign.
      sign = dot(cross(n, dpdu), dpdv) > 0.f ? -1.f : 1.f;
      if (inst.to_world.linear_determinant() < 0.f) sign = -sign;
    }
  }
  instance_to_world(inst.to_world, inst.to_object, &p, &p_error, &n, &clearance);
  hit->p = p;
  hit->n = n;
  hit->p_bound = PointBound(error_along(p_error, n), clearance);
  hit->ns = kShading ? normalize(inst.to_object.transpose_vector(ns)) : hit->n;
  hit->dpdu = inst.to_world.vector(dpdu);
  hit->bitangent_sign = sign;
  hit->uv = uv;
  hit->material = triangle_material(inst, tri);
  hit->light = inst.light >= 0 ? inst.light
               : (inst.light_base >= 0 && m.face_lights && m.face_lights[tri] >= 0) ? inst.light_base + m.face_lights[tri]
                                                                                      : -1;
}

// Any hit of a backend, as a shading point.
template <uint32_t kFeatures = kAllFeatures>
PN_FN SurfaceHit resolve_hit(const SceneView& scene, const Ray& ray, const HitRecord& rec) {
  SurfaceHit hit;
  hit.t = rec.t;
  if (rec.instance == kSphereInstance) {
    const SphereView& s = scene.spheres[rec.prim];
    Vec3 p_error;
    sphere_hit(s.center, s.radius, ray, rec.t, &hit.p, &p_error, &hit.n);
    hit.p_bound = PointBound(error_along(p_error, hit.n));  // no clearance: a sphere has no edges to keep from
    hit.ns = hit.n;
    hit.material = s.material;
    hit.light = s.light;
  } else {
    resolve_triangle_hit<kFeatures>(scene.instances[rec.instance], rec.prim, rec.b1, rec.b2, &hit);
  }
  return hit;
}

// Alpha masking: whether a candidate triangle hit is a hole (the ray goes on).
// Called from Embree's filter functions and OptiX's any-hit program alike.
PN_FN bool alpha_discards(const SceneView& scene, const InstanceView& inst, uint32_t tri, float b1, float b2) {
  const Material& m = scene.materials[triangle_material(inst, tri)];
  if (m.alpha_mode != AlphaMode::Mask) return false;
  float a = m.alpha;
  if (m.base_color_tex >= 0 && inst.mesh.uvs) {
    const MeshView& mv = inst.mesh;
    const uint32_t* I = mv.indices + 3 * tri;
    a *= texture_lookup(scene.textures[m.base_color_tex], lerp_uv(mv.uvs[I[0]], mv.uvs[I[1]], mv.uvs[I[2]], b1, b2)).a;
  }
  return a < m.alpha_cutoff;
}

// --- Shading -----------------------------------------------------------------

// The BSDF at a hit seen from wo: textures applied, the normal map's normal,
// both normals turned to wo's side. A shading normal for which wo would lie
// below the surface is bent just enough towards wo (never past the geometric
// normal's hemisphere), so that a path does not stop on a black band where
// normal map and geometry disagree; leaks stay excluded by bsdf_eval's
// geometric test.
template <uint32_t kFeatures = kAllFeatures>
PN_FN Bsdf surface_bsdf(const SceneView& scene, const SurfaceHit& hit, Vec3 wo) {
  constexpr bool kTextures = (kFeatures & kFeatureTextures) != 0;
  const Material& m = scene.materials[hit.material];
  Vec3 base = m.base_color;
  float metallic = m.metallic, roughness = m.roughness;
  if (kTextures && m.base_color_tex >= 0) base = base * texture_lookup(scene.textures[m.base_color_tex], hit.uv).rgb;
  if (kTextures && m.metallic_roughness_tex >= 0) {
    Vec3 mr = texture_lookup(scene.textures[m.metallic_roughness_tex], hit.uv).rgb;
    roughness *= mr.y;
    metallic *= mr.z;
  }
  Vec3 ns = hit.ns;
  if (kTextures && m.normal_tex >= 0 && length_sq(hit.dpdu) > 0.f) {
    Vec3 t = hit.dpdu - ns * dot(ns, hit.dpdu);
    float len = length(t);
    if (len > 1e-12f) {
      t = t / len;
      Vec3 b = cross(ns, t) * hit.bitangent_sign;
      Vec3 c = texture_lookup(scene.textures[m.normal_tex], hit.uv).rgb;
      Vec3 tn((2.f * c.x - 1.f) * m.normal_scale, (2.f * c.y - 1.f) * m.normal_scale, 2.f * c.z - 1.f);
      Vec3 mapped = t * tn.x + b * tn.y + ns * tn.z;
      float ml = length(mapped);
      if (ml > 1e-12f && std::isfinite(ml)) ns = mapped / ml;
    }
  }
  const bool front = dot(hit.n, wo) >= 0.f;
  Vec3 ng = front ? hit.n : -hit.n;
  if (!front) ns = -ns;
  if (dot(ns, ng) < 0.f) ns = ng;
  const float c = dot(ns, wo);
  if (c < 1e-4f) ns = normalize(ns + wo * (1e-4f - c));
  return make_bsdf(base, metallic, roughness, m.specular, ns, ng);
}

}  // namespace pn
