// Uniform sampling of the solid angle of a triangle or a rectangle: the
// spherical triangle (Arvo 1995, "Stratified Sampling of Spherical Triangles")
// and the spherical rectangle (Urena, Fajardo & King 2013, "An Area-Preserving
// Parametrization for Spherical Rectangles"), each with its inverse (the u a
// direction comes from), which MIS and the projected-solid-angle warp need.
//
// Solid angles are computed by Van Oosterom & Strackee's formula (1983),
//   tan(Omega / 2) = |A . (B x C)| / (abc + (A.B) c + (A.C) b + (B.C) a),
// from the vertex vectors A, B, C (lengths a, b, c): unlike Girard's angle
// excess (alpha + beta + gamma - pi) it does not cancel for small triangles,
// so the pdf 1 / Omega stays accurate down to the lights' fallback threshold.
//
// The parametrizations themselves cancel for small polygons as the papers write
// them: Arvo's cos of the arc a-c' near 1, Urena's angle k + u Omega with k near
// pi. Written as they are, in float, a triangle of 1e-3 sr came back through its
// inverse 1% off in u, and a rectangle's samples were visibly non-uniform.
// Here Arvo's terms are rewritten without cancellation (half-angle forms, 1 - q
// directly), Urena's angle is added as cos/sin pairs, and one Newton step on the
// accurate solid angle finishes the rectangle's u.x: in float, samples map back
// to u within 2e-5 down to the 3e-4 sr bound (tests/core/test_sampling.cpp checks 2e-3).
// Double precision did the same at eight times the GPU code (4,600 SASS
// instructions a sampler against 480-1,860): the GPU's megakernel is bound by
// instruction fetch.
#pragma once

#include "common.h"
#include "sampling.h"
#include "vec.h"

