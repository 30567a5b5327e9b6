// OptiX backend, host side: device and context, acceleration structures (one
// compacted GAS per mesh, one GAS of spheres, an IAS over all instances), the
// scene's arrays and textures in device memory (the core SceneView the device
// programs shade with), the pipeline built from the embedded OptiX-IR, and
// progressive launches with per-launch CUDA-event timing.
#include "backends/optix/optix_backend.h"

#include <dlfcn.h>

#include <algorithm>
#include <array>
#include <cctype>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <condition_variable>
#include <cstring>
#include <fstream>
#include <mutex>
#include <sstream>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

#include <cuda_runtime.h>
#include <optix.h>
#include <optix_function_table_definition.h>
#include <optix_stack_size.h>
#include <optix_stubs.h>

#include "backends/optix/kernels.h"
#include "backends/optix/launch_params.h"
#include "backends/wavefront/wavefront_gpu.h"
#include "core/geometry.h"
#include "core/restir.h"
#include "core/scene_view.h"
#include "render/resources.h"

// The device programs, OptiX-IR embedded at build time (embed_file.cmake).
extern const unsigned char penumbra_optix_ir[];
extern const size_t penumbra_optix_ir_size;

namespace pn {
namespace {

using optix::LaunchParams;

// ---- Errors: every CUDA and OptiX call is checked; messages are one line. ------

std::string one_line(std::string s) {
  for (char& c : s)
    if (c == '\n' || c == '\r') c = ' ';
  while (!s.empty() && s.back() == ' ') s.pop_back();
  return s;
}

// "cudaMalloc(&p, n)" -> "cudaMalloc"
std::string call_name(const char* expr) {
  std::string s(expr);
  size_t paren = s.find('(');
  return paren == std::string::npos ? s : s.substr(0, paren);
}

void check_cuda(cudaError_t e, const char* expr) {
  if (e == cudaSuccess) return;
  throw std::runtime_error("CUDA error in " + call_name(expr) + ": " + cudaGetErrorName(e) + " (" +
                           cudaGetErrorString(e) + ")");
}

void check_optix(OptixResult r, const char* expr, const char* log = nullptr) {
  if (r == OPTIX_SUCCESS) return;
  std::string msg = "OptiX error in " + call_name(expr) + ": " + optixGetErrorName(r) + " (" +
                    optixGetErrorString(r) + ")";
  if (log && *log) msg += ": " + one_line(log);
  throw std::runtime_error(msg);
}

#define PN_CUDA(call) check_cuda((call), #call)
#define PN_OPTIX(call) check_optix((call), #call)
#define PN_OPTIX_LOG(call, log) check_optix((call), #call, (log))


// Device-wide memory in use (all processes), by cudaMemGetInfo; 0 if unknown.
uint64_t device_memory_used() {
  size_t free_b = 0, total_b = 0;
  if (cudaMemGetInfo(&free_b, &total_b) != cudaSuccess) {
    cudaGetLastError();
    return 0;
  }
  return uint64_t(total_b - free_b);
}

std::string optix_version_string(unsigned v) {
  return std::to_string(v / 10000) + "." + std::to_string((v % 10000) / 100) + "." + std::to_string(v % 100);
}

// The NVIDIA driver's version ("580.159.04"): from the kernel module, else NVML.
std::string driver_version() {
  std::ifstream f("/proc/driver/nvidia/version");
  std::string line;
  if (f && std::getline(f, line)) {
    std::istringstream words(line);
    // "NVRM version: NVIDIA UNIX [Open Kernel Module for] x86_64 Kernel Module  580.159.04  Release Build ..."
    std::string w;
    bool after_module = false;
    while (words >> w) {
      if (w == "Module") after_module = true;
      else if (after_module && std::isdigit((unsigned char)w[0]) && w.find('.') != std::string::npos) return w;
    }
  }
  if (void* nvml = dlopen("libnvidia-ml.so.1", RTLD_NOW | RTLD_LOCAL)) {
    using InitFn = int (*)();
    using VersionFn = int (*)(char*, unsigned);
    auto init = reinterpret_cast<InitFn>(dlsym(nvml, "nvmlInit_v2"));
    auto version = reinterpret_cast<VersionFn>(dlsym(nvml, "nvmlSystemGetDriverVersion"));
    auto shutdown = reinterpret_cast<InitFn>(dlsym(nvml, "nvmlShutdown"));
    char buf[96] = {0};
    std::string v;
    if (init && version && init() == 0) {
      if (version(buf, sizeof buf) == 0) v = buf;
      if (shutdown) shutdown();
    }
    dlclose(nvml);
    if (!v.empty()) return v;
  }
  return "unknown";
}

// ---- Availability: checked once per process. -------------------------------------

struct Availability {
  bool ok = false;
  std::string why;
};

const Availability& availability() {
  static Availability a;
  static std::once_flag once;
  std::call_once(once, [] {
    int n = 0;
    cudaError_t e = cudaGetDeviceCount(&n);
    if (e == cudaErrorNoDevice || (e == cudaSuccess && n == 0)) {
      a.why = "no NVIDIA GPU found (cudaGetDeviceCount: no CUDA-capable device)";
      return;
    }
    if (e == cudaErrorInsufficientDriver) {
      if (void* libcuda = dlopen("libcuda.so.1", RTLD_NOW | RTLD_LOCAL)) {
        dlclose(libcuda);
      } else {
        a.why = "no NVIDIA driver found (libcuda.so.1 cannot be loaded)";
        return;
      }
      int rt = 0;
      cudaRuntimeGetVersion(&rt);
      a.why = "the NVIDIA driver is older than this build's CUDA runtime " + std::to_string(rt / 1000) +
              "." + std::to_string((rt % 1000) / 10) + " (cudaGetDeviceCount: " + cudaGetErrorString(e) + ")";
      return;
    }
    if (e != cudaSuccess) {
      a.why = std::string("no usable NVIDIA driver or GPU (cudaGetDeviceCount: ") + cudaGetErrorName(e) + ": " +
              cudaGetErrorString(e) + ")";
      return;
    }
    OptixResult r = optixInit();
    if (r == OPTIX_ERROR_UNSUPPORTED_ABI_VERSION) {
      a.why = "the NVIDIA driver (" + driver_version() + ") does not support the OptiX ABI this penumbra was built with: OptiX " +
              optix_version_string(OPTIX_VERSION) + " (ABI " + std::to_string(OPTIX_ABI_VERSION) +
              "); driver 580 supports up to OptiX 9.0 (ABI 105): rebuild with OptiX 9.0 headers (OptiX_ROOT) or update the driver";
      return;
    }
    if (r == OPTIX_ERROR_LIBRARY_NOT_FOUND || r == OPTIX_ERROR_ENTRY_SYMBOL_NOT_FOUND) {
      a.why = std::string("the NVIDIA driver has no usable OptiX library (libnvoptix.so.1): optixInit: ") +
              optixGetErrorName(r);
      return;
    }
    if (r != OPTIX_SUCCESS) {
      a.why = std::string("optixInit failed: ") + optixGetErrorName(r) + " (" + optixGetErrorString(r) + ")";
      return;
    }
    a.ok = true;
  });
  return a;
}

// ---- Device memory ---------------------------------------------------------------

// What out-of-memory messages say about the scene.
struct SceneSize {
  size_t triangles = 0, meshes = 0, instances = 0, spheres = 0;
  std::string describe() const {
    auto n = [](size_t v, const char* one, const char* many) { return std::to_string(v) + " " + (v == 1 ? one : many); };
    return n(triangles, "triangle", "triangles") + " (" + n(meshes, "mesh", "meshes") + ", " +
           n(instances, "instance", "instances") + "), " + n(spheres, "sphere", "spheres");
  }
};

// The out-of-memory message of a failed allocation (shared by buffers and textures).
[[noreturn]] void throw_out_of_memory(size_t bytes, const std::string& what, const SceneSize& scene) {
  cudaGetLastError();  // clear it
  size_t free_b = 0, total_b = 0;
  cudaMemGetInfo(&free_b, &total_b);
  throw std::runtime_error("out of GPU memory: " + std::to_string(bytes) + " bytes (" + format_bytes(uint64_t(bytes)) +
                           ") requested for " + what + ", " + format_bytes(uint64_t(free_b)) + " of " +
                           format_bytes(uint64_t(total_b)) + " free; scene: " + scene.describe());
}

// Device memory of a scene, estimated on the host from its sizes. The
// acceleration structures use per-primitive bounds that err high (OptiX
// reports the exact sizes only through the device context, per build): a GAS
// keeps about 64 bytes a triangle after compaction, and building the largest
// one needs its temporary and uncompacted buffers (up to 256 bytes a
// triangle) at once; the IAS about 256 bytes an instance with its build.
struct DeviceEstimate {
  uint64_t accels = 0, geometry = 0, textures = 0, frame = 0, fixed = 0;
  int width = 0, height = 0;
  uint64_t total() const { return accels + geometry + textures + frame + fixed; }
  std::string describe() const {
    return "acceleration structures " + format_bytes(accels) + ", geometry and scene arrays " +
           format_bytes(geometry) + ", textures " + format_bytes(textures) + ", a " + std::to_string(width) + "x" +
           std::to_string(height) + " frame " + format_bytes(frame) + ", pipeline " + format_bytes(fixed);
  }
};

DeviceEstimate estimate_device_memory(const Scene& scene) {
  DeviceEstimate e;
  std::vector<bool> used(scene.meshes.size(), false);
  for (const Instance& inst : scene.instances)
    if (inst.mesh < used.size()) used[inst.mesh] = true;
  uint64_t largest = 0;
  for (size_t m = 0; m < scene.meshes.size(); ++m) {
    if (!used[m]) continue;
    const TriangleMesh& mesh = scene.meshes[m];
    const uint64_t tris = mesh.indices.size(), verts = mesh.positions.size();
    const uint64_t per_vertex =
        sizeof(Vec3) + (mesh.normals.empty() ? 0 : sizeof(Vec3)) + (mesh.uvs.empty() ? 0 : sizeof(Vec2));
    // indices, face materials and face lights, one SBT index byte
    e.geometry += verts * per_vertex + tris * (3 * sizeof(uint32_t) + 2 * sizeof(uint32_t) + 1);
    e.accels += 64 * tris;
    largest = std::max(largest, tris);
  }
  const uint64_t n_inst = scene.instances.size(), n_sph = scene.spheres.size();
  e.accels += 256 * largest + 256 * (n_inst + 1) + 128 * n_sph;
  e.geometry += n_inst * (sizeof(InstanceView) + 80) + n_sph * sizeof(SphereView) +
                scene.lights.size() * (sizeof(Light) + sizeof(float)) + scene.materials.size() * sizeof(Material);
  const Environment& env = scene.environment;
  e.geometry += (env.conditional_func.size() + env.conditional_cdf.size() + env.marginal_func.size() +
                 env.marginal_cdf.size()) * sizeof(float);
  e.geometry += scene.light_bvh.bytes();  // the light BVH's nodes and trails
  for (const TextureImage& t : scene.textures) e.textures += t.texels.size() + sizeof(TextureView);
  // Per pixel: the launch's float4 sums (2 x 16), the double sums (2 x 24), the
  // non-finite counts (4) and the display's RGBA8 (4).
  e.width = scene.render.width;
  e.height = scene.render.height;
  e.frame = uint64_t(e.width) * uint64_t(e.height) * 88;
  // restir's frame passes: a shading point and two reservoirs a pixel.
  if (restir_frame_passes(scene.integrator()))
    e.frame += uint64_t(e.width) * uint64_t(e.height) * (sizeof(RestirPixel) + 2 * sizeof(Reservoir));
  e.fixed = uint64_t(64) << 20;  // module, program groups, SBT, stacks, launch parameters
  return e;
}

class DeviceBuffer {
 public:
  DeviceBuffer() = default;
  DeviceBuffer(const DeviceBuffer&) = delete;
  DeviceBuffer& operator=(const DeviceBuffer&) = delete;
  DeviceBuffer(DeviceBuffer&& o) noexcept : ptr_(o.ptr_), size_(o.size_) { o.ptr_ = nullptr, o.size_ = 0; }
  DeviceBuffer& operator=(DeviceBuffer&& o) noexcept {
    if (this != &o) {
      release();
      ptr_ = o.ptr_, size_ = o.size_;
      o.ptr_ = nullptr, o.size_ = 0;
    }
    return *this;
  }
  ~DeviceBuffer() { release(); }

