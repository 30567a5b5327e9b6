// compare_images (render/compare.h): its two tests, the statistical one and the
// bound on the image means, judged and reported apart; the bound is the
// caller's, whatever the noise.
#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <vector>

#include "render/compare.h"

namespace pn {
namespace {

// n channels of value v (a mean, or a variance of the mean).
std::vector<float> flat(size_t n, float v) { return std::vector<float>(n, v); }

TEST(Compare, TheBoundIsNotWidenedByNoise) {
  // Means 5% apart with a standard error of the difference of 10%: the
  // statistical test cannot tell them apart, the 1% bound can.
  const size_t n = 100;
  const float var = 0.5f * 0.01f * n;  // the variance of the difference of the means: 2 n var / n^2 = 0.1^2
  CompareResult r = compare_images(flat(n, 1.05f), flat(n, var), flat(n, 1.f), flat(n, var));
  EXPECT_NEAR(r.mean_rel_diff, 0.05, 1e-6);
  EXPECT_NEAR(r.mean_rel_se, 0.1, 1e-6);
  EXPECT_NEAR(r.image_z, 0.5, 1e-5);
  EXPECT_TRUE(r.statistical_pass) << r.summary();
  EXPECT_FALSE(r.bound_pass) << r.bound_summary();
  EXPECT_FALSE(r.pass) << r.summary();
  EXPECT_EQ(r.summary().rfind("FAIL: ", 0), 0u) << r.summary();
  EXPECT_EQ(r.statistical_summary().rfind("statistical test: PASS: ", 0), 0u) << r.statistical_summary();
  EXPECT_EQ(r.bound_summary().rfind("bound on the means (--max-rel-diff 1%): FAIL: they differ by 5.000%", 0), 0u)
      << r.bound_summary();

  CompareOptions loose;
  loose.max_mean_rel_diff = 0.06;
  r = compare_images(flat(n, 1.05f), flat(n, var), flat(n, 1.f), flat(n, var), loose);
  EXPECT_TRUE(r.bound_pass && r.statistical_pass && r.pass) << r.summary();
}

TEST(Compare, TheStatisticalTestFailsWhereTheBoundPasses) {
  // Means 0.5% apart, known to 0.01%: z = 50.
  const size_t n = 100;
  const float var = 0.5f * 1e-8f * n;  // 2 n var / n^2 = 0.0001^2
  CompareResult r = compare_images(flat(n, 1.005f), flat(n, var), flat(n, 1.f), flat(n, var));
  EXPECT_TRUE(r.bound_pass) << r.bound_summary();
  EXPECT_FALSE(r.statistical_pass) << r.statistical_summary();
  EXPECT_FALSE(r.pass);
  EXPECT_EQ(r.statistical_summary().rfind("statistical test: FAIL: image means not within 4 standard errors", 0), 0u)
      << r.statistical_summary();
}

TEST(Compare, OutliersAndZeroVarianceMismatchesFailTheStatisticalTestAlone) {
  const size_t n = 1000;
  std::vector<float> a = flat(n, 1.f), b = flat(n, 1.f), v = flat(n, 1e-4f);
  a[0] = 1.1f;  // z = 0.1 / sqrt(2e-4) = 7: one outlier in 1000 channels, 0.1%: within the 0.2% allowed
  CompareResult r = compare_images(a, v, b, v);
  EXPECT_EQ(r.outliers, 1u);
  EXPECT_TRUE(r.statistical_pass) << r.summary();
  a[1] = a[2] = 1.1f;  // 3 outliers: 0.3%
  r = compare_images(a, v, b, v);
  EXPECT_FALSE(r.statistical_pass) << r.summary();
  EXPECT_TRUE(r.bound_pass) << r.summary();
  // Where both variances are 0, the values must agree.
  std::vector<float> c = flat(n, 1.f), zero = flat(n, 0.f);
  c[5] = 1.01f;
  r = compare_images(c, zero, flat(n, 1.f), zero);
  EXPECT_EQ(r.zero_var_mismatches, 1u);
  EXPECT_FALSE(r.statistical_pass);
  EXPECT_TRUE(r.bound_pass);
}

// A pixel's channels are one sample's values: where they move together (a white light on grey) the image mean's
// standard error is sqrt(3) times what independent channels would give, and the image z must not be that much too
// large. Simulated: pairs of images whose pixels are averages of 16 samples, grey (R = G = B) or with independent
// channels; the image z over 4,000 pairs has variance near 1 for grey, at most 1 for independent channels.
TEST(Compare, ImageZKnowsAPixelsChannelsMoveTogether) {
  std::mt19937 g(17);
  std::normal_distribution<double> u(0.0, 1.0);
  const int pixels = 64, samples = 16, trials = 4000;
  for (bool grey : {true, false}) {
    double sum_z2 = 0;
    for (int t = 0; t < trials; ++t) {
      std::vector<float> img[2], var[2];
      for (int k = 0; k < 2; ++k) {
        img[k].resize(3 * pixels);
        var[k].resize(3 * pixels);
        for (int p = 0; p < pixels; ++p) {
          double s[3] = {0, 0, 0}, s2[3] = {0, 0, 0};
          for (int i = 0; i < samples; ++i) {
            const double x = u(g);
            for (int c = 0; c < 3; ++c) {
              const double v = 1.0 + (grey ? x : u(g));
              s[c] += v;
              s2[c] += v * v;
            }
          }
          for (int c = 0; c < 3; ++c) {
            const double m = s[c] / samples;
            img[k][3 * p + c] = float(m);
            var[k][3 * p + c] = float((s2[c] / samples - m * m) * samples / (samples - 1) / samples);
          }
        }
      }
      const CompareResult r = compare_images(img[0], var[0], img[1], var[1]);
      sum_z2 += r.image_z * r.image_z;
    }
    const double var_z = sum_z2 / trials;
    if (grey) {
      EXPECT_GT(var_z, 0.85) << "grey";
      EXPECT_LT(var_z, 1.15) << "grey";
    } else {
      EXPECT_LT(var_z, 1.15) << "independent channels";
    }
  }
}

TEST(Compare, TheSameImagePassesBoth) {
  const std::vector<float> m = {0.1f, 0.2f, 0.3f, 0.f}, v = {1e-4f, 2e-4f, 0.f, 0.f};
  CompareOptions exact;
  exact.max_mean_rel_diff = 1e-9;
  CompareResult r = compare_images(m, v, m, v, exact);
  EXPECT_TRUE(r.statistical_pass && r.bound_pass && r.pass) << r.summary();
  EXPECT_EQ(r.mean_rel_diff, 0.0);
}

}  // namespace
}  // namespace pn