namespace pn {

PN_FN void sincos_single(float x, float* s, float* c) {
#if defined(__CUDACC__) && defined(__CUDA_ARCH__)
  sincosf(x, s, c);
#else
  *s = std::sin(x);
  *c = std::cos(x);
#endif
}

// Solid angle of the triangle with vertex vectors A, B, C seen from the origin.
template <class V>
PN_FN auto triangle_solid_angle_t(V A, V B, V C) {
  const auto a = length(A), b = length(B), c = length(C);
  // The triple product from the edges: A . ((B - A) x (C - A)) = A . (B x C),
  // without the cancellation of two large, nearly parallel cross terms.
  const auto num = std::fabs(dot(A, cross(B - A, C - A)));
  const auto den = a * b * c + dot(A, B) * c + dot(A, C) * b + dot(B, C) * a;
  return 2 * std::atan2(num, den);  // den < 0: Omega > pi
}
PN_FN float triangle_solid_angle(Vec3 A, Vec3 B, Vec3 C) { return triangle_solid_angle_t(A, B, C); }

// 1 - cos(angle between unit vectors a and b), accurate for small angles.
PN_FN float one_minus_dot(Vec3 a, Vec3 b) { return 0.5f * length_sq(a - b); }

// --- Spherical triangle --------------------------------------------------------

struct SphericalTriangle {
  Vec3 a, b, c;               // unit directions to the vertices
  float cos_alpha = 1, sin_alpha = 0;  // the interior angle at a
  float one_minus_cos_c = 0;  // 1 - a . b (the side opposite c)
  float area = 0.f;            // solid angle; 0: degenerate, do not sample
};

// The spherical triangle that triangle (p0, p1, p2) subtends at x.
PN_FN SphericalTriangle make_spherical_triangle(Vec3 x, Vec3 p0, Vec3 p1, Vec3 p2) {
  SphericalTriangle t;
  const Vec3 Af = p0 - x, Bf = p1 - x, Cf = p2 - x;
  const Vec3 A(Af), B(Bf), C(Cf);
  const float la = length(A), lb = length(B), lc = length(C);
  if (!(la > 0 && lb > 0 && lc > 0)) return t;
  t.a = A * (1.0f / la);
  t.b = B * (1.0f / lb);
  t.c = C * (1.0f / lc);
  const Vec3 n_ab = cross(t.a, t.b), n_ac = cross(t.a, t.c);
  const float l_ab = length(n_ab), l_ac = length(n_ac);
  if (!(l_ab > 0 && l_ac > 0) || !(length_sq(cross(t.b, t.c)) > 0)) return t;
  // alpha: the angle between the planes (a, b) and (a, c).
  const float inv = 1.0f / (l_ab * l_ac);
  t.cos_alpha = clamp(dot(n_ab, n_ac) * inv, -1.0f, 1.0f);
  t.sin_alpha = length(cross(n_ab, n_ac)) * inv;
  t.one_minus_cos_c = one_minus_dot(t.a, t.b);
  t.area = triangle_solid_angle(Af, Bf, Cf);
  return t;
}

// A direction uniform over the spherical triangle: u.x chooses the sub-triangle
// (a, b, c') of area u.x * area, c' on the arc from a to c; u.y the point on
// the arc from b to c' (Arvo's algorithm). pdf = 1 / area.
PN_FN Vec3 sample_spherical_triangle(const SphericalTriangle& t, Vec2 u) {
  // Arvo's quantities, rewritten without the cancellations of small triangles
  // (A' the sub-triangle's area, alpha the angle at a, c the side a-b):
  //   uu = cos(A' - alpha) - cos(alpha)      = 2 sin(A'/2) sin(alpha - A'/2)
  //   vv = sin(A' - alpha) + sin(alpha) cos c = 2 sin(A'/2) cos(alpha - A'/2) - sin(alpha) (1 - cos c)
  //   q  = cos of the arc a-c' = 1 - (vv (1 - cos A') + uu sin A') / ((vv s + uu c) sin alpha)
  // with s, c = sin, cos(A' - alpha); 1 - q then stays accurate when c' is near a.
  float sh, ch;
  sincos_single(0.5f * u.x * t.area, &sh, &ch);
  const float ca = t.cos_alpha, sa = t.sin_alpha;
  const float sin_a = 2.f * sh * ch, one_minus_cos_a = 2.f * sh * sh, cos_a = 1.f - one_minus_cos_a;
  const float s_ah = sa * ch - ca * sh, c_ah = ca * ch + sa * sh;  // sin, cos(alpha - A'/2)
  const float s = sin_a * ca - cos_a * sa, c = cos_a * ca + sin_a * sa;
  const float uu = 2.f * sh * s_ah;
  const float vv = 2.f * sh * c_ah - sa * t.one_minus_cos_c;
  const float den = (vv * s + uu * c) * sa;
  float one_minus_q = den != 0.f ? (vv * one_minus_cos_a + uu * sin_a) / den : 0.f;
  one_minus_q = clamp(one_minus_q, 0.f, 2.f);
  const float q = 1.f - one_minus_q;
  const Vec3 c_perp = normalize(t.c - t.a * dot(t.c, t.a));
  const Vec3 cp = normalize(t.a * q + c_perp * safe_sqrt(one_minus_q * (2.f - one_minus_q)));
  // Along the arc from b to c': 1 - cos theta = u.y (1 - cos(b, c')).
  const float one_minus_z = u.y * one_minus_dot(cp, t.b);
  const float z = 1.f - one_minus_z;
  const Vec3 d = cp - t.b * dot(cp, t.b);
  const float dl = length(d);
  if (!(dl > 0.f)) return t.b;
  return normalize(t.b * z + d * (safe_sqrt(one_minus_z * (2.f - one_minus_z)) / dl));
}

// The u that sample_spherical_triangle maps to direction w (in the triangle).
PN_FN Vec2 invert_spherical_triangle_sample(const SphericalTriangle& t, Vec3 wf) {
  const Vec3 w = normalize(wf);
  // c' is where the great circle through b and w meets the arc from a to c.
  Vec3 cp = cross(cross(t.b, w), cross(t.c, t.a));
  const float l = length(cp);
  if (!(l > 0)) return Vec2(0.5f, 0.5f);
  cp = cp * (1.0f / l);
  if (dot(cp, t.a + t.c) < 0) cp = -cp;
  float u0 = 0.f;
  if (one_minus_dot(t.a, cp) > 1e-12f) u0 = triangle_solid_angle(t.a, t.b, cp) / t.area;
  const float den = one_minus_dot(cp, t.b);
  const float u1 = den > 0 ? one_minus_dot(w, t.b) / den : 0;
  return Vec2(clamp(u0, 0.f, kOneMinusEpsilon), clamp(u1, 0.f, kOneMinusEpsilon));
}

// --- Spherical rectangle ----------------------------------------------------------

// A rectangle s + a ex + b ey (ex orthogonal to ey, a, b in [0, 1]) as seen from
// o, in the local frame of Urena et al.: x along ex, y along ey, z towards o's
// side flipped so that the rectangle lies at z = z0 < 0.
struct SphericalRectangle {
  Vec3 o, x, y, z;
  float x0 = 0, y0 = 0, x1 = 0, y1 = 0, z0 = 0;
  float b0 = 0, b1 = 0;         // the parametrization's constants
  float cos_k = 1, sin_k = 0;   // k = 2 pi - g2 - g3, as its cos and sin
  float area = 0.f;              // solid angle; 0: degenerate
};

// Solid angle of the local rectangle [x0, x1] x [y0, y1] at height z0, as two triangles.
PN_FN float local_rectangle_solid_angle(float x0, float y0, float x1, float y1, float z0) {
  const Vec3 v00(x0, y0, z0), v10(x1, y0, z0), v11(x1, y1, z0), v01(x0, y1, z0);
  return triangle_solid_angle(v00, v10, v11) + triangle_solid_angle(v00, v11, v01);
}

PN_FN SphericalRectangle make_spherical_rectangle(Vec3 o, Vec3 s, Vec3 ex, Vec3 ey) {
  SphericalRectangle r;
  const Vec3 EX(ex), EY(ey);
  const float exl = length(EX), eyl = length(EY);
  r.o = o;
  r.x = EX * (1.0f / exl);
  r.y = EY * (1.0f / eyl);
  r.z = cross(r.x, r.y);
  const Vec3 d = s - r.o;
  r.z0 = dot(d, r.z);
  if (r.z0 > 0) {
    r.z = -r.z;
    r.z0 = -r.z0;
  }
  if (!(r.z0 < 0)) return r;  // o in the rectangle's plane
  r.x0 = dot(d, r.x);
  r.y0 = dot(d, r.y);
  r.x1 = r.x0 + exl;
  r.y1 = r.y0 + eyl;
  const Vec3 v00(r.x0, r.y0, r.z0), v01(r.x0, r.y1, r.z0), v10(r.x1, r.y0, r.z0), v11(r.x1, r.y1, r.z0);
  // Unit normals of the planes through o and the edges; g2, g3 the interior
  // angles at (x0, y1) and (x0, y0), as cos = -n_i . n_j and sin = |n_i x n_j|.
  const Vec3 n0 = normalize(cross(v00, v10)), n2 = normalize(cross(v11, v01)), n3 = normalize(cross(v01, v00));
  const float cg2 = -dot(n2, n3), sg2 = length(cross(n2, n3)), cg3 = -dot(n3, n0), sg3 = length(cross(n3, n0));
  r.b0 = n0.z;
  r.b1 = n2.z;
  r.cos_k = cg2 * cg3 - sg2 * sg3;     // cos(2 pi - (g2 + g3)) = cos(g2 + g3)
  r.sin_k = -(sg2 * cg3 + cg2 * sg3);  // sin(2 pi - (g2 + g3)) = -sin(g2 + g3)
  r.area = local_rectangle_solid_angle(float(r.x0), float(r.y0), float(r.x1), float(r.y1), float(r.z0));
  return r;
}

// A point of the rectangle whose direction from o is uniform in solid angle:
// u.x sets the sub-rectangle [x0, xu] of solid angle u.x * area, u.y the height
// along it. pdf = 1 / area (in solid angle at o).
PN_FN Vec3 sample_spherical_rectangle(const SphericalRectangle& r, Vec2 u) {
  // a_u = k + u.x area, by its cos and sin (angle addition: no k + small in float).
  float sp, cp;
  sincos_single(u.x * r.area, &sp, &cp);
  const float cau = r.cos_k * cp - r.sin_k * sp, sau = r.sin_k * cp + r.cos_k * sp;
  const float fu = (cau * r.b0 - r.b1) / sau;
  float cu = (fu >= 0 ? 1.0f : -1.0f) / std::sqrt(fu * fu + r.b0 * r.b0);
  cu = clamp(cu, -kOneMinusEpsilon, kOneMinusEpsilon);
  float xu = clamp(-(cu * r.z0) / safe_sqrt(1.0f - cu * cu), r.x0, r.x1);
  // Urena's closed form loses precision as the rectangle shrinks (its angle
  // k + u Omega: float's absolute error over Omega). One Newton step on the
  // accurate solid angle of [x0, xu] restores it: dOmega/dxu is the integral
  // of |z0| / (xu^2 + y^2 + z0^2)^(3/2) over y in [y0, y1].
  {
    const float dd2 = xu * xu + r.z0 * r.z0;
    const float g = std::fabs(r.z0) / dd2 *
                    (r.y1 / std::sqrt(dd2 + r.y1 * r.y1) - r.y0 / std::sqrt(dd2 + r.y0 * r.y0));
    const float f = local_rectangle_solid_angle(r.x0, r.y0, xu, r.y1, r.z0) - u.x * r.area;
    if (g > 0.f) xu = clamp(xu - f / g, r.x0, r.x1);
  }
  const float dd2 = xu * xu + r.z0 * r.z0;
  const float h0 = r.y0 / std::sqrt(dd2 + r.y0 * r.y0), h1 = r.y1 / std::sqrt(dd2 + r.y1 * r.y1);
  const float hv = h0 + float(u.y) * (h1 - h0), hv2 = hv * hv;
  const float yv = hv2 < 1.f - 1e-6f ? clamp(hv * std::sqrt(dd2) / std::sqrt(1.0f - hv2), r.y0, r.y1) : r.y1;
  return (r.o + r.x * xu + r.y * yv + r.z * r.z0);
}

// The u that sample_spherical_rectangle maps to point p of the rectangle.
PN_FN Vec2 invert_spherical_rectangle_sample(const SphericalRectangle& r, Vec3 p) {
  const Vec3 d = p - r.o;
  const float xu = clamp(dot(d, r.x), r.x0, r.x1), yv = clamp(dot(d, r.y), r.y0, r.y1);
  const float u0 = local_rectangle_solid_angle(float(r.x0), float(r.y0), float(xu), float(r.y1), float(r.z0)) / r.area;
  const float dd2 = xu * xu + r.z0 * r.z0;
  const float h0 = r.y0 / std::sqrt(dd2 + r.y0 * r.y0), h1 = r.y1 / std::sqrt(dd2 + r.y1 * r.y1);
  const float hv = yv / std::sqrt(dd2 + yv * yv);
  const float u1 = h1 != h0 ? (hv - h0) / (h1 - h0) : 0;
  return Vec2(clamp(u0, 0.f, kOneMinusEpsilon), clamp(u1, 0.f, kOneMinusEpsilon));
}

}  // namespace pn