  // Allocates `bytes`; an allocation failure becomes the out-of-memory message.
  void alloc(size_t bytes, const char* what, const SceneSize& scene) {
    release();
    if (bytes == 0) return;
    cudaError_t e = cudaMalloc(&ptr_, bytes);
    if (e == cudaErrorMemoryAllocation) {
      ptr_ = nullptr;
      throw_out_of_memory(bytes, what, scene);
    }
    check_cuda(e, "cudaMalloc");
    size_ = bytes;
  }
  template <class T>
  void upload(const std::vector<T>& v, const char* what, const SceneSize& scene) {
    alloc(v.size() * sizeof(T), what, scene);
    if (!v.empty()) PN_CUDA(cudaMemcpy(ptr_, v.data(), v.size() * sizeof(T), cudaMemcpyHostToDevice));
  }
  void release() {
    if (ptr_) cudaFree(ptr_);  // never throws from a destructor
    ptr_ = nullptr;
    size_ = 0;
  }
  CUdeviceptr dptr() const { return reinterpret_cast<CUdeviceptr>(ptr_); }
  template <class T>
  T* as() const { return static_cast<T*>(ptr_); }
  size_t size() const { return size_; }

 private:
  void* ptr_ = nullptr;
  size_t size_ = 0;
};

// One of Scene::textures as a CUDA array and a texture object with the settings
// core/texture.h describes: 8-bit texels read as normalized floats (sRGB decoded
// by the texture unit before filtering for colour textures), float texels as
// they are; bilinear or nearest; repeat wrapping; normalized coordinates.
class DeviceTexture {
 public:
  DeviceTexture() = default;
  DeviceTexture(const DeviceTexture&) = delete;
  DeviceTexture& operator=(const DeviceTexture&) = delete;
  DeviceTexture(DeviceTexture&& o) noexcept : array_(o.array_), object_(o.object_), bytes_(o.bytes_) {
    o.array_ = nullptr, o.object_ = 0, o.bytes_ = 0;
  }
  ~DeviceTexture() { release(); }

  // An empty image (no texels) becomes one white texel, as the CPU's lookup of
  // an empty texture returns white.
  void create(const TextureImage& image, const SceneSize& scene) {
    release();
    const bool is_float = image.format == TexelFormat::Rgba32f;
    const size_t texel = is_float ? 4 * sizeof(float) : 4;
    int w = image.width, h = image.height;
    const void* texels = image.texels.data();
    static const uint8_t white8[4] = {255, 255, 255, 255};
    static const float white32[4] = {1.f, 1.f, 1.f, 1.f};
    if (w <= 0 || h <= 0 || image.texels.size() < size_t(w) * size_t(h) * texel) {
      w = h = 1;
      texels = is_float ? static_cast<const void*>(white32) : static_cast<const void*>(white8);
    }
    const cudaChannelFormatDesc desc = is_float ? cudaCreateChannelDesc<float4>() : cudaCreateChannelDesc<uchar4>();
    const size_t bytes = size_t(w) * size_t(h) * texel;
    cudaError_t e = cudaMallocArray(&array_, &desc, size_t(w), size_t(h));
    if (e == cudaErrorMemoryAllocation) throw_out_of_memory(bytes, "the texture " + image.path, scene);
    if (e != cudaSuccess) {
      array_ = nullptr;
      throw std::runtime_error(image.path + ": cannot create a " + std::to_string(w) + "x" + std::to_string(h) +
                               " GPU texture (cudaMallocArray: " + cudaGetErrorName(e) + ": " + cudaGetErrorString(e) +
                               ")");
    }
    bytes_ = bytes;
    PN_CUDA(cudaMemcpy2DToArray(array_, 0, 0, texels, size_t(w) * texel, size_t(w) * texel, size_t(h),
                                cudaMemcpyHostToDevice));
    cudaResourceDesc res = {};
    res.resType = cudaResourceTypeArray;
    res.res.array.array = array_;
    cudaTextureDesc td = {};
    td.addressMode[0] = td.addressMode[1] = td.addressMode[2] = cudaAddressModeWrap;
    td.filterMode = image.nearest ? cudaFilterModePoint : cudaFilterModeLinear;
    td.readMode = is_float ? cudaReadModeElementType : cudaReadModeNormalizedFloat;
    td.sRGB = image.format == TexelFormat::Rgba8Srgb ? 1 : 0;
    td.normalizedCoords = 1;
    PN_CUDA(cudaCreateTextureObject(&object_, &res, &td, nullptr));
  }
  void release() {
    if (object_) cudaDestroyTextureObject(object_);  // never throws from a destructor
    if (array_) cudaFreeArray(array_);
    object_ = 0;
    array_ = nullptr;
    bytes_ = 0;
  }
  cudaTextureObject_t object() const { return object_; }
  size_t bytes() const { return bytes_; }

 private:
  cudaArray_t array_ = nullptr;
  cudaTextureObject_t object_ = 0;
  size_t bytes_ = 0;
};

template <class T>
struct alignas(OPTIX_SBT_RECORD_ALIGNMENT) SbtRecord {
  char header[OPTIX_SBT_RECORD_HEADER_SIZE];
  T data;
};
struct Empty {};
using EmptyRecord = SbtRecord<Empty>;

void optix_log(unsigned level, const char* tag, const char* message, void*) {
  std::fprintf(stderr, "optix: [%u][%s] %s\n", level, tag, one_line(message).c_str());
}

// ---- The backend -------------------------------------------------------------------

enum class SphereMode { Builtin, Custom };
// Measured on the H100 (software traversal): see src/backends/optix/NOTES.md.
constexpr SphereMode kDefaultSphereMode = SphereMode::Custom;
// A W x H launch measured faster than a 1D one on the target scene (NOTES.md).
constexpr bool kDefaultLaunch2d = true;

class OptixBackendImpl final : public OptixBackend {
 public:
  OptixBackendImpl(const Scene& scene, const BackendOptions& options) : scene_(scene) {
    const Availability& a = availability();
    if (!a.ok) throw std::runtime_error(a.why);
    spp_per_launch_ = std::max(0, options.spp_per_launch);
    device_ = options.device;
    // Tuning knobs (see NOTES.md): threads per pixel and launch shape.
    if (const char* env = std::getenv("PENUMBRA_OPTIX_PIXELS_PER_THREAD")) pixels_per_thread_ = std::max(1, std::atoi(env));
    if (const char* env = std::getenv("PENUMBRA_OPTIX_LAUNCH")) launch_2d_ = std::string(env) != "1d";
    size_.meshes = scene.meshes.size();
    size_.instances = scene.instances.size();
    size_.spheres = scene.spheres.size();
    for (const Instance& inst : scene.instances)
      if (inst.mesh < scene.meshes.size()) size_.triangles += scene.meshes[inst.mesh].indices.size();
    sphere_mode_ = kDefaultSphereMode;
    if (const char* env = std::getenv("PENUMBRA_OPTIX_SPHERES")) {
      std::string v = env;
      if (v == "builtin") sphere_mode_ = SphereMode::Builtin;
      else if (v == "custom") sphere_mode_ = SphereMode::Custom;
      else if (!v.empty())
        throw std::runtime_error("PENUMBRA_OPTIX_SPHERES must be 'builtin' or 'custom', not '" + v + "'");
    }
    try {
      init_device();
      build_stats_.valid = true;
      build_stats_.device_used_before = device_memory_used();
      check_device_memory();
      build_pipeline();
      build_scene_data();
      build_accels();
      build_sbt();
      if (options.wavefront) build_wavefront(options.traversal);
      build_stats_.device_used_after = device_memory_used();
    } catch (...) {
      destroy();
      throw;
    }
  }
  ~OptixBackendImpl() override { destroy(); }

