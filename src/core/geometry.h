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

// --- Floating-point error bounds (pbrt-v4, section 6.8) ------------------------

// gamma(n) bounds the relative error of n successive roundings: (1 + eps)^n
// <= 1 + gamma(n) for float's unit roundoff eps = 2^-24 (Higham).
PN_FN constexpr float fp_gamma(int n) {
  constexpr float kUnitRoundoff = 5.96046448e-8f;  // 2^-24
  return (float(n) * kUnitRoundoff) / (1.f - float(n) * kUnitRoundoff);
}

// The next float above / below v (v finite; -0 and +0 alike).
PN_FN uint32_t float_bits(float v) {
#if defined(__CUDACC__) && defined(__CUDA_ARCH__)
  return uint32_t(__float_as_int(v));
#else
  uint32_t bits;
  __builtin_memcpy(&bits, &v, sizeof bits);
  return bits;
#endif
}
PN_FN float bits_float(uint32_t bits) {
#if defined(__CUDACC__) && defined(__CUDA_ARCH__)
  return __int_as_float(int(bits));
#else
  float v;
  __builtin_memcpy(&v, &bits, sizeof v);
  return v;
#endif
}
PN_FN float next_float_up(float v) {
  if (std::isinf(v) && v > 0.f) return v;
  if (v == 0.f) return bits_float(1u);  // -0 and +0: the smallest positive float
  const uint32_t bits = float_bits(v);
  return bits_float(v > 0.f ? bits + 1 : bits - 1);
}
PN_FN float next_float_down(float v) {
  if (std::isinf(v) && v < 0.f) return v;
  if (v == 0.f) return bits_float(0x80000001u);  // the largest negative float
  const uint32_t bits = float_bits(v);
  return bits_float(v > 0.f ? bits - 1 : bits + 1);
}

// A bound on how far a computed point with per-axis error bound `p_error` can
// lie from the true surface along the unit normal n: sum |n_i| p_error_i.
PN_FN float error_along(Vec3 p_error, Vec3 n) {
  return std::fabs(n.x) * p_error.x + std::fabs(n.y) * p_error.y + std::fabs(n.z) * p_error.z;
}

// What offset_ray_origin needs of a shading point besides where it is.
struct PointBound {
  float error = 0.f;      // bound on the point's distance from the true surface along n (error_along)
  float clearance = 0.f;  // how far along the surface the point keeps from its primitive's edges (0: unknown)
  PointBound() = default;
  PN_HD PointBound(float error_, float clearance_ = 0.f) : error(error_), clearance(clearance_) {}  // NOLINT
};

// The origin of a ray leaving a surface point p in unit direction w: a point of
// the ray's own line through p, `error` off the surface along the unit geometric
// normal n (error: the bound on p's distance from the true surface along n,
// error_along), each coordinate then rounded away from the surface. So a ray
// cannot find the surface it starts on, and it is the ray from p itself, less its
// first error / cos: a light seen through it is the light seen from the shading
// point, as next-event estimation sees it. (pbrt-v4's OffsetRayOrigin moves the
// origin along n instead; then a BSDF-sampled ray sees a light from a point
// `error` above p, and MIS images of a plane under a light were 0.004-0.026% too
// bright with large triangles, H200, 0.0002% standard errors.)
//
// The move along the ray, error / cos, grows without bound as the ray grazes.
// It may reach as far as the point's clearance from its primitive's edges, and
// at least error / kMinOriginCos (the band edge_keep keeps every triangle hit
// inside its edges): within that reach the origin stays over the point's own
// primitive, no more than `error` off it, so it cannot pass through a
// neighbouring face of a closed mesh. A ray too grazing for its reach moves that
// far along itself and the rest of `error` along n: its line is off p by less
// than `error`, and a light seen through it is seen from a little above p. With
// a fixed reach of error / kMinOriginCos alone (no clearance), MIS images of a
// quad 0.1 above a 120 x 120 floor, lit mostly at such angles, were 0.013-0.017%
// too bright on the H200. n must be on w's side.
constexpr float kMinOriginCos = 0.25f;
PN_FN Vec3 offset_ray_origin(Vec3 p, Vec3 n, PointBound bound, Vec3 w) {
  const float error = bound.error;
  const float c = dot(n, w);
  const float reach = pn_max(error * (1.f / kMinOriginCos), bound.clearance);
  Vec3 o;
  if (c > 0.f && error <= reach * c) {
    o = p + w * (error / c);
  } else if (c > 0.f) {
    o = p + w * reach + n * (error - reach * c);
  } else {
    o = p + n * error;  // w below the surface (a ray nothing will count): off it along n alone
  }
  for (int i = 0; i < 3; ++i) {
    if (n[i] * error > 0.f) o[i] = next_float_up(o[i]);
    else if (n[i] * error < 0.f) o[i] = next_float_down(o[i]);
  }
  return o;
}

