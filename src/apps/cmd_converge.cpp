// `penumbra converge`: one convergence experiment (the thesis's chapter 4): the
// options of apps/converge.h, whose run_converge() does the work (and also
// serves the Python module's penumbra.converge()). scripts/study.py drives it
// over scenes and sweeps and draws the report.
#include <cstdio>
#include <filesystem>
#include <memory>
#include <string>

#include "apps/commands.h"
#include "apps/environment.h"
#include "apps/exit_status.h"
#include "apps/options.h"
#include "apps/progress.h"
#include "io/output.h"
#include "apps/converge.h"

namespace pn {

Command add_converge_command(CLI::App& app) {
  auto a = std::make_shared<ConvergeOptions>();
  auto* sub = app.add_subcommand(
      "converge",
      "Convergence experiment: ground truth, error against spp and time for each strategy, fits and time-to-quality "
      "(scripts/study.py runs the whole study and draws the report)");
  sub->add_option("scene", a->scene, "Built-in scene name or scene file")->required();
  sub->add_option("--out", a->out, "Output folder (default: converge-<scene>)");
  sub->add_option("--strategies", a->strategies, "Strategies to compare")
      ->delimiter(',')
      ->capture_default_str()
      ->check(strategy_names_check());
  sub->add_option("--mis", a->mis,
                  "MIS modes, each with every strategy that samples lights (" + mis_names() +
                      "); a technique is named 'area' (MIS none) or 'area+power'")
      ->delimiter(',')
      ->capture_default_str()
      ->check(mis_names_check());
  sub->add_option("--max-spp", a->max_spp, "Largest spp (renders at 1, 2, 4, ... up to it)")
      ->capture_default_str()
      ->check(CLI::Range(1, 1 << 24));
  sub->add_option("--seeds", a->seeds, "Independent renders per point")
      ->capture_default_str()
      ->check(CLI::Range(1, 10000));
  sub->add_option("--reference-spp", a->reference_spp, "Samples per pixel of the ground truth")
      ->capture_default_str()
      ->check(CLI::Range(1, 1 << 24));
  sub->add_option("--reference-chunk", a->reference_chunk,
                  "Samples per pixel of each chunk of the ground truth: chunks are rendered from zero and added in "
                  "order (scripts/study.py --executor ray renders them as tasks and merges them to the same bits)")
      ->capture_default_str()
      ->check(CLI::Range(1, 1 << 24));
  sub->add_option("--reference-strategy", a->reference_strategy, "Strategy of the ground truth")
      ->capture_default_str()
      ->check(strategy_names_check());
  sub->add_option("--reference-mis", a->reference_mis, "MIS mode of the ground truth")
      ->capture_default_str()
      ->check(mis_names_check());
  sub->add_option("--reference-selection", a->reference_selection,
                  "Light selection of the ground truth: uniform, power or bvh (the runs select by the scene's)")
      ->capture_default_str()
      ->check(light_selection_names_check(false));
  sub->add_option("--cache", a->cache, "Folder for cached ground truths (default: $XDG_CACHE_HOME/penumbra or ~/.cache/penumbra)");
  add_size_options(sub, &a->width, &a->height, "the scene's");
  sub->add_option("--threshold", a->threshold, "RMSE for time-to-quality")
      ->capture_default_str()
      ->check(finite_number())
      ->check(CLI::PositiveNumber);
  sub->add_option("--crop-spp", a->crop_spp, "spp of the visual-comparison crops")
      ->capture_default_str()
      ->check(CLI::Range(1, 1 << 24));
  sub->add_option("--frame-spp", a->frame_spp,
                  "Also measure sample N alone after N - 1 of the same render (a real-time frame with N - 1 frames "
                  "of history: restir's temporal reuse), from one more render a seed; 0: off")
      ->capture_default_str()
      ->check(CLI::Range(0, 1 << 24));
  sub->add_option("--crop", a->crop, "Crop rectangle x,y,w,h (default: around the light)")->delimiter(',')->expected(4);
  sub->add_option("--fit-min-spp", a->fit_min_spp, "Smallest spp used in the log-log fits")
      ->capture_default_str()
      ->check(CLI::Range(1, 1 << 24));
  add_backend_options(sub, &a->backend, &a->backend_options, /*gpus=*/true);
  sub->add_flag("--yes", a->yes, "Run even when the estimated time on the CPU is more than an hour");
  sub->add_flag("--estimate-only", a->estimate_only,
                "Measure and print the estimated run time (JSON on stdout), render nothing else, write nothing");
  add_set_option(sub, &a->sets);
  return {sub, [a]() {
    ConvergeOptions o = *a;
    if (o.out.empty()) o.out = "converge-" + std::filesystem::path(o.scene).stem().string();
    if (o.cache.empty()) o.cache = cache_dir_from_environment();
    o.bars = stderr_progress_bars();
    ConvergeResult r;
    try {
      r = run_converge(o);
    } catch (const ConvergeOptionError& e) {  // options that do not go together: the command line is wrong
      std::fprintf(stderr, "penumbra: error: %s\n", e.what());
      return int(kExitUsage);
    }
    if (o.estimate_only) {
      std::printf("%s\n", r.summary.dump().c_str());
      return int(kExitOk);
    }
    std::fprintf(stderr, "wrote %s/summary.json and measurements.csv (%s)\n", o.out.c_str(),
                 format_duration(r.summary["seconds"].get<double>()).c_str());
    const uint64_t nonfinite = r.summary.value("nonfinite_samples", uint64_t(0));
    if (nonfinite > 0) {
      std::fprintf(stderr,
                   "warning: %s: %llu samples were NaN or infinite and left out (counted as black) over all renders; "
                   "the outputs were written (exit status %d)\n",
                   o.scene.c_str(), (unsigned long long)nonfinite, int(kExitNonFinite));
      return int(kExitNonFinite);
    }
    return int(kExitOk);
  }};
}

}  // namespace pn
