// The CPU reference backend: Embree 3 for ray queries, all cores, tiled.
#pragma once

#include <memory>

#include "render/backend.h"

namespace pn {

// The order in which the CPU advances paths (core/integrator.h's step
// functions). Both give the same image, bit for bit.
enum class CpuSchedule {
  DepthFirst,    // one path at a time, to its end (trace_path): the default
  BreadthFirst,  // a pool of paths per tile, one step at a time, in a wavefront GPU's order (tests)
};

std::unique_ptr<Backend> make_cpu_backend(const Scene& scene, int threads,
                                          CpuSchedule schedule = CpuSchedule::DepthFirst);

}  // namespace pn
