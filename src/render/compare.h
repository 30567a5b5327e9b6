// Statistical comparison of two renders of the same scene, each given as the
// per-pixel mean and the per-pixel variance of that mean (Film::mean() and
// Film::variance_of_mean()). Two unbiased renderers of the same image differ
// per pixel by z = (a - b) / sqrt(var_a + var_b) ~ N(0, 1) (Mitsuba 3's
// per-pixel Z-test), and their image means by a relative amount that shrinks
// as 1/sqrt(spp).
#pragma once

#include <string>
#include <vector>

namespace pn {

struct CompareOptions {
  double max_mean_rel_diff = 0.01;  // |sum a - sum b| / sum b (or max_image_z standard errors of it, if larger)
  double max_image_z = 4.0;         // z of the difference of the image means
  double outlier_z = 5.0;           // a pixel channel with |z| above this is an outlier
  double max_outlier_fraction = 0.002;
  // Pixel channels whose combined variance is zero must agree to this relative
  // tolerance (e.g. pixels that see only black or only a light).
  double exact_rel_tol = 1e-4;
};

struct CompareResult {
  double mean_a = 0, mean_b = 0;
  double mean_rel_diff = 0;   // |mean_a - mean_b| / mean_b
  double image_z = 0;         // (mean_a - mean_b) / sqrt(var(mean_a) + var(mean_b))
  double mean_z2 = 0;         // average z^2 over channels with variance (about 1 if equal)
  double max_abs_z = 0;
  size_t outliers = 0, channels = 0, zero_var_mismatches = 0;
  bool pass = false;
  std::string summary() const;  // one line
};

CompareResult compare_images(const std::vector<float>& mean_a, const std::vector<float>& var_a,
                             const std::vector<float>& mean_b, const std::vector<float>& var_b,
                             const CompareOptions& options = CompareOptions());

}  // namespace pn
