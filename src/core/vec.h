// Small vector types for RGB radiance and 3D geometry. Plain structs of floats.
#pragma once

#include "common.h"

namespace pn {

struct Vec2 {
  float x = 0, y = 0;
  PN_HD Vec2() {}
  PN_HD Vec2(float x_, float y_) : x(x_), y(y_) {}
};

struct Vec3 {
  float x = 0, y = 0, z = 0;
  PN_HD Vec3() {}
  PN_HD explicit Vec3(float s) : x(s), y(s), z(s) {}
  PN_HD Vec3(float x_, float y_, float z_) : x(x_), y(y_), z(z_) {}
  PN_HD float operator[](int i) const { return i == 0 ? x : (i == 1 ? y : z); }
  PN_HD float& operator[](int i) { return i == 0 ? x : (i == 1 ? y : z); }
};

PN_FN Vec3 operator+(Vec3 a, Vec3 b) { return {a.x + b.x, a.y + b.y, a.z + b.z}; }
PN_FN Vec3 operator-(Vec3 a, Vec3 b) { return {a.x - b.x, a.y - b.y, a.z - b.z}; }
PN_FN Vec3 operator-(Vec3 a) { return {-a.x, -a.y, -a.z}; }
PN_FN Vec3 operator*(Vec3 a, Vec3 b) { return {a.x * b.x, a.y * b.y, a.z * b.z}; }
PN_FN Vec3 operator*(Vec3 a, float s) { return {a.x * s, a.y * s, a.z * s}; }
PN_FN Vec3 operator*(float s, Vec3 a) { return {a.x * s, a.y * s, a.z * s}; }
PN_FN Vec3 operator/(Vec3 a, float s) { return a * (1.f / s); }
PN_FN Vec3& operator+=(Vec3& a, Vec3 b) { a = a + b; return a; }
PN_FN Vec3& operator*=(Vec3& a, Vec3 b) { a = a * b; return a; }
PN_FN Vec3& operator*=(Vec3& a, float s) { a = a * s; return a; }

PN_FN float dot(Vec3 a, Vec3 b) { return a.x * b.x + a.y * b.y + a.z * b.z; }
PN_FN Vec3 cross(Vec3 a, Vec3 b) {
  return {a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x};
}
PN_FN float length_sq(Vec3 a) { return dot(a, a); }
PN_FN float length(Vec3 a) { return std::sqrt(dot(a, a)); }
PN_FN Vec3 normalize(Vec3 a) { return a * (1.f / length(a)); }
PN_FN float max_component(Vec3 a) { return pn_max(a.x, pn_max(a.y, a.z)); }
PN_FN float luminance(Vec3 c) { return 0.2126f * c.x + 0.7152f * c.y + 0.0722f * c.z; }
PN_FN bool is_black(Vec3 a) { return a.x == 0.f && a.y == 0.f && a.z == 0.f; }
PN_FN bool is_finite(Vec3 a) {
  return std::isfinite(a.x) && std::isfinite(a.y) && std::isfinite(a.z);
}
PN_FN Vec3 vmin(Vec3 a, Vec3 b) { return {pn_min(a.x, b.x), pn_min(a.y, b.y), pn_min(a.z, b.z)}; }
PN_FN Vec3 vmax(Vec3 a, Vec3 b) { return {pn_max(a.x, b.x), pn_max(a.y, b.y), pn_max(a.z, b.z)}; }
PN_FN Vec3 vabs(Vec3 a) { return {std::fabs(a.x), std::fabs(a.y), std::fabs(a.z)}; }

// Orthonormal basis around a unit vector n (Duff et al. 2017, "Building an
// Orthonormal Basis, Revisited"): branch-free apart from the sign, no NaN.
struct Frame {
  Vec3 s, t, n;
  PN_HD static Frame from_z(Vec3 n) {
    float sign = std::copysign(1.f, n.z);
    float a = -1.f / (sign + n.z);
    float b = n.x * n.y * a;
    Frame f;
    f.s = Vec3(1.f + sign * n.x * n.x * a, sign * b, -sign * n.x);
    f.t = Vec3(b, sign + n.y * n.y * a, -n.y);
    f.n = n;
    return f;
  }
  PN_HD Vec3 to_world(Vec3 v) const { return s * v.x + t * v.y + n * v.z; }
  PN_HD Vec3 to_local(Vec3 v) const { return Vec3(dot(v, s), dot(v, t), dot(v, n)); }
};

struct Ray {
  Vec3 o, d;  // origin, unit direction
  PN_HD Ray() {}
  PN_HD Ray(Vec3 o_, Vec3 d_) : o(o_), d(d_) {}
  PN_HD Vec3 at(float t) const { return o + d * t; }
};

}  // namespace pn
