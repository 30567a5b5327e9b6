// `penumbra compare`: are two renders statistically the same image?
#include <cstdio>
#include <memory>
#include <string>

#include "apps/commands.h"
#include "apps/exit_status.h"
#include "io/image.h"
#include "render/compare.h"

namespace pn {

Command add_compare_command(CLI::App& app) {
  struct Args {
    std::string a, a_var, b, b_var;
    CompareOptions opt;
  };
  auto x = std::make_shared<Args>();
  auto* sub = app.add_subcommand(
      "compare",
      "Test two renders for equality, each given as mean and variance EXRs (render -o A.exr --variance A_var.exr). "
      "Two tests, each with its own PASS/FAIL line: the statistical test (per-pixel z = (a - b) / sqrt(var_a + "
      "var_b): the image means within 4 standard errors, at most --max-outliers of the channels beyond 5 sigma, "
      "pixels without variance equal) and the bound on the image means (their relative difference at most "
      "--max-rel-diff, whatever their noise: where the difference's standard error, printed, is above a quarter of "
      "the bound, equal images can fail it; a larger bound leaves the verdict to the statistical test). Exit "
      "status 0 when both pass, 3 when either fails.");
  sub->add_option("a", x->a, "First image (EXR)")->required()->check(CLI::ExistingFile);
  sub->add_option("a_var", x->a_var, "Its per-pixel variance of the mean (EXR)")->required()->check(CLI::ExistingFile);
  sub->add_option("b", x->b, "Second image (EXR)")->required()->check(CLI::ExistingFile);
  sub->add_option("b_var", x->b_var, "Its variance (EXR)")->required()->check(CLI::ExistingFile);
  sub->add_option("--max-rel-diff", x->opt.max_mean_rel_diff,
                  "The bound: the image means' relative difference |mean_a - mean_b| / |mean_b| must be at most this "
                  "(0: equal means; 1: the statistical test alone decides, for images whose means are known to "
                  "better than 25%)")
      ->capture_default_str()
      ->check(finite_number())
      ->check(CLI::NonNegativeNumber);
  sub->add_option("--max-outliers", x->opt.max_outlier_fraction, "Largest accepted fraction of channels beyond 5 sigma")
      ->capture_default_str()
      ->check(finite_number())
      ->check(CLI::Range(0.0, 1.0));
  return {sub, [x]() {
            int w[4], h[4];
            auto a = read_exr(x->a, &w[0], &h[0]);
            auto va = read_exr(x->a_var, &w[1], &h[1]);
            auto b = read_exr(x->b, &w[2], &h[2]);
            auto vb = read_exr(x->b_var, &w[3], &h[3]);
            for (int i = 1; i < 4; ++i)
              if (w[i] != w[0] || h[i] != h[0])
                throw std::runtime_error("compare: the four images must have the same size (" + x->a + " is " +
                                         std::to_string(w[0]) + "x" + std::to_string(h[0]) + ")");
            CompareResult r = compare_images(a, va, b, vb, x->opt);
            std::printf("%s vs %s: %s\n  %s\n  %s\n", x->a.c_str(), x->b.c_str(), r.summary().c_str(),
                        r.statistical_summary().c_str(), r.bound_summary().c_str());
            return r.pass ? kExitOk : kExitDiffer;
          }};
}

}  // namespace pn
