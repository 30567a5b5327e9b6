// Ray-shape intersection and ray-origin offsetting, shared by both backends
// (Embree user geometry on the CPU, a custom intersection program on OptiX).
#pragma once

#include "common.h"
#include "transform.h"
#include "vec.h"

namespace pn {

// Relative shortening of shadow rays, so that the light's own surface, at exactly
// the sampled distance, never counts as an occluder (pbrt's ShadowEpsilon).
constexpr float kShadowEpsilon = 1e-4f;

// Moves a surface point off the surface along its normal by an amount that scales
// with the magnitude of the coordinates, so that spawned rays do not re-hit the
// surface they start on. Integer-ULP offsetting after Waechter and Binder, "A Fast
// and Robust Method for Avoiding Self-Intersection", Ray Tracing Gems, ch. 6.
// `n` must point to the side the new ray leaves towards.
PN_FN float offset_component(float p, float n) {
  constexpr float kOrigin = 1.f / 32.f;
  constexpr float kFloatScale = 1.f / 65536.f;
  constexpr float kIntScale = 256.f;
  int of_i = int(kIntScale * n);
  int bits;
  float result;
  // Reinterpret p's bits, move it by of_i ULPs away from zero in n's direction.
#if defined(__CUDACC__) && defined(__CUDA_ARCH__)
  bits = __float_as_int(p);
  bits += (p < 0.f) ? -of_i : of_i;
  result = __int_as_float(bits);
#else
  static_assert(sizeof(int) == sizeof(float), "int and float must have equal size");
  __builtin_memcpy(&bits, &p, sizeof bits);
  bits += (p < 0.f) ? -of_i : of_i;
  __builtin_memcpy(&result, &bits, sizeof result);
#endif
  return std::fabs(p) < kOrigin ? p + kFloatScale * n : result;
}
PN_FN Vec3 offset_ray_origin(Vec3 p, Vec3 n) {
  return Vec3(offset_component(p.x, n.x), offset_component(p.y, n.y), offset_component(p.z, n.z));
}

// Ray-sphere intersection; d must be unit length. Returns the nearest t in
// (tmin, tmax) or false. The discriminant is computed as r^2 - |f - (f.d) d|^2
// rather than b^2 - c, which loses far fewer digits for distant or small spheres
// (Haines et al., "Precision Improvements for Ray/Sphere Intersection", Ray
// Tracing Gems, ch. 7).
PN_FN bool intersect_sphere(const Ray& ray, Vec3 center, float radius, float tmin, float tmax,
                            float* t_hit) {
  Vec3 f = ray.o - center;
  float b = dot(f, ray.d);
  Vec3 l = f - ray.d * b;
  float disc = radius * radius - dot(l, l);
  if (disc < 0.f) return false;
  float c = dot(f, f) - radius * radius;
  float q = -b - std::copysign(std::sqrt(disc), b);
  float t0 = (q != 0.f) ? c / q : 0.f;
  float t1 = q;
  if (t0 > t1) { float tmp = t0; t0 = t1; t1 = tmp; }
  if (t0 > tmin && t0 < tmax) { *t_hit = t0; return true; }
  if (t1 > tmin && t1 < tmax) { *t_hit = t1; return true; }
  return false;
}

// Half-extent of a sphere's bounding box for the acceleration structures of
// both backends: padded by a relative epsilon, because intersect_sphere may
// report a hit a rounding error outside the exact sphere.
PN_FN float sphere_bounds_radius(float radius) { return radius * 1.0001f; }

// Watertight ray-triangle intersection (Woop, Benthin and Wald, "Watertight
// Ray/Triangle Intersection", JCGT 2(1), 2013): the vertices are moved into a
// frame where the ray runs along +z from the origin, and the three edge
// functions are evaluated there, each edge the same way for both triangles that
// share it; a ray through an edge or a vertex hits at least one of them. Edge
// functions that round to exactly 0 are recomputed in double. Embree answers
// the same way with RTC_SCENE_FLAG_ROBUST (CPU backend); OptiX's built-in
// triangles are watertight; the cuda traversal (backends/cuda) runs this code.
//
// The ray's part (the axis permutation and the shear) is computed once per ray
// by make_watertight_ray, then tested against many triangles.
struct WatertightRay {
  Vec3 o;
  int kx = 0, ky = 1, kz = 2;
  float sx = 0.f, sy = 0.f, sz = 0.f;  // sz == 0: a zero direction, which hits nothing
};

PN_FN WatertightRay make_watertight_ray(const Ray& ray) {
  WatertightRay r;
  r.o = ray.o;
  // The axis along which the direction is largest becomes z; x and y follow,
  // swapped when d.z < 0 so that the winding is kept.
  const float ax = std::fabs(ray.d.x), ay = std::fabs(ray.d.y), az = std::fabs(ray.d.z);
  r.kz = ax > ay ? (ax > az ? 0 : 2) : (ay > az ? 1 : 2);
  r.kx = r.kz == 2 ? 0 : r.kz + 1;
  r.ky = r.kx == 2 ? 0 : r.kx + 1;
  if (ray.d[r.kz] < 0.f) {
    const int k = r.kx;
    r.kx = r.ky;
    r.ky = k;
  }
  if (ray.d[r.kz] == 0.f) return r;  // a zero direction: sz stays 0
  r.sx = ray.d[r.kx] / ray.d[r.kz];
  r.sy = ray.d[r.ky] / ray.d[r.kz];
  r.sz = 1.f / ray.d[r.kz];
  return r;
}

// a * b - c * d such that swapping the pairs negates the result exactly, which
// the edge functions of two triangles that share an edge need (watertightness).
// A compiler that contracts the plain expression into fma(a, b, -c * d) breaks
// that: nvcc does by default (--fmad=true), and the cuda traversal then let a
// closed box leak light (gpu_check, H200). On the GPU the intrinsics are never
// contracted; on the host the products are exact in double, so contraction
// there changes nothing.
PN_FN float diff_of_products(float a, float b, float c, float d) {
#if defined(__CUDA_ARCH__)
  return __fsub_rn(__fmul_rn(a, b), __fmul_rn(c, d));
#else
  return float(double(a) * double(b) - double(c) * double(d));
#endif
}

// The hit's t in (tmin, tmax) and, where asked for, its barycentrics b1, b2 (of
// p1 and p2, as Embree's u, v and OptiX's triangle barycentrics).
PN_FN bool intersect_triangle(const WatertightRay& r, Vec3 p0, Vec3 p1, Vec3 p2, float tmin, float tmax,
                              float* t_hit, float* b1 = nullptr, float* b2 = nullptr) {
  if (r.sz == 0.f) return false;
  const Vec3 a = p0 - r.o, b = p1 - r.o, c = p2 - r.o;
  const float a_x = a[r.kx] - r.sx * a[r.kz], a_y = a[r.ky] - r.sy * a[r.kz];
  const float b_x = b[r.kx] - r.sx * b[r.kz], b_y = b[r.ky] - r.sy * b[r.kz];
  const float c_x = c[r.kx] - r.sx * c[r.kz], c_y = c[r.ky] - r.sy * c[r.kz];
  // Edge functions: u of edge (b, c), v of (c, a), w of (a, b): the weights of a, b, c.
  float u = diff_of_products(c_x, b_y, c_y, b_x), v = diff_of_products(a_x, c_y, a_y, c_x),
        w = diff_of_products(b_x, a_y, b_y, a_x);
  if (u == 0.f || v == 0.f || w == 0.f) {
    u = float(double(c_x) * double(b_y) - double(c_y) * double(b_x));
    v = float(double(a_x) * double(c_y) - double(a_y) * double(c_x));
    w = float(double(b_x) * double(a_y) - double(b_y) * double(a_x));
  }
  if ((u < 0.f || v < 0.f || w < 0.f) && (u > 0.f || v > 0.f || w > 0.f)) return false;
  const float det = u + v + w;
  if (det == 0.f) return false;
  const float t = (u * r.sz * a[r.kz] + v * r.sz * b[r.kz] + w * r.sz * c[r.kz]) / det;
  if (!(t > tmin && t < tmax)) return false;
  *t_hit = t;
  if (b1) {
    const float inv = 1.f / det;
    *b1 = v * inv;
    *b2 = w * inv;
  }
  return true;
}

// One ray, one triangle (tests, code outside a backend).
PN_FN bool intersect_triangle(const Ray& ray, Vec3 p0, Vec3 p1, Vec3 p2, float tmin, float tmax,
                              float* t_hit) {
  return intersect_triangle(make_watertight_ray(ray), p0, p1, p2, tmin, tmax, t_hit);
}

// Closest-hit reconstruction, shared by both backends so that a hit at the same
// (primitive, t) yields bit-identical points and normals on CPU and GPU.

// Triangle: barycentrics (b1, b2) of p1 and p2. The point is interpolated, which
// is more accurate than o + t d; the normal follows the winding (p1-p0) x (p2-p0).
//
// The barycentrics are first pulled towards the centroid by kHitShrink of the
// way. A hit at an edge, interpolated in floats, can land a rounding error
// beyond the plane of the neighbouring face; offset_ray_origin then moves it
// along this face's normal only, so a ray leaving towards the neighbour starts
// behind it and escapes a closed mesh (a camera inside a closed box would see
// light at its seams). Pulled in, the point is inside the triangle by far more
// than that rounding error (by kHitShrink of the triangle's size), and the
// image moves by nothing measurable.
constexpr float kHitShrink = 1.f / 65536.f;
PN_FN void triangle_hit(Vec3 p0, Vec3 p1, Vec3 p2, float b1, float b2, Vec3* p, Vec3* n) {
  b1 = b1 * (1.f - 3.f * kHitShrink) + kHitShrink;
  b2 = b2 * (1.f - 3.f * kHitShrink) + kHitShrink;
  *p = p0 * (1.f - b1 - b2) + p1 * b1 + p2 * b2;
  *n = normalize(cross(p1 - p0, p2 - p0));
}

// Sphere: outward normal; the point is re-projected onto the surface.
PN_FN void sphere_hit(Vec3 center, float radius, const Ray& ray, float t, Vec3* p, Vec3* n) {
  Vec3 q = ray.at(t);
  *n = normalize(q - center);
  *p = center + *n * radius;
}

// Moves an object-space hit of an instance into world space.
PN_FN void instance_to_world(const Affine& to_world, const Affine& to_object, Vec3* p, Vec3* n) {
  *p = to_world.point(*p);
  *n = normalize(to_object.transpose_vector(*n));
}

}  // namespace pn
