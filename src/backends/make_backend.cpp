#include "backends/make_backend.h"

#include <exception>
#include <stdexcept>
#include <thread>
#include <vector>

#include "backends/cpu/cpu_backend.h"
#include "render/multi_backend.h"
#if PN_HAVE_OPTIX
#include "backends/optix/optix_backend.h"
#endif

namespace pn {

#if PN_HAVE_OPTIX
namespace {

// The GPU backend on the GPUs options.gpus selects: one OptiX backend, or a
// MultiBackend over one per GPU (built concurrently: each builds its own
// acceleration structures).
std::unique_ptr<Backend> make_gpu_backend(const Scene& scene, const BackendOptions& options) {
  check_gpus(options.gpus);
  const std::vector<int> gpus = select_gpus(options.gpus, options.gpus.empty() ? 1 : optix_device_count());
  if (gpus.size() == 1) {
    BackendOptions one = options;
    one.device = gpus[0];
    return make_optix_backend(scene, one);
  }
  std::vector<std::unique_ptr<Backend>> devices(gpus.size());
  std::vector<std::exception_ptr> errors(gpus.size());
  std::vector<std::thread> threads;
  for (size_t i = 0; i < gpus.size(); ++i)
    threads.emplace_back([&, i] {
      try {
        BackendOptions one = options;
        one.device = gpus[i];
        devices[i] = make_optix_backend(scene, one);
      } catch (...) {
        errors[i] = std::current_exception();
      }
    });
  for (std::thread& t : threads) t.join();
  for (size_t i = 0; i < gpus.size(); ++i)
    if (errors[i]) {
      try {
        std::rethrow_exception(errors[i]);
      } catch (const std::exception& e) {
        throw std::runtime_error("GPU " + std::to_string(gpus[i]) + ": " + e.what());
      }
    }
  std::vector<std::string> labels;
  for (int g : gpus) labels.push_back("GPU " + std::to_string(g));
  return std::make_unique<MultiBackend>(std::move(devices), std::move(labels));
}

}  // namespace
#endif

std::unique_ptr<Backend> make_backend(const std::string& which, const Scene& scene,
                                      const BackendOptions& options, std::string* note) {
  check_gpus(options.gpus);  // a malformed --gpus is an error on any machine
  if (which == "cpu") {
    auto b = make_cpu_backend(scene, options.threads);
    *note = "backend: cpu (" + b->device_name() + ")";
    return b;
  }
  if (which == "optix") {
#if PN_HAVE_OPTIX
    std::string why;
    if (!optix_available(&why)) throw std::runtime_error(why);
    auto b = make_gpu_backend(scene, options);
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
      auto b = make_gpu_backend(scene, options);
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