  std::string name() const override { return "optix"; }
  std::string device_name() const override {
    return gpu_name_ + ", driver " + driver_ + ", OptiX " + optix_version_string(OPTIX_VERSION) + ", spheres " +
           sphere_mode() + (wavefront_ ? ", wavefront (" + wavefront_->traversal() + " traversal)" : "");
  }
  std::string sphere_mode() const override { return sphere_mode_ == SphereMode::Builtin ? "builtin" : "custom"; }
  int cuda_device() const override { return device_; }
  std::vector<std::pair<std::string, std::string>> device_info() const override {
    int drv = 0;
    cudaDriverGetVersion(&drv);
    return {{"gpu", gpu_name_},
            {"compute_capability", std::to_string(props_.major) + "." + std::to_string(props_.minor)},
            {"multiprocessors", std::to_string(props_.multiProcessorCount)},
            {"gpu_memory", format_bytes(uint64_t(props_.totalGlobalMem))},
            {"driver", driver_},
            {"cuda_driver_api", std::to_string(drv / 1000) + "." + std::to_string((drv % 1000) / 10)},
            {"optix", optix_version_string(OPTIX_VERSION) + " (ABI " + std::to_string(OPTIX_ABI_VERSION) + ")"},
            {"kernel", optix::kFeatureLevelNames[feature_level_]},
            {"spheres", sphere_mode()},
            {"rtcore_version", std::to_string(rtcore_version())},
            {"path_tracer", wavefront_ ? "wavefront" : "megakernel"},
            {"traversal", wavefront_ ? wavefront_->traversal() : "optix"},
            {"wavefront_paths", wavefront_ ? std::to_string(wavefront_->capacity()) : "0"},
            {"wavefront_path_bytes", std::to_string(kWavefrontBytesPerPath)},
            {"wavefront_pool", wavefront_ ? format_bytes(wavefront_->device_bytes()) : "0"}};
  }

  RenderStats last_render_stats() const override { return stats_; }
  SceneBuildStats scene_build_stats() const override { return build_stats_; }

  void set_spp_per_launch(int spp) override { spp_per_launch_ = std::max(0, spp); }
  void set_display(bool enabled, float exposure_stops) override {
    display_ = enabled;
    exposure_ = exposure_stops;
  }
  uint64_t accumulated_samples() const override { return accumulated_; }
  const void* device_rgba8() const override { return rgba_.as<void>(); }
  const double* device_sums() const override { return acc_sum_.as<double>(); }
  const double* device_sums_sq() const override { return acc_sum_sq_.as<double>(); }

  void reset(const FrameSpec& frame) override {
    use_device();
    const int W = frame.camera.width, H = frame.camera.height;
    if (W <= 0 || H <= 0) throw std::logic_error("frame size must be positive");
    const size_t pixels = size_t(W) * size_t(H);
    if (W != width_ || H != height_) {
      width_ = W;
      height_ = H;
      launch_sum_.alloc(pixels * sizeof(float4), "the per-launch sample sums", size_);
      launch_sum_sq_.alloc(pixels * sizeof(float4), "the per-launch sample sums", size_);
      acc_sum_.alloc(pixels * 3 * sizeof(double), "the accumulation buffers", size_);
      acc_sum_sq_.alloc(pixels * 3 * sizeof(double), "the accumulation buffers", size_);
      acc_bad_.alloc(pixels * sizeof(unsigned), "the accumulation buffers", size_);
      rgba_.release();
    }
    PN_CUDA(cudaMemsetAsync(acc_sum_.as<void>(), 0, acc_sum_.size(), stream_));
    PN_CUDA(cudaMemsetAsync(acc_sum_sq_.as<void>(), 0, acc_sum_sq_.size(), stream_));
    PN_CUDA(cudaMemsetAsync(acc_bad_.as<void>(), 0, acc_bad_.size(), stream_));
    accumulated_ = 0;
  }

  void accumulate(const FrameSpec& frame, uint32_t first_sample, uint32_t count,
                  const ProgressFn& progress) override {
    use_device();
    const int W = frame.camera.width, H = frame.camera.height;
    if (W != width_ || H != height_) reset(frame);
    const size_t pixels = size_t(W) * size_t(H);
    if (display_) ensure_rgba();
    stats_ = RenderStats();
    PN_CUDA(cudaMemsetAsync(counters_.as<void>(), 0, counters_.size(), stream_));

    LaunchParams p = base_params_;
    p.camera = frame.camera;
    p.integrator = frame.integrator;
    p.seed = frame.seed;
    p.sum = launch_sum_.as<float4>();
    p.sum_sq = launch_sum_sq_.as<float4>();

    const uint32_t per_launch = split_granularity(frame, count);
    // restir with spatial reuse: each sample is a frame of its own passes.
    const bool restir = restir_frame_passes(frame.integrator);
    if (restir && restir_pixels_.size() != pixels * sizeof(RestirPixel)) {
      restir_pixels_.alloc(pixels * sizeof(RestirPixel), "restir's shading points", size_);
      restir_a_.alloc(pixels * sizeof(Reservoir), "restir's reservoirs", size_);
      restir_b_.alloc(pixels * sizeof(Reservoir), "restir's reservoirs", size_);
    }
    const uint32_t launches = count == 0 ? 0 : (count + per_launch - 1) / per_launch;
    const uint64_t total = uint64_t(pixels) * count;
    // The raygen program of the strategy, with or without MIS.
    const int strategy = int(frame.integrator.strategy);
    if (strategy < 0 || strategy >= kNumStrategies || int(frame.integrator.mis) >= kNumMisModes)
      throw std::logic_error("unknown strategy or MIS mode");
    OptixShaderBindingTable sbt = sbt_;
    sbt.raygenRecord = sbt_raygen_.dptr() +
                       CUdeviceptr(optix::raygen_index(frame.integrator.strategy, frame.integrator.mis)) *
                           sizeof(EmptyRecord);
    // A W x H launch, or a 1D launch of pixels / pixels_per_thread threads
    // (see render_pixels in device_programs.cu).
    const bool launch_2d = launch_2d_ && pixels_per_thread_ == 1;
    const unsigned launch_x = launch_2d ? unsigned(W)
                                        : unsigned(std::max<size_t>(1, (pixels + size_t(pixels_per_thread_) - 1) /
                                                                           size_t(pixels_per_thread_)));
    const unsigned launch_y = launch_2d ? unsigned(H) : 1u;
    stats_.launches.resize(launches);

    // Launch j uses event slot j % kSlots; launches run ahead of the host by at
    // most kInFlight, and the host reads each launch's times when it finishes.
    uint32_t collected = 0;
    uint64_t samples_done = 0;
    auto collect = [&](uint32_t j) {
      Slot& s = slots_[j % kSlots];
      PN_CUDA(cudaEventSynchronize(s.end));
      float trace = 0.f, acc = 0.f;
      PN_CUDA(cudaEventElapsedTime(&trace, s.start, s.traced));
      PN_CUDA(cudaEventElapsedTime(&acc, s.traced, s.end));
      stats_.launches[j].trace_ms = trace;
      stats_.launches[j].accumulate_ms = acc;
      samples_done += stats_.launches[j].spp;
      if (progress) progress(samples_done * pixels, total);
    };
    for (uint32_t j = 0; j < launches; ++j) {
      if (j >= kInFlight) collect(collected++);
      const uint32_t spp = std::min(per_launch, count - j * per_launch);
      p.first_sample = first_sample + j * per_launch;
      p.spp = spp;
      stats_.launches[j].spp = spp;
      Slot& s = slots_[j % kSlots];
      // Ordered after the previous launch on the stream; the host copy is staged
      // before cudaMemcpyAsync returns, so `p` may change right after.
      PN_CUDA(cudaEventRecord(s.start, stream_));
      if (restir) {
        launch_restir(p, sbt, unsigned(W), unsigned(H));
      } else if (wavefront_) {
        wavefront_->render(frame, base_params_.scene, feature_level_, p.first_sample, spp, p.sum, p.sum_sq, stream_);
      } else {
        PN_CUDA(cudaMemcpyAsync(params_.as<void>(), &p, sizeof p, cudaMemcpyHostToDevice, stream_));
        PN_OPTIX(optixLaunch(pipeline_, stream_, params_.dptr(), sizeof(LaunchParams), &sbt, launch_x, launch_y, 1));
      }
      PN_CUDA(cudaEventRecord(s.traced, stream_));
      accumulated_ += spp;
      const float scale = std::exp2(exposure_) / float(accumulated_);
      PN_CUDA(optix::launch_accumulate(launch_sum_.as<float4>(), launch_sum_sq_.as<float4>(), pixels,
                                       acc_sum_.as<double>(), acc_sum_sq_.as<double>(),
                                       counters_.as<unsigned long long>(), acc_bad_.as<unsigned>(),
                                       display_ ? rgba_.as<uchar4>() : nullptr,
                                       scale, props_.multiProcessorCount, stream_));
      PN_CUDA(cudaEventRecord(s.end, stream_));
    }
    while (collected < launches) collect(collected++);
    PN_CUDA(cudaStreamSynchronize(stream_));
    unsigned long long counters[2] = {0, 0};
    PN_CUDA(cudaMemcpy(counters, counters_.as<void>(), sizeof counters, cudaMemcpyDeviceToHost));
    stats_.rays = counters[0];
    stats_.nonfinite = counters[1];
    if (stats_.nonfinite > 0) {  // which pixels: the first few, in row order
      std::vector<unsigned> bad(pixels);
      PN_CUDA(cudaMemcpy(bad.data(), acc_bad_.as<void>(), pixels * sizeof(unsigned), cudaMemcpyDeviceToHost));
      for (size_t i = 0; i < pixels && stats_.nonfinite_pixels.size() < RenderStats::kMaxNonfinitePixels; ++i)
        if (bad[i]) note_nonfinite_pixel(stats_, int(i % size_t(W)), int(i / size_t(W)), W);
    }
  }

