// Affine transforms of instances: a row-major 3x4 matrix [R | t], the layout
// OptiX instances use, with its inverse kept beside it for normals.
#pragma once

#include "common.h"
#include "vec.h"

namespace pn {

struct Affine {
  float m[12] = {1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0};  // rows (r00 r01 r02 tx), ...

  PN_HD Vec3 point(Vec3 p) const {
    return Vec3(m[0] * p.x + m[1] * p.y + m[2] * p.z + m[3], m[4] * p.x + m[5] * p.y + m[6] * p.z + m[7],
                m[8] * p.x + m[9] * p.y + m[10] * p.z + m[11]);
  }
  PN_HD Vec3 vector(Vec3 v) const {
    return Vec3(m[0] * v.x + m[1] * v.y + m[2] * v.z, m[4] * v.x + m[5] * v.y + m[6] * v.z,
                m[8] * v.x + m[9] * v.y + m[10] * v.z);
  }
  // Multiplies by the transpose of the 3x3 part: with the INVERSE transform,
  // this maps object-space normals to world space (n' = M^-T n).
  PN_HD Vec3 transpose_vector(Vec3 v) const {
    return Vec3(m[0] * v.x + m[4] * v.y + m[8] * v.z, m[1] * v.x + m[5] * v.y + m[9] * v.z,
                m[2] * v.x + m[6] * v.y + m[10] * v.z);
  }
  // Determinant of the 3x3 part: negative for a mirroring transform, which
  // reverses the winding (and the handedness of cross products) it maps.
  PN_HD float linear_determinant() const {
    return m[0] * (m[5] * m[10] - m[6] * m[9]) + m[1] * (m[6] * m[8] - m[4] * m[10]) +
           m[2] * (m[4] * m[9] - m[5] * m[8]);
  }
  PN_HD bool is_identity() const {
    const float id[12] = {1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0};
    for (int i = 0; i < 12; ++i)
      if (m[i] != id[i]) return false;
    return true;
  }
};

// C = A * B (apply B first).
PN_FN Affine compose(const Affine& a, const Affine& b) {
  Affine c;
  for (int r = 0; r < 3; ++r) {
    for (int k = 0; k < 4; ++k) {
      float v = a.m[4 * r + 0] * b.m[k] + a.m[4 * r + 1] * b.m[4 + k] + a.m[4 * r + 2] * b.m[8 + k];
      c.m[4 * r + k] = v + (k == 3 ? a.m[4 * r + 3] : 0.f);
    }
  }
  return c;
}

// Inverse of an affine transform; `ok` is false if the 3x3 part is singular.
PN_FN Affine inverse(const Affine& a, bool* ok) {
  const float* m = a.m;
  float c00 = m[5] * m[10] - m[6] * m[9], c01 = m[6] * m[8] - m[4] * m[10], c02 = m[4] * m[9] - m[5] * m[8];
  float det = a.linear_determinant();
  Affine r;
  *ok = det != 0.f && std::isfinite(det);
  if (!*ok) return r;
  float id = 1.f / det;
  float* o = r.m;
  o[0] = c00 * id;
  o[1] = (m[2] * m[9] - m[1] * m[10]) * id;
  o[2] = (m[1] * m[6] - m[2] * m[5]) * id;
  o[4] = c01 * id;
  o[5] = (m[0] * m[10] - m[2] * m[8]) * id;
  o[6] = (m[2] * m[4] - m[0] * m[6]) * id;
  o[8] = c02 * id;
  o[9] = (m[1] * m[8] - m[0] * m[9]) * id;
  o[10] = (m[0] * m[5] - m[1] * m[4]) * id;
  Vec3 t = r.vector(Vec3(m[3], m[7], m[11]));
  o[3] = -t.x;
  o[7] = -t.y;
  o[11] = -t.z;
  return r;
}

PN_FN Affine translation(Vec3 t) {
  Affine a;
  a.m[3] = t.x;
  a.m[7] = t.y;
  a.m[11] = t.z;
  return a;
}
PN_FN Affine scaling(Vec3 s) {
  Affine a;
  a.m[0] = s.x;
  a.m[5] = s.y;
  a.m[10] = s.z;
  return a;
}
// Rotation by `degrees` about the unit `axis` (right-handed).
PN_FN Affine rotation(Vec3 axis, float degrees) {
  float th = degrees * kPi / 180.f, c = std::cos(th), s = std::sin(th), k = 1.f - c;
  Vec3 u = axis;
  Affine a;
  a.m[0] = c + u.x * u.x * k;       a.m[1] = u.x * u.y * k - u.z * s; a.m[2] = u.x * u.z * k + u.y * s;
  a.m[4] = u.y * u.x * k + u.z * s; a.m[5] = c + u.y * u.y * k;       a.m[6] = u.y * u.z * k - u.x * s;
  a.m[8] = u.z * u.x * k - u.y * s; a.m[9] = u.z * u.y * k + u.x * s; a.m[10] = c + u.z * u.z * k;
  return a;
}

}  // namespace pn
