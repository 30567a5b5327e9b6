// `penumbra bench --probe`: the trace stage alone, both implementations on the
// same rays. Random incoherent rays inside the scene's bounds (probe_rays.h),
// closest hits and shadow rays, each launch timed by CUDA events; then the two
// implementations' answers compared ray by ray.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "backends/cuda/bvh_build.h"
#include "backends/optix/optix_backend.h"

namespace pn {

struct ProbeSettings {
  uint32_t rays = 1u << 22;  // per launch, for each ray kind
  int warmup = 3;
  int launches = 20;
  uint32_t seed = 0;
  GpuTuning tuning{};  // the cuda traversal's BVH and kernels (BackendOptions::tuning; the optix backend's own)
};

// Median launch times of one implementation.
struct ProbeTimes {
  double closest_ms = 0, shadow_ms = 0;
  double closest_min_ms = 0, closest_max_ms = 0, shadow_min_ms = 0, shadow_max_ms = 0;
};

struct ProbeResult {
  uint32_t rays = 0;
  ProbeTimes optix, cuda;
  uint64_t hits_optix = 0, hits_cuda = 0;         // closest rays that hit something
  uint64_t blocked_optix = 0, blocked_cuda = 0;   // shadow rays blocked
  uint64_t closest_ties = 0;   // different primitives at the same distance (relative 1e-4 of the coordinates)
  uint64_t closest_other = 0;  // hit against miss, or different primitives at different distances
  uint64_t closest_t_off = 0;  // the same primitive at distances further apart than 2e-5 of the coordinates
  uint64_t shadow_mismatched = 0;
  // Rays that leave surfaces (probe_surface_rays: bounces and shadow rays as a path makes them), traced once by
  // each implementation and compared as above; self-hits are closest hits on the ray's own triangle.
  struct Surface {
    uint64_t hits_optix = 0, hits_cuda = 0, self_optix = 0, self_cuda = 0;
    uint64_t closest_ties = 0, closest_other = 0, closest_t_off = 0;
    uint64_t blocked_optix = 0, blocked_cuda = 0, shadow_mismatched = 0;
    std::vector<std::string> examples;  // the first disagreements, one line each
  } surface;
  BvhStats bvh;
  std::string cuda_form;  // how the cuda kernels traced (CudaTraceForms::reason)
  uint64_t bvh_bytes = 0;
  double upload_ms = 0;
};

// Runs the probe on `scene`, whose OptiX backend is `optix` (its stream, its
// device scene view for alpha masks). Throws std::runtime_error with one line.
ProbeResult run_trace_probe(const Scene& scene, OptixBackend& optix, const ProbeSettings& settings);

}  // namespace pn
