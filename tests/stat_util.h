// Statistical helpers for the tests: chi-square goodness of fit of a sampler
// against its own pdf (after Mitsuba 3's chi2.py), numerical integration of
// pdfs over the sphere, and mean/standard-error accumulation.
#pragma once

#include <cmath>
#include <functional>
#include <string>
#include <vector>

#include "core/rng.h"
#include "core/vec.h"

namespace pn::test {

// Regularised upper incomplete gamma Q(a, x) (series for x < a + 1, Lentz's
// continued fraction otherwise).
inline double gamma_q(double a, double x) {
  if (x <= 0) return 1.0;
  double gln = std::lgamma(a);
  if (x < a + 1) {
    double ap = a, sum = 1.0 / a, del = sum;
    for (int n = 0; n < 10000; ++n) {
      ap += 1;
      del *= x / ap;
      sum += del;
      if (std::fabs(del) < std::fabs(sum) * 1e-15) break;
    }
    return 1.0 - sum * std::exp(-x + a * std::log(x) - gln);
  }
  double b = x + 1 - a, c = 1e300, d = 1 / b, h = d;
  for (int i = 1; i < 10000; ++i) {
    double an = -i * (i - a);
    b += 2;
    d = an * d + b;
    if (std::fabs(d) < 1e-300) d = 1e-300;
    c = b + an / c;
    if (std::fabs(c) < 1e-300) c = 1e-300;
    d = 1 / d;
    double del = d * c;
    h *= del;
    if (std::fabs(del - 1) < 1e-15) break;
  }
  return std::exp(-x + a * std::log(x) - gln) * h;
}

struct Chi2Result {
  double statistic = 0, p_value = 0;
  int dof = 0;
  std::string message;
};

// Pearson's chi-square test. Bins with small expected counts are pooled (in
// order of increasing expectation) until every pooled bin expects >= min_expected.
// A bin with observations but (numerically) zero expectation fails outright.
inline Chi2Result chi2_test(const std::vector<double>& observed, const std::vector<double>& expected,
                            double min_expected = 5.0) {
  Chi2Result r;
  std::vector<size_t> order(observed.size());
  for (size_t i = 0; i < order.size(); ++i) order[i] = i;
  std::sort(order.begin(), order.end(), [&](size_t a, size_t b) { return expected[a] < expected[b]; });
  double pool_o = 0, pool_e = 0;
  int bins = 0;
  for (size_t k = 0; k < order.size(); ++k) {
    size_t i = order[k];
    if (expected[i] < 1e-9 * (observed.size()) && observed[i] > 0) {
      r.message = "bin " + std::to_string(i) + " has " + std::to_string(observed[i]) + " samples but zero expectation";
      r.p_value = 0;
      return r;
    }
    if (expected[i] < min_expected) {
      pool_o += observed[i];
      pool_e += expected[i];
      if (pool_e >= min_expected) {
        r.statistic += (pool_o - pool_e) * (pool_o - pool_e) / pool_e;
        ++bins;
        pool_o = pool_e = 0;
      }
      continue;
    }
    r.statistic += (observed[i] - expected[i]) * (observed[i] - expected[i]) / expected[i];
    ++bins;
  }
  if (pool_e > 0) {
    r.statistic += (pool_o - pool_e) * (pool_o - pool_e) / pool_e;
    ++bins;
  }
  r.dof = bins - 1;
  r.p_value = r.dof > 0 ? gamma_q(0.5 * r.dof, 0.5 * r.statistic) : 1.0;
  r.message = "chi2 = " + std::to_string(r.statistic) + ", dof = " + std::to_string(r.dof) +
              ", p = " + std::to_string(r.p_value);
  return r;
}

// A grid over directions around `axis`: z = cos(angle to axis) in [z_min, 1]
// and azimuth phi in [0, 2 pi). dw = dz dphi, so bins are equal-area in z.
struct DirectionGrid {
  Frame frame;
  double z_min;
  int nz, nphi;