// How far inside every edge a triangle hit keeps (triangle_hit), so that a ray's
// origin, which moves along the ray by at least error / kMinOriginCos, never
// leaves a closed mesh through a neighbouring face.
PN_FN float edge_keep(float interpolation_error, float error_along_n) {
  return 2.f * interpolation_error + error_along_n * (1.f / kMinOriginCos);
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

// a * b - c * d with its sign exact, which the edge functions of two triangles
// that share an edge need (watertightness: a ray through the edge must see
// opposite signs from the two, or 0 from both). Kahan's algorithm: c * d's
// rounding error recovered by an fma and added back, within 2 units in the last
// place of the exact result (Jeannerod, Louvet & Muller, "Further analysis of
// Kahan's algorithm for the accurate computation of 2x2 determinants", 2013),
// hence never of the wrong sign and 0 only where the exact result is 0.
PN_FN float kahan_diff_of_products(float a, float b, float c, float d) {
#if defined(__CUDA_ARCH__)
  const float cd = __fmul_rn(c, d);
  const float err = __fmaf_rn(-c, d, cd);  // cd - c * d, exactly
  return __fadd_rn(__fmaf_rn(a, b, -cd), err);
#else
  const float cd = c * d;
  const float err = std::fma(-c, d, cd);
  return std::fma(a, b, -cd) + err;
#endif
}

// The edge functions' a * b - c * d. On the host the products are exact in
// double and the result is rounded once. On the GPU Kahan's algorithm comes
// within 2 units in the last place of that for 4 float operations (double is
// slow on most GPUs). The plain float expression is not enough: contracted into
// fma(a, b, -c * d) (nvcc does by default) it loses the sign, and a closed box
// leaked light; with two rounded products it stays watertight but cancels near
// an edge, and t, interpolated from these weights, put rays leaving Sponza's
// surfaces back on the triangle they left (78 of 1,048,576 at t 4e-7 to 6e-5:
// `bench --probe`'s surface rays, H200; 0 with Kahan's, as on the host).
PN_FN float diff_of_products(float a, float b, float c, float d) {
#if defined(__CUDA_ARCH__)
  return kahan_diff_of_products(a, b, c, d);
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
// (primitive, t) yields bit-identical points and normals on CPU and GPU. Each
// returns the point where the ray hit, a conservative bound on its error per
// axis (pbrt-v4, section 6.8), and the unit geometric normal.
//
// The bound has a second part, for the intersectors. pbrt's own triangle test
// rejects a t within its rounding of 0, so that a ray leaving a surface from a
// point just off it cannot find it again; Embree, OptiX's built-in triangles and
// the cuda traversal's watertight test do not: a ray whose origin lies within a
// few units in the last place of the primitive's size from its surface can find
// it at t ~ 0 (on a floor at y = 0 the point's own bound along the normal is 0,
// and every shadow ray from it was blocked). So the bound also holds
// kIntersectionUlps units in the last place of the primitive's extent (the
// farthest vertex from the point, the sphere's radius) in every direction.
constexpr int kIntersectionUlps = 8;

// Triangle: barycentrics (b1, b2) of p1 and p2. The point is interpolated, which
// is more accurate than o + t d; the normal follows the winding (p1-p0) x (p2-p0).
//
// Closed meshes stay closed. A hit at an edge, interpolated in floats, can land
// a rounding error behind the plane of the neighbouring face; offset_ray_origin
// moves it along this face's normal only, so a ray leaving towards the
// neighbour would start behind it and escape (a camera inside a closed box
// would see light at its seams); and the next ray's origin moves along the ray
// too (offset_ray_origin). So a hit closer to an edge than edge_keep (twice the
// interpolation's error bound, plus four times its bound along the normal) is
// moved into the triangle, perpendicular to the edge, to that distance: a move of
// a few dozen units in the last place of the coordinates at most, made only that
// close to an edge (tests/data/closed_box*.json; Geometry.HitPointsAreWhereTheRay-
// Hits bounds the move). Its bias is second order: the band's share of the area
// times the move.
//
// `clearance`, where asked for, is a lower bound on the point's distance from
// the triangle's edges (offset_ray_origin's reach; at least edge_keep's band).
PN_FN void triangle_hit(Vec3 p0, Vec3 p1, Vec3 p2, float b1, float b2, Vec3* p, Vec3* p_error, Vec3* n,
                        float* clearance = nullptr) {
  const Vec3 c = cross(p1 - p0, p2 - p0);
  const float inv_area2 = 1.f / length(c);
  float b[3] = {1.f - b1 - b2, b1, b2};
  const Vec3 v[3] = {p0, p1, p2};
  // The interpolation's own rounding, and the distance `keep` a point keeps from every edge: barycentric
  // b_i >= m_i = keep / h_i, h_i the height over the edge opposite vertex i.
  const Vec3 err = (vabs(p0 * b[0]) + vabs(p1 * b[1]) + vabs(p2 * b[2])) * fp_gamma(7);
  const Vec3 n_unit = c * inv_area2;
  const float extent_bound = fp_gamma(kIntersectionUlps) *
                             pn_max(pn_max(max_component(vabs(p1 - p0)), max_component(vabs(p2 - p0))),
                                    max_component(vabs(p2 - p1)));
  const float keep = edge_keep(length(err), error_along(err, n_unit) + 3.f * extent_bound) * inv_area2;
  const float len[3] = {length(p2 - p1), length(p2 - p0), length(p1 - p0)};  // the edges opposite 0, 1, 2
  const float m[3] = {keep * len[0], keep * len[1], keep * len[2]};
  if (b[0] < m[0] || b[1] < m[1] || b[2] < m[2]) {
    for (int i = 0; i < 3; ++i) {
      if (!(b[i] < m[i])) continue;
      // Move the point perpendicular to the edge opposite i, towards vertex i: along the altitude from the
      // edge's point f = (1 - l) pj + l pk to v[i], which adds s to b_i and takes (1 - l) s and l s from the
      // edge's two.
      const int j = i == 0 ? 1 : 0, k = i == 2 ? 1 : 2;
      const Vec3 edge = v[k] - v[j];
      const float l = dot(v[i] - v[j], edge) / dot(edge, edge), s = m[i] - b[i];
      b[i] = m[i];
      b[j] -= (1.f - l) * s;
      b[k] -= l * s;
    }
    // Near a corner one move can take another barycentric below its bound: the point then goes to the
    // corner of the triangle of points 2 |err| inside every edge (a triangle too thin to hold one: its
    // centroid).
    for (int i = 0; i < 3; ++i) b[i] = pn_max(b[i], m[i]);
    bool thin;
    if (b[0] >= b[1] && b[0] >= b[2]) {
      b[0] = 1.f - b[1] - b[2];
      thin = b[0] < m[0];
    } else if (b[1] >= b[2]) {
      b[1] = 1.f - b[0] - b[2];
      thin = b[1] < m[1];
    } else {
      b[2] = 1.f - b[0] - b[1];
      thin = b[2] < m[2];
    }
    if (thin) b[0] = b[1] = b[2] = 1.f / 3.f;
  }
  *p = p0 * b[0] + p1 * b[1] + p2 * b[2];
  const Vec3 d0 = vabs(p0 - *p), d1 = vabs(p1 - *p), d2 = vabs(p2 - *p);
  const float extent = pn_max(pn_max(max_component(d0), max_component(d1)), max_component(d2));
  *p_error = (vabs(p0 * b[0]) + vabs(p1 * b[1]) + vabs(p2 * b[2])) * fp_gamma(7) +
             Vec3(extent * fp_gamma(kIntersectionUlps));
  *n = c * inv_area2;
  if (clearance) {
    // The distance from edge i is b_i times the height over it, |c| / len_i; less a relative 1e-5 for the
    // arithmetic here and twice the point's own error bound.
    const float b_over_len = pn_min(pn_min(b[0] / len[0], b[1] / len[1]), b[2] / len[2]);
    *clearance = pn_max(0.f, b_over_len * (1.f - 1e-5f) / inv_area2 - 2.f * length(*p_error));
  }
}

// Sphere: outward normal; the point is re-projected onto the surface (pbrt's
// error bound for the re-projected point: gamma(5) |p|).
PN_FN void sphere_hit(Vec3 center, float radius, const Ray& ray, float t, Vec3* p, Vec3* p_error, Vec3* n) {
  Vec3 q = ray.at(t);
  *n = normalize(q - center);
  *p = center + *n * radius;
  *p_error = vabs(*p - center) * fp_gamma(5) + vabs(center) * fp_gamma(1) + Vec3(radius * fp_gamma(kIntersectionUlps));
}

// Moves an object-space point, its error bound and normal of an instance into
// world space; the bound grows by the transform's own rounding (pbrt-v4's
// Transform applied to a point with error). A clearance (triangle_hit's) scales
// by no less than the transform's smallest singular value, 1 / |B|_2 for B
// to_object's linear part, and |B|_2 is at most |B|_F (sqrt(3) for the identity:
// a conservative reach); then it shrinks by the world point's error.
PN_FN void instance_to_world(const Affine& to_world, const Affine& to_object, Vec3* p, Vec3* p_error, Vec3* n,
                             float* clearance = nullptr) {
  const float* m = to_world.m;
  const Vec3 q = *p, e = *p_error;
  Vec3 err;
  for (int r = 0; r < 3; ++r) {
    const float a0 = std::fabs(m[4 * r]), a1 = std::fabs(m[4 * r + 1]), a2 = std::fabs(m[4 * r + 2]);
    err[r] = (fp_gamma(3) + 1.f) * (a0 * e.x + a1 * e.y + a2 * e.z) +
             fp_gamma(3) * (a0 * std::fabs(q.x) + a1 * std::fabs(q.y) + a2 * std::fabs(q.z) + std::fabs(m[4 * r + 3]));
  }
  *p = to_world.point(q);
  // A ray leaving the point enters the instance again through to_object, which the trace stage (Embree, OptiX,
  // the cuda traversal) applies to its origin in floats: up to gamma(3) (|B| |o| + |b|) per object-space axis for
  // to_object = (B, b), which to_world's linear part A carries back as A times that. The bound covers it, or the
  // ray can start on the surface's far side in object space and find the triangle it leaves (bunnies: 3 rays in
  // 20,000 leaving the surface did, tests/backends/test_cuda_traversal.cpp). An identity instance is traced in world space
  // (or through an exact identity product) and pays nothing.
  if (!to_object.is_identity()) {
    const float* b = to_object.m;
    const Vec3 o = vabs(*p) + err;
    Vec3 back;
    for (int r = 0; r < 3; ++r)
      back[r] = fp_gamma(3) * (std::fabs(b[4 * r]) * o.x + std::fabs(b[4 * r + 1]) * o.y +
                               std::fabs(b[4 * r + 2]) * o.z + std::fabs(b[4 * r + 3]));
    for (int r = 0; r < 3; ++r)
      err[r] += (1.f + fp_gamma(3)) * (std::fabs(m[4 * r]) * back.x + std::fabs(m[4 * r + 1]) * back.y +
                                       std::fabs(m[4 * r + 2]) * back.z);
  }
  *p_error = err;
  *n = normalize(to_object.transpose_vector(*n));
  if (clearance) {
    const float* a = to_object.m;
    float frobenius2 = 0.f;
    for (int r = 0; r < 3; ++r)
      for (int k = 0; k < 3; ++k) frobenius2 += a[4 * r + k] * a[4 * r + k];
    *clearance = pn_max(0.f, *clearance * (1.f - 1e-5f) / std::sqrt(frobenius2) - length(err));
  }
}

}  // namespace pn
