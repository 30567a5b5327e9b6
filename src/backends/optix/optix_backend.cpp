// OptiX backend, host side: the launches. A backend holds the device and its
// context (context.h), the scene's arrays and textures in device memory
// (device_memory.h: the SceneView the device programs shade with, built by the
// same build_scene_view as the CPU's), the acceleration structures (accels.h),
// the programs (pipeline.h), and runs progressive launches with per-launch
// CUDA-event timing, restir's frame passes (in the wavefront), the denoiser's guides, and the
// trace-only launches of the wavefront's optix trace stage.
#include "backends/optix/optix_backend.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <stdexcept>
#include <string>
#include <vector>

#include <cuda_runtime.h>
#include <optix.h>
#include <optix_stubs.h>

#include "backends/optix/accels.h"
#include "backends/optix/context.h"
#include "backends/optix/device_memory.h"
#include "backends/optix/kernels.h"
#include "backends/optix/launch_params.h"
#include "backends/optix/pipeline.h"
#include "backends/wavefront/wavefront_gpu.h"
#include "core/geometry.h"
#include "core/restir.h"
#include "core/scene_view.h"
#include "io/host_memory.h"

namespace pn {
namespace {

using namespace optix;  // the backend's parts: context.h, device_memory.h, accels.h, pipeline.h

// ---- The backend -------------------------------------------------------------------

class OptixBackendImpl final : public OptixBackend {
 public:
  OptixBackendImpl(const Scene& scene, const BackendOptions& options) : scene_(scene), tuning_(options.tuning) {
    const Availability& a = availability();
    if (!a.ok) throw std::runtime_error(a.why);
    spp_per_launch_ = std::max(0, options.spp_per_launch);
    device_ = options.device;
    // Tuning knobs (NOTES.md; the defaults there measured): pixels a thread and launch shape, and how spheres are
    // intersected (custom: measured on the H100, software traversal).
    pixels_per_thread_ = std::max(1, tuning_.optix_pixels_per_thread);
    launch_2d_ = tuning_.optix_launch == OptixLaunch::Grid2d;
    sphere_mode_ = tuning_.optix_spheres == OptixSpheres::Builtin ? SphereMode::Builtin : SphereMode::Custom;
    size_.meshes = scene.meshes.size();
    size_.instances = scene.instances.size();
    size_.spheres = scene.spheres.size();
    for (const Instance& inst : scene.instances)
      if (inst.mesh < scene.meshes.size()) size_.triangles += scene.meshes[inst.mesh].indices.size();
    try {
      init_device();
      build_stats_.valid = true;
      build_stats_.device_used_before = device_memory_used();
      check_device_memory();
      pipeline_.build(context_, scene_.features(), sphere_mode_, tuning_.optix_maxreg, size_, build_stats_);
      const PlacedSceneView placed = build_scene_view(scene_, device_scene_);
      build_stats_.scene_bytes = device_scene_.buffer_bytes();
      build_stats_.texture_bytes = device_scene_.texture_bytes();
      base_params_.scene = placed.view;
      accels_.build(context_, stream_, scene_, placed.meshes, sphere_mode_, size_, build_stats_);
      base_params_.handle = accels_.handle();
      base_params_.ray_flags = accels_.ray_flags();
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
            {"kernel", gpu::kFeatureLevelNames[pipeline_.feature_level()]},
            {"spheres", sphere_mode()},
            {"rtcore_version", std::to_string(rtcore_version())},
            {"path_tracer", wavefront_ ? "wavefront" : "megakernel"},
            {"traversal", wavefront_ ? wavefront_->traversal() : "optix"},
            {"wavefront_paths", wavefront_ ? std::to_string(wavefront_->capacity()) : "0"},
            {"wavefront_path_bytes", std::to_string(kWavefrontBytesPerPath)},
            {"wavefront_pool", wavefront_ ? format_bytes(wavefront_->device_bytes()) : "0"},
            {"shadow_order", wavefront_ ? wavefront_->shadow_order_reason() : "queue order (megakernel)"},
            {"ray_order", wavefront_ ? wavefront_->ray_order_reason() : "queue order (megakernel)"},
            {"traversal_form", wavefront_ ? wavefront_->traversal_form() : ""}};
  }

