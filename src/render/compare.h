// Statistical comparison of two renders of the same scene, each given as the
// per-pixel mean and the per-pixel variance of that mean (Film::mean() and
// Film::variance_of_mean()). Two unbiased renderers of the same image differ
// per pixel by z = (a - b) / sqrt(var_a + var_b) ~ N(0, 1) (Mitsuba 3's
// per-pixel Z-test), and their image means by a relative amount that shrinks
// as 1/sqrt(spp).
//
// Two verdicts, each reported on its own, and the images agree when both pass:
// - the statistical test: the image means within max_image_z standard errors of
//   their difference, few per-pixel outliers, no mismatch where the variance is 0;
// - the bound: the image means' relative difference at most max_mean_rel_diff, the
//   caller's own, never widened: a guard against a bias that variance estimates
//   miss (heavy tails). Where the standard error of the difference is above a
//   quarter of the bound, it is tighter than the noise allows and can fail equal
//   images; a caller that wants the statistical test alone passes a large bound.
#pragma once

#include <string>
#include <vector>

namespace pn {

struct CompareOptions {
  double max_mean_rel_diff = 0.01;  // the bound: |mean_a - mean_b| / |mean_b| at most this (0: equal means)
  double max_image_z = 4.0;         // the statistical test: |z| of the difference of the image means below this
  double outlier_z = 5.0;           // a pixel channel with |z| above this is an outlier
  double max_outlier_fraction = 0.002;
  // Pixel channels whose combined variance is zero must agree to this relative
  // tolerance (e.g. pixels that see only black or only a light).
  double exact_rel_tol = 1e-4;
};

struct CompareResult {
  double mean_a = 0, mean_b = 0;
  double mean_rel_diff = 0;   // |mean_a - mean_b| / mean_b
  double mean_rel_se = 0;     // the standard error of mean_a - mean_b, relative to |mean_b|
  double image_z = 0;         // (mean_a - mean_b) / sqrt(var(mean_a) + var(mean_b))
  double mean_z2 = 0;         // average z^2 over channels with variance (about 1 if equal)
  double max_abs_z = 0;
  size_t outliers = 0, channels = 0, zero_var_mismatches = 0;
  bool statistical_pass = false;  // |image_z| < max_image_z, outliers at most max_outlier_fraction, no mismatch
  bool bound_pass = false;        // mean_rel_diff <= max_mean_rel_diff
  bool pass = false;              // both
  CompareOptions options;         // what it was judged by
  std::string summary() const;              // one line: the verdict (both) and the numbers
  std::string statistical_summary() const;  // one line: "statistical test: PASS: ..."
  std::string bound_summary() const;        // one line: "bound on the means (--max-rel-diff ...): PASS: ..."
};

CompareResult compare_images(const std::vector<float>& mean_a, const std::vector<float>& var_a,
                             const std::vector<float>& mean_b, const std::vector<float>& var_b,
                             const CompareOptions& options = CompareOptions());

}  // namespace pn
