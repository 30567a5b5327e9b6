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
// The parametrizations themselves (Arvo's cos of an arc, Urena's angles near
// pi / 2) cancel for small polygons: in float, a triangle of 1e-3 sr came back
// through its inverse 0.7% off in u and its samples were visibly non-uniform
// (tests/test_sampling.cpp). They run in double here, from float inputs to
// float outputs, which makes them exact to float precision down to the
// 3e-4 sr bound (at double's cost on GPUs; penumbra bench reports it).
#pragma once

#include "common.h"
#include "sampling.h"
#include "vec.h"

namespace pn {

// Double-precision vectors for the parametrizations (see above).
struct DVec3 {
  double x = 0, y = 0, z = 0;
  PN_HD DVec3() {}
  PN_HD DVec3(double x_, double y_, double z_) : x(x_), y(y_), z(z_) {}
  PN_HD explicit DVec3(Vec3 v) : x(v.x), y(v.y), z(v.z) {}
  PN_HD Vec3 to_float() const { return Vec3(float(x), float(y), float(z)); }
};
PN_FN DVec3 operator+(DVec3 a, DVec3 b) { return {a.x + b.x, a.y + b.y, a.z + b.z}; }
PN_FN DVec3 operator-(DVec3 a, DVec3 b) { return {a.x - b.x, a.y - b.y, a.z - b.z}; }
PN_FN DVec3 operator-(DVec3 a) { return {-a.x, -a.y, -a.z}; }
PN_FN DVec3 operator*(DVec3 a, double s) { return {a.x * s, a.y * s, a.z * s}; }
PN_FN double dot(DVec3 a, DVec3 b) { return a.x * b.x + a.y * b.y + a.z * b.z; }
PN_FN DVec3 cross(DVec3 a, DVec3 b) { return {a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x}; }
PN_FN double length(DVec3 a) { return std::sqrt(dot(a, a)); }
PN_FN double length_sq(DVec3 a) { return dot(a, a); }
PN_FN DVec3 normalize(DVec3 a) { return a * (1.0 / length(a)); }
PN_FN double clampd(double v, double lo, double hi) { return v < lo ? lo : (v > hi ? hi : v); }
PN_FN double safe_sqrtd(double v) { return std::sqrt(v > 0.0 ? v : 0.0); }

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
PN_FN double one_minus_dot(DVec3 a, DVec3 b) { return 0.5 * length_sq(a - b); }

// --- Spherical triangle --------------------------------------------------------

struct SphericalTriangle {
  DVec3 a, b, c;        // unit directions to the vertices
  double alpha = 0;     // interior angle at a
  double cos_c = 1;     // a . b (the side opposite c)
  float area = 0.f;     // solid angle; 0: degenerate, do not sample
};

// The spherical triangle that triangle (p0, p1, p2) subtends at x.
PN_FN SphericalTriangle make_spherical_triangle(Vec3 x, Vec3 p0, Vec3 p1, Vec3 p2) {
  SphericalTriangle t;
  const DVec3 X(x), A = DVec3(p0) - X, B = DVec3(p1) - X, C = DVec3(p2) - X;
  const double la = length(A), lb = length(B), lc = length(C);
  if (!(la > 0 && lb > 0 && lc > 0)) return t;
  t.a = A * (1.0 / la);
  t.b = B * (1.0 / lb);
  t.c = C * (1.0 / lc);
  const DVec3 n_ab = cross(t.a, t.b), n_ca = cross(t.c, t.a);
  const double l_ab = length(n_ab), l_ca = length(n_ca);
  if (!(l_ab > 0 && l_ca > 0) || !(length_sq(cross(t.b, t.c)) > 0)) return t;
  t.alpha = std::acos(clampd(-dot(n_ab, n_ca) / (l_ab * l_ca), -1.0, 1.0));
  t.cos_c = dot(t.a, t.b);
  t.area = float(triangle_solid_angle_t(A, B, C));
  return t;
}

// A direction uniform over the spherical triangle: u.x chooses the sub-triangle
// (a, b, c') of area u.x * area, c' on the arc from a to c; u.y the point on
// the arc from b to c' (Arvo's algorithm). pdf = 1 / area.
PN_FN Vec3 sample_spherical_triangle(const SphericalTriangle& t, Vec2 u) {
  const double area_sub = double(u.x) * double(t.area);
  const double s = std::sin(area_sub - t.alpha), c = std::cos(area_sub - t.alpha);
  const double ca = std::cos(t.alpha), sa = std::sin(t.alpha);
  const double uu = c - ca, vv = s + sa * t.cos_c;
  const double q = clampd(((vv * c - uu * s) * ca - vv) / ((vv * s + uu * c) * sa), -1.0, 1.0);
  const DVec3 c_perp = normalize(t.c - t.a * dot(t.c, t.a));
  const DVec3 cp = t.a * q + c_perp * safe_sqrtd(1.0 - q * q);
  // Along the arc from b to c': 1 - cos theta = u.y (1 - cos(b, c')).
  const double one_minus_z = double(u.y) * one_minus_dot(cp, t.b);
  const double z = 1.0 - one_minus_z;
  const DVec3 d = cp - t.b * dot(cp, t.b);
  const double dl = length(d);
  if (!(dl > 0)) return t.b.to_float();
  return (t.b * z + d * (safe_sqrtd(one_minus_z * (2.0 - one_minus_z)) / dl)).to_float();
}

// The u that sample_spherical_triangle maps to direction w (in the triangle).
PN_FN Vec2 invert_spherical_triangle_sample(const SphericalTriangle& t, Vec3 wf) {
  const DVec3 w = normalize(DVec3(wf));
  // c' is where the great circle through b and w meets the arc from a to c.
  DVec3 cp = cross(cross(t.b, w), cross(t.c, t.a));
  const double l = length(cp);
  if (!(l > 0)) return Vec2(0.5f, 0.5f);
  cp = cp * (1.0 / l);
  if (dot(cp, t.a + t.c) < 0) cp = -cp;
  double u0 = 0;
  if (one_minus_dot(t.a, cp) > 1e-20) u0 = triangle_solid_angle_t(t.a, t.b, cp) / double(t.area);
  const double den = one_minus_dot(cp, t.b);
  const double u1 = den > 0 ? one_minus_dot(w, t.b) / den : 0;
  return Vec2(float(clampd(u0, 0.0, kOneMinusEpsilon)), float(clampd(u1, 0.0, kOneMinusEpsilon)));
}

// --- Spherical rectangle ----------------------------------------------------------

// A rectangle s + a ex + b ey (ex orthogonal to ey, a, b in [0, 1]) as seen from
// o, in the local frame of Urena et al.: x along ex, y along ey, z towards o's
// side flipped so that the rectangle lies at z = z0 < 0.
struct SphericalRectangle {
  DVec3 o, x, y, z;
  double x0 = 0, y0 = 0, x1 = 0, y1 = 0, z0 = 0;
  double b0 = 0, b1 = 0, k = 0;  // the parametrization's constants
  float area = 0.f;              // solid angle; 0: degenerate
};

// Solid angle of the local rectangle [x0, x1] x [y0, y1] at height z0, as two triangles.
PN_FN double local_rectangle_solid_angle(double x0, double y0, double x1, double y1, double z0) {
  const DVec3 v00(x0, y0, z0), v10(x1, y0, z0), v11(x1, y1, z0), v01(x0, y1, z0);
  return triangle_solid_angle_t(v00, v10, v11) + triangle_solid_angle_t(v00, v11, v01);
}

PN_FN SphericalRectangle make_spherical_rectangle(Vec3 o, Vec3 s, Vec3 ex, Vec3 ey) {
  SphericalRectangle r;
  const DVec3 EX(ex), EY(ey);
  const double exl = length(EX), eyl = length(EY);
  r.o = DVec3(o);
  r.x = EX * (1.0 / exl);
  r.y = EY * (1.0 / eyl);
  r.z = cross(r.x, r.y);
  const DVec3 d = DVec3(s) - r.o;
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
  const DVec3 v00(r.x0, r.y0, r.z0), v01(r.x0, r.y1, r.z0), v10(r.x1, r.y0, r.z0), v11(r.x1, r.y1, r.z0);
  // Unit normals of the planes through o and the edges; g2, g3 the interior
  // angles at (x0, y1) and (x0, y0).
  const DVec3 n0 = normalize(cross(v00, v10)), n2 = normalize(cross(v11, v01)), n3 = normalize(cross(v01, v00));
  const double g2 = std::acos(clampd(-dot(n2, n3), -1.0, 1.0)), g3 = std::acos(clampd(-dot(n3, n0), -1.0, 1.0));
  r.b0 = n0.z;
  r.b1 = n2.z;
  r.k = 2 * 3.14159265358979323846 - g2 - g3;  // pi in double: float's pi is off by 9e-8
  r.area = float(local_rectangle_solid_angle(r.x0, r.y0, r.x1, r.y1, r.z0));
  return r;
}

// A point of the rectangle whose direction from o is uniform in solid angle:
// u.x sets the sub-rectangle [x0, xu] of solid angle u.x * area, u.y the height
// along it. pdf = 1 / area (in solid angle at o).
PN_FN Vec3 sample_spherical_rectangle(const SphericalRectangle& r, Vec2 u) {
  const double au = double(u.x) * double(r.area) + r.k;
  const double fu = (std::cos(au) * r.b0 - r.b1) / std::sin(au);
  double cu = (fu >= 0 ? 1.0 : -1.0) / std::sqrt(fu * fu + r.b0 * r.b0);
  cu = clampd(cu, -1.0 + 1e-15, 1.0 - 1e-15);
  const double xu = clampd(-(cu * r.z0) / safe_sqrtd(1.0 - cu * cu), r.x0, r.x1);
  const double dd2 = xu * xu + r.z0 * r.z0;
  const double h0 = r.y0 / std::sqrt(dd2 + r.y0 * r.y0), h1 = r.y1 / std::sqrt(dd2 + r.y1 * r.y1);
  const double hv = h0 + double(u.y) * (h1 - h0), hv2 = hv * hv;
  const double yv = hv2 < 1.0 - 1e-12 ? clampd(hv * std::sqrt(dd2) / std::sqrt(1.0 - hv2), r.y0, r.y1) : r.y1;
  return (r.o + r.x * xu + r.y * yv + r.z * r.z0).to_float();
}

// The u that sample_spherical_rectangle maps to point p of the rectangle.
PN_FN Vec2 invert_spherical_rectangle_sample(const SphericalRectangle& r, Vec3 p) {
  const DVec3 d = DVec3(p) - r.o;
  const double xu = clampd(dot(d, r.x), r.x0, r.x1), yv = clampd(dot(d, r.y), r.y0, r.y1);
  const double u0 = local_rectangle_solid_angle(r.x0, r.y0, xu, r.y1, r.z0) / double(r.area);
  const double dd2 = xu * xu + r.z0 * r.z0;
  const double h0 = r.y0 / std::sqrt(dd2 + r.y0 * r.y0), h1 = r.y1 / std::sqrt(dd2 + r.y1 * r.y1);
  const double hv = yv / std::sqrt(dd2 + yv * yv);
  const double u1 = h1 != h0 ? (hv - h0) / (h1 - h0) : 0;
  return Vec2(float(clampd(u0, 0.0, kOneMinusEpsilon)), float(clampd(u1, 0.0, kOneMinusEpsilon)));
}

}  // namespace pn
