// Command-line options that several subcommands share, declared once: the
// integrator's choices (--strategy, --mis, --light-selection), which become
// scene overrides (render.strategy=...) validated with the scene like any --set.
#pragma once

#include <limits>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>

namespace pn {

struct IntegratorOptions {
  std::string strategy, mis, light_selection;  // empty: the scene's
  // restir's settings (render.restir.*); kUnset / empty: the scene's.
  static constexpr long long kUnset = std::numeric_limits<long long>::min();
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

// --gpus (render, converge): which GPUs split the samples of each image; "all"
// by default. Its syntax is checked when parsed (render/backend.h: check_gpus).
void add_gpus_option(CLI::App* sub, std::string* gpus);

// --wavefront and --traversal (render, bench, converge, view): the GPU's path tracer and its trace stage
// (BackendOptions::wavefront, ::traversal; backends/optix/WAVEFRONT.md). The cpu backend ignores them.
void add_wavefront_options(CLI::App* sub, bool* wavefront, std::string* traversal);

// "none, balance, power: what each does" lines for --help.
std::string mis_help();

}  // namespace pn