  // A sphere light moved, resized or re-powered in the scene (set_sphere_light): the lights, the light selection's
  // arrays and the sphere records are written over their device copies (the same sizes: the SceneView's addresses
  // stay), the spheres' GAS and the IAS are built again over the meshes' GASes as they are, and the wavefront's
  // trace stage follows (the cuda traversal's top level rebuilt, OptiX's stage rebound to the new IAS). false where
  // the arrays' sizes changed: the caller makes a new backend.
  bool update_lights() override {
    use_device();
    SceneView& v = base_params_.scene;
    if (!(light_counts(scene_) == light_counts_)) return false;
    auto write = [&](const void* device, const void* host, size_t bytes) {
      if (bytes) PN_CUDA(cudaMemcpyAsync(const_cast<void*>(device), host, bytes, cudaMemcpyHostToDevice, stream_));
    };
    write(v.lights, scene_.lights.data(), scene_.lights.size() * sizeof(Light));
    write(v.selection.power_cdf, scene_.light_cdf.data(), scene_.light_cdf.size() * sizeof(float));
    write(v.selection.bvh.nodes, scene_.light_bvh.nodes.data(), scene_.light_bvh.nodes.size() * sizeof(LightBvhNode));
    write(v.selection.bvh.trails, scene_.light_bvh.trails.data(), scene_.light_bvh.trails.size() * sizeof(uint64_t));
    const std::vector<SphereView> spheres = sphere_views(scene_);
    write(v.spheres, spheres.data(), spheres.size() * sizeof(SphereView));
    PN_CUDA(cudaStreamSynchronize(stream_));  // `spheres` is a host temporary
    v.selection = make_light_selection_view(scene_, v.selection.power_cdf, v.selection.bvh.nodes,
                                            v.selection.bvh.trails);
    SceneBuildStats scratch;
    accels_.rebuild_spheres(scene_, scratch);
    base_params_.handle = accels_.handle();
    clear_restir_history();  // of the old lights
    return !wavefront_ || wavefront_->update_scene(scene_, base_params_.scene);
  }

  RenderStats last_render_stats() const override { return stats_; }
  SceneBuildStats scene_build_stats() const override { return build_stats_; }

  void set_spp_per_launch(int spp) override { spp_per_launch_ = std::max(0, spp); }
  uint64_t accumulated_samples() const override { return accumulated_; }
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
    }
    PN_CUDA(cudaMemsetAsync(acc_sum_.as<void>(), 0, acc_sum_.size(), stream_));
    PN_CUDA(cudaMemsetAsync(acc_sum_sq_.as<void>(), 0, acc_sum_sq_.size(), stream_));
    PN_CUDA(cudaMemsetAsync(acc_bad_.as<void>(), 0, acc_bad_.size(), stream_));
    clear_restir_history();  // temporal reuse starts over with the image
    accumulated_ = 0;
  }

