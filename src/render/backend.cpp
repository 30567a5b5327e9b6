#include "render/backend.h"

#include <algorithm>
#include <stdexcept>

#include "backends/cpu/cpu_backend.h"
#if PN_HAVE_OPTIX
#include "backends/optix/optix_backend.h"
#endif

namespace pn {

std::string describe_nonfinite(const RenderStats& stats) {
  std::string s = std::to_string(stats.nonfinite) + (stats.nonfinite == 1 ? " sample was" : " samples were") +
                  " NaN or infinite and left out (counted as black)";
  for (size_t i = 0; i < stats.nonfinite_pixels.size(); ++i)
    s += (i ? ", (" : ", at pixel" + std::string(stats.nonfinite_pixels.size() > 1 ? "s (" : " (")) +
         std::to_string(stats.nonfinite_pixels[i][0]) + ", " + std::to_string(stats.nonfinite_pixels[i][1]) + ")";
  if (stats.nonfinite_pixels.size() == RenderStats::kMaxNonfinitePixels) s += ", ...";
  return s;
}

void note_nonfinite_pixel(RenderStats& stats, int x, int y, int width) {
  auto& v = stats.nonfinite_pixels;
  auto index = [width](const std::array<int, 2>& p) { return int64_t(p[1]) * width + p[0]; };
  const std::array<int, 2> p = {x, y};
  auto it = std::lower_bound(v.begin(), v.end(), p, [&](const auto& a, const auto& b) { return index(a) < index(b); });
  if (it != v.end() && *it == p) return;
  if (v.size() == RenderStats::kMaxNonfinitePixels && it == v.end()) return;
  v.insert(it, p);
  if (v.size() > RenderStats::kMaxNonfinitePixels) v.pop_back();
}

FrameSpec frame_spec(const Scene& scene) {
  FrameSpec f;
  f.camera = scene.make_camera();
  f.integrator = scene.integrator();
  f.seed = scene.render.seed;
  return f;
}

std::unique_ptr<Backend> make_backend(const std::string& which, const Scene& scene,
                                      const BackendOptions& options, std::string* note) {
  if (which == "cpu") {
    auto b = make_cpu_backend(scene, options.threads);
    *note = "backend: cpu (" + b->device_name() + ")";
    return b;
  }
  if (which == "optix") {
#if PN_HAVE_OPTIX
    auto b = make_optix_backend(scene, options);
    *note = "backend: optix (" + b->device_name() + ")";
    return b;
#else
    throw std::runtime_error(
        "this penumbra was built without the OptiX backend: reconfigure with OptiX headers "
        "(cmake -DOptiX_ROOT=/path/to/optix, the folder that holds include/optix.h) and CUDA");
#endif
  }
  if (which == "auto") {
#if PN_HAVE_OPTIX
    std::string why;
    if (optix_available(&why)) {
      auto b = make_optix_backend(scene, options);
      *note = "backend: optix (" + b->device_name() + "), chosen by --backend auto";
      return b;
    }
    auto b = make_cpu_backend(scene, options.threads);
    *note = "backend: cpu (" + b->device_name() + "), chosen by --backend auto: " + why;
    return b;
#else
    auto b = make_cpu_backend(scene, options.threads);
    *note = "backend: cpu (" + b->device_name() + "), chosen by --backend auto: built without OptiX";
    return b;
#endif
  }
  throw std::runtime_error("unknown backend '" + which + "' (expected cpu, optix or auto)");
}

}  // namespace pn
