// One convergence experiment (the thesis's chapter 4), shared by `penumbra
// converge` and the Python module's penumbra.converge().
//
// For one scene: a ground-truth image (cached on disk under a key derived from
// the scene and settings; rendered in chunks of samples whose sums are added in
// chunk order, so that the chunks may also be rendered apart, e.g. as tasks on
// a cluster by scripts/study.py, and merged to the same bits), then renders at 1, 2, 4, ... spp for each technique
// (strategy x MIS mode) with several independent seeds, each timed; errors against the ground truth
// (metrics.h), log-log fits of error against spp, efficiency and the time each
// strategy needs to reach an error threshold; crops for the visual comparison.
#pragma once

#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include <nlohmann/json.hpp>

#include "render/backend.h"
#include "render/progress.h"

namespace pn {

struct ConvergeOptions {
  std::string scene;              // built-in scene name or scene file
  std::vector<std::string> sets;  // "key=value" scene overrides
  std::string out;                // folder for measurements.csv, summary.json, crops, images; "" = none
  // Ground-truth cache folder; the applications fill in default_cache_dir($XDG_CACHE_HOME, $HOME) where not given;
  // "": .penumbra-cache.
  std::string cache;
  std::string backend = "auto";
  std::string reference_strategy = "solid-angle", reference_mis = "power";
  // How the ground truth selects lights: power, or uniform or bvh (restir's frame passes are not offered: a
  // reference is one unbiased estimator rendered long). Every run's error is against the same reference.
  std::string reference_selection = "power";
  std::vector<std::string> strategies = {"area", "solid-angle"};
  // MIS modes, each with every strategy that samples lights: the techniques
  // compared, named "area" (MIS none) or "area+power" (render/technique.h).
  std::vector<std::string> mis = {"none"};
  int width = 0, height = 0;  // 0: the scene's
  int max_spp = 1024, seeds = 4, reference_spp = 65536, crop_spp = 32, fit_min_spp = 4;
  int reference_chunk = 4096;  // samples per pixel of each chunk of the ground truth
  // With N > 0 (one of the spp levels, N >= 2): the error of sample N alone, after N - 1 samples of the same
  // render call (the difference of the N and N - 1 spp renders of each seed, one more render a seed), what a
  // real-time frame shows after N - 1 frames of history (restir's temporal reuse; for independent samples, the
  // error of one sample). summary.json: each technique's "frame".
  int frame_spp = 0;
  // --threads, --gpus (the GPUs that split every render; "all" here), --wavefront, --traversal, --tune.
  BackendOptions backend_options = [] {
    BackendOptions o;
    o.gpus = "all";
    return o;
  }();
  double threshold = 0.05;
  std::vector<int> crop;  // x, y, w, h; empty: around the light
  bool verbose = true;    // notes and progress bars on stderr
  bool yes = false;            // run even when the estimate on the CPU exceeds kConvergeConfirmSeconds
  bool estimate_only = false;  // measure and return the estimate (summary: estimated_seconds, ...), run nothing
  // Called during every render (see Backend::render); may throw to stop the
  // experiment (the Python module's Ctrl-C).
  ProgressFn progress;
  // Shows the ground truth's and the runs' progress while verbose (the apps:
  // bars on stderr); none: nothing shown.
  ProgressReporter bars;
};

// One render of the experiment: a row of measurements.csv.
struct ConvergeMeasurement {
  std::string strategy;  // the technique's name: "area", "area+power"
  int spp = 0, seed = 0;
  double time_ms = 0;  // GPU time on the GPU, wall time on the CPU (docs/metrics.md)
  double wall_ms = 0;  // the host's clock around the render call, the film's read-back included
  double rmse = 0, rmse_nolight = 0, relmse = 0, relmse_nolight = 0;
};

// Past this estimated time on the CPU, run_converge() asks for `yes`.
constexpr double kConvergeConfirmSeconds = 3600;

struct ConvergeResult {
  std::vector<ConvergeMeasurement> measurements;
  nlohmann::json summary;  // what summary.json holds: settings, reference, per-strategy points and fits
};

// What an experiment will do, before it renders anything: its ground truth
// (where it is cached, its chunks) and its techniques.
struct ReferencePlan {
  std::string key;             // the cache key: a hash of the scene document and the reference's settings
  std::string path, var_path;  // the cached mean and variance of the mean (EXR)
  int width = 0, height = 0;
  int spp = 0, chunk_spp = 0;  // chunk k holds samples [k chunk_spp, min((k + 1) chunk_spp, spp))
  int chunks = 0;
  bool cached = false;  // both files exist
};
struct ConvergePlan {
  ReferencePlan reference;
  std::vector<std::string> techniques;  // in the order of measurements.csv: "area", "area+power", ...
  std::vector<std::pair<std::string, std::string>> technique_parts;  // (strategy, MIS mode) of each
};

// Options that cannot go together or do not fit the scene (--frame-spp beyond --max-spp, a --crop outside the
// image, ...): the command line is wrong, not the scene (`penumbra converge` exits 2; Python: ValueError).
class ConvergeOptionError : public std::invalid_argument {
 public:
  using std::invalid_argument::invalid_argument;
};

// Loads the scene and checks the options as run_converge() does (same errors).
ConvergePlan plan_converge(const ConvergeOptions& options);

// The sums of chunk `index` of the ground truth (samples from zero, one render
// on the backend the options choose): what run_converge() adds, in chunk
// order, when the reference is not cached; and how many of its samples were
// NaN or infinite (left out; summary.json's nonfinite_by_part.reference).
struct ReferenceChunk {
  Film film;
  uint64_t nonfinite = 0;
};
ReferenceChunk render_reference_chunk(const ConvergeOptions& options, int index);

// Writes the ground truth of `film` (the sums of all its samples: the chunks
// added in chunk order) to the cache as run_converge() does; later runs with
// the same options find it there. Throws std::invalid_argument when the film
// has not the plan's size or samples.
void store_reference(const ConvergeOptions& options, const Film& film);

// Runs the experiment; with a non-empty `out`, also writes its files there.
// Throws SceneError for a bad scene, ConvergeOptionError for bad options,
// std::invalid_argument for a run refused without `yes`, and
// std::runtime_error when a backend fails.
//
// Each technique's time to the RMSE threshold (summary.json: fit_rmse and
// fit_rmse_nolight) is read off its fitted line, never measured: "fit_spp" is
// the range of spp the line was fitted to, and "extrapolated" is true where
// spp_to_threshold lies outside it (or is infinite); the text says so too.
ConvergeResult run_converge(const ConvergeOptions& options);

// The header of measurements.csv and one of its rows.
std::string converge_csv_header();
std::string converge_csv_row(const std::string& scene, const ConvergeMeasurement& m);

// The ground truths' cache folder by the XDG convention: <xdg_cache_home>/penumbra,
// else <home>/.cache/penumbra, else .penumbra-cache ("": unset). The applications
// pass $XDG_CACHE_HOME and $HOME (src/apps/environment.h) and fill
// ConvergeOptions::cache with it; nothing below src/apps reads the environment.
std::string default_cache_dir(const std::string& xdg_cache_home, const std::string& home);

}  // namespace pn
