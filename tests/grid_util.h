// Chi-square over a parametrised grid of directions, with bin integrals
// computed by adaptive cubature, for densities with narrow peaks (GGX lobes)
// or discontinuities (the horizon) that a fixed midpoint rule gets wrong.
//
// A ParamGrid maps (a, b) in [0, 1]^2 to a unit direction and gives the
// Jacobian |d omega / (da db)|; the inverse map bins samples. Bins are equal
// cells of the (a, b) square; directions outside the domain go to an extra
// last bin whose expectation is 1 minus the grid's integral (so that a sampler
// that puts mass where the pdf says there is none, or the reverse, fails).
#pragma once

#include <algorithm>
#include <cmath>
#include <functional>
#include <vector>

#include "core/rng.h"
#include "core/vec.h"
#include "stat_util.h"

namespace pn::test {

struct ParamGrid {
  int na = 16, nb = 16;
  // (a, b) -> direction; *jac = |d omega / (da db)|.
  std::function<Vec3(double a, double b, double* jac)> to_dir;
  // direction -> (a, b); false when outside the domain.
  std::function<bool(Vec3 w, double* a, double* b)> from_dir;

  int bins() const { return na * nb + 1; }
  int bin(Vec3 w) const {
    double a, b;
    if (!from_dir(w, &a, &b)) return na * nb;
    int ia = std::clamp(int(a * na), 0, na - 1), ib = std::clamp(int(b * nb), 0, nb - 1);
    return ia * nb + ib;
  }
};

// Integral of f(a, b) over [a0, a1] x [b0, b1]: midpoint 2x2 against its four
// quadrants' 2x2, recursing where they disagree.
inline double adaptive_cell(const std::function<double(double, double)>& f, double a0, double a1, double b0,
                            double b1, double coarse, int depth, double tol_abs, double tol_rel,
                            int min_depth = 0) {
  const double am = 0.5 * (a0 + a1), bm = 0.5 * (b0 + b1);
  auto mid2 = [&](double x0, double x1, double y0, double y1) {
    double dx = x1 - x0, dy = y1 - y0, s = 0;
    for (double fx : {0.25, 0.75})
      for (double fy : {0.25, 0.75}) s += f(x0 + fx * dx, y0 + fy * dy);
    return s * 0.25 * dx * dy;
  };
  double q[4] = {mid2(a0, am, b0, bm), mid2(am, a1, b0, bm), mid2(a0, am, bm, b1), mid2(am, a1, bm, b1)};
  double fine = q[0] + q[1] + q[2] + q[3];
  if (depth <= 0 || (min_depth <= 0 && std::fabs(fine - coarse) <= tol_abs + tol_rel * std::fabs(fine)))
    return fine;
  const double ta = 0.5 * tol_abs;  // the error of smooth cells falls 4x per level: this converges
  return adaptive_cell(f, a0, am, b0, bm, q[0], depth - 1, ta, tol_rel, min_depth - 1) +
         adaptive_cell(f, am, a1, b0, bm, q[1], depth - 1, ta, tol_rel, min_depth - 1) +
         adaptive_cell(f, a0, am, bm, b1, q[2], depth - 1, ta, tol_rel, min_depth - 1) +
         adaptive_cell(f, am, a1, bm, b1, q[3], depth - 1, ta, tol_rel, min_depth - 1);
}

// Integral of pdf over bin (ia, ib), adaptively: the bin is split into
// pre x pre cells and those at least min_depth times more (so that a sliver of
// support between the sample points is not missed), then further where the
// estimates disagree by more than tol_abs (in probability) + tol_rel.
inline double integrate_bin(const ParamGrid& g, const std::function<double(Vec3)>& pdf, int ia, int ib, int pre,
                            int depth, double tol_abs, double tol_rel, int min_depth) {
  auto f = [&](double a, double b) {
    double jac = 0;
    Vec3 w = g.to_dir(a, b, &jac);
    if (!(jac > 0)) return 0.0;
    double p = pdf(w);
    return std::isfinite(p) ? p * jac : 0.0;
  };
  const double da = 1.0 / g.na, db = 1.0 / g.nb;
  double acc = 0;
  for (int x = 0; x < pre; ++x)
    for (int y = 0; y < pre; ++y) {
      double a0 = da * (ia + double(x) / pre), a1 = da * (ia + double(x + 1) / pre);
      double b0 = db * (ib + double(y) / pre), b1 = db * (ib + double(y + 1) / pre);
      double c = f(0.5 * (a0 + a1), 0.5 * (b0 + b1)) * (a1 - a0) * (b1 - b0);
      acc += adaptive_cell(f, a0, a1, b0, b1, c, depth, tol_abs / (pre * pre), tol_rel, min_depth);
    }
  return acc;
}

// integrate_bin over every bin of the grid (the last bin, outside: 0).
inline std::vector<double> integrate_grid(const ParamGrid& g, const std::function<double(Vec3)>& pdf,
                                          int pre = 2, int depth = 6, double tol_abs = 1e-7,
                                          double tol_rel = 1e-4, int min_depth = 1) {
  std::vector<double> out(g.bins(), 0.0);
  for (int ia = 0; ia < g.na; ++ia)
    for (int ib = 0; ib < g.nb; ++ib)
      out[ia * g.nb + ib] = integrate_bin(g, pdf, ia, ib, pre, depth, tol_abs, tol_rel, min_depth);
  return out;
}

inline double grid_total(const std::vector<double>& e) {
  double s = 0;
  for (size_t i = 0; i + 1 < e.size(); ++i) s += e[i];
  return s;
}

// Chi-square of n samples (sample returns false: no sample, the outside bin)
// against the pdf's bin integrals. With `pdf`, a sample where the pdf is 0
// fails outright, and a bin whose integral came out (nearly) 0 although it
// got samples where the pdf is positive (a sliver of support thinner than the
// cubature's points, at the edge of a continuous pdf) is integrated again,
// 32 times finer. strict_support = false: a sample where the pdf is 0 only
// counts (a sampler's space mapped to another one through float rounding).
inline Chi2Result chi2_on_grid(const ParamGrid& g, const std::vector<double>& integrals, int n,
                               const std::function<bool(Rng&, Vec3*)>& sample, uint32_t seed,
                               const std::function<double(Vec3)>& pdf = nullptr, bool strict_support = true) {
  std::vector<double> expected = integrals;
  expected.back() = std::max(0.0, 1.0 - grid_total(integrals));
  for (double& e : expected) e *= n;
  std::vector<double> observed(g.bins(), 0.0);
  Rng rng(0, 0, seed);
  for (int i = 0; i < n; ++i) {
    Vec3 w;
    if (sample(rng, &w)) {
      int b = g.bin(w);
      observed[b] += 1;
      if (pdf) {
        double p = pdf(w);
        if (strict_support && !(p > 0)) {
          Chi2Result r;
          r.message = "a sample (" + std::to_string(w.x) + ", " + std::to_string(w.y) + ", " + std::to_string(w.z) +
                      ") where the pdf is " + std::to_string(p);
          return r;
        }
      }
    } else {
      observed.back() += 1;
    }
  }
  if (pdf) {
    double outside_change = 0;
    for (int b = 0; b + 1 < g.bins(); ++b)
      if (observed[b] > 0 && expected[b] < 0.1) {
        double fine = n * integrate_bin(g, pdf, b / g.nb, b % g.nb, 8, 3, 0.0, 0.0, 3);
        outside_change -= fine - expected[b];
        expected[b] = fine;
      }
    expected.back() = std::max(0.0, expected.back() + outside_change);
  }
  return chi2_test(observed, expected);
}

// --- Grids -------------------------------------------------------------------

// The hemisphere around frame.n: a = cos(theta), b = phi / (2 pi); d omega = 2 pi da db.
inline ParamGrid hemisphere_grid(const Frame& frame, int na, int nb) {
  ParamGrid g;
  g.na = na;
  g.nb = nb;
  g.to_dir = [frame](double a, double b, double* jac) {
    double z = a, s = std::sqrt(std::max(0.0, 1 - z * z)), phi = 2 * M_PI * b;
    *jac = 2 * M_PI;
    return frame.to_world(Vec3(float(s * std::cos(phi)), float(s * std::sin(phi)), float(z)));
  };
  g.from_dir = [frame](Vec3 w, double* a, double* b) {
    Vec3 l = frame.to_local(w);
    if (!(l.z > 0.f)) return false;
    *a = std::min(1.0, double(l.z));
    double phi = std::atan2(double(l.y), double(l.x));
    if (phi < 0) phi += 2 * M_PI;
    *b = phi / (2 * M_PI);
    return true;
  };
  return g;
}

// GGX's slope space around frame.n: tan(theta) = alpha * r / (1 - r), a = r,
// b = phi / (2 pi). Uniform cells in (a, b) resolve a lobe of width alpha.
inline ParamGrid slope_grid(const Frame& frame, double alpha, int na, int nb) {
  ParamGrid g;
  g.na = na;
  g.nb = nb;
  g.to_dir = [frame, alpha](double a, double b, double* jac) {
    double s = a / (1 - a), theta = std::atan(alpha * s), phi = 2 * M_PI * b;
    double dtheta = alpha / (1 + alpha * alpha * s * s) / ((1 - a) * (1 - a));
    *jac = std::sin(theta) * dtheta * 2 * M_PI;
    return frame.to_world(Vec3(float(std::sin(theta) * std::cos(phi)), float(std::sin(theta) * std::sin(phi)),
                               float(std::cos(theta))));
  };
  g.from_dir = [frame, alpha](Vec3 w, double* a, double* b) {
    Vec3 l = frame.to_local(w);
    if (!(l.z > 0.f)) return false;
    double st = std::sqrt(double(l.x) * l.x + double(l.y) * l.y);
    double s = std::atan2(st, double(l.z));
    s = std::tan(s) / alpha;
    *a = s / (1 + s);
    double phi = std::atan2(double(l.y), double(l.x));
    if (phi < 0) phi += 2 * M_PI;
    *b = phi / (2 * M_PI);
    return true;
  };
  return g;
}

}  // namespace pn::test
