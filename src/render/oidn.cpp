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

Oidn::~Oidn() {
  if (cpu_device_) api_->release_device(cpu_device_);
  if (cuda_device_) api_->release_device(cuda_device_);
  // The library stays open: OIDN's device modules may keep threads that must not outlive their code.
}

bool Oidn::cuda_supported(int cuda_device) const { return api_->is_cuda_device_supported(cuda_device); }

void* Oidn::device_for(OidnDeviceKind kind) {
  void*& d = kind == OidnDeviceKind::Cpu ? cpu_device_ : cuda_device_;
  if (d) return d;
  void* made = api_->new_device(kind == OidnDeviceKind::Cpu ? kDeviceCpu : kDeviceCuda);
  const char* message = nullptr;
  if (!made) throw std::runtime_error("Intel Open Image Denoise (" + library_ + ") made no device");
  api_->commit_device(made);
  if (api_->get_device_error(made, &message) != kErrorNone) {
    const std::string m = message ? message : "unknown error";
    api_->release_device(made);
    throw std::runtime_error("Intel Open Image Denoise's " +
                             std::string(kind == OidnDeviceKind::Cpu ? "CPU" : "CUDA") + " device: " + m);
  }
  d = made;
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
  const size_t bytes = n * sizeof(float);
  struct Buffers {
    const Api* api;
    void* b[4] = {nullptr, nullptr, nullptr, nullptr};
    ~Buffers() {
      for (void* x : b)
        if (x) api->release_buffer(x);
    }
  } buffers{api_.get()};
  void* filter = nullptr;
  auto check = [&](const char* what) {
    const char* message = nullptr;
    if (api_->get_device_error(device, &message) != kErrorNone) {
      if (filter) api_->release_filter(filter);
      throw std::runtime_error(std::string("Intel Open Image Denoise, ") + what + ": " +
                               (message ? message : "unknown error"));
    }
  };
  const std::vector<float>* sources[3] = {&in, albedo.empty() ? nullptr : &albedo, normal.empty() ? nullptr : &normal};
  for (int i = 0; i < 4; ++i) {
    if (i < 3 && !sources[i]) continue;
    buffers.b[i] = api_->new_buffer(device, bytes);
    check("allocating an image");
    if (i < 3) api_->write_buffer(buffers.b[i], 0, bytes, sources[i]->data());
  }
  check("copying the images in");
  filter = api_->new_filter(device, "RT");
  check("making the filter");
  const char* names[4] = {"color", "albedo", "normal", "output"};
  for (int i = 0; i < 4; ++i)
    if (buffers.b[i]) api_->set_filter_image(filter, names[i], buffers.b[i], kFormatFloat3, width, height, 0, 0, 0);
  api_->set_filter_bool(filter, "hdr", true);
  if (buffers.b[1]) api_->set_filter_bool(filter, "cleanAux", options.clean_aux);
  api_->set_filter_int(filter, "quality", quality_value(options.quality));
  api_->commit_filter(filter);
  check("setting up the filter");
  const auto t0 = std::chrono::steady_clock::now();
  api_->execute_filter(filter);
  check("denoising");
  if (ms) *ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
  std::vector<float> out(n);
  api_->read_buffer(buffers.b[3], 0, bytes, out.data());
  check("copying the image out");
  api_->release_filter(filter);
  return out;
}

Oidn& oidn_for(const std::string& library) {
  static std::mutex mutex;
  // Never destroyed: a CUDA device released after CUDA's own teardown would fail.
  static auto* loaded = new std::map<std::string, std::unique_ptr<Oidn>>();
  std::lock_guard<std::mutex> lock(mutex);
  std::unique_ptr<Oidn>& o = (*loaded)[library];
  if (!o) o = std::make_unique<Oidn>(library);
  return *o;
}

}  // namespace pn
