// The CPU reference backend: Embree 3 for ray queries, all cores, tiled.
#pragma once

#include <memory>

#include "render/backend.h"

namespace pn {

std::unique_ptr<Backend> make_cpu_backend(const Scene& scene, int threads);

}  // namespace pn
