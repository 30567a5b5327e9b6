// The GPU backend's three paths, for unit tests that run a case on each: the wavefront with penumbra's cuda
// traversal (the default), the wavefront with OptiX's trace stage, and the megakernel.
#pragma once

#include "render/backend.h"

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
};

inline constexpr GpuPath kGpuPaths[] = {{"wavefront, cuda traversal", true, Traversal::Cuda},
                                        {"wavefront, optix traversal", true, Traversal::Optix},
                                        {"megakernel", false, Traversal::Auto}};

}  // namespace pn
