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
#include <utility>
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

// Images in CUDA device memory, 3 floats a pixel, row 0 at the top, all of one
// size, on GPU `cuda_device`: OIDN's CUDA device reads and writes them where they
// are (shared, never copied through the host).
struct OidnDeviceImages {
  int cuda_device = 0;
  int width = 0, height = 0;
  const float* color = nullptr;   // finite values (the caller repairs the rest)
  const float* albedo = nullptr;  // optional guide
  const float* normal = nullptr;  // optional guide; needs albedo
  float* output = nullptr;
  bool operator==(const OidnDeviceImages& o) const {
    return cuda_device == o.cuda_device && width == o.width && height == o.height && color == o.color &&
           albedo == o.albedo && normal == o.normal && output == o.output;
  }
};

// The loaded library and one device of it, made on first use. A filter is kept
// between calls while the size, the guides and the options stay the same: OIDN
// loads its weights and sizes its scratch memory when a filter is committed,
// which costs more than a 1080p execution (a viewer denoises every frame).
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

  // Denoises images in GPU memory on that GPU by OIDN's CUDA device, output
  // written when this returns. Throws with one line (OIDN's error; no CUDA
  // device in this OIDN). *ms: host clock around the execution.
  void denoise_device(const OidnDeviceImages& images, const OidnFilterOptions& options, double* ms = nullptr);

  // Whether OIDN can use the CUDA device `cuda_device` (false where its CUDA
  // module is missing or no such GPU exists).
  bool cuda_supported(int cuda_device) const;

  // Releases the filters kept between calls (their buffers and scratch memory);
  // the devices stay.
  void release_filters();

 private:
  struct Api;
  struct KeptFilter;
  void* device_for(OidnDeviceKind kind);
  void* cuda_device_for(int cuda_device);
  void* committed(void* made, const std::string& what);
  void check_device(void* device, const char* what);
  std::string library_;
  void* handle_ = nullptr;
  std::unique_ptr<Api> api_;
  void* cpu_device_ = nullptr;
  void* cuda_device_ = nullptr;  // oidnNewDevice's choice of GPU (host images)
  std::vector<std::pair<int, void*>> cuda_devices_;  // one a GPU, for images in its memory
  std::unique_ptr<KeptFilter> host_filter_, device_filter_;
  std::mutex mutex_;  // a device is used by one thread at a time
};

// Releases the kept filters of every library opened so far (release_denoisers).
void release_oidn_filters();

// The library opened once per process for each path (a device is costly to make).
Oidn& oidn_for(const std::string& library);

}  // namespace pn