  // Samples per pixel of each launch of accumulate(frame, ., count).
  uint32_t split_granularity(const FrameSpec& frame, uint32_t count) const override {
    const size_t pixels = std::max<size_t>(1, size_t(frame.camera.width) * size_t(frame.camera.height));
    uint32_t per_launch = uint32_t(spp_per_launch_);
    if (per_launch == 0) {  // automatic: about a million paths per launch
      size_t want = (size_t(1) << 20) / pixels;
      per_launch = uint32_t(std::max<size_t>(1, std::min<size_t>(want, 1024)));
    }
    if (restir_frame_passes(frame.integrator)) per_launch = 1;  // each sample a frame of restir's passes
    return std::min(per_launch, std::max(count, 1u));
  }

  // One sample of every pixel by restir's passes (core/restir.h): the
  // strategy's raygen program as the primary pass, the spatial passes
  // ping-ponging between two reservoir buffers, then shading, which writes the
  // launch sums the accumulation kernel reads. Ordered on the stream; each
  // launch's parameters are staged before cudaMemcpyAsync returns.
  // NOT YET RUN ON A GPU (written and compiled in a session without device
  // time): scripts/gpu_check.sh compares it with the CPU backend.
  void launch_restir(LaunchParams p, const OptixShaderBindingTable& primary_sbt, unsigned W, unsigned H) {
    p.restir_pixels = restir_pixels_.as<RestirPixel>();
    p.restir_in = restir_a_.as<Reservoir>();
    p.restir_out = restir_b_.as<Reservoir>();
    p.spp = 1;
    PN_CUDA(cudaMemcpyAsync(params_.as<void>(), &p, sizeof p, cudaMemcpyHostToDevice, stream_));
    PN_OPTIX(optixLaunch(pipeline_, stream_, params_.dptr(), sizeof(LaunchParams), &primary_sbt, W, H, 1));
    OptixShaderBindingTable sbt = primary_sbt;
    sbt.raygenRecord = sbt_raygen_.dptr() + CUdeviceptr(optix::kRaygenRestirSpatial) * sizeof(EmptyRecord);
    for (uint32_t pass = 0; pass < p.integrator.restir.spatial_passes; ++pass) {
      p.restir_pass = pass;
      PN_CUDA(cudaMemcpyAsync(params_.as<void>(), &p, sizeof p, cudaMemcpyHostToDevice, stream_));
      PN_OPTIX(optixLaunch(pipeline_, stream_, params_.dptr(), sizeof(LaunchParams), &sbt, W, H, 1));
      std::swap(p.restir_in, p.restir_out);
    }
    sbt.raygenRecord = sbt_raygen_.dptr() + CUdeviceptr(optix::kRaygenRestirShade) * sizeof(EmptyRecord);
    PN_CUDA(cudaMemcpyAsync(params_.as<void>(), &p, sizeof p, cudaMemcpyHostToDevice, stream_));
    PN_OPTIX(optixLaunch(pipeline_, stream_, params_.dptr(), sizeof(LaunchParams), &sbt, W, H, 1));
  }

  void trace_closest(const TraceRay* rays, uint32_t count, HitRecord* hits) override {
    LaunchParams p = base_params_;
    p.trace_rays = rays;
    p.trace_hits = hits;
    p.trace_count = count;
    launch_trace(p, optix::kRaygenTraceClosest);
  }
  void trace_shadow(const TraceRay* rays, uint32_t count, uint32_t* blocked_bits) override {
    use_device();
    PN_CUDA(cudaMemsetAsync(blocked_bits, 0, trace_bit_words(count) * sizeof(uint32_t), stream_));
    LaunchParams p = base_params_;
    p.trace_rays = rays;
    p.trace_bits = blocked_bits;
    p.trace_count = count;
    launch_trace(p, optix::kRaygenTraceShadow);
  }
  void* cuda_stream() const override { return stream_; }
  SceneView device_scene_view() const override { return base_params_.scene; }
  unsigned rtcore_version() const override {
    unsigned v = 0;
    PN_OPTIX(optixDeviceContextGetProperty(context_, OPTIX_DEVICE_PROPERTY_RTCORE_VERSION, &v, sizeof v));
    return v;
  }

  // The trace stage's optix implementation for the wavefront: the same trace-only raygens, their launch
  // parameters uploaded once per queue (bind), launched at the pool's width with the queue's length read on the
  // device (LaunchParams::trace_count_device), so that a CUDA graph can record the launches.
  class OptixTraceStage final : public WavefrontTraceStage {
   public:
    explicit OptixTraceStage(OptixBackendImpl& b) : b_(b) {}
    void bind(const Queues& q) override {
      capacity_ = q.capacity;
      bits_ = q.blocked_bits;
      LaunchParams p[3] = {b_.base_params_, b_.base_params_, b_.base_params_};
      for (int k = 0; k < 3; ++k) p[k].trace_count = q.capacity;
      for (int k = 0; k < 2; ++k) {
        p[k].trace_rays = q.closest_rays[k];
        p[k].trace_count_device = q.closest_count[k];
        p[k].trace_hits = q.hits;
      }
      p[2].trace_rays = q.shadow_rays;
      p[2].trace_count_device = q.shadow_count;
      p[2].trace_bits = q.blocked_bits;
      params_.alloc(sizeof p, "the wavefront's trace parameters", b_.size_);
      PN_CUDA(cudaMemcpy(params_.as<void>(), p, sizeof p, cudaMemcpyHostToDevice));
      for (int k = 0; k < 2; ++k) {
        sbt_[k] = b_.sbt_;
        sbt_[k].raygenRecord = b_.sbt_raygen_.dptr() + CUdeviceptr(optix::kRaygenTraceClosest) * sizeof(EmptyRecord);
      }
      sbt_[2] = b_.sbt_;
      sbt_[2].raygenRecord = b_.sbt_raygen_.dptr() + CUdeviceptr(optix::kRaygenTraceShadow) * sizeof(EmptyRecord);
    }
    void closest(int queue, void* stream) override { launch(queue, stream); }
    void shadow(void* stream) override {
      PN_CUDA(cudaMemsetAsync(bits_, 0, trace_bit_words(capacity_) * sizeof(uint32_t),
                              static_cast<cudaStream_t>(stream)));
      launch(2, stream);
    }
    std::string name() const override { return "optix"; }

   private:
    void launch(int k, void* stream) {
      PN_OPTIX(optixLaunch(b_.pipeline_, static_cast<cudaStream_t>(stream),
                           params_.dptr() + CUdeviceptr(k) * sizeof(LaunchParams), sizeof(LaunchParams), &sbt_[k],
                           capacity_, 1, 1));
    }
    OptixBackendImpl& b_;
    DeviceBuffer params_;
    OptixShaderBindingTable sbt_[3] = {};
    uint32_t capacity_ = 0;
    uint32_t* bits_ = nullptr;
  };

  // --wavefront: the path pool and its trace stage (--traversal; auto: OptiX where the GPU has RT cores).
  void build_wavefront(const std::string& traversal) {
    const unsigned rt = rtcore_version();
    std::string choice = traversal;
    if (traversal == "auto") choice = rt > 0 ? "optix" : "cuda";
    else if (traversal != "optix" && traversal != "cuda")
      throw std::runtime_error("--traversal must be auto, optix or cuda, not '" + traversal + "'");
    std::fprintf(stderr, "wavefront on GPU %d: traversal %s%s (OPTIX_DEVICE_PROPERTY_RTCORE_VERSION %u: %s)\n",
                 device_, choice.c_str(), traversal == "auto" ? " (auto)" : "", rt,
                 rt > 0 ? "RT cores" : "no RT cores");
    std::unique_ptr<WavefrontTraceStage> stage;
    if (choice == "optix") stage = std::make_unique<OptixTraceStage>(*this);
    else stage = make_cuda_trace_stage(scene_, base_params_.scene);
    wavefront_ = std::make_unique<WavefrontGpu>(std::move(stage), wavefront_default_paths(),
                                                props_.multiProcessorCount);
  }

  void launch_trace(const LaunchParams& p, uint32_t raygen) {
    if (p.trace_count == 0) return;
    use_device();
    OptixShaderBindingTable sbt = sbt_;
    sbt.raygenRecord = sbt_raygen_.dptr() + CUdeviceptr(raygen) * sizeof(EmptyRecord);
    PN_CUDA(cudaMemcpyAsync(params_.as<void>(), &p, sizeof p, cudaMemcpyHostToDevice, stream_));
    PN_OPTIX(optixLaunch(pipeline_, stream_, params_.dptr(), sizeof(LaunchParams), &sbt, p.trace_count, 1, 1));
  }

  void render(const FrameSpec& frame, Film& film, uint32_t first_sample, uint32_t count,
              const ProgressFn& progress) override {
    use_device();
    const int W = frame.camera.width, H = frame.camera.height;
    if (film.width() != W || film.height() != H) throw std::logic_error("film size differs from the camera's");
    reset(frame);
    accumulate(frame, first_sample, count, progress);
    const size_t n = size_t(W) * size_t(H) * 3;
    host_.resize(n);
    PN_CUDA(cudaMemcpy(host_.data(), acc_sum_.as<void>(), n * sizeof(double), cudaMemcpyDeviceToHost));
    double* sum = film.sum();
    for (size_t i = 0; i < n; ++i) sum[i] += host_[i];
    PN_CUDA(cudaMemcpy(host_.data(), acc_sum_sq_.as<void>(), n * sizeof(double), cudaMemcpyDeviceToHost));
    double* sum_sq = film.sum_sq();
    for (size_t i = 0; i < n; ++i) sum_sq[i] += host_[i];
    film.add_samples(count);
  }

