// The backends by name: the CPU backend, the GPU backend (one OptiX backend,
// or a MultiBackend over one per GPU), or auto's choice between them. Above
// render/, whose Backend interface they implement.
#pragma once

#include <memory>
#include <string>

#include "render/backend.h"

namespace pn {

// Returns "cpu", "optix" or "auto"'s choice. Throws std::runtime_error with one
// line when the requested backend cannot run here. `note` receives a line that
// says which backend was chosen and why. With options.gpus selecting several
// GPUs, the GPU backend is a MultiBackend over one OptiX backend per GPU.
std::unique_ptr<Backend> make_backend(const std::string& which, const Scene& scene,
                                      const BackendOptions& options, std::string* note);

}  // namespace pn
