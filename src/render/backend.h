// What every backend offers the applications: render some samples per pixel of
// a frame into a Film. The light transport itself is core/integrator.h; a
// backend only answers ray queries and schedules the work.
#pragma once

#include <cstdint>
#include <functional>
#include <memory>
#include <string>

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
// sample is one path through one pixel. Calls are serialised by the backend.
using ProgressFn = std::function<void(uint64_t done, uint64_t total)>;

class Backend {
 public:
  virtual ~Backend() = default;
  virtual std::string name() const = 0;         // "cpu" or "optix"
  virtual std::string device_name() const = 0;  // e.g. "2 threads (Embree 3.13.5)"
  // Adds samples [first_sample, first_sample + count) of every pixel to `film`,
  // which must already have the camera's size. Sample i of a pixel is the same
  // path whichever call or thread computes it.
  virtual void render(const FrameSpec& frame, Film& film, uint32_t first_sample, uint32_t count,
                      const ProgressFn& progress = nullptr) = 0;
};

struct BackendOptions {
  int threads = 0;  // CPU: 0 = all hardware threads
};

// Returns "cpu", "optix" or "auto"'s choice. Throws std::runtime_error with one
// line when the requested backend cannot run here. `note` receives a line that
// says which backend was chosen and why.
std::unique_ptr<Backend> make_backend(const std::string& which, const Scene& scene,
                                      const BackendOptions& options, std::string* note);

}  // namespace pn
