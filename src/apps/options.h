// Command-line options that several subcommands share, declared once: the
// integrator's choices (--strategy, --mis, --light-selection, --max-depth,
// restir's) and the run's --seed, which become scene overrides
// (render.strategy=...) validated with the scene like any --set; what makes a
// backend; --set; the denoiser's.
#pragma once

#include <limits>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>

namespace pn {

struct BackendOptions;

struct IntegratorOptions {
  static constexpr long long kUnset = std::numeric_limits<long long>::min();  // not given: the scene's
  std::string strategy, mis, light_selection;  // empty: the scene's
  bool mis_compensation = false;               // --mis-compensation (render.mis_compensation=true)
  long long max_depth = kUnset, seed = kUnset;  // --max-depth, --seed (render.max_depth, render.seed)
  long long slc_cut = kUnset;  // --slc-cut (render.slc_cut)
  // restir's settings (render.restir.*); kUnset / empty: the scene's.
  long long restir_candidates = kUnset, restir_spatial = kUnset, restir_neighbors = kUnset;
  double restir_radius = -std::numeric_limits<double>::infinity();
  std::string restir_source;
  bool restir_biased = false;
  bool restir_pairwise = false;
  bool restir_unshadowed = false;
  bool restir_temporal = false;
  double restir_temporal_cap = -std::numeric_limits<double>::infinity();  // unset
};

void add_integrator_options(CLI::App* sub, IntegratorOptions* o);

// Appends "render.strategy=..." (and render.restir.*) for the options that were given.
void append_integrator_overrides(const IntegratorOptions& o, std::vector<std::string>* overrides);

// Every option that decides a command's backend (render, bench, converge, view), declared here once with one
// help text, written straight into the command's BackendOptions (render/backend.h), which make_backend takes:
//   --backend cpu|optix|auto (into *backend), --threads;
//   --gpus (where `gpus`: render, converge): which GPUs split the samples of each image, "all" by default, its
//     syntax checked when parsed (check_gpus);
//   --wavefront / --megakernel and --traversal: the GPU's path tracer and its trace stage
//     (backends/optix/WAVEFRONT.md);
//   --tune KEY=VALUE, repeatable or comma-separated: the GPU's tuning knobs (render/gpu_tuning.h), their table
//     in --help; a bad key or value is a usage error whose one line names the key and the accepted values.
// The cpu backend ignores the GPU's options.
void add_backend_options(CLI::App* sub, std::string* backend, BackendOptions* options, bool gpus);

// --width and --height: the image's size in pixels, checked as the scene checks render.width and render.height;
// `defaults` says what an absent one means for the command ("the scene's"). Declared for every command here.
template <typename Int>
void add_size_options(CLI::App* sub, Int* width, Int* height, const std::string& defaults);

// --set KEY=VALUE (repeatable): any scene value, validated with the scene like the file's own.
void add_set_option(CLI::App* sub, std::vector<std::string>* sets);

// --denoiser, --denoise-quality, --denoise-clean-aux and --oidn-library (render, view): which denoiser
// --denoise uses and how (backends/denoise.h). The choices as the command line gave them; denoise_options()
// turns them into DenoiseOptions, finding Intel Open Image Denoise's library.
struct DenoiseArgs {
  std::string denoiser = "oidn", quality = "high", oidn_library;
  bool clean_aux = false;
};
void add_denoise_options(CLI::App* sub, DenoiseArgs* a);

// Where libOpenImageDenoise is: `explicit_path` where given; else the PyPI wheel pyoidn's copy, found by asking
// python3 where pyoidn is; else "" (the system's library path, by soname). *how says which.
std::string find_oidn_library(const std::string& explicit_path, std::string* how = nullptr);

struct DenoiseOptions;
// The options for backends/denoise.h; *how: where OIDN's library was found (find_oidn_library).
DenoiseOptions denoise_options(const DenoiseArgs& a, std::string* how = nullptr);

// "none, balance, power: what each does" lines for --help.
std::string mis_help();

// Option values are checked when the command line is parsed, so that a wrong one is a usage error (exit status 2)
// whose one line names the option, before any scene is loaded or file written.

// An option whose value becomes the scene value render.<key> (--spp: "spp", --restir-radius: "restir.radius"):
// the value goes into an empty scene document as that override and through the scene's own parser of the render
// block (parse_frame_settings), which stays the one place that knows the ranges; `name`: the value is a name
// (a JSON string: --strategy).
CLI::Validator render_setting(const std::string& key, bool name = false);

// Names, one or a comma-separated list of them: strategies, MIS modes, light-selection methods (with or
// without restir).
CLI::Validator strategy_names_check();
CLI::Validator mis_names_check();
CLI::Validator light_selection_names_check(bool restir = true);

// An image to write (-o, --variance): .exr or .png.
CLI::Validator image_path_check();

template <typename Int>
void add_size_options(CLI::App* sub, Int* width, Int* height, const std::string& defaults) {
  sub->add_option("--width", *width, "Image width in pixels (default size: " + defaults + ")")
      ->check(render_setting("width"));
  sub->add_option("--height", *height, "Image height in pixels (default size: " + defaults + ")")
      ->check(render_setting("height"));
}

}  // namespace pn
