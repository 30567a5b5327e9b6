#include "render/oidn.h"

#include <dlfcn.h>

#include <chrono>
#include <cmath>
#include <cstddef>
#include <map>
#include <mutex>
#include <stdexcept>
#include <type_traits>

namespace pn {

const char* denoise_quality_name(DenoiseQuality q) {
  switch (q) {
    case DenoiseQuality::Fast: return "fast";
    case DenoiseQuality::Balanced: return "balanced";
    case DenoiseQuality::High: return "high";
  }
  return "?";
}

namespace {

// OIDN 2.x's C API (OpenImageDenoise/oidn.h): the enumerators penumbra passes.
constexpr int kDeviceCpu = 1, kDeviceCuda = 3;
constexpr int kFormatFloat3 = 3;
constexpr int kQualityFast = 4, kQualityBalanced = 5, kQualityHigh = 6;
constexpr int kErrorNone = 0;

int quality_value(DenoiseQuality q) {
  switch (q) {
    case DenoiseQuality::Fast: return kQualityFast;
    case DenoiseQuality::Balanced: return kQualityBalanced;
    case DenoiseQuality::High: return kQualityHigh;
  }
  return kQualityHigh;
}

}  // namespace

struct Oidn::Api {
  void* (*new_device)(int) = nullptr;
  void* (*new_cuda_device)(const int*, void* const*, int) = nullptr;  // (device ids, cudaStream_t's, pairs)
  void (*commit_device)(void*) = nullptr;
  void (*release_device)(void*) = nullptr;
  int (*get_device_error)(void*, const char**) = nullptr;
  bool (*is_cuda_device_supported)(int) = nullptr;
  void* (*new_buffer)(void*, size_t) = nullptr;
  void (*write_buffer)(void*, size_t, size_t, const void*) = nullptr;
  void (*read_buffer)(void*, size_t, size_t, void*) = nullptr;
  void (*release_buffer)(void*) = nullptr;
  void* (*new_filter)(void*, const char*) = nullptr;
  void (*set_filter_image)(void*, const char*, void*, int, size_t, size_t, size_t, size_t, size_t) = nullptr;
  void (*set_shared_filter_image)(void*, const char*, void*, int, size_t, size_t, size_t, size_t, size_t) = nullptr;
  void (*set_filter_bool)(void*, const char*, bool) = nullptr;
  void (*set_filter_int)(void*, const char*, int) = nullptr;
  void (*commit_filter)(void*) = nullptr;
  void (*execute_filter)(void*) = nullptr;
  void (*release_filter)(void*) = nullptr;
};

Oidn::Oidn(const std::string& library) : library_(library.empty() ? "libOpenImageDenoise.so.2" : library) {
  handle_ = dlopen(library_.c_str(), RTLD_NOW | RTLD_LOCAL);
  if (!handle_) {
    const char* e = dlerror();
    throw std::runtime_error("cannot open Intel Open Image Denoise (" + library_ + "): " + (e ? e : "unknown error"));
  }
  api_ = std::make_unique<Api>();
  auto bind = [&](auto& fn, const char* name) {
    void* s = dlsym(handle_, name);
    if (!s) throw std::runtime_error(library_ + " has no " + name + ": not Intel Open Image Denoise 2.x");
    fn = reinterpret_cast<std::remove_reference_t<decltype(fn)>>(s);
  };
  try {
    bind(api_->new_device, "oidnNewDevice");
    bind(api_->new_cuda_device, "oidnNewCUDADevice");
    bind(api_->commit_device, "oidnCommitDevice");
    bind(api_->release_device, "oidnReleaseDevice");
    bind(api_->get_device_error, "oidnGetDeviceError");
    bind(api_->is_cuda_device_supported, "oidnIsCUDADeviceSupported");
    bind(api_->new_buffer, "oidnNewBuffer");
    bind(api_->write_buffer, "oidnWriteBuffer");
    bind(api_->read_buffer, "oidnReadBuffer");
    bind(api_->release_buffer, "oidnReleaseBuffer");
    bind(api_->new_filter, "oidnNewFilter");
    bind(api_->set_filter_image, "oidnSetFilterImage");
    bind(api_->set_shared_filter_image, "oidnSetSharedFilterImage");
    bind(api_->set_filter_bool, "oidnSetFilterBool");
    bind(api_->set_filter_int, "oidnSetFilterInt");
    bind(api_->commit_filter, "oidnCommitFilter");
    bind(api_->execute_filter, "oidnExecuteFilter");
    bind(api_->release_filter, "oidnReleaseFilter");
  } catch (...) {
    dlclose(handle_);
    throw;
  }
}

// A committed filter and what it was committed for: its device, size, guides and options, and its images (OIDN's
// buffers that host images are copied into and out of, or shared device images).
struct Oidn::KeptFilter {
  const Api* api = nullptr;
  void* device = nullptr;
  void* filter = nullptr;
  void* buffers[4] = {nullptr, nullptr, nullptr, nullptr};  // host images: color, albedo, normal, output
  int width = 0, height = 0;
  bool albedo = false, normal = false;
  OidnFilterOptions options;
  OidnDeviceImages shared;  // device images

