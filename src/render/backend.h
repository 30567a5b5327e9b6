// What every backend offers the applications: render some samples per pixel of
// a frame into a Film. The light transport itself is core/integrator.h; a
// backend only answers ray queries and schedules the work.
#pragma once

#include <array>
#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "core/camera.h"
#include "core/integrator.h"
#include "render/film.h"
#include "scene/scene.h"

namespace pn {

// Everything about a frame that may change without rebuilding the geometry.
struct FrameSpec {
  Camera camera;
  IntegratorSettings integrator;
  uint32_t seed = 0;
};

FrameSpec frame_spec(const Scene& scene);

// Called from the rendering thread(s) with (samples done, samples total), where a
// sample is one path through one pixel. Calls are serialised by the backend. An
// exception it throws stops the render and leaves render() (the film then holds
// part of the samples).
using ProgressFn = std::function<void(uint64_t done, uint64_t total)>;

// GPU time of one launch, measured with CUDA events (`render --stats`, `bench`).
struct LaunchTiming {
  uint32_t spp = 0;           // samples per pixel the launch added
  float trace_ms = 0.f;       // path tracing (the OptiX launch)
  float accumulate_ms = 0.f;  // accumulation into the progressive buffers (+ tone-map when displaying)
};

// What the last render() call measured. Backends fill what they can.
struct RenderStats {
  std::vector<LaunchTiming> launches;  // one per GPU launch; empty on the CPU
  uint64_t rays = 0;                   // rays traced (path + shadow rays), counted exactly; 0 = not counted
  // Samples whose radiance was NaN or infinite: left out of the film's sums
  // (they count as black), never thrown away with the render. Every backend
  // counts them, and lists the first pixels (lowest y * width + x) that had one.
  uint64_t nonfinite = 0;
  std::vector<std::array<int, 2>> nonfinite_pixels;  // (x, y), at most kMaxNonfinitePixels
  static constexpr size_t kMaxNonfinitePixels = 5;
};

// One line for a user: how many samples were dropped and where, e.g.
// "3 samples were NaN or infinite and were left out (counted as black), at pixels (4, 0), (7, 2)".
std::string describe_nonfinite(const RenderStats& stats);

// Adds pixel (x, y) of a width-wide image to the first pixels of `stats` (kept
// sorted by row-major index, at most kMaxNonfinitePixels).
void note_nonfinite_pixel(RenderStats& stats, int x, int y, int width);

// What building a scene cost a GPU backend (`bench` reports it): acceleration
// structure build times and the device memory the scene holds.
struct SceneBuildStats {
  bool valid = false;          // false: the backend measures none of this (CPU)
  uint32_t gas_count = 0;      // geometry acceleration structures (meshes + spheres)
  double gas_build_ms = 0;     // all GASes: build + compaction, host clock around synchronised calls
  double ias_build_ms = 0;     // the instance acceleration structure
  uint64_t accel_bytes = 0;    // final (compacted) GAS and IAS buffers
  uint64_t scene_bytes = 0;    // geometry, instance, sphere, light, material and environment arrays
  uint64_t texture_bytes = 0;  // texel storage of the textures (CUDA arrays)
  uint64_t device_used_before = 0;  // cudaMemGetInfo total - free, device-wide: before the scene was built
  uint64_t device_used_after = 0;   // ... and after (pipeline, accelerations, scene, textures)
  uint64_t estimated_bytes = 0;     // the estimate checked against free memory before building (GPU)
};

class Backend {
 public:
  virtual ~Backend() = default;
  virtual std::string name() const = 0;         // "cpu" or "optix"
  virtual std::string device_name() const = 0;  // e.g. "2 threads (Embree 3.13.5)"
  // Adds samples [first_sample, first_sample + count) of every pixel to `film`,
  // which must already have the camera's size. Sample i of a pixel is the same
  // path whichever call or thread computes it. Samples that are NaN or infinite
  // are left out and counted in last_render_stats(); they never make render() fail.
  virtual void render(const FrameSpec& frame, Film& film, uint32_t first_sample, uint32_t count,
                      const ProgressFn& progress = nullptr) = 0;
  // Statistics of the last render() call.
  virtual RenderStats last_render_stats() const { return {}; }
  // Facts about the device for reports (GPU name, driver, versions), in order.
  virtual std::vector<std::pair<std::string, std::string>> device_info() const { return {}; }
  // Costs of building the scene on the device (GPU backends).
  virtual SceneBuildStats scene_build_stats() const { return {}; }
};

struct BackendOptions {
  int threads = 0;  // CPU: 0 = all hardware threads
  int spp_per_launch = 0;  // GPU: samples per pixel per launch; 0 = automatic
};

// Returns "cpu", "optix" or "auto"'s choice. Throws std::runtime_error with one
// line when the requested backend cannot run here. `note` receives a line that
// says which backend was chosen and why.
std::unique_ptr<Backend> make_backend(const std::string& which, const Scene& scene,
                                      const BackendOptions& options, std::string* note);

}  // namespace pn