  DirectionGrid(Vec3 axis, double z_min_, int nz_, int nphi_)
      : frame(Frame::from_z(normalize(axis))), z_min(z_min_), nz(nz_), nphi(nphi_) {}
  int bins() const { return nz * nphi + 1; }  // the last bin: outside the grid
  int bin(Vec3 w) const {
    Vec3 l = frame.to_local(w);
    double z = std::max(-1.0, std::min(1.0, double(l.z)));
    // Directions on the grid's rim within float rounding count as inside.
    if (z < z_min - 2e-6) return nz * nphi;
    int iz = std::max(0, std::min(nz - 1, int((z - z_min) / (1.0 - z_min) * nz)));
    double phi = std::atan2(double(l.y), double(l.x));
    if (phi < 0) phi += 2 * M_PI;
    int ip = std::min(nphi - 1, int(phi / (2 * M_PI) * nphi));
    return iz * nphi + ip;
  }
  // Integral of pdf(w) over every grid bin; the last (outside) bin gets 0.
  // Midpoint rule on res x res sub-cells, in t = sqrt(z - z_min) rather than z:
  // pdfs of area sampling grow like 1/sqrt(z - z_min) towards a sphere's
  // silhouette, and in t that singularity becomes smooth.
  std::vector<double> integrate(const std::function<double(Vec3)>& pdf, int res = 12) const {
    std::vector<double> out(bins(), 0.0);
    double dz = (1.0 - z_min) / nz, dp = 2 * M_PI / nphi;
    for (int iz = 0; iz < nz; ++iz) {
      double t0 = std::sqrt(dz * iz), t1 = std::sqrt(dz * (iz + 1)), dt = (t1 - t0) / res;
      for (int ip = 0; ip < nphi; ++ip) {
        double acc = 0;
        for (int a = 0; a < res; ++a)
          for (int b = 0; b < res; ++b) {
            double t = t0 + dt * (a + 0.5);
            double z = z_min + t * t;
            double phi = dp * (ip + (b + 0.5) / res);
            double s = std::sqrt(std::max(0.0, 1 - z * z));
            Vec3 w = frame.to_world(Vec3(float(s * std::cos(phi)), float(s * std::sin(phi)), float(z)));
            acc += pdf(normalize(w)) * 2 * t;  // dz = 2 t dt
          }
        out[iz * nphi + ip] = acc * dt * dp / res;
      }
    }
    return out;
  }
};

// Chi-square of n sampled directions against a solid-angle pdf over a
// DirectionGrid; sample() returns false for "no sample" (the last bin, whose
// expectation is 1 - the pdf's mass on the grid). A bin that a discontinuity
// (a horizon, a cone's rim) cuts to a sliver between the integration points can
// come out empty although samples land in it: then the grid is integrated again,
// finer.
inline Chi2Result chi2_directions(const DirectionGrid& grid, const std::function<bool(Vec2, Vec3*)>& sample,
                                  const std::function<double(Vec3)>& pdf, int n, uint32_t seed, int res = 12) {
  auto expected_counts = [&](int r) {
    std::vector<double> e = grid.integrate(pdf, r);
    double inside = 0;
    for (int i = 0; i + 1 < grid.bins(); ++i) inside += e[i];
    e.back() = std::max(0.0, 1.0 - inside);
    for (double& x : e) x *= n;
    return e;
  };
  std::vector<double> expected = expected_counts(res), observed(grid.bins(), 0.0);
  Rng rng(0, 0, seed);
  for (int i = 0; i < n; ++i) {
    Vec3 w;
    observed[sample(rng.uniform2(), &w) ? grid.bin(w) : grid.bins() - 1] += 1;
  }
  bool sliver = false;
  for (int i = 0; i + 1 < grid.bins(); ++i) sliver = sliver || (observed[i] > 0 && expected[i] < 0.5);
  if (sliver) expected = expected_counts(8 * res);
  return chi2_test(observed, expected);
}

// Running mean and standard error of i.i.d. samples.
struct MeanEstimator {
  double sum = 0, sum_sq = 0;
  long n = 0;
  void add(double x) {
    sum += x;
    sum_sq += x * x;
    ++n;
  }
  double mean() const { return sum / n; }
  double std_error() const {
    double m = mean();
    return std::sqrt(std::max(0.0, (sum_sq / n - m * m) / (n - 1)));
  }
};

}  // namespace pn::test