  // The denoiser's guides: one W x H launch of the guides' raygen program
  // (core/aov.h), float4 images on the device, copied out as RGB floats.
  GuideImages render_guides(const FrameSpec& frame, uint32_t samples) override {
    use_device();
    const int W = frame.camera.width, H = frame.camera.height;
    if (W <= 0 || H <= 0) throw std::logic_error("frame size must be positive");
    const size_t pixels = size_t(W) * size_t(H);
    DeviceBuffer albedo, normal;
    albedo.alloc(pixels * sizeof(float4), "the denoiser's albedo guide", size_);
    normal.alloc(pixels * sizeof(float4), "the denoiser's normal guide", size_);
    LaunchParams p = base_params_;
    p.camera = frame.camera;
    p.integrator = frame.integrator;
    p.seed = frame.seed;
    p.first_sample = 0;
    p.spp = samples;
    p.guide_albedo = albedo.as<float4>();
    p.guide_normal = normal.as<float4>();
    OptixShaderBindingTable sbt = sbt_;
    sbt.raygenRecord = sbt_raygen_.dptr() + CUdeviceptr(optix::kRaygenGuides) * sizeof(EmptyRecord);
    PN_CUDA(cudaMemcpyAsync(params_.as<void>(), &p, sizeof p, cudaMemcpyHostToDevice, stream_));
    PN_OPTIX(optixLaunch(pipeline_, stream_, params_.dptr(), sizeof(LaunchParams), &sbt, unsigned(W), unsigned(H), 1));
    PN_CUDA(cudaStreamSynchronize(stream_));
    std::vector<float4> a(pixels), n(pixels);
    PN_CUDA(cudaMemcpy(a.data(), albedo.as<void>(), pixels * sizeof(float4), cudaMemcpyDeviceToHost));
    PN_CUDA(cudaMemcpy(n.data(), normal.as<void>(), pixels * sizeof(float4), cudaMemcpyDeviceToHost));
    GuideImages g;
    g.width = W;
    g.height = H;
    g.albedo.resize(pixels * 3);
    g.normal.resize(pixels * 3);
    for (size_t i = 0; i < pixels; ++i) {
      g.albedo[3 * i] = a[i].x, g.albedo[3 * i + 1] = a[i].y, g.albedo[3 * i + 2] = a[i].z;
      g.normal[3 * i] = n[i].x, g.normal[3 * i + 1] = n[i].y, g.normal[3 * i + 2] = n[i].z;
    }
    return g;
  }

  void tonemap(float exposure_stops) override {
    use_device();
    if (width_ <= 0) throw std::logic_error("tonemap() before any frame");
    ensure_rgba();
    const size_t pixels = size_t(width_) * size_t(height_);
    const float scale = accumulated_ ? std::exp2(exposure_stops) / float(accumulated_) : 0.f;
    PN_CUDA(optix::launch_tonemap(acc_sum_.as<double>(), pixels, scale, rgba_.as<uchar4>(),
                                  props_.multiProcessorCount, stream_));
    PN_CUDA(cudaStreamSynchronize(stream_));
  }

  std::vector<uint8_t> download_rgba8() const override {
    std::vector<uint8_t> out;
    if (!rgba_.size()) return out;
    out.resize(rgba_.size());
    use_device();
    PN_CUDA(cudaStreamSynchronize(stream_));
    PN_CUDA(cudaMemcpy(out.data(), rgba_.as<void>(), out.size(), cudaMemcpyDeviceToHost));
    return out;
  }

 private:
  static constexpr uint32_t kSlots = 8, kInFlight = 3;
  struct Slot {
    cudaEvent_t start = nullptr, traced = nullptr, end = nullptr;
  };

  // CUDA's current device is per host thread: every method that calls CUDA on
  // this backend's memory sets it first.
  void use_device() const { PN_CUDA(cudaSetDevice(device_)); }

  void init_device() {
    int count = 0;
    PN_CUDA(cudaGetDeviceCount(&count));
    if (device_ < 0 || device_ >= count)
      throw std::runtime_error("no GPU " + std::to_string(device_) + " (this machine has " + std::to_string(count) +
                               ")");
    use_device();
    PN_CUDA(cudaFree(nullptr));  // creates the primary context
    PN_CUDA(cudaGetDeviceProperties(&props_, device_));
    gpu_name_ = props_.name;
    driver_ = driver_version();
    PN_CUDA(cudaStreamCreateWithFlags(&stream_, cudaStreamNonBlocking));
    for (Slot& s : slots_) {
      PN_CUDA(cudaEventCreate(&s.start));
      PN_CUDA(cudaEventCreate(&s.traced));
      PN_CUDA(cudaEventCreate(&s.end));
    }
    OptixDeviceContextOptions o = {};
    o.logCallbackFunction = &optix_log;
    o.logCallbackLevel = 2;  // errors
    PN_OPTIX(optixDeviceContextCreate(nullptr, &o, &context_));
    params_.alloc(sizeof(LaunchParams), "the launch parameters", size_);
    counters_.alloc(2 * sizeof(unsigned long long), "the ray counters", size_);
  }

  // What the scene and a frame of its size will take on the device, from their
  // sizes alone (nothing is allocated yet), against what cudaMemGetInfo says is
  // free: one line, instead of running out half-way through the builds.
  void check_device_memory() {
    const DeviceEstimate e = estimate_device_memory(scene_);
    build_stats_.estimated_bytes = e.total();
    size_t free_b = 0, total_b = 0;
    PN_CUDA(cudaMemGetInfo(&free_b, &total_b));
    if (e.total() <= free_b) return;
    throw std::runtime_error(scene_.source + ": needs about " + format_bytes(e.total()) + " of GPU memory (" +
                             e.describe() + "), but " + format_bytes(uint64_t(free_b)) + " of " +
                             format_bytes(uint64_t(total_b)) + " is free on the " + gpu_name_ +
                             "; scene: " + size_.describe());
  }

  void build_pipeline() {
    OptixModuleCompileOptions mco = {};
    mco.maxRegisterCount = OPTIX_COMPILE_DEFAULT_MAX_REGISTER_COUNT;
    if (const char* env = std::getenv("PENUMBRA_OPTIX_MAXREG")) mco.maxRegisterCount = std::atoi(env);  // tuning
    mco.optLevel = OPTIX_COMPILE_OPTIMIZATION_DEFAULT;
    mco.debugLevel = OPTIX_COMPILE_DEBUG_LEVEL_MINIMAL;

    OptixPipelineCompileOptions pco = {};
    pco.usesMotionBlur = 0;
    pco.traversableGraphFlags = OPTIX_TRAVERSABLE_GRAPH_FLAG_ALLOW_SINGLE_LEVEL_INSTANCING;
    pco.numPayloadValues = optix::kNumPayloadValues;
    pco.numAttributeValues = 2;
    pco.exceptionFlags = OPTIX_EXCEPTION_FLAG_NONE;
    pco.pipelineLaunchParamsVariableName = "params";
    pco.usesPrimitiveTypeFlags = OPTIX_PRIMITIVE_TYPE_FLAGS_TRIANGLE |
                                 (sphere_mode_ == SphereMode::Builtin ? OPTIX_PRIMITIVE_TYPE_FLAGS_SPHERE
                                                                      : OPTIX_PRIMITIVE_TYPE_FLAGS_CUSTOM);

    char log[4096];
    size_t log_size = sizeof log;
    log[0] = 0;
    const auto t_compile = std::chrono::steady_clock::now();
    module_ = create_module(mco, pco);
    if (sphere_mode_ == SphereMode::Builtin) {
      OptixBuiltinISOptions bo = {};
      bo.builtinISModuleType = OPTIX_PRIMITIVE_TYPE_SPHERE;
      bo.usesMotionBlur = 0;
      bo.buildFlags = kGasBuildFlags;
      PN_OPTIX(optixBuiltinISModuleGet(context_, &mco, &pco, &bo, &sphere_is_module_));
    }

    OptixProgramGroupOptions pgo = {};
    auto make_group = [&](const OptixProgramGroupDesc& d, OptixProgramGroup* g) {
      log_size = sizeof log;
      log[0] = 0;
      PN_OPTIX_LOG(optixProgramGroupCreate(context_, &d, 1, &pgo, log, &log_size, g), log);
    };
    // The raygen programs of every strategy, without and with MIS, named after
    // the registry's enum, at the smallest feature level that covers the scene.
    const uint32_t features = scene_.features();
    feature_level_ = optix::kNumFeatureLevels - 1;
    for (uint32_t l = 0; l < optix::kNumFeatureLevels; ++l)
      if ((features & ~optix::kFeatureLevels[l]) == 0) {
        feature_level_ = l;
        break;
      }
    OptixProgramGroupDesc d = {};
    static const char* const strategy_enum_names[] = {
#define PN_X(e, name, impl, nee, desc) #e,
        PN_STRATEGIES(PN_X)
#undef PN_X
    };
    raygen_.assign(optix::kNumRaygenPrograms, nullptr);
    for (int i = 0; i < kNumStrategies; ++i)
      for (Mis mis : {Mis::None, Mis::Power}) {
        const std::string entry = std::string("__raygen__") + strategy_enum_names[i] + (mis == Mis::None ? "_" : "_mis_") +
                                  optix::kFeatureLevelNames[feature_level_];
        d = {};
        d.kind = OPTIX_PROGRAM_GROUP_KIND_RAYGEN;
        d.raygen.module = module_;
        d.raygen.entryFunctionName = entry.c_str();
        make_group(d, &raygen_[optix::raygen_index(Strategy(i), mis)]);
      }
    const std::string guides = std::string("__raygen__guides_") + optix::kFeatureLevelNames[feature_level_];
    for (auto [index, entry] : {std::pair<uint32_t, const char*>{optix::kRaygenRestirSpatial, "__raygen__restir_spatial"},
                                {optix::kRaygenRestirShade, "__raygen__restir_shade"},
                                {optix::kRaygenTraceClosest, "__raygen__trace_closest"},
                                {optix::kRaygenTraceShadow, "__raygen__trace_shadow"},
                                {optix::kRaygenGuides, guides.c_str()}}) {
      d = {};
      d.kind = OPTIX_PROGRAM_GROUP_KIND_RAYGEN;
      d.raygen.module = module_;
      d.raygen.entryFunctionName = entry;
      make_group(d, &raygen_[index]);
    }

    d = {};
    d.kind = OPTIX_PROGRAM_GROUP_KIND_MISS;
    d.miss.module = module_;
    d.miss.entryFunctionName = "__miss__radiance";
    make_group(d, &miss_[optix::kMissRadiance]);
    d.miss.entryFunctionName = "__miss__shadow";
    make_group(d, &miss_[optix::kMissShadow]);

    d = {};
    d.kind = OPTIX_PROGRAM_GROUP_KIND_HITGROUP;
    d.hitgroup.moduleCH = module_;
    d.hitgroup.entryFunctionNameCH = "__closesthit__mesh";
    d.hitgroup.moduleAH = module_;  // alpha masks; disabled by the flags of opaque geometry
    d.hitgroup.entryFunctionNameAH = "__anyhit__mesh";
    make_group(d, &hit_[optix::kHitGroupMesh]);

    d = {};
    d.kind = OPTIX_PROGRAM_GROUP_KIND_HITGROUP;
    d.hitgroup.moduleCH = module_;
    d.hitgroup.entryFunctionNameCH = "__closesthit__sphere";
    if (sphere_mode_ == SphereMode::Builtin) {
      d.hitgroup.moduleIS = sphere_is_module_;
      d.hitgroup.entryFunctionNameIS = nullptr;
    } else {
      d.hitgroup.moduleIS = module_;
      d.hitgroup.entryFunctionNameIS = "__intersection__sphere";
    }
    make_group(d, &hit_[optix::kHitGroupSphere]);

    std::vector<OptixProgramGroup> groups = raygen_;
    for (OptixProgramGroup g : {miss_[0], miss_[1], hit_[0], hit_[1]}) groups.push_back(g);
    OptixPipelineLinkOptions plo = {};
    plo.maxTraceDepth = 1;
    log_size = sizeof log;
    log[0] = 0;
    PN_OPTIX_LOG(optixPipelineCreate(context_, &pco, &plo, groups.data(), unsigned(groups.size()), log, &log_size,
                                     &pipeline_),
                 log);

    OptixStackSizes ss = {};
    for (OptixProgramGroup g : groups) PN_OPTIX(optixUtilAccumulateStackSizes(g, &ss, pipeline_));
    unsigned dc_traversal = 0, dc_state = 0, continuation = 0;
    PN_OPTIX(optixUtilComputeStackSizes(&ss, 1, 0, 0, &dc_traversal, &dc_state, &continuation));
    // Graph depth 2: IAS -> GAS.
    PN_OPTIX(optixPipelineSetStackSize(pipeline_, dc_traversal, dc_state, continuation, 2));
    build_stats_.pipeline_ms =
        std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t_compile).count();
  }

