// The GPU backend's three paths, for unit tests that run a case on each: the wavefront with penumbra's cuda
// traversal (the default), the wavefront with OptiX's trace stage, and the megakernel.
#pragma once

#include <exception>
#include <memory>
#include <string>

#include "backends/make_backend.h"
#include "render/backend.h"
#include "scene/scene.h"

namespace pn {

struct GpuPath {
  const char* name;
  bool wavefront;
  Traversal traversal;

  BackendOptions options() const {
    BackendOptions o;
    o.wavefront = wavefront;
    o.traversal = traversal;
    return o;
  }

  // This path's GPU backend of `scene`; null, with `why`, where this build or machine has none (the caller skips).
  std::unique_ptr<Backend> backend(const Scene& scene, std::string* why) const {
    std::string note;
    try {
      return make_backend("optix", scene, options(), &note);
    } catch (const std::exception& e) {
      *why = e.what();
      return nullptr;
    }
  }
};

inline constexpr GpuPath kGpuPaths[] = {{"wavefront, cuda traversal", true, Traversal::Cuda},
                                        {"wavefront, optix traversal", true, Traversal::Optix},
                                        {"megakernel", false, Traversal::Auto}};

}  // namespace pn
