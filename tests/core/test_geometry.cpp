// Hit points and ray origins (core/geometry.h) against exact arithmetic: a hit
// point is where the ray hit, to within its own error bound, which is
// conservative; the next ray's origin is on the right side of the surface and
// no further from it than the bound needs; a hit is moved only within a few
// rounding errors of an edge, and never by more than its bound.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <random>

#include "core/geometry.h"
#include "double_vec.h"
#include "core/reservoir.h"

namespace pn {
namespace {

using test::D3;
using test::cross;
using test::dot;
using test::len;

struct Triangle {
  Vec3 p[3];
};

// Roughly 10^x (within 6%), in exact arithmetic: the test's draws must not depend on the machine's libm, whose code
// paths differ between CPUs.
float pow10(float x) {
  const float log2_x = x * 3.3219281f;
  const float k = std::floor(log2_x);
  return std::ldexp(1.f + (log2_x - k), int(k));
}

// Triangles of every size from 1e-3 to 1e3, 1 to 1,000 times their size from the origin (so at least
// ~10^4 units in the last place wide), turned at random.
Triangle random_triangle(std::mt19937& g) {
  std::uniform_real_distribution<float> u(-1.f, 1.f);
  const float size = pow10(3.f * u(g)), offset = size * pow10(1.5f + 1.5f * u(g));
  const Vec3 c(offset * u(g), offset * u(g), offset * u(g));
  Triangle t;
  for (Vec3& v : t.p) v = c + Vec3(u(g), u(g), u(g)) * size;
  return t;
}

// Signed distance of x from the triangle's plane (normal along the winding), and from each edge's line
// inside the plane (positive inside), in double.
double plane_distance(const Triangle& t, D3 x) {
  const D3 a(t.p[0]), b(t.p[1]), c(t.p[2]);
  const D3 n = cross(b - a, c - a);
  return dot(x - a, n) / len(n);
}
double edge_distance(const D3 v[3], D3 x) {
  const D3 n = cross(v[1] - v[0], v[2] - v[0]);
  double d = 1e300;
  for (int i = 0; i < 3; ++i) {
    const D3 e = v[(i + 1) % 3] - v[i];
    const D3 inward = cross(n, e);
    d = std::min(d, dot(x - v[i], inward) / len(inward));
  }
  return d;
}
double edge_distance(const Triangle& t, D3 x) {
  const D3 v[3] = {D3(t.p[0]), D3(t.p[1]), D3(t.p[2])};
  return edge_distance(v, x);
}

double smallest_angle(const Triangle& t) {
  double a = M_PI;
  for (int i = 0; i < 3; ++i) {
    const D3 u = D3(t.p[(i + 1) % 3]) - D3(t.p[i]), w = D3(t.p[(i + 2) % 3]) - D3(t.p[i]);
    a = std::min(a, std::acos(std::clamp(dot(u, w) / (len(u) * len(w)), -1.0, 1.0)));
  }
  return a;
}

bool degenerate(const Triangle& t) {
  const D3 a(t.p[0]), b(t.p[1]), c(t.p[2]);
  const double area2 = len(cross(b - a, c - a));
  const double longest = std::max({len(b - a), len(c - a), len(c - b)});
  return area2 < 1e-2 * longest * longest;  // slivers: their edge functions say little
}

TEST(Geometry, HitPointsAreWhereTheRayHits) {
  std::mt19937 g(7);
  std::uniform_real_distribution<float> u(0.f, 1.f);
  int tested = 0, moved = 0, interior = 0, interior_moved = 0;
  for (int i = 0; i < 200000; ++i) {
    const Triangle t = random_triangle(g);
    if (degenerate(t)) continue;
    float b1 = u(g), b2 = u(g);
    if (b1 + b2 > 1.f) b1 = 1.f - b1, b2 = 1.f - b2;
    // Every fourth hit lies on an edge or a rounding error from one.
    if (i % 4 == 1) b1 = 0.f;
    if (i % 4 == 2) b2 = std::ldexp(u(g), -30);
    if (i % 4 == 3) b2 = 1.f - b1;
    Vec3 p, err, n;
    float clearance = -1.f;
    triangle_hit(t.p[0], t.p[1], t.p[2], b1, b2, &p, &err, &n, &clearance);
    const double b0 = 1.0 - double(b1) - double(b2);
    const D3 exact = D3(t.p[0]) * b0 + D3(t.p[1]) * double(b1) + D3(t.p[2]) * double(b2);
    const D3 d = D3(p) - exact;
    const double bound = len(D3(err));
    const double dist = len(d);
    ++tested;
    interior += i % 4 == 0;
    // The point is where the ray hit: within its error bound, or, where it was within twice that bound of
    // an edge, moved inside by at most three times the bound.
    // What the hit keeps from every edge (triangle_hit: edge_keep of the interpolation's bound and its bound
    // along the normal).
    const Vec3 err_i = (vabs(t.p[0] * (1.f - b1 - b2)) + vabs(t.p[1] * b1) + vabs(t.p[2] * b2)) * fp_gamma(7);
    const float eb = fp_gamma(kIntersectionUlps) * std::max({max_component(vabs(t.p[1] - t.p[0])),
                                                             max_component(vabs(t.p[2] - t.p[0])),
                                                             max_component(vabs(t.p[2] - t.p[1]))});
    const double keep = 1.01 * edge_keep(length(err_i), error_along(err_i, n) + 3.f * eb);
    const bool near_edge = edge_distance(t, exact) < keep;
    // Near a corner of angle theta the point keeps 2 |err| from both edges: up to 2 |err| / sin(theta / 2)
    // from the vertex.
    const double corner = 1.0 / std::sin(0.5 * smallest_angle(t));
    if (!near_edge) {
      ASSERT_LE(std::fabs(d.x), err.x) << i;
      ASSERT_LE(std::fabs(d.y), err.y) << i;
      ASSERT_LE(std::fabs(d.z), err.z) << i;
    } else {
      ++moved;
      interior_moved += i % 4 == 0;
      ASSERT_LE(dist, (keep + bound) * corner) << i << " b " << b1 << " " << b2 << " bound " << bound;
    }
    // The computed point is inside the triangle, off every edge (closed meshes stay closed), and its
    // clearance is a lower bound on how far: of the true point, and of the computed one.
    ASSERT_GT(edge_distance(t, D3(p)), 0.0) << i << " near edge " << near_edge;
    ASSERT_GE(clearance, 0.f) << i;
    ASSERT_LE(double(clearance), edge_distance(t, D3(p))) << i;
    if (!near_edge) {
      ASSERT_LE(double(clearance), edge_distance(t, exact)) << i;
      // and a tight one, away from the edges: within the point's bound and a relative 1e-4.
      ASSERT_GE(double(clearance), edge_distance(t, exact) * (1.0 - 1e-4) - 4.0 * bound) << i;
    }
    // The bound is a rounding error, not a displacement: at most ~1e-6 of the coordinates' magnitude or the
    // triangle's size.
    const double mag = std::max({std::fabs(t.p[0].x), std::fabs(t.p[0].y), std::fabs(t.p[0].z),
                                 std::fabs(t.p[1].x), std::fabs(t.p[1].y), std::fabs(t.p[1].z),
                                 std::fabs(t.p[2].x), std::fabs(t.p[2].y), std::fabs(t.p[2].z)});
    const double longest = std::max({len(D3(t.p[1]) - D3(t.p[0])), len(D3(t.p[2]) - D3(t.p[0])),
                                     len(D3(t.p[2]) - D3(t.p[1]))});
    ASSERT_LE(bound, 2e-6 * std::max(mag, longest)) << i;
  }
  EXPECT_GT(tested, 100000);
  EXPECT_GT(moved, tested / 2);            // the edge cases above reach the guard
  // Hits at random rarely do (0.12% here, where triangles lie up to 1000x their size from the origin: the band,
  // four bounds along the normal, grows with that distance).
  EXPECT_LT(interior_moved, interior / 200);
}

TEST(Geometry, RayOriginsLeaveTheSurfaceBarelyAndOnTheRightSide) {
  std::mt19937 g(11);
  std::uniform_real_distribution<float> u(0.f, 1.f);
  for (int i = 0; i < 200000; ++i) {
    const Triangle t = random_triangle(g);
    if (degenerate(t)) continue;
    float b1 = u(g), b2 = u(g);
    if (b1 + b2 > 1.f) b1 = 1.f - b1, b2 = 1.f - b2;
    // Every other hit with its clearance (the renderer's), every other without (the least reach).
    Vec3 p, err, n;
    float clearance = 0.f;
    triangle_hit(t.p[0], t.p[1], t.p[2], b1, b2, &p, &err, &n, (i & 2) ? &clearance : nullptr);
    const float e = error_along(err, n);
    const float reach = std::max(e / kMinOriginCos, clearance);
    const Vec3 side = (i & 1) ? n : -n;
    // Directions over the whole hemisphere; every third one grazes at a cosine near e / reach, where the move
    // along the ray reaches as far as the clearance allows.
    Vec3 w = normalize(Vec3(2.f * u(g) - 1.f, 2.f * u(g) - 1.f, 2.f * u(g) - 1.f));
    if (i % 3 == 0) {
      const Vec3 tangent = normalize(w - side * dot(w, side));
      const float cos_target = std::min(1.f, 2.f * u(g) * e / reach);
      w = normalize(tangent * std::sqrt(std::max(0.f, 1.f - cos_target * cos_target)) + side * cos_target);
    }
    if (dot(w, side) < 0.f) w = -w;
    const float c = dot(w, side);
    const Vec3 o = offset_ray_origin(p, side, PointBound(e, clearance), w);
    const double h = plane_distance(t, D3(o)) * ((i & 1) ? 1.0 : -1.0);
    ASSERT_GT(h, 0.0) << i;  // on the side the ray leaves towards
    // and no further than twice the bound plus the rounding of the move (a unit in the last place of o).
    const double ulp = std::max({std::fabs(o.x), std::fabs(o.y), std::fabs(o.z)}) * 1.2e-7;
    ASSERT_LE(h, 2.0 * e + 2.0 * ulp) << i;
    // On the ray's own line through p (but for the rounding), unless it grazes beyond its reach: then within e
    // of it.
    const D3 op = D3(o) - D3(p), wd(w);
    const double off_line = len(op - wd * dot(op, wd));
    const bool on_line = c >= kMinOriginCos || e <= reach * c;
    ASSERT_LE(off_line, (on_line ? 0.0 : double(e)) + 4.0 * ulp) << i << " cos " << c;
    ASSERT_LE(dot(op, wd), double(reach) + double(e) + 4.0 * ulp) << i;
    // Over the triangle itself: it cannot have left through a neighbouring face of a closed mesh.
    ASSERT_GT(edge_distance(t, D3(o)), 0.0) << i << " cos " << c << " clearance " << clearance;
  }
}

TEST(Geometry, InstanceTransformsKeepTheBound) {
  std::mt19937 g(5);
  std::uniform_real_distribution<float> u(-1.f, 1.f);
  int tested = 0, clipped = 0;
  for (int i = 0; i < 50000; ++i) {
    const Triangle t = random_triangle(g);
    if (degenerate(t)) continue;
    Affine m;
    for (float& v : m.m) v = u(g) * 3.f;
    m.m[3] *= 100.f, m.m[7] *= 100.f, m.m[11] *= 100.f;
    const float b1 = 1.f / 3.f + 0.05f * u(g), b2 = 1.f / 3.f + 0.05f * u(g);  // far from edges: not moved
    bool ok = false;
    const Affine inv = inverse(m, &ok);
    if (!ok || std::fabs(m.linear_determinant()) < 1e-2f) continue;
    Vec3 p, err, n;
    float clearance = 0.f;
    triangle_hit(t.p[0], t.p[1], t.p[2], b1, b2, &p, &err, &n, &clearance);
    // The object-space point is within its bound (HitPointsAreWhereTheRayHits); here the transform's part: the
    // world point against the object point transformed exactly.
    const auto world = [&m](D3 x) {
      return D3(m.m[0] * x.x + m.m[1] * x.y + m.m[2] * x.z + m.m[3], m.m[4] * x.x + m.m[5] * x.y + m.m[6] * x.z + m.m[7],
                m.m[8] * x.x + m.m[9] * x.y + m.m[10] * x.z + m.m[11]);
    };
    const D3 exact_world = world(D3(p));
    instance_to_world(m, inv, &p, &err, &n, &clearance);
    ASSERT_LE(std::fabs(p.x - exact_world.x), err.x) << i;
    ASSERT_LE(std::fabs(p.y - exact_world.y), err.y) << i;
    ASSERT_LE(std::fabs(p.z - exact_world.z), err.z) << i;
    // The clearance, moved to world space, is still a lower bound on the world point's distance from the world
    // triangle's edges. Where the world point's rounding error is larger than the clearance the bound is clipped
    // to 0: the rounded point may then lie outside the triangle, but by no more than that error.
    const D3 v[3] = {world(D3(t.p[0])), world(D3(t.p[1])), world(D3(t.p[2]))};
    ASSERT_GE(clearance, 0.f) << i;
    ++tested, clipped += clearance == 0.f;
    if (clearance > 0.f)
      ASSERT_LE(double(clearance), edge_distance(v, D3(p))) << i;
    else
      ASSERT_GE(edge_distance(v, D3(p)), -len(D3(err))) << i;
  }
  EXPECT_GT(tested, 10000);
  // About 14%: tiny triangles far out in the instance's space, under transforms whose inverse is large (the bound
  // holds to_object's rounding of a ray's origin too, up to |B| |p| gamma(3); 2% without it).
  EXPECT_LT(clipped, tested / 5);
}

TEST(Geometry, SphereHitsAreOnTheSphereAndOriginsOutside) {
  std::mt19937 g(3);
  std::uniform_real_distribution<float> u(-1.f, 1.f);
  for (int i = 0; i < 100000; ++i) {
    const float scale = pow10(3.f * u(g));
    const Vec3 c = Vec3(u(g), u(g), u(g)) * (scale * 10.f);
    const float r = scale * (0.01f + std::fabs(u(g)));
    const Vec3 o = c + normalize(Vec3(u(g), u(g), u(g))) * (r * 3.f);
    const Vec3 target = c + Vec3(u(g), u(g), u(g)) * (r * 0.5f);
    const Ray ray(o, normalize(target - o));
    float t = 0;
    if (!intersect_sphere(ray, c, r, 0.f, kInf, &t)) continue;
    Vec3 p, err, n;
    sphere_hit(c, r, ray, t, &p, &err, &n);
    const double dist = len(D3(p) - D3(c));
    ASSERT_LE(std::fabs(dist - r), len(D3(err))) << i;  // on the sphere, to its bound
    const Vec3 out = offset_ray_origin(p, n, error_along(err, n), n);
    ASSERT_GT(len(D3(out) - D3(c)), double(r)) << i;  // outside it
    const Vec3 in = offset_ray_origin(p, -n, error_along(err, n), -n);
    ASSERT_LT(len(D3(in) - D3(c)), double(r)) << i;  // or inside, as asked
  }
}

// What a shadow ray leaves out of the segment from a shading point p to a light point y: the first
// offset (p's bound along the normal over the cosine, at most 1 / kMinOriginCos of it, plus rounding) and the
// last kShadowEpsilon of its length.
// An occluder inside those ends is not seen; that is the whole of the shadow ray's bias.
TEST(Geometry, ShadowRaysLeaveOutOnlyTheirEnds) {
  std::mt19937 g(13);
  std::uniform_real_distribution<float> u(-1.f, 1.f);
  for (int i = 0; i < 100000; ++i) {
    const float scale = pow10(2.f * u(g));
    const Vec3 p = Vec3(u(g), u(g), u(g)) * scale, n = normalize(Vec3(u(g), u(g), u(g)));
    Vec3 y = p + Vec3(u(g), u(g), u(g)) * (scale * pow10(u(g)));
    if (dot(y - p, n) < 0.f) y = y - n * (2.f * dot(y - p, n));  // on the side the shadow ray leaves towards
    const float p_error = std::fabs(u(g)) * 1e-5f * scale;
    const ShadowRay r = light_shadow_ray(p, p_error, n, normalize(y - p), y, false);
    const double dist = len(D3(y) - D3(p));
    const double start = len(D3(r.ray.o) - D3(p));
    const double ulp = 1.2e-7 * std::max({std::fabs(p.x), std::fabs(p.y), std::fabs(p.z)});
    ASSERT_LE(start, p_error / kMinOriginCos + 2.0 * p_error + 3.0 * ulp) << i;
    const Vec3 end = r.ray.o + r.ray.d * r.tmax;
    const double short_of_y = len(D3(y) - D3(end));
    ASSERT_LE(short_of_y, 1.001 * kShadowEpsilon * dist + 4.0 * ulp + 1e-6 * dist) << i;
    ASSERT_GE(short_of_y, 0.99 * kShadowEpsilon * dist - 4.0 * ulp) << i;  // never on or past the light
  }
}

// The GPU's edge functions (kahan_diff_of_products; the host build computes the
// same thing with std::fma) against the exact a * b - c * d: two float products
// are exact in double and their difference is rounded once there, so its sign is
// exact. Near-cancelling inputs, where the plain float expression loses most of
// its digits, are the ones that matter for rays grazing an edge or leaving a
// surface.
TEST(Geometry, KahanDiffOfProductsHasTheExactSignAndTwoUlps) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<float> mag(-30.f, 30.f);
  std::uniform_int_distribution<int> nudge(-8, 8);
  int naive_far = 0;
  for (int i = 0; i < 200000; ++i) {
    const float a = std::ldexp(mag(rng), nudge(rng)), b = std::ldexp(mag(rng), nudge(rng));
    // c * d within a few units in the last place of a * b (or exactly it).
    float c = a, d = b;
    for (int k = nudge(rng); k != 0; k += k > 0 ? -1 : 1) c = k > 0 ? next_float_up(c) : next_float_down(c);
    for (int k = nudge(rng); k != 0; k += k > 0 ? -1 : 1) d = k > 0 ? next_float_up(d) : next_float_down(d);
    if (i % 2) std::swap(c, d);
    const double exact = double(a) * double(b) - double(c) * double(d);
    const float got = kahan_diff_of_products(a, b, c, d);
    ASSERT_EQ(got > 0.f, exact > 0.0) << i << ": " << a << " " << b << " " << c << " " << d;
    ASSERT_EQ(got < 0.f, exact < 0.0) << i;
    ASSERT_LE(std::fabs(double(got) - exact), std::ldexp(std::fabs(exact), -23)) << i;
    const float naive = a * b - c * d;
    if (std::fabs(double(naive) - exact) > std::ldexp(std::fabs(exact), -4)) ++naive_far;
  }
  // The inputs do cancel: the plain float expression is off by more than 1/16 in many.
  EXPECT_GT(naive_far, 20000);
}

TEST(Geometry, NextFloatSteps) {
  EXPECT_GT(next_float_up(0.f), 0.f);
  EXPECT_GT(next_float_up(-0.f), 0.f);
  EXPECT_LT(next_float_down(0.f), 0.f);
  EXPECT_EQ(next_float_up(1.f), std::nextafter(1.f, 2.f));
  EXPECT_EQ(next_float_down(1.f), std::nextafter(1.f, 0.f));
  EXPECT_EQ(next_float_up(-1.f), std::nextafter(-1.f, 0.f));
  EXPECT_EQ(next_float_down(-1.f), std::nextafter(-1.f, -2.f));
  EXPECT_EQ(next_float_up(kInf * 10.f), kInf * 10.f);
}

}  // namespace
}  // namespace pn
