// One convergence experiment (the thesis's chapter 4), shared by `penumbra
// converge` and the Python module's penumbra.converge().
//
// For one scene: a ground-truth image (cached on disk under a key derived from
// the scene and settings), then renders at 1, 2, 4, ... spp for each technique
// (strategy x MIS mode) with several independent seeds, each timed; errors against the ground truth
// (metrics.h), log-log fits of error against spp, efficiency and the time each
// strategy needs to reach an error threshold; crops for the visual comparison.
#pragma once

#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "render/backend.h"

namespace pn {

struct ConvergeOptions {
  std::string scene;              // built-in scene name or scene file
  std::vector<std::string> sets;  // "key=value" scene overrides
  std::string out;                // folder for measurements.csv, summary.json, crops, images; "" = none
  std::string cache;              // ground-truth cache folder; "" = default_cache_dir()
  std::string backend = "auto";
  std::string reference_strategy = "solid-angle", reference_mis = "power";
  std::vector<std::string> strategies = {"area", "solid-angle"};
  // MIS modes, each with every strategy that samples lights: the techniques
  // compared, named "area" (MIS none) or "area+power" (render/technique.h).
  std::vector<std::string> mis = {"none"};
  int width = 0, height = 0;  // 0: the scene's
  int max_spp = 1024, seeds = 4, reference_spp = 65536, crop_spp = 32, fit_min_spp = 4;
  int threads = 0;
  double threshold = 0.05;
  std::vector<int> crop;  // x, y, w, h; empty: around the light
  bool verbose = true;    // notes and progress bars on stderr
  bool yes = false;            // run even when the estimate on the CPU exceeds kConvergeConfirmSeconds
  bool estimate_only = false;  // measure and return the estimate (summary: estimated_seconds, ...), run nothing
  // Called during every render (see Backend::render); may throw to stop the
  // experiment (the Python module's Ctrl-C).
  ProgressFn progress;
};

// One render of the experiment: a row of measurements.csv.
struct ConvergeMeasurement {
  std::string strategy;  // the technique's name: "area", "area+power"
  int spp = 0, seed = 0;
  double time_ms = 0, rmse = 0, rmse_nolight = 0, relmse = 0, relmse_nolight = 0;
};

// Past this estimated time on the CPU, run_converge() asks for `yes`.
constexpr double kConvergeConfirmSeconds = 3600;

struct ConvergeResult {
  std::vector<ConvergeMeasurement> measurements;
  nlohmann::json summary;  // what summary.json holds: settings, reference, per-strategy points and fits
};

// Runs the experiment; with a non-empty `out`, also writes its files there.
// Throws SceneError for a bad scene, std::invalid_argument for bad options and
// std::runtime_error when a backend fails.
ConvergeResult run_converge(const ConvergeOptions& options);

// The header of measurements.csv and one of its rows.
std::string converge_csv_header();
std::string converge_csv_row(const std::string& scene, const ConvergeMeasurement& m);

// $XDG_CACHE_HOME/penumbra, else ~/.cache/penumbra.
std::string default_cache_dir();

}  // namespace pn
