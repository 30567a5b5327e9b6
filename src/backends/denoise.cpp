#include "backends/denoise.h"

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

const char* denoiser_name(DenoiserKind k) { return k == DenoiserKind::Oidn ? "oidn" : "optix"; }

DenoiseOptions make_denoise_options(const std::string& denoiser, const std::string& quality, bool clean_aux,
                                    const std::string& oidn_library) {
  DenoiseOptions o;
  if (denoiser == "optix") o.denoiser = DenoiserKind::Optix;
  else if (denoiser != "oidn") throw std::invalid_argument("denoiser must be oidn or optix, not '" + denoiser + "'");
  bool known = false;
  for (DenoiseQuality q : {DenoiseQuality::Fast, DenoiseQuality::Balanced, DenoiseQuality::High})
    if (quality == denoise_quality_name(q)) o.quality = q, known = true;
  if (!known) throw std::invalid_argument("denoise quality must be fast, balanced or high, not '" + quality + "'");
  o.clean_aux = clean_aux;
  o.oidn_library = oidn_library;
  return o;
}

namespace {

// The CUDA device of the GPU backend `backend` (device 0's of a MultiBackend); 0 elsewhere.
int cuda_device_of(Backend& backend) {
#if PN_HAVE_OPTIX
  Backend* b = &backend;
  if (auto* multi = dynamic_cast<MultiBackend*>(b)) b = &multi->first_device();
  if (auto* optix = dynamic_cast<OptixBackend*>(b)) return optix->cuda_device();
#else
  (void)backend;
#endif
  return 0;
}

std::runtime_error needs_gpu(const std::string& what, const std::string& why) {
  return std::runtime_error(what + ": the OptiX AI denoiser needs the GPU backend: " + why +
                            " (--denoiser oidn denoises on any backend)");
}

// OIDN's library, opened (once per process), or a line saying how to get it.
Oidn& oidn_or_throw(const std::string& what, const DenoiseOptions& options) {
  try {
    return oidn_for(options.oidn_library);
  } catch (const std::exception& e) {
    throw std::runtime_error(what + ": " + e.what() +
                             "; pip install pyoidn (scripts/install-deps.sh does), or give the library's path "
                             "with --oidn-library");
  }
}

// Intel Open Image Denoise on the backend's device: its CUDA device for the GPU backend where OIDN can use that
// GPU, else its CPU device.
std::vector<float> denoise_oidn(Backend& backend, const std::vector<float>& mean, const GuideImages& guides,
                                const DenoiseOptions& options, double* ms, std::string* how, size_t* repaired) {
  Oidn& oidn = oidn_or_throw("denoise", options);
  OidnDeviceKind device = OidnDeviceKind::Cpu;
  std::string note;
  if (backend.name() == "optix") {
    const int gpu = cuda_device_of(backend);
    if (oidn.cuda_supported(gpu)) device = OidnDeviceKind::Cuda;
    else note = " (its CUDA device cannot use GPU " + std::to_string(gpu) + ")";
  }
  OidnFilterOptions filter;
  filter.quality = options.quality;
  filter.clean_aux = options.clean_aux;
  std::vector<float> out = oidn.denoise(device, guides.width, guides.height, mean, guides.albedo, guides.normal,
                                        filter, ms, repaired);
  if (how)
    *how = std::string("Intel Open Image Denoise, ") + (device == OidnDeviceKind::Cuda ? "CUDA" : "CPU") +
           " device" + note + ", quality " + denoise_quality_name(options.quality) +
           (options.clean_aux ? ", cleanAux" : "");
  return out;
}

#if PN_HAVE_OPTIX
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

void check_denoise_choice(const std::string& what, const std::string& backend_choice,
                          const DenoiseOptions& options) {
  if (options.denoiser == DenoiserKind::Oidn) {
    oidn_or_throw(what, options);
    return;
  }
#if PN_HAVE_OPTIX
  if (backend_choice == "cpu") throw needs_gpu(what, "--backend cpu renders on the CPU");
#else
  (void)backend_choice;
  throw needs_gpu(what, "this penumbra was built without it (CPU only)");
#endif
}

void check_denoise_backend(const std::string& what, const Backend& backend, const DenoiseOptions& options,
                           const std::string& why) {
  if (options.denoiser == DenoiserKind::Oidn || backend.name() == "optix") return;
  throw needs_gpu(what, "the image is rendered on the " + backend.name() + " backend" +
                            (why.empty() ? "" : " (" + why + ")"));
}

void release_denoisers() {
  release_oidn_filters();
#if PN_HAVE_OPTIX
  std::lock_guard<std::mutex> lock(denoisers_mutex);
  denoisers().clear();
#endif
}

std::vector<float> denoise_image(Backend& backend, const std::vector<float>& mean, const GuideImages& guides,
                                 const DenoiseOptions& options, double* denoise_ms, std::string* how,
                                 size_t* repaired) {
  check_denoise_backend("denoise", backend, options);
  if (options.denoiser == DenoiserKind::Oidn) return denoise_oidn(backend, mean, guides, options, denoise_ms, how, repaired);
  if (how) *how = "the OptiX AI denoiser";
  if (repaired) *repaired = 0;
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
                             const DenoiseOptions& options, uint32_t guide_samples) {
  check_denoise_backend("denoise", backend, options);
  DenoisedImage r;
  const auto t0 = std::chrono::steady_clock::now();
  r.guides = backend.render_guides(frame, guide_samples);
  r.guide_ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
  r.rgb = denoise_image(backend, mean, r.guides, options, &r.denoise_ms, &r.how, &r.repaired);
  return r;
}

}  // namespace pn
