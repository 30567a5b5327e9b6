// `penumbra converge`: one convergence experiment (the thesis's chapter 4): the
// options of render/converge.h, whose run_converge() does the work (and also
// serves the Python module's penumbra.converge()). scripts/study.py drives it
// over scenes and sweeps and draws the report.
#include <cstdio>
#include <filesystem>
#include <memory>
#include <string>

#include "apps/commands.h"
#include "apps/options.h"
#include "apps/progress.h"
#include "render/converge.h"

namespace pn {

Command add_converge_command(CLI::App& app) {
  auto a = std::make_shared<ConvergeOptions>();
  auto* sub = app.add_subcommand(
      "converge",
      "Convergence experiment: ground truth, error against spp and time for each strategy, fits and time-to-quality "
      "(scripts/study.py runs the whole study and draws the report)");
  sub->add_option("scene", a->scene, "Built-in scene name or scene file")->required();
  sub->add_option("--out", a->out, "Output folder (default: converge-<scene>)");
  sub->add_option("--strategies", a->strategies, "Strategies to compare")->delimiter(',')->capture_default_str();
  sub->add_option("--mis", a->mis,
                  "MIS modes, each with every strategy that samples lights (" + mis_names() +
                      "); a technique is named 'area' (MIS none) or 'area+power'")
      ->delimiter(',')
      ->capture_default_str();
  sub->add_option("--max-spp", a->max_spp, "Largest spp (renders at 1, 2, 4, ... up to it)")->capture_default_str();
  sub->add_option("--seeds", a->seeds, "Independent renders per point")->capture_default_str();
  sub->add_option("--reference-spp", a->reference_spp, "Samples per pixel of the ground truth")->capture_default_str();
  sub->add_option("--reference-chunk", a->reference_chunk,
                  "Samples per pixel of each chunk of the ground truth: chunks are rendered from zero and added in "
                  "order (scripts/study.py --executor ray renders them as tasks and merges them to the same bits)")
      ->capture_default_str();
  sub->add_option("--reference-strategy", a->reference_strategy, "Strategy of the ground truth")->capture_default_str();
  sub->add_option("--reference-mis", a->reference_mis, "MIS mode of the ground truth")->capture_default_str();
  sub->add_option("--cache", a->cache, "Folder for cached ground truths (default: $XDG_CACHE_HOME/penumbra or ~/.cache/penumbra)");
  sub->add_option("--width", a->width, "Image width (default: the scene's)");
  sub->add_option("--height", a->height, "Image height (default: the scene's)");
  sub->add_option("--threshold", a->threshold, "RMSE for time-to-quality")->capture_default_str();
  sub->add_option("--crop-spp", a->crop_spp, "spp of the visual-comparison crops")->capture_default_str();
  sub->add_option("--crop", a->crop, "Crop rectangle x,y,w,h (default: around the light)")->delimiter(',')->expected(4);
  sub->add_option("--fit-min-spp", a->fit_min_spp, "Smallest spp used in the log-log fits")->capture_default_str();
  sub->add_option("--backend", a->backend, "cpu, optix or auto")->capture_default_str()->check(CLI::IsMember({"cpu", "optix", "auto"}));
  add_gpus_option(sub, &a->gpus);
  sub->add_option("--threads", a->threads, "CPU threads (default: all)");
  sub->add_option("--set", a->sets, "Override a scene value (repeatable), e.g. --set light.radius=0.05")->allow_extra_args(false);
  return {sub, [a]() {
    ConvergeOptions o = *a;
    if (o.out.empty()) o.out = "converge-" + std::filesystem::path(o.scene).stem().string();
    ConvergeResult r = run_converge(o);
    std::fprintf(stderr, "wrote %s/summary.json and measurements.csv (%s)\n", o.out.c_str(),
                 format_duration(r.summary["seconds"].get<double>()).c_str());
    return 0;
  }};
}

}  // namespace pn
