#include "render/backend.h"

#include <stdexcept>

#include "backends/cpu/cpu_backend.h"
#if PN_HAVE_OPTIX
#include "backends/optix/optix_backend.h"
#endif

namespace pn {

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