  // The module of every program, compiled by OptiX's tasks on all the host's
  // cores: on a cold cache (a new build or driver) the one-threaded
  // optixModuleCreate took 44 s on the H200's host before the first render.
  // With a warm cache the first task finds the module and makes no others.
  OptixModule create_module(const OptixModuleCompileOptions& mco, const OptixPipelineCompileOptions& pco) {
    char log[4096];
    size_t log_size = sizeof log;
    log[0] = 0;
    OptixModule module = nullptr;
    OptixTask first = nullptr;
    PN_OPTIX_LOG(optixModuleCreateWithTasks(context_, &mco, &pco, reinterpret_cast<const char*>(penumbra_optix_ir),
                                            penumbra_optix_ir_size, log, &log_size, &module, &first),
                 log);
    std::mutex m;
    std::condition_variable cv;
    std::vector<OptixTask> queue{first};
    unsigned running = 0;
    OptixResult failed = OPTIX_SUCCESS;
    auto worker = [&]() {
      std::unique_lock<std::mutex> lock(m);
      for (;;) {
        cv.wait(lock, [&]() { return !queue.empty() || running == 0; });
        if (queue.empty()) return;  // nothing queued and nothing running: done
        OptixTask task = queue.back();
        queue.pop_back();
        ++running;
        lock.unlock();
        std::array<OptixTask, 64> more;
        unsigned made = 0;
        const OptixResult r = optixTaskExecute(task, more.data(), unsigned(more.size()), &made);
        lock.lock();
        --running;
        if (r != OPTIX_SUCCESS && failed == OPTIX_SUCCESS) failed = r;
        queue.insert(queue.end(), more.begin(), more.begin() + made);
        cv.notify_all();
      }
    };
    std::vector<std::thread> pool;
    const unsigned n = std::max(1u, std::min(32u, std::thread::hardware_concurrency()));
    for (unsigned i = 1; i < n; ++i) pool.emplace_back(worker);
    worker();
    for (std::thread& t : pool) t.join();
    PN_OPTIX(failed);
    OptixModuleCompileState state = OPTIX_MODULE_COMPILE_STATE_FAILED;
    PN_OPTIX(optixModuleGetCompilationState(module, &state));
    if (state != OPTIX_MODULE_COMPILE_STATE_COMPLETED) {
      optixModuleDestroy(module);
      throw std::runtime_error("OptiX could not compile the device programs (module state " +
                               std::to_string(int(state)) + ")");
    }
    return module;
  }

  // The scene's arrays in device memory and the SceneView that points at them
  // (the device twin of make_host_view in scene/scene.cpp).
  void build_scene_data() {
    auto upload = [&](DeviceBuffer& buf, const auto& v, const char* what) {
      buf.upload(v, what, size_);
      build_stats_.scene_bytes += buf.size();
    };
    // Mesh geometry on the device, once per placed mesh; instances refer to it.
    std::vector<bool> used(scene_.meshes.size(), false);
    for (const Instance& inst : scene_.instances) used.at(inst.mesh) = true;
    meshes_.clear();
    meshes_.resize(scene_.meshes.size());
    for (size_t m = 0; m < scene_.meshes.size(); ++m) {
      if (!used[m]) continue;
      const TriangleMesh& mesh = scene_.meshes[m];
      MeshBuffers& d = meshes_[m];
      upload(d.positions, mesh.positions, "mesh vertices");
      upload(d.indices, mesh.indices, "mesh indices");
      upload(d.normals, mesh.normals, "mesh normals");
      upload(d.uvs, mesh.uvs, "mesh texture coordinates");
      upload(d.face_materials, mesh.face_materials, "mesh face materials");
      upload(d.face_lights, mesh.face_lights, "mesh face lights");
    }
    std::vector<InstanceView> instances;
    instances.reserve(scene_.instances.size());
    for (const Instance& inst : scene_.instances) {
      const TriangleMesh& mesh = scene_.meshes.at(inst.mesh);
      const MeshBuffers& d = meshes_.at(inst.mesh);
      InstanceView v;
      v.to_world = inst.to_world;
      v.to_object = inst.to_object;
      v.mesh.positions = d.positions.as<Vec3>();  // null where the host array is empty
      v.mesh.indices = d.indices.as<uint32_t>();
      v.mesh.normals = d.normals.as<Vec3>();
      v.mesh.uvs = d.uvs.as<Vec2>();
      v.mesh.face_materials = d.face_materials.as<uint32_t>();
      v.mesh.face_lights = d.face_lights.as<int32_t>();
      v.mesh.num_triangles = uint32_t(mesh.indices.size());
      v.material = inst.material;
      v.light = inst.light;
      v.light_base = inst.light_base;
      instances.push_back(v);
    }
    upload(instances_, instances, "instance records");
    std::vector<SphereView> spheres;
    spheres.reserve(scene_.spheres.size());
    for (const Sphere& sp : scene_.spheres) spheres.push_back(SphereView{sp.center, sp.radius, sp.material, sp.light});
    upload(spheres_, spheres, "sphere records");
    upload(lights_, scene_.lights, "lights");
    upload(light_cdf_, scene_.light_cdf, "the light selection CDF");
    upload(light_bvh_nodes_, scene_.light_bvh.nodes, "the light BVH");
    upload(light_bvh_trails_, scene_.light_bvh.trails, "the light BVH");
    upload(materials_, scene_.materials, "materials");

    // Textures: one CUDA array and texture object each.
    textures_.clear();
    textures_.resize(scene_.textures.size());
    std::vector<TextureView> views(scene_.textures.size());
    for (size_t i = 0; i < scene_.textures.size(); ++i) {
      const TextureImage& img = scene_.textures[i];
      textures_[i].create(img, size_);
      build_stats_.texture_bytes += textures_[i].bytes();
      TextureView& v = views[i];
      v.handle = uint64_t(textures_[i].object());
      v.texels = nullptr;
      v.width = img.width;
      v.height = img.height;
      v.format = img.format;
      v.nearest = img.nearest;
    }
    upload(texture_views_, views, "texture records");

    SceneView& v = base_params_.scene;
    v = SceneView();
    v.lights = lights_.as<Light>();
    v.num_lights = uint32_t(scene_.lights.size());
    v.selection = make_light_selection_view(scene_, light_cdf_.as<float>(), light_bvh_nodes_.as<LightBvhNode>(),
                                            light_bvh_trails_.as<uint64_t>());
    v.materials = materials_.as<Material>();
    v.num_materials = uint32_t(scene_.materials.size());
    v.textures = texture_views_.as<TextureView>();
    v.num_textures = uint32_t(views.size());
    v.instances = instances_.as<InstanceView>();
    v.num_instances = uint32_t(instances.size());
    v.spheres = spheres_.as<SphereView>();
    v.num_spheres = uint32_t(spheres.size());
    v.background = scene_.background;
    const Environment& env = scene_.environment;
    if (env.texture >= 0 && size_t(env.texture) < views.size()) {
      EnvironmentView& e = v.environment;
      e.image = views[size_t(env.texture)];
      e.width = uint32_t(e.image.width);
      e.height = uint32_t(e.image.height);
      upload(env_marginal_func_, env.marginal_func, "the environment's distribution");
      upload(env_marginal_cdf_, env.marginal_cdf, "the environment's distribution");
      upload(env_conditional_func_, env.conditional_func, "the environment's distribution");
      upload(env_conditional_cdf_, env.conditional_cdf, "the environment's distribution");
      e.marginal.func = env_marginal_func_.as<float>();
      e.marginal.cdf = env_marginal_cdf_.as<float>();
      e.marginal.n = e.height;
      e.marginal.integral = env.integral;
      e.conditional_func = env_conditional_func_.as<float>();
      e.conditional_cdf = env_conditional_cdf_.as<float>();
      const float rad = env.rotation * kPi / 180.f;
      e.cos_rot = std::cos(rad);
      e.sin_rot = std::sin(rad);
      e.scale = env.scale;
      for (size_t i = 0; i < scene_.lights.size(); ++i)
        if (scene_.lights[i].type == LightType::Environment) v.environment_light = int32_t(i);
    }
  }