  void accumulate(const FrameSpec& frame, uint32_t first_sample, uint32_t count,
                  const ProgressFn& progress) override {
    use_device();
    const int W = frame.camera.width, H = frame.camera.height;
    if (W != width_ || H != height_) reset(frame);
    const size_t pixels = size_t(W) * size_t(H);
    stats_ = RenderStats();
    PN_CUDA(cudaMemsetAsync(counters_.as<void>(), 0, counters_.size(), stream_));

    LaunchParams p = base_params_;
    p.camera = frame.camera;
    p.integrator = frame.integrator;
    p.seed = frame.seed;
    p.sum = launch_sum_.as<float4>();
    p.sum_sq = launch_sum_sq_.as<float4>();

    const uint32_t per_launch = split_granularity(frame, count);
    // restir with spatial or temporal reuse: each sample is a frame of its own passes, run by the wavefront.
    const bool restir = restir_frame_passes(frame.integrator);
    if (restir && !wavefront_)  // settings, not a device failure: std::invalid_argument (the viewer shows it)
      throw std::invalid_argument(
          "--megakernel: restir's spatial and temporal reuse run in the wavefront path tracer only (drop "
          "--megakernel, or set render.restir.spatial_passes=0 without render.restir.temporal)");
    if (restir && restir_pixels_.size() != pixels * sizeof(RestirPixel)) {
      restir_pixels_.alloc(pixels * sizeof(RestirPixel), "restir's shading points", size_);
      restir_a_.alloc(pixels * sizeof(Reservoir), "restir's reservoirs", size_);
      restir_b_.alloc(pixels * sizeof(Reservoir), "restir's reservoirs", size_);
    }
    if (restir && frame.integrator.restir.temporal && restir_history_.size() != pixels * sizeof(Reservoir)) {
      restir_history_pixels_.alloc(pixels * sizeof(RestirPixel), "restir's history", size_);
      restir_history_.alloc(pixels * sizeof(Reservoir), "restir's history", size_);
      clear_restir_history();
    }
    const uint32_t launches = count == 0 ? 0 : (count + per_launch - 1) / per_launch;
    const uint64_t total = uint64_t(pixels) * count;
    // The raygen program of the strategy, with or without MIS, with the extra light sampling where it runs any.
    const int strategy = int(frame.integrator.strategy);
    if (strategy < 0 || strategy >= kNumStrategies || int(frame.integrator.mis) >= kNumMisModes)
      throw std::logic_error("unknown strategy or MIS mode");
    const OptixShaderBindingTable sbt = pipeline_.sbt(raygen_index(
        frame.integrator.strategy, frame.integrator.mis, extra_light_sampling(frame.integrator) != 0));
    // A W x H launch, or a 1D launch of pixels / pixels_per_thread threads
    // (see render_pixels in device_programs.cu).
    const bool launch_2d = launch_2d_ && pixels_per_thread_ == 1;
    const unsigned launch_x = launch_2d ? unsigned(W)
                                        : unsigned(std::max<size_t>(1, (pixels + size_t(pixels_per_thread_) - 1) /
                                                                           size_t(pixels_per_thread_)));
    const unsigned launch_y = launch_2d ? unsigned(H) : 1u;
    stats_.launches.resize(launches);
    DeviceFilm film;  // where the wavefront may add a launch it holds in one wave (no launch_accumulate then)
    film.sum = acc_sum_.as<double>();
    film.sum_sq = acc_sum_sq_.as<double>();
    film.counters = counters_.as<unsigned long long>();
    film.bad_pixels = acc_bad_.as<unsigned>();

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
      bool in_film = false;  // the launch's samples already in the film
      if (restir && wavefront_) {
        RestirFrameBuffers b;
        b.pixels = restir_pixels_.as<RestirPixel>();
        b.reservoirs[0] = restir_a_.as<Reservoir>();
        b.reservoirs[1] = restir_b_.as<Reservoir>();
        if (frame.integrator.restir.temporal) {
          b.history_pixels = restir_history_pixels_.as<RestirPixel>();
          b.history = restir_history_.as<Reservoir>();
        }
        wavefront_->render_restir(frame, base_params_.scene, pipeline_.feature_level(), p.first_sample, b, p.sum,
                                  p.sum_sq, stream_);
      } else if (wavefront_) {
        in_film = wavefront_->render(frame, base_params_.scene, pipeline_.feature_level(), p.first_sample, spp, p.sum,
                                     p.sum_sq, &film, stream_);
      } else {
        PN_CUDA(cudaMemcpyAsync(params_.as<void>(), &p, sizeof p, cudaMemcpyHostToDevice, stream_));
        PN_OPTIX(optixLaunch(pipeline_.get(), stream_, params_.dptr(), sizeof(LaunchParams), &sbt, launch_x, launch_y, 1));
      }
      PN_CUDA(cudaEventRecord(s.traced, stream_));
      accumulated_ += spp;
      if (!in_film)
        PN_CUDA(launch_accumulate(launch_sum_.as<float4>(), launch_sum_sq_.as<float4>(), pixels, acc_sum_.as<double>(),
                                  acc_sum_sq_.as<double>(), counters_.as<unsigned long long>(), acc_bad_.as<unsigned>(),
                                  props_.multiProcessorCount, stream_));
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

  void trace_closest(const TraceRay* rays, uint32_t count, HitRecord* hits) override {
    LaunchParams p = base_params_;
    p.trace_rays = rays;
    p.trace_hits = hits;
    p.trace_count = count;
    launch_trace(p, kRaygenTraceClosest);
  }
  void trace_shadow(const TraceRay* rays, uint32_t count, uint32_t* blocked_bits) override {
    use_device();
    PN_CUDA(cudaMemsetAsync(blocked_bits, 0, trace_bit_words(count) * sizeof(uint32_t), stream_));
    LaunchParams p = base_params_;
    p.trace_rays = rays;
    p.trace_bits = blocked_bits;
    p.trace_count = count;
    launch_trace(p, kRaygenTraceShadow);
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
      queues_ = q;
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
      sbt_[0] = sbt_[1] = b_.pipeline_.sbt(kRaygenTraceClosest);
      sbt_[2] = b_.pipeline_.sbt(kRaygenTraceShadow);
    }
    void closest(int queue, void* stream) override { launch(queue, stream); }
    void shadow(void* stream) override {
      PN_CUDA(cudaMemsetAsync(bits_, 0, trace_bit_words(capacity_) * sizeof(uint32_t),
                              static_cast<cudaStream_t>(stream)));
      launch(2, stream);
    }
    std::string name() const override { return "optix"; }
    bool capturable() const override { return false; }
    // The backend's new IAS handle (and the same scene arrays) into the launches' parameters.
    bool update_scene(const Scene&, const SceneView&) override {
      bind(queues_);
      return true;
    }

   private:
    void launch(int k, void* stream) {
      PN_OPTIX(optixLaunch(b_.pipeline_.get(), static_cast<cudaStream_t>(stream),
                           params_.dptr() + CUdeviceptr(k) * sizeof(LaunchParams), sizeof(LaunchParams), &sbt_[k],
                           capacity_, 1, 1));
    }
    OptixBackendImpl& b_;
    Queues queues_;
    DeviceBuffer params_;
    OptixShaderBindingTable sbt_[3] = {};
    uint32_t capacity_ = 0;
    uint32_t* bits_ = nullptr;
  };

