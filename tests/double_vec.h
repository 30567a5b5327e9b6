// A 3-vector in double for the tests' exact references (closed forms, error bounds), beside the core's float Vec3.
#pragma once

#include <cmath>

#include "core/vec.h"

namespace pn::test {

struct D3 {
  double x = 0, y = 0, z = 0;
  D3() = default;
  D3(double x_, double y_, double z_) : x(x_), y(y_), z(z_) {}
  explicit D3(Vec3 v) : x(v.x), y(v.y), z(v.z) {}
};
inline D3 operator-(D3 a, D3 b) { return {a.x - b.x, a.y - b.y, a.z - b.z}; }
inline D3 operator+(D3 a, D3 b) { return {a.x + b.x, a.y + b.y, a.z + b.z}; }
inline D3 operator*(D3 a, double s) { return {a.x * s, a.y * s, a.z * s}; }
inline double dot(D3 a, D3 b) { return a.x * b.x + a.y * b.y + a.z * b.z; }
inline D3 cross(D3 a, D3 b) { return {a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x}; }
inline double len(D3 a) { return std::sqrt(dot(a, a)); }
inline D3 unit(D3 a) { return a * (1.0 / len(a)); }

}  // namespace pn::test