  // Whether a triangle's material is alpha-masked (per-face SBT records).
  bool masked_material(uint32_t material) const {
    return material < scene_.materials.size() && scene_.materials[material].alpha_mode == AlphaMode::Mask;
  }

  // Builds one acceleration structure into `out`; compacts GASes.
  OptixTraversableHandle build_accel(const OptixBuildInput& input, unsigned flags, bool compact, DeviceBuffer* out,
                                     const char* what) {
    OptixAccelBuildOptions o = {};
    o.buildFlags = flags | (compact ? unsigned(OPTIX_BUILD_FLAG_ALLOW_COMPACTION) : 0u);
    o.operation = OPTIX_BUILD_OPERATION_BUILD;
    OptixAccelBufferSizes sizes = {};
    PN_OPTIX(optixAccelComputeMemoryUsage(context_, &o, &input, 1, &sizes));
    DeviceBuffer temp, full;
    temp.alloc(std::max<size_t>(sizes.tempSizeInBytes, 8), what, size_);
    full.alloc(sizes.outputSizeInBytes, what, size_);
    OptixAccelEmitDesc emit = {};
    emit.type = OPTIX_PROPERTY_TYPE_COMPACTED_SIZE;
    emit.result = compacted_size_.dptr();
    OptixTraversableHandle handle = 0;
    PN_OPTIX(optixAccelBuild(context_, stream_, &o, &input, 1, temp.dptr(), temp.size(), full.dptr(), full.size(),
                             &handle, compact ? &emit : nullptr, compact ? 1 : 0));
    PN_CUDA(cudaStreamSynchronize(stream_));
    if (!compact) {
      *out = std::move(full);
      return handle;
    }
    uint64_t compacted = 0;
    PN_CUDA(cudaMemcpy(&compacted, compacted_size_.as<void>(), sizeof compacted, cudaMemcpyDeviceToHost));
    if (compacted == 0 || compacted >= full.size()) {
      *out = std::move(full);
      return handle;
    }
    out->alloc(compacted, what, size_);
    PN_OPTIX(optixAccelCompact(context_, stream_, handle, out->dptr(), out->size(), &handle));
    PN_CUDA(cudaStreamSynchronize(stream_));
    return handle;
  }

  void build_accels() {
    compacted_size_.alloc(sizeof(uint64_t), "acceleration structure sizes", size_);
    using Clock = std::chrono::steady_clock;
    auto ms_since = [](Clock::time_point t0) {
      return std::chrono::duration<double, std::milli>(Clock::now() - t0).count();
    };
    // Any-hit (alpha masks) only where a masked material can be hit: per GAS
    // SBT record through the geometry flags, per instance through its flags.
    static const unsigned kOpaque = OPTIX_GEOMETRY_FLAG_DISABLE_ANYHIT;
    static const unsigned kMasked = OPTIX_GEOMETRY_FLAG_NONE;
    static const unsigned kMixed[2] = {kOpaque, kMasked};  // SBT records 0 (opaque) and 1 (masked)

    std::vector<bool> used(scene_.meshes.size(), false), mesh_masked(scene_.meshes.size(), false);
    bool any_masked = false;
    for (const Instance& inst : scene_.instances) {
      used.at(inst.mesh) = true;
      if (scene_.instance_alpha_masked(inst)) mesh_masked[inst.mesh] = true, any_masked = true;
    }
    base_params_.ray_flags = any_masked ? OPTIX_RAY_FLAG_NONE : OPTIX_RAY_FLAG_DISABLE_ANYHIT;

    // One GAS per used, non-empty mesh.
    mesh_gas_.resize(scene_.meshes.size());
    std::vector<OptixTraversableHandle> mesh_handle(scene_.meshes.size(), 0);
    for (size_t m = 0; m < scene_.meshes.size(); ++m) {
      const TriangleMesh& mesh = scene_.meshes[m];
      if (!used[m] || mesh.indices.empty() || mesh.positions.empty()) continue;
      OptixBuildInput in = {};
      in.type = OPTIX_BUILD_INPUT_TYPE_TRIANGLES;
      CUdeviceptr vertices = meshes_[m].positions.dptr();
      in.triangleArray.vertexFormat = OPTIX_VERTEX_FORMAT_FLOAT3;
      in.triangleArray.vertexStrideInBytes = sizeof(Vec3);
      in.triangleArray.numVertices = unsigned(mesh.positions.size());
      in.triangleArray.vertexBuffers = &vertices;
      in.triangleArray.indexFormat = OPTIX_INDICES_FORMAT_UNSIGNED_INT3;
      in.triangleArray.indexStrideInBytes = 3 * sizeof(uint32_t);
      in.triangleArray.numIndexTriplets = unsigned(mesh.indices.size());
      in.triangleArray.indexBuffer = meshes_[m].indices.dptr();
      in.triangleArray.flags = mesh_masked[m] ? &kMasked : &kOpaque;
      in.triangleArray.numSbtRecords = 1;
      // Per-face materials mixing opaque and masked ones: the masked triangles
      // get SBT record 1, the only one whose any-hit program runs.
      DeviceBuffer sbt_index;
      if (mesh_masked[m] && !mesh.face_materials.empty()) {
        std::vector<uint8_t> record(mesh.face_materials.size());
        size_t masked = 0;
        for (size_t t = 0; t < record.size(); ++t) {
          record[t] = masked_material(mesh.face_materials[t]) ? 1 : 0;
          masked += record[t];
        }
        if (masked < record.size()) {
          sbt_index.upload(record, "a mesh's per-triangle SBT indices", size_);
          in.triangleArray.flags = kMixed;
          in.triangleArray.numSbtRecords = 2;
          in.triangleArray.sbtIndexOffsetBuffer = sbt_index.dptr();
          in.triangleArray.sbtIndexOffsetSizeInBytes = 1;
          in.triangleArray.sbtIndexOffsetStrideInBytes = 1;
        }
      }
      const auto t0 = Clock::now();
      mesh_handle[m] = build_accel(in, kGasBuildFlags, true, &mesh_gas_[m], "a mesh's acceleration structure");
      build_stats_.gas_build_ms += ms_since(t0);
      build_stats_.accel_bytes += mesh_gas_[m].size();
      ++build_stats_.gas_count;
    }

    // The spheres' GAS, world space.
    OptixTraversableHandle sphere_handle = 0;
    if (!scene_.spheres.empty()) {
      const size_t n = scene_.spheres.size();
      OptixBuildInput in = {};
      DeviceBuffer centers, radii, aabbs;
      CUdeviceptr centers_ptr = 0, radii_ptr = 0, aabbs_ptr = 0;
      if (sphere_mode_ == SphereMode::Builtin) {
        std::vector<Vec3> c(n);
        std::vector<float> r(n);
        for (size_t i = 0; i < n; ++i) c[i] = scene_.spheres[i].center, r[i] = scene_.spheres[i].radius;
        centers.upload(c, "sphere centres", size_);
        radii.upload(r, "sphere radii", size_);
        centers_ptr = centers.dptr();
        radii_ptr = radii.dptr();
        in.type = OPTIX_BUILD_INPUT_TYPE_SPHERES;
        in.sphereArray.vertexBuffers = &centers_ptr;
        in.sphereArray.vertexStrideInBytes = sizeof(Vec3);
        in.sphereArray.numVertices = unsigned(n);
        in.sphereArray.radiusBuffers = &radii_ptr;
        in.sphereArray.radiusStrideInBytes = sizeof(float);
        in.sphereArray.singleRadius = 0;
        in.sphereArray.flags = &kOpaque;
        in.sphereArray.numSbtRecords = 1;
      } else {
        std::vector<OptixAabb> boxes(n);
        for (size_t i = 0; i < n; ++i) {
          const Sphere& s = scene_.spheres[i];
          const float r = sphere_bounds_radius(s.radius);  // the CPU's bounds too
          boxes[i] = {s.center.x - r, s.center.y - r, s.center.z - r, s.center.x + r, s.center.y + r, s.center.z + r};
        }
        aabbs.upload(boxes, "sphere bounds", size_);
        aabbs_ptr = aabbs.dptr();
        in.type = OPTIX_BUILD_INPUT_TYPE_CUSTOM_PRIMITIVES;
        in.customPrimitiveArray.aabbBuffers = &aabbs_ptr;
        in.customPrimitiveArray.numPrimitives = unsigned(n);
        in.customPrimitiveArray.strideInBytes = sizeof(OptixAabb);
        in.customPrimitiveArray.flags = &kOpaque;
        in.customPrimitiveArray.numSbtRecords = 1;
      }
      const auto t0 = Clock::now();
      sphere_handle = build_accel(in, kGasBuildFlags, true, &sphere_gas_, "the spheres' acceleration structure");
      build_stats_.gas_build_ms += ms_since(t0);
      build_stats_.accel_bytes += sphere_gas_.size();
      ++build_stats_.gas_count;
    }

    // The IAS: every placement of a mesh (instanceId = its index in
    // SceneView::instances), plus the spheres' GAS once with the identity.
    std::vector<OptixInstance> instances;
    const Affine identity;
    for (size_t i = 0; i < scene_.instances.size(); ++i) {
      const Instance& inst = scene_.instances[i];
      if (!mesh_handle[inst.mesh]) continue;
      OptixInstance o = {};
      std::memcpy(o.transform, inst.to_world.m, sizeof o.transform);
      o.instanceId = unsigned(i);
      o.sbtOffset = optix::kSbtMesh;
      o.visibilityMask = 255;
      o.flags = scene_.instance_alpha_masked(inst) ? OPTIX_INSTANCE_FLAG_NONE : OPTIX_INSTANCE_FLAG_DISABLE_ANYHIT;
      o.traversableHandle = mesh_handle[inst.mesh];
      instances.push_back(o);
    }
    if (sphere_handle) {
      OptixInstance o = {};
      std::memcpy(o.transform, identity.m, sizeof o.transform);
      o.instanceId = unsigned(scene_.instances.size());
      o.sbtOffset = optix::kSbtSphere;
      o.visibilityMask = 255;
      o.flags = OPTIX_INSTANCE_FLAG_DISABLE_ANYHIT;
      o.traversableHandle = sphere_handle;
      instances.push_back(o);
    }
    if (instances.empty()) {
      base_params_.handle = 0;  // nothing to hit: every ray runs the miss program
      return;
    }
    DeviceBuffer ias_instances;
    ias_instances.upload(instances, "the instance list", size_);
    OptixBuildInput in = {};
    in.type = OPTIX_BUILD_INPUT_TYPE_INSTANCES;
    in.instanceArray.instances = ias_instances.dptr();
    in.instanceArray.numInstances = unsigned(instances.size());
    const auto t0 = Clock::now();
    base_params_.handle = build_accel(in, OPTIX_BUILD_FLAG_PREFER_FAST_TRACE, false, &ias_, "the instance acceleration structure");
    build_stats_.ias_build_ms = ms_since(t0);
    build_stats_.accel_bytes += ias_.size();
  }

