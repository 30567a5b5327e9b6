#include "render/denoise.h"

#include <chrono>
#include <map>
#include <memory>
#include <mutex>
#include <stdexcept>

#if PN_HAVE_OPTIX
#include "backends/optix/denoiser.h"
#include "backends/optix/optix_backend.h"
#include "render/multi_backend.h"
#endif

namespace pn {
namespace {

std::runtime_error needs_gpu(const std::string& what, const std::string& why) {
  return std::runtime_error(what + ": denoising needs the GPU backend (the OptiX AI denoiser): " + why);
}

#if PN_HAVE_OPTIX
// The CUDA device of the GPU backend `backend` (device 0's of a MultiBackend).
int cuda_device_of(Backend& backend) {
  Backend* b = &backend;
  if (auto* multi = dynamic_cast<MultiBackend*>(b)) b = &multi->first_device();
  if (auto* optix = dynamic_cast<OptixBackend*>(b)) return optix->cuda_device();
  return 0;
}

// One denoiser per GPU, made on first use and kept until release_denoisers()
// (the map itself is never destroyed: static destructors would run after
// CUDA's own teardown).
std::mutex denoisers_mutex;
std::map<int, std::unique_ptr<Denoiser>>& denoisers() {
  static auto* d = new std::map<int, std::unique_ptr<Denoiser>>();
  return *d;
}

Denoiser& denoiser_for(int device, std::unique_lock<std::mutex>* lock) {
  *lock = std::unique_lock<std::mutex>(denoisers_mutex);
  std::unique_ptr<Denoiser>& d = denoisers()[device];
  if (!d) d = std::make_unique<Denoiser>(device);
  return *d;
}
#endif

}  // namespace

void check_denoise_choice(const std::string& what, const std::string& backend_choice) {
#if PN_HAVE_OPTIX
  if (backend_choice == "cpu") throw needs_gpu(what, "--backend cpu renders on the CPU");
#else
  (void)backend_choice;
  throw needs_gpu(what, "this penumbra was built without it (CPU only)");
#endif
}

void check_denoise_backend(const std::string& what, const Backend& backend, const std::string& why) {
  if (backend.name() == "optix") return;
  throw needs_gpu(what, "the image is rendered on the " + backend.name() + " backend" +
                            (why.empty() ? "" : " (" + why + ")"));
}

void release_denoisers() {
#if PN_HAVE_OPTIX
  std::lock_guard<std::mutex> lock(denoisers_mutex);
  denoisers().clear();
#endif
}

std::vector<float> denoise_image(Backend& backend, const std::vector<float>& mean, const GuideImages& guides,
                                 double* denoise_ms) {
  check_denoise_backend("denoise", backend);
#if PN_HAVE_OPTIX
  std::unique_lock<std::mutex> lock;
  Denoiser& d = denoiser_for(cuda_device_of(backend), &lock);
  std::vector<float> out = d.denoise(guides.width, guides.height, mean, guides);
  if (denoise_ms) *denoise_ms = d.last_ms();
  return out;
#else
  (void)mean;
  (void)guides;
  (void)denoise_ms;
  throw needs_gpu("denoise", "this penumbra was built without it (CPU only)");
#endif
}

DenoisedImage denoise_render(Backend& backend, const FrameSpec& frame, const std::vector<float>& mean,
                             uint32_t guide_samples) {
  check_denoise_backend("denoise", backend);
  DenoisedImage r;
  const auto t0 = std::chrono::steady_clock::now();
  r.guides = backend.render_guides(frame, guide_samples);
  r.guide_ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
  r.rgb = denoise_image(backend, mean, r.guides, &r.denoise_ms);
  return r;
}

}  // namespace pn
