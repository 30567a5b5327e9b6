// Sampling a spherical cap by projected solid angle: directions w in the cap
// with density cos(theta) / Omega_p, theta measured from a normal n, Omega_p
// the cap's projected solid angle. For a Lambertian surface lit by a uniform
// sphere light, L f cos / pdf = L f Omega_p is then the same for every sample:
// with nothing in the way, the direct light has zero variance.
//
// Method: the one of Urena & Georgiev 2018 ("Stratified Sampling of Projected
// Spherical Caps") and Peters & Dachsbacher 2019 ("Sampling Projected Spherical
// Caps in Real Time"): project the cap orthographically onto the unit disk of
// the plane z = 0 (z = n). dA = cos(theta) d omega, so a point uniform in the
// projected region, lifted back to the hemisphere, has exactly the density
// wanted. The region is exact here (not approximated); its pieces are sampled
// exactly, with one numerically inverted 1D CDF (core/sampling.h's disk segment,
// Newton to float precision), and one rejection case:
//
// In the frame z = n, x towards the cap's axis a = (sin b, 0, cos b), a cap of
// half-angle alpha has its boundary circle project to the ellipse of centre
// (cos alpha sin b, 0) and semi-axes (sin alpha cos b, sin alpha).
//   * cos b >= sin alpha (the cap wholly above the horizon): the ellipse;
//     Omega_p = pi sin^2(alpha) cos b.
//   * 0 < cos b < sin alpha (the cap crosses the horizon, its axis above):
//     the part of the ellipse left of the chord x = x_h = cos alpha / sin b,
//     plus the segment of the unit disk right of it (the horizon's silhouette):
//     two disjoint pieces, chosen in proportion to their areas.
//   * -sin alpha < cos b <= 0 (axis at or below the horizon): the segment of
//     the unit disk right of x_h minus the ellipse's part there. Points of the
//     segment are drawn and those outside the cap rejected (no sample): the
//     density of the others is cos(theta) / area(segment), still exact, and
//     only a cap that pokes above a surface from behind pays for it.
//   * cos b <= -sin alpha: nothing above the horizon.
// Caps narrower than sin^2(alpha) = kMinProjectedCapSin2 are sampled by their
// cone instead (cos theta varies by less than 0.1% over them, and float cannot
// place points in so small an ellipse well): pdf = the cone's.
#pragma once

#include "common.h"
#include "sampling.h"
#include "vec.h"