  // --wavefront: the path pool and its trace stage (--traversal; auto: OptiX where the GPU has RT cores).
  void build_wavefront(Traversal traversal) {
    const unsigned rt = rtcore_version();
    Traversal choice = traversal;
    if (traversal == Traversal::Auto) choice = rt > 0 ? Traversal::Optix : Traversal::Cuda;
    std::fprintf(stderr, "wavefront on GPU %d: traversal %s%s (OPTIX_DEVICE_PROPERTY_RTCORE_VERSION %u: %s)\n",
                 device_, traversal_name(choice), traversal == Traversal::Auto ? " (auto)" : "", rt,
                 rt > 0 ? "RT cores" : "no RT cores");
    std::unique_ptr<WavefrontTraceStage> stage;
    if (choice == Traversal::Optix) stage = std::make_unique<OptixTraceStage>(*this);
    else stage = make_cuda_trace_stage(scene_, base_params_.scene, tuning_);
    wavefront_ = std::make_unique<WavefrontGpu>(std::move(stage), tuning_, props_.multiProcessorCount);
    std::fprintf(stderr, "wavefront on GPU %d: shadow rays in %s; the bounces' rays in %s\n", device_,
                 wavefront_->shadow_order_reason().c_str(), wavefront_->ray_order_reason().c_str());
    if (!wavefront_->traversal_form().empty())
      std::fprintf(stderr, "wavefront on GPU %d: cuda traversal: %s\n", device_, wavefront_->traversal_form().c_str());
  }

