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
#include "render/gpu_tuning.h"
#include "scene/scene.h"

namespace pn {

// Everything about a frame that may change without rebuilding the geometry.
struct FrameSpec {
  Camera camera;
  IntegratorSettings integrator;
  uint32_t seed = 0;
};

FrameSpec frame_spec(const Scene& scene);
// Whether two frames are the same image: camera, integrator and seed.
bool same_frame(const FrameSpec& a, const FrameSpec& b);

// Called from the rendering thread(s) with (samples done, samples total), where a
// sample is one path through one pixel. Calls are serialised by the backend. An
// exception it throws stops the render and leaves render() (the film then holds
// part of the samples).
using ProgressFn = std::function<void(uint64_t done, uint64_t total)>;

// GPU time of one launch, measured with CUDA events (`render --stats`, `bench`).
struct LaunchTiming {
  uint32_t spp = 0;           // samples per pixel the launch added
  float trace_ms = 0.f;       // path tracing (the OptiX launch; with the wavefront's accumulation where one wave
                              // holds the launch, its accumulate_ms then ~0)
  float accumulate_ms = 0.f;  // accumulation into the progressive buffers (+ tone-map when displaying)
};

// One device's share of a render split across several (MultiBackend).
struct DeviceTiming {
  std::string device;         // the device's backend: device_name()
  uint32_t first_sample = 0;  // its samples: [first_sample, first_sample + count) of every pixel
  uint32_t count = 0;
  double wall_ms = 0;         // host clock around its render() call
  double gpu_ms = 0;          // GPU time of its launches (CUDA events); 0 on the CPU
};

// What the last render() call measured. Backends fill what they can.
struct RenderStats {
  std::vector<LaunchTiming> launches;  // one per GPU launch (of every device); empty on the CPU
  uint64_t rays = 0;                   // rays traced (path + shadow rays), counted exactly; 0 = not counted
  // Samples whose radiance was NaN or infinite: left out of the film's sums
  // (they count as black), never thrown away with the render. Every backend
  // counts them, and lists the first pixels (lowest y * width + x) that had one.
  uint64_t nonfinite = 0;
  std::vector<std::array<int, 2>> nonfinite_pixels;  // (x, y), at most kMaxNonfinitePixels
  static constexpr size_t kMaxNonfinitePixels = 5;
  std::vector<DeviceTiming> devices;   // one per device of a split render; empty for one device
  // GPU render() (host clock): from the first launch until the GPU finished
  // the last, and then the film's sums copied out and added to the host film.
  // 0 where not measured (the CPU; accumulate() alone).
  double launches_wall_ms = 0;
  double readback_ms = 0;
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
  double pipeline_ms = 0;      // compiling the device programs (cold: minutes' worth of work; cached: well under 1 s)
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

// A denoiser's guide images (core/aov.h): per pixel, the albedo in [0, 1] and
// the unit world-space normal (0: the rays escaped) of the first non-specular
// surface, 3 floats a pixel each, row 0 at the top.
struct GuideImages {
  int width = 0, height = 0;
  std::vector<float> albedo, normal;
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
  // The denoiser's guides of the frame, each pixel's mean over `samples`
  // jittered camera rays (those of its samples 0 .. samples - 1), through the
  // backend's closest-hit query. The default throws std::logic_error.
  virtual GuideImages render_guides(const FrameSpec& frame, uint32_t samples);
  // The split of `count` samples (from some first sample) into sample ranges
  // that keeps the image of this backend bit for bit: a multiple of this many
  // samples per range (the GPU's samples per launch: its per-launch sums are
  // float), the last range taking the rest. 1: any split.
  virtual uint32_t split_granularity(const FrameSpec& frame, uint32_t count) const {
    (void)frame;
    (void)count;
    return 1;
  }
  // Facts about the device for reports (GPU name, driver, versions), in order.
  virtual std::vector<std::pair<std::string, std::string>> device_info() const { return {}; }
  // Costs of building the scene on the device (GPU backends).
  virtual SceneBuildStats scene_build_stats() const { return {}; }
  // The scene's lights were edited in place (set_sphere_light, scene/scene.h): take the new lights, sphere
  // surfaces and light selection without rebuilding the meshes' acceleration structures, so that the next
  // render() is the image a backend made from the edited scene would render. False where this backend cannot
  // (then make a new one from the edited scene); the default.
  virtual bool update_lights() { return false; }
};

// The wavefront's trace stage (--traversal): trace-only OptiX launches, penumbra's cuda traversal
// (backends/cuda), or auto: OptiX where the GPU has RT cores (OPTIX_DEVICE_PROPERTY_RTCORE_VERSION > 0), else cuda.
enum class Traversal : int { Auto = 0, Optix = 1, Cuda = 2 };
constexpr int kNumTraversals = 3;
const char* traversal_name(Traversal t);  // "auto", "optix", "cuda"
bool find_traversal(const std::string& name, Traversal* out);
std::string traversal_names();  // "auto, optix, cuda"

struct BackendOptions {
  int threads = 0;  // CPU: 0 = all hardware threads
  int spp_per_launch = 0;  // GPU: samples per pixel per launch; 0 = automatic
  // GPU: which GPUs render (the --gpus option: "all", a count "2" or a list of
  // CUDA device indices "0,2"); several split every render() in sample ranges
  // (MultiBackend). "": GPU 0 alone (the viewer, bench).
  std::string gpus = "";
  int device = 0;  // GPU: the CUDA device of a single-GPU backend (make_optix_backend)
  // GPU: the wavefront path tracer (backends/wavefront; the default: on the H200 1.8x the megakernel's speed with
  // the cuda trace stage, and the same images, scripts/wavefront_check.sh) or the megakernel (--megakernel), and
  // the wavefront's trace stage (--traversal).
  bool wavefront = true;
  Traversal traversal = Traversal::Auto;
  // GPU: the tuning knobs (render/gpu_tuning.h: --tune KEY=VALUE); the defaults are the measured choices.
  GpuTuning tuning{};
};

// --gpus: "all", a count N >= 1 (the first N GPUs) or a comma-separated list of
// distinct CUDA device indices. Throws std::invalid_argument with one line that
// names --gpus for anything else (checked before any GPU is looked at).
void check_gpus(const std::string& spec);
// The CUDA devices that `spec` selects among `available` GPUs ("" = GPU 0).
// Throws std::invalid_argument (one line, naming --gpus) when it asks for more
// GPUs than there are or for an index that does not exist.
std::vector<int> select_gpus(const std::string& spec, int available);

}  // namespace pn