namespace pn {

constexpr float kMinProjectedCapSin2 = 1e-6f;

enum class ProjectedCapMode : uint32_t {
  Empty,      // the cap is wholly below the horizon
  Cone,       // too narrow: uniform cone sampling
  Ellipse,    // wholly above: the ellipse
  Crossing,   // axis above, cap crosses the horizon: ellipse part + disk segment
  Rejection,  // axis at or below the horizon: disk segment minus ellipse part
};

struct ProjectedCap {
  ProjectedCapMode mode = ProjectedCapMode::Empty;
  Frame frame;             // z = n, x = the axis' direction in the tangent plane
  Vec3 axis;               // unit direction of the cap's centre
  Cone cone;               // the cap as a cone around `axis`
  float cx = 0.f, ax = 0.f, ay = 0.f;  // the ellipse: centre (cx, 0), semi-axes ax, ay
  float theta_e = 0.f, area_e = 0.f;   // Crossing: its part as a unit-disk segment, area in the plane
  float theta_s = 0.f, area_s = 0.f;   // Crossing, Rejection: the unit-disk segment x >= x_h
  float norm = 0.f;        // the density in the plane is 1 / norm (Omega_p, or the segment's area)
};

// The cap of directions around unit `axis` with sin^2(half-angle) = sin2_alpha,
// seen from a point with unit normal n.
PN_FN ProjectedCap make_projected_cap(Vec3 axis, float sin2_alpha, Vec3 n) {
  ProjectedCap c;
  c.axis = axis;
  c.cone = make_cone(sin2_alpha);
  const float sin_a = std::sqrt(c.cone.sin2_max), cos_a = c.cone.cos_max;
  const float cos_b = clamp(dot(axis, n), -1.f, 1.f);
  if (cos_b <= -sin_a) return c;  // Empty
  if (c.cone.sin2_max < kMinProjectedCapSin2) {
    c.mode = ProjectedCapMode::Cone;
    return c;
  }
  // The tangent towards the axis, orthogonal to n; below 1e-6 its direction is
  // rounding noise, and the ellipse's centre (cos alpha sin b) is 0 anyway.
  Vec3 t = axis - n * cos_b;
  t = t - n * dot(t, n);
  const float tl = length(t);
  float sin_b = tl;
  if (tl > 1e-6f) {
    c.frame.n = n;
    c.frame.s = t / tl;
    c.frame.t = cross(n, c.frame.s);
  } else {
    c.frame = Frame::from_z(n);
    sin_b = 0.f;
  }
  c.cx = cos_a * sin_b;
  c.ax = sin_a * std::fabs(cos_b);
  c.ay = sin_a;
  if (cos_b >= sin_a) {
    c.mode = ProjectedCapMode::Ellipse;
    c.norm = kPi * c.ax * c.ay;
    return c;
  }
  // The chord x = x_h where the cap meets the horizon: with
  // D = sqrt(sin^2 alpha - cos^2 b), its half-angle in the unit disk is
  // atan2(D, cos alpha), and in the ellipse's own unit disk (where the chord is
  // at cot alpha cot b) it is atan2(D, -cos alpha cos b) for the ellipse's part
  // on the far side. Both without acos of values near 1.
  const float D = safe_sqrt(c.cone.sin2_max - cos_b * cos_b);
  c.theta_s = std::atan2(D, cos_a);
  c.area_s = disk_segment_area(c.theta_s);
  if (cos_b > 0.f) {
    c.mode = ProjectedCapMode::Crossing;
    c.theta_e = std::atan2(D, -cos_a * cos_b);
    c.area_e = c.ax * c.ay * disk_segment_area(c.theta_e);
    c.norm = c.area_e + c.area_s;
  } else {
    c.mode = ProjectedCapMode::Rejection;
    c.norm = c.area_s;
  }
  if (!(c.norm > 0.f)) c.mode = ProjectedCapMode::Empty;
  return c;
}

// Whether direction w lies in the cap (by sin^2, see cone_contains).
PN_FN bool projected_cap_contains(const ProjectedCap& c, Vec3 w) {
  const float cos_t = dot(w, c.axis);
  return cos_t > 0.f && length_sq(cross(w, c.axis)) <= cone_containment_bound(c.cone);
}

// Solid-angle density of sample_projected_cap() at direction w.
PN_FN float projected_cap_pdf(const ProjectedCap& c, Vec3 w) {
  if (c.mode == ProjectedCapMode::Empty || !projected_cap_contains(c, w)) return 0.f;
  if (c.mode == ProjectedCapMode::Cone) return uniform_cone_pdf(c.cone);
  const float cos_theta = dot(w, c.frame.n);
  return cos_theta > 0.f ? cos_theta / c.norm : 0.f;
}

// A direction of the cap with density cos(theta) / Omega_p (see above); false:
// no sample (Empty, or a rejected point).
PN_FN bool sample_projected_cap(const ProjectedCap& c, Vec2 u, Vec3* w, float* pdf) {
  Vec2 q;
  switch (c.mode) {
    case ProjectedCapMode::Empty:
      return false;
    case ProjectedCapMode::Cone: {
      Frame f = Frame::from_z(c.axis);
      *w = f.to_world(sample_uniform_cone(u, c.cone).direction());
      *pdf = uniform_cone_pdf(c.cone);
      return true;
    }
    case ProjectedCapMode::Ellipse: {
      Vec2 d = sample_uniform_disk_concentric(u);
      q = Vec2(c.cx + c.ax * d.x, c.ay * d.y);
      break;
    }
    case ProjectedCapMode::Crossing: {
      const float pe = c.area_e / c.norm;
      if (u.x < pe) {
        // The ellipse's part left of the chord: the mirror image of a segment of its unit disk.
        Vec2 d = sample_disk_segment(Vec2(pn_min(u.x / pe, kOneMinusEpsilon), u.y), c.theta_e, disk_segment_area(c.theta_e));
        q = Vec2(c.cx - c.ax * d.x, c.ay * d.y);
      } else {
        q = sample_disk_segment(Vec2(pn_min((u.x - pe) / (1.f - pe), kOneMinusEpsilon), u.y), c.theta_s, c.area_s);
      }
      break;
    }
    case ProjectedCapMode::Rejection:
      q = sample_disk_segment(u, c.theta_s, c.area_s);
      break;
  }
  const float z = safe_sqrt(1.f - q.x * q.x - q.y * q.y);
  *w = normalize(c.frame.to_world(Vec3(q.x, q.y, z)));
  if (c.mode == ProjectedCapMode::Rejection && !projected_cap_contains(c, *w)) return false;
  *pdf = dot(*w, c.frame.n) / c.norm;
  return *pdf > 0.f;
}

}  // namespace pn