  void launch_trace(const LaunchParams& p, uint32_t raygen) {
    if (p.trace_count == 0) return;
    use_device();
    const OptixShaderBindingTable sbt = pipeline_.sbt(raygen);
    PN_CUDA(cudaMemcpyAsync(params_.as<void>(), &p, sizeof p, cudaMemcpyHostToDevice, stream_));
    PN_OPTIX(optixLaunch(pipeline_.get(), stream_, params_.dptr(), sizeof(LaunchParams), &sbt, p.trace_count, 1, 1));
  }

  void render(const FrameSpec& frame, Film& film, uint32_t first_sample, uint32_t count,
              const ProgressFn& progress) override {
    use_device();
    const int W = frame.camera.width, H = frame.camera.height;
    if (film.width() != W || film.height() != H) throw std::logic_error("film size differs from the camera's");
    reset(frame);
    using Clock = std::chrono::steady_clock;
    const Clock::time_point start = Clock::now();
    accumulate(frame, first_sample, count, progress);  // returns when the GPU has finished
    const Clock::time_point launched = Clock::now();
    const size_t n = size_t(W) * size_t(H) * 3;
    add_to_host(acc_sum_, film.sum(), n);
    add_to_host(acc_sum_sq_, film.sum_sq(), n);
    film.add_samples(count);
    stats_.launches_wall_ms = std::chrono::duration<double, std::milli>(launched - start).count();
    stats_.readback_ms = std::chrono::duration<double, std::milli>(Clock::now() - launched).count();
  }

