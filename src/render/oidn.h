// Intel Open Image Denoise (OIDN 2.x), loaded at run time. penumbra neither
// vendors nor links it: the library is opened with dlopen from a path the
// application found (the PyPI wheel `pyoidn` ships OIDN's libraries, and
// penumbra's apps look there; see find_oidn_library in src/apps/options.h) or,
// with no path, by its soname from the system's library path. Only the few
// entry points of OIDN's C API that denoising needs are looked up, each by name.
#pragma once

#include <memory>
#include <mutex>
#include <string>
#include <vector>

namespace pn {

enum class DenoiseQuality { Fast, Balanced, High };
const char* denoise_quality_name(DenoiseQuality q);

// OIDN's devices penumbra uses: its CPU device (all cores), or its CUDA device
// (the GPU backend's GPU).
enum class OidnDeviceKind { Cpu, Cuda };

struct OidnFilterOptions {
  DenoiseQuality quality = DenoiseQuality::High;
  // OIDN's cleanAux: the guides are taken as noise-free (penumbra's are the mean of
  // several camera rays a pixel, noisy only where those rays disagree).
  bool clean_aux = false;
};

// The loaded library and one device of it, made on first use.
class Oidn {
 public:
  // Opens `library` (a path; empty: "libOpenImageDenoise.so.2" from the system's
  // library path) and looks up the entry points. Throws std::runtime_error with
  // one line naming the library and what failed.
  explicit Oidn(const std::string& library);
  ~Oidn();
  Oidn(const Oidn&) = delete;
  Oidn& operator=(const Oidn&) = delete;

  const std::string& library() const { return library_; }

  // The denoised image of `color` (width * height * 3 floats, linear HDR), with
  // albedo and normal guides where they are non-empty (the same size). Pixels
  // that are not finite are set to 0 before denoising and counted in
  // *repaired. Throws with one line on an OIDN error or on guides of another
  // size. *ms: host clock around the filter's execution.
  std::vector<float> denoise(OidnDeviceKind device, int width, int height, const std::vector<float>& color,
                             const std::vector<float>& albedo, const std::vector<float>& normal,
                             const OidnFilterOptions& options, double* ms = nullptr, size_t* repaired = nullptr);

  // Whether OIDN can use the CUDA device `cuda_device` (false where its CUDA
  // module is missing or no such GPU exists).
  bool cuda_supported(int cuda_device) const;

 private:
  struct Api;
  void* device_for(OidnDeviceKind kind);
  std::string library_;
  void* handle_ = nullptr;
  std::unique_ptr<Api> api_;
  void* cpu_device_ = nullptr;
  void* cuda_device_ = nullptr;
  std::mutex mutex_;  // a device is used by one thread at a time
};

// The library opened once per process for each path (a device is costly to make).
Oidn& oidn_for(const std::string& library);

}  // namespace pn