  explicit KeptFilter(const Api* a) : api(a) {}
  KeptFilter(const KeptFilter&) = delete;
  KeptFilter& operator=(const KeptFilter&) = delete;
  ~KeptFilter() {
    if (filter) api->release_filter(filter);
    for (void* b : buffers)
      if (b) api->release_buffer(b);
  }
  bool same(void* d, int w, int h, bool a, bool n, const OidnFilterOptions& o) const {
    return device == d && width == w && height == h && albedo == a && normal == n && options.quality == o.quality &&
           options.clean_aux == o.clean_aux;
  }
};

Oidn::~Oidn() {
  host_filter_.reset();
  device_filter_.reset();
  if (cpu_device_) api_->release_device(cpu_device_);
  if (cuda_device_) api_->release_device(cuda_device_);
  for (auto& [id, d] : cuda_devices_) api_->release_device(d);
  // The library stays open: OIDN's device modules may keep threads that must not outlive their code.
}

bool Oidn::cuda_supported(int cuda_device) const { return api_->is_cuda_device_supported(cuda_device); }

void Oidn::release_filters() {
  std::lock_guard<std::mutex> lock(mutex_);
  host_filter_.reset();
  device_filter_.reset();
}

void Oidn::check_device(void* device, const char* what) {
  const char* message = nullptr;
  if (api_->get_device_error(device, &message) != kErrorNone)
    throw std::runtime_error(std::string("Intel Open Image Denoise, ") + what + ": " +
                             (message ? message : "unknown error"));
}

// Commits a device just made, or releases it and throws one line naming `what` where OIDN reports an error.
void* Oidn::committed(void* made, const std::string& what) {
  if (!made) throw std::runtime_error("Intel Open Image Denoise (" + library_ + ") made no " + what);
  api_->commit_device(made);
  const char* message = nullptr;
  if (api_->get_device_error(made, &message) != kErrorNone) {
    const std::string m = message ? message : "unknown error";
    api_->release_device(made);
    throw std::runtime_error("Intel Open Image Denoise's " + what + ": " + m);
  }
  return made;
}

void* Oidn::cuda_device_for(int cuda_device) {
  for (auto& [id, d] : cuda_devices_)
    if (id == cuda_device) return d;
  if (!api_->is_cuda_device_supported(cuda_device))
    throw std::runtime_error("Intel Open Image Denoise (" + library_ + ") cannot use CUDA device " +
                             std::to_string(cuda_device));
  void* const default_stream = nullptr;  // OIDN's work on the device's default stream, finished when it returns
  void* d = committed(api_->new_cuda_device(&cuda_device, &default_stream, 1),
                      "CUDA device " + std::to_string(cuda_device));
  cuda_devices_.emplace_back(cuda_device, d);
  return d;
}

void* Oidn::device_for(OidnDeviceKind kind) {
  void*& d = kind == OidnDeviceKind::Cpu ? cpu_device_ : cuda_device_;
  if (!d)
    d = committed(api_->new_device(kind == OidnDeviceKind::Cpu ? kDeviceCpu : kDeviceCuda),
                  kind == OidnDeviceKind::Cpu ? "CPU device" : "CUDA device");
  return d;
}

std::vector<float> Oidn::denoise(OidnDeviceKind kind, int width, int height, const std::vector<float>& color,
                                 const std::vector<float>& albedo, const std::vector<float>& normal,
                                 const OidnFilterOptions& options, double* ms, size_t* repaired) {
  std::lock_guard<std::mutex> lock(mutex_);
  const size_t n = size_t(width) * size_t(height) * 3;
  if (width <= 0 || height <= 0 || color.size() != n)
    throw std::runtime_error("denoise: the image holds " + std::to_string(color.size()) + " values, not " +
                             std::to_string(width) + " x " + std::to_string(height) + " x 3");
  if (!albedo.empty() && albedo.size() != n)
    throw std::runtime_error("denoise: the albedo guide holds " + std::to_string(albedo.size()) + " values, not " +
                             std::to_string(n) + " (the image's size)");
  if (!normal.empty() && normal.size() != n)
    throw std::runtime_error("denoise: the normal guide holds " + std::to_string(normal.size()) + " values, not " +
                             std::to_string(n) + " (the image's size)");
  if (!normal.empty() && albedo.empty())
    throw std::runtime_error("denoise: a normal guide needs an albedo guide (Intel Open Image Denoise's rule)");
  // Not-finite values would spread over the filter's whole receptive field: 0 instead, counted.
  std::vector<float> in = color;
  size_t bad = 0;
  for (float& v : in)
    if (!std::isfinite(v)) v = 0.f, ++bad;
  if (repaired) *repaired = bad;

  void* device = device_for(kind);
  const bool has_albedo = !albedo.empty(), has_normal = !normal.empty();
  const size_t bytes = n * sizeof(float);
  try {
    if (!host_filter_ || !host_filter_->same(device, width, height, has_albedo, has_normal, options)) {
      host_filter_.reset();
      auto k = std::make_unique<KeptFilter>(api_.get());
      k->device = device;
      k->width = width, k->height = height;
      k->albedo = has_albedo, k->normal = has_normal;
      k->options = options;
      const bool used[4] = {true, has_albedo, has_normal, true};
      for (int i = 0; i < 4; ++i)
        if (used[i]) {
          k->buffers[i] = api_->new_buffer(device, bytes);
          check_device(device, "allocating an image");
        }
      k->filter = api_->new_filter(device, "RT");
      check_device(device, "making the filter");
      const char* names[4] = {"color", "albedo", "normal", "output"};
      for (int i = 0; i < 4; ++i)
        if (k->buffers[i])
          api_->set_filter_image(k->filter, names[i], k->buffers[i], kFormatFloat3, width, height, 0, 0, 0);
      api_->set_filter_bool(k->filter, "hdr", true);
      if (has_albedo) api_->set_filter_bool(k->filter, "cleanAux", options.clean_aux);
      api_->set_filter_int(k->filter, "quality", quality_value(options.quality));
      api_->commit_filter(k->filter);
      check_device(device, "setting up the filter");
      host_filter_ = std::move(k);
    }
    KeptFilter& k = *host_filter_;
    const std::vector<float>* sources[3] = {&in, has_albedo ? &albedo : nullptr, has_normal ? &normal : nullptr};
    for (int i = 0; i < 3; ++i)
      if (sources[i]) api_->write_buffer(k.buffers[i], 0, bytes, sources[i]->data());
    check_device(device, "copying the images in");
    const auto t0 = std::chrono::steady_clock::now();
    api_->execute_filter(k.filter);
    check_device(device, "denoising");
    if (ms) *ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
    std::vector<float> out(n);
    api_->read_buffer(k.buffers[3], 0, bytes, out.data());
    check_device(device, "copying the image out");
    return out;
  } catch (...) {
    host_filter_.reset();  // made again next time
    throw;
  }
}

void Oidn::denoise_device(const OidnDeviceImages& images, const OidnFilterOptions& options, double* ms) {
  std::lock_guard<std::mutex> lock(mutex_);
  if (images.width <= 0 || images.height <= 0 || !images.color || !images.output)
    throw std::runtime_error("denoise: no device image of " + std::to_string(images.width) + " x " +
                             std::to_string(images.height) + " pixels to denoise");
  if (images.normal && !images.albedo)
    throw std::runtime_error("denoise: a normal guide needs an albedo guide (Intel Open Image Denoise's rule)");
  void* device = cuda_device_for(images.cuda_device);
  try {
    if (!device_filter_ || !(device_filter_->shared == images) ||
        !device_filter_->same(device, images.width, images.height, images.albedo, images.normal, options)) {
      device_filter_.reset();
      auto k = std::make_unique<KeptFilter>(api_.get());
      k->device = device;
      k->width = images.width, k->height = images.height;
      k->albedo = images.albedo != nullptr, k->normal = images.normal != nullptr;
      k->options = options;
      k->shared = images;
      k->filter = api_->new_filter(device, "RT");
      check_device(device, "making the filter");
      const std::pair<const char*, const float*> shared[4] = {
          {"color", images.color}, {"albedo", images.albedo}, {"normal", images.normal}, {"output", images.output}};
      for (const auto& [name, ptr] : shared)
        if (ptr)
          api_->set_shared_filter_image(k->filter, name, const_cast<float*>(ptr), kFormatFloat3, images.width,
                                        images.height, 0, 0, 0);
      api_->set_filter_bool(k->filter, "hdr", true);
      if (images.albedo) api_->set_filter_bool(k->filter, "cleanAux", options.clean_aux);
      api_->set_filter_int(k->filter, "quality", quality_value(options.quality));
      api_->commit_filter(k->filter);
      check_device(device, "setting up the filter on device images");
      device_filter_ = std::move(k);
    }
    const auto t0 = std::chrono::steady_clock::now();
    api_->execute_filter(device_filter_->filter);  // synchronous: the output is written when it returns
    check_device(device, "denoising device images");
    if (ms) *ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
  } catch (...) {
    device_filter_.reset();
    throw;
  }
}

namespace {

// Every library opened so far. Never destroyed: a CUDA device released after CUDA's own teardown would fail.
std::mutex loaded_mutex;
std::map<std::string, std::unique_ptr<Oidn>>& loaded() {
  static auto* l = new std::map<std::string, std::unique_ptr<Oidn>>();
  return *l;
}

}  // namespace

Oidn& oidn_for(const std::string& library) {
  std::lock_guard<std::mutex> lock(loaded_mutex);
  std::unique_ptr<Oidn>& o = loaded()[library];
  if (!o) o = std::make_unique<Oidn>(library);
  return *o;
}

void release_oidn_filters() {
  std::lock_guard<std::mutex> lock(loaded_mutex);
  for (auto& [path, o] : loaded())
    if (o) o->release_filters();
}

}  // namespace pn