  // dst[i] += src[i] for i < n (doubles): src copied out in chunks through two
  // page-locked buffers, the copy of one chunk overlapping the host's sums of
  // the one before. A 1080p film's two sums are 100 MB.
  void add_to_host(const DeviceBuffer& src, double* dst, size_t n) {
    constexpr size_t kChunk = size_t(1) << 20;  // doubles: 8 MiB a buffer
    staging_.ensure(2 * kChunk * sizeof(double));
    double* const buffers[2] = {staging_.as<double>(), staging_.as<double>() + kChunk};
    const size_t chunks = (n + kChunk - 1) / kChunk;
    auto copy = [&](size_t k) {  // chunk k into buffers[k % 2], its event recorded after it
      const size_t len = std::min(kChunk, n - k * kChunk);
      PN_CUDA(cudaMemcpyAsync(buffers[k & 1], src.as<double>() + k * kChunk, len * sizeof(double),
                              cudaMemcpyDeviceToHost, stream_));
      PN_CUDA(cudaEventRecord(copied_[k & 1], stream_));
    };
    if (chunks > 0) copy(0);
    for (size_t k = 0; k < chunks; ++k) {
      if (k + 1 < chunks) copy(k + 1);  // into the buffer whose sums finished in step k - 1
      PN_CUDA(cudaEventSynchronize(copied_[k & 1]));
      const double* from = buffers[k & 1];
      double* to = dst + k * kChunk;
      const size_t len = std::min(kChunk, n - k * kChunk);
      for (size_t i = 0; i < len; ++i) to[i] += from[i];
    }
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
    const OptixShaderBindingTable sbt = pipeline_.sbt(kRaygenGuides);
    PN_CUDA(cudaMemcpyAsync(params_.as<void>(), &p, sizeof p, cudaMemcpyHostToDevice, stream_));
    PN_OPTIX(optixLaunch(pipeline_.get(), stream_, params_.dptr(), sizeof(LaunchParams), &sbt, unsigned(W), unsigned(H), 1));
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


 private:
  static constexpr uint32_t kSlots = 8, kInFlight = 3;
  struct Slot {
    cudaEvent_t start = nullptr, traced = nullptr, end = nullptr;
  };

  // No restir history (valid = 0, M = 0): the next sample's temporal reuse has nothing to take.
  void clear_restir_history() {
    if (!restir_history_.size()) return;
    PN_CUDA(cudaMemsetAsync(restir_history_pixels_.as<void>(), 0, restir_history_pixels_.size(), stream_));
    PN_CUDA(cudaMemsetAsync(restir_history_.as<void>(), 0, restir_history_.size(), stream_));
  }

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
    for (cudaEvent_t& e : copied_) PN_CUDA(cudaEventCreateWithFlags(&e, cudaEventDisableTiming));
    OptixDeviceContextOptions o = {};
    o.logCallbackFunction = &log_callback;
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

  // Releases everything; used by the destructor and a failed constructor, so it
  // ignores errors (a sticky CUDA error must not hide the first message).
  void destroy() {
    cudaSetDevice(device_);  // unchecked, as everything here
    if (stream_) cudaStreamSynchronize(stream_);
    wavefront_.reset();  // its trace stage holds device memory and launches this pipeline
    pipeline_.release();
    accels_.release();
    device_scene_.release();
    if (context_) optixDeviceContextDestroy(context_);  // with it, the built-in sphere module
    context_ = nullptr;
    for (Slot& s : slots_) {
      for (cudaEvent_t* e : {&s.start, &s.traced, &s.end})
        if (*e) cudaEventDestroy(*e), *e = nullptr;
    }
    for (cudaEvent_t& e : copied_)
      if (e) cudaEventDestroy(e), e = nullptr;
    staging_.release();
    for (DeviceBuffer* b : {&params_, &counters_, &launch_sum_, &launch_sum_sq_, &acc_sum_, &acc_sum_sq_, &acc_bad_,
                            &restir_pixels_, &restir_a_, &restir_b_, &restir_history_pixels_, &restir_history_})
      b->release();
    if (stream_) cudaStreamDestroy(stream_);
    stream_ = nullptr;
  }

  // The sizes of the arrays update_lights writes over.
  struct LightCounts {
    size_t lights = 0, cdf = 0, nodes = 0, trails = 0, spheres = 0;
    bool operator==(const LightCounts& o) const {
      return lights == o.lights && cdf == o.cdf && nodes == o.nodes && trails == o.trails && spheres == o.spheres;
    }
  };
  static LightCounts light_counts(const Scene& s) {
    return {s.lights.size(), s.light_cdf.size(), s.light_bvh.nodes.size(), s.light_bvh.trails.size(),
            s.spheres.size()};
  }
  const Scene& scene_;
  LightCounts light_counts_ = light_counts(scene_);
  GpuTuning tuning_;  // BackendOptions::tuning
  SceneSize size_;
  SphereMode sphere_mode_ = SphereMode::Custom;
  int spp_per_launch_ = 0;
  int device_ = 0;  // the CUDA device
  int pixels_per_thread_ = 1;
  bool launch_2d_ = true;

  cudaDeviceProp props_ = {};
  std::string gpu_name_, driver_;
  cudaStream_t stream_ = nullptr;
  Slot slots_[kSlots];
  cudaEvent_t copied_[2] = {nullptr, nullptr};  // the film's read-back: chunk k % 2 copied out
  PinnedBuffer staging_;                        // ... into these two halves
  OptixDeviceContext context_ = nullptr;
  Pipeline pipeline_;
  DeviceScene device_scene_{size_};  // the arrays base_params_.scene points at
  Accels accels_;
  DeviceBuffer restir_pixels_, restir_a_, restir_b_;  // restir's passes: shading points, reservoirs (ping-pong)
  DeviceBuffer restir_history_pixels_, restir_history_;  // temporal reuse: the previous sample's, since reset()
  DeviceBuffer params_, counters_;
  DeviceBuffer launch_sum_, launch_sum_sq_, acc_sum_, acc_sum_sq_, acc_bad_;
  LaunchParams base_params_;
  std::unique_ptr<WavefrontGpu> wavefront_;  // --wavefront: renders in place of the megakernel, restir's passes too

  int width_ = 0, height_ = 0;
  uint64_t accumulated_ = 0;
  RenderStats stats_;
  SceneBuildStats build_stats_;
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