  void build_sbt() {
    std::vector<EmptyRecord> rg(raygen_.size());
    for (size_t i = 0; i < raygen_.size(); ++i) PN_OPTIX(optixSbtRecordPackHeader(raygen_[i], &rg[i]));
    std::vector<EmptyRecord> miss(optix::kNumMissPrograms), hit(optix::kNumHitRecords);
    for (uint32_t i = 0; i < optix::kNumMissPrograms; ++i) PN_OPTIX(optixSbtRecordPackHeader(miss_[i], &miss[i]));
    // Records kSbtMesh and kSbtMesh + 1 (a mixed mesh's masked triangles): the
    // mesh hit group; kSbtSphere: the spheres'.
    for (uint32_t i = 0; i < optix::kNumHitRecords; ++i)
      PN_OPTIX(optixSbtRecordPackHeader(hit_[i < optix::kSbtSphere ? optix::kHitGroupMesh : optix::kHitGroupSphere],
                                        &hit[i]));
    sbt_raygen_.upload(rg, "the shader binding table", size_);
    sbt_miss_.upload(miss, "the shader binding table", size_);
    sbt_hit_.upload(hit, "the shader binding table", size_);
    sbt_ = {};
    sbt_.raygenRecord = sbt_raygen_.dptr();
    sbt_.missRecordBase = sbt_miss_.dptr();
    sbt_.missRecordStrideInBytes = sizeof(EmptyRecord);
    sbt_.missRecordCount = optix::kNumMissPrograms;
    sbt_.hitgroupRecordBase = sbt_hit_.dptr();
    sbt_.hitgroupRecordStrideInBytes = sizeof(EmptyRecord);
    sbt_.hitgroupRecordCount = optix::kNumHitRecords;
  }

  void ensure_rgba() {
    if (!rgba_.size()) rgba_.alloc(size_t(width_) * size_t(height_) * 4, "the display image", size_);
  }

  // Releases everything; used by the destructor and a failed constructor, so it
  // ignores errors (a sticky CUDA error must not hide the first message).
  void destroy() {
    cudaSetDevice(device_);  // unchecked, as everything here
    if (stream_) cudaStreamSynchronize(stream_);
    wavefront_.reset();  // its trace stage holds device memory and launches this pipeline
    if (pipeline_) optixPipelineDestroy(pipeline_);
    for (OptixProgramGroup g : raygen_)
      if (g) optixProgramGroupDestroy(g);
    raygen_.clear();
    for (OptixProgramGroup g : {miss_[0], miss_[1], hit_[0], hit_[1]})
      if (g) optixProgramGroupDestroy(g);
    if (module_) optixModuleDestroy(module_);
    // The built-in IS module belongs to the context.
    if (context_) optixDeviceContextDestroy(context_);
    pipeline_ = nullptr;
    miss_[0] = miss_[1] = hit_[0] = hit_[1] = nullptr;
    module_ = sphere_is_module_ = nullptr;
    context_ = nullptr;
    for (Slot& s : slots_) {
      for (cudaEvent_t* e : {&s.start, &s.traced, &s.end})
        if (*e) cudaEventDestroy(*e), *e = nullptr;
    }
    mesh_gas_.clear();
    meshes_.clear();
    textures_.clear();  // destroys the texture objects and their arrays
    for (DeviceBuffer* b : {&sphere_gas_, &ias_, &instances_, &spheres_, &lights_, &light_cdf_, &light_bvh_nodes_,
                            &light_bvh_trails_, &materials_,
                            &texture_views_, &env_marginal_func_, &env_marginal_cdf_, &env_conditional_func_,
                            &env_conditional_cdf_, &params_, &counters_, &compacted_size_, &sbt_raygen_, &sbt_miss_,
                            &sbt_hit_, &launch_sum_, &launch_sum_sq_, &acc_sum_, &acc_sum_sq_, &acc_bad_, &rgba_,
                            &restir_pixels_, &restir_a_, &restir_b_})
      b->release();
    if (stream_) cudaStreamDestroy(stream_);
    stream_ = nullptr;
  }

  static constexpr unsigned kGasBuildFlags = OPTIX_BUILD_FLAG_PREFER_FAST_TRACE;

  const Scene& scene_;
  SceneSize size_;
  SphereMode sphere_mode_ = SphereMode::Custom;
  uint32_t feature_level_ = optix::kNumFeatureLevels - 1;  // index into kFeatureLevels
  int spp_per_launch_ = 0;
  int device_ = 0;  // the CUDA device
  int pixels_per_thread_ = 1;
  bool launch_2d_ = kDefaultLaunch2d;
  bool display_ = false;
  float exposure_ = 0.f;

  cudaDeviceProp props_ = {};
  std::string gpu_name_, driver_;
  cudaStream_t stream_ = nullptr;
  Slot slots_[kSlots];
  OptixDeviceContext context_ = nullptr;
  OptixModule module_ = nullptr, sphere_is_module_ = nullptr;
  std::vector<OptixProgramGroup> raygen_;  // by optix::raygen_index(strategy, mis), then restir's passes
  OptixProgramGroup miss_[optix::kNumMissPrograms] = {}, hit_[optix::kNumHitGroups] = {};
  OptixPipeline pipeline_ = nullptr;
  OptixShaderBindingTable sbt_ = {};

  // A mesh's arrays on the device (empty buffers, null pointers, for absent ones).
  struct MeshBuffers {
    DeviceBuffer positions, indices, normals, uvs, face_materials, face_lights;
  };
  std::vector<MeshBuffers> meshes_;  // by scene mesh index; unplaced meshes stay empty
  std::vector<DeviceBuffer> mesh_gas_;
  std::vector<DeviceTexture> textures_;  // by scene texture index
  DeviceBuffer sphere_gas_, ias_, instances_, spheres_, lights_, light_cdf_, materials_, texture_views_;
  DeviceBuffer light_bvh_nodes_, light_bvh_trails_;
  DeviceBuffer restir_pixels_, restir_a_, restir_b_;  // restir's passes: shading points, reservoirs (ping-pong)
  DeviceBuffer env_marginal_func_, env_marginal_cdf_, env_conditional_func_, env_conditional_cdf_;
  DeviceBuffer params_, counters_, compacted_size_, sbt_raygen_, sbt_miss_, sbt_hit_;
  DeviceBuffer launch_sum_, launch_sum_sq_, acc_sum_, acc_sum_sq_, acc_bad_, rgba_;
  LaunchParams base_params_;
  std::unique_ptr<WavefrontGpu> wavefront_;  // --wavefront: renders in place of the megakernel (not restir's passes)

  int width_ = 0, height_ = 0;
  uint64_t accumulated_ = 0;
  RenderStats stats_;
  SceneBuildStats build_stats_;
  std::vector<double> host_;
};

}  // namespace

std::unique_ptr<Backend> make_optix_backend(const Scene& scene, const BackendOptions& options) {
  return std::make_unique<OptixBackendImpl>(scene, options);
}

std::unique_ptr<Backend> make_optix_backend(const Scene& scene) { return make_optix_backend(scene, BackendOptions()); }

bool optix_available(std::string* why) {
  const Availability& a = availability();
  if (why) *why = a.ok ? std::string() : a.why;
  return a.ok;
}

int optix_device_count() {
  if (!availability().ok) return 0;
  int n = 0;
  if (cudaGetDeviceCount(&n) != cudaSuccess) {
    cudaGetLastError();
    return 0;
  }
  return n;
}

}  // namespace pn
