#include "render/compare.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <stdexcept>

namespace pn {

CompareResult compare_images(const std::vector<float>& a, const std::vector<float>& va,
                             const std::vector<float>& b, const std::vector<float>& vb,
                             const CompareOptions& o) {
  if (a.size() != b.size() || a.size() != va.size() || b.size() != vb.size() || a.empty())
    throw std::runtime_error("compare: images differ in size");
  CompareResult r;
  double sa = 0, sb = 0, sva = 0, svb = 0, z2 = 0;
  size_t with_var = 0;
  for (size_t i = 0; i < a.size(); ++i) {
    sa += a[i];
    sb += b[i];
    sva += va[i];
    svb += vb[i];
    double v = double(va[i]) + vb[i];
    double d = double(a[i]) - b[i];
    if (v > 0) {
      double z = d / std::sqrt(v);
      z2 += z * z;
      ++with_var;
      r.max_abs_z = std::max(r.max_abs_z, std::fabs(z));
      if (std::fabs(z) > o.outlier_z) ++r.outliers;
    } else if (std::fabs(d) > o.exact_rel_tol * std::max(std::fabs(double(a[i])), std::fabs(double(b[i])))) {
      ++r.zero_var_mismatches;
    }
  }
  double n = double(a.size());
  r.channels = a.size();
  r.mean_a = sa / n;
  r.mean_b = sb / n;
  r.mean_rel_diff = r.mean_b != 0 ? std::fabs(r.mean_a - r.mean_b) / std::fabs(r.mean_b) : std::fabs(r.mean_a);
  // The image means' variance. A pixel's R, G and B are one sample's three values, correlated (a white light
  // on grey moves them together), and the film keeps no covariance: bounded by full correlation, the variance of
  // a pixel's channel sum is (sd_r + sd_g + sd_b)^2, up to 3x the sum of the channels' variances that assuming
  // independence gives (which made glossy's image z up to sqrt(3) too large). RGB images (size a multiple of 3).
  double var_means = (sva + svb) / (n * n);
  if (a.size() % 3 == 0) {
    double bound = 0;
    for (size_t i = 0; i < a.size(); i += 3) {
      double sd_a = 0, sd_b = 0;
      for (size_t c = i; c < i + 3; ++c) {
        sd_a += std::sqrt(std::max(0.f, va[c]));
        sd_b += std::sqrt(std::max(0.f, vb[c]));
      }
      bound += sd_a * sd_a + sd_b * sd_b;
    }
    var_means = bound / (n * n);
  }
  r.image_z = var_means > 0 ? (r.mean_a - r.mean_b) / std::sqrt(var_means) : 0.0;
  r.mean_z2 = with_var ? z2 / double(with_var) : 0.0;
  r.mean_rel_se = r.mean_b != 0 ? std::sqrt(var_means) / std::fabs(r.mean_b) : 0.0;
  // Two tests, judged and reported apart: a bound the noise widened would let a
  // user's --max-rel-diff pass images that differ by more than it says.
  r.options = o;
  r.statistical_pass = std::fabs(r.image_z) < o.max_image_z &&
                       double(r.outliers) <= o.max_outlier_fraction * double(r.channels) && r.zero_var_mismatches == 0;
  r.bound_pass = r.mean_rel_diff <= o.max_mean_rel_diff;
  r.pass = r.statistical_pass && r.bound_pass;
  return r;
}

std::string CompareResult::summary() const {
  char buf[400];
  std::snprintf(buf, sizeof buf,
                "%s: means %.6g vs %.6g (rel. diff %.3f%%), image z %.2f, mean z^2 %.3f, max |z| %.2f, "
                "%zu/%zu channels beyond 5 sigma, %zu zero-variance mismatches",
                pass ? "PASS" : "FAIL", mean_a, mean_b, 100 * mean_rel_diff, image_z, mean_z2, max_abs_z, outliers,
                channels, zero_var_mismatches);
  return buf;
}

std::string CompareResult::statistical_summary() const {
  char buf[400];
  std::snprintf(buf, sizeof buf,
                "statistical test: %s: image means %s %g standard errors (z %.2f), %zu/%zu channels beyond "
                "%g sigma (at most %g%%), %zu zero-variance mismatches",
                statistical_pass ? "PASS" : "FAIL", std::fabs(image_z) < options.max_image_z ? "within" : "not within",
                options.max_image_z, image_z, outliers, channels, options.outlier_z,
                100 * options.max_outlier_fraction, zero_var_mismatches);
  return buf;
}

std::string CompareResult::bound_summary() const {
  char buf[400];
  std::snprintf(buf, sizeof buf,
                "bound on the means (--max-rel-diff %g%%): %s: they differ by %.3f%%%s (standard error of the "
                "difference: %.3f%%)",
                100 * options.max_mean_rel_diff, bound_pass ? "PASS" : "FAIL", 100 * mean_rel_diff,
                bound_pass ? "" : ", more than that", 100 * mean_rel_se);
  return buf;
}

}  // namespace pn
