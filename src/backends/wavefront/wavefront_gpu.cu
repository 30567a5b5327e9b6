// The wavefront's kernels and its driver: one kernel per stage of wavefront.h over a fixed grid (grid-stride
// loops bounded by the queue lengths the previous kernel wrote), the trace stage between them, one wave's launches
// recorded in a CUDA graph. Per wave the host writes only the wave's items (a WaveSpec) before replaying it.
#include "backends/wavefront/wavefront_gpu.h"

#include <cstdio>
#include <cstdlib>
#include <map>
#include <memory>
#include <mutex>
#include <stdexcept>
#include <string>
#include <type_traits>

#include <cuda_runtime.h>

#include "backends/cuda/bvh_build.h"
#include "backends/cuda/trace_kernels.h"
#include "backends/gpu/feature_levels.h"
#include "backends/gpu/launch_sums.h"
#include "backends/probe_rays.h"
#include "backends/wavefront/restir_passes.h"
#include "backends/wavefront/wavefront_shadow.h"

namespace pn {
namespace {

constexpr int kBlock = 256;

void check(cudaError_t e, const char* what) {
  if (e != cudaSuccess)
    throw std::runtime_error(std::string("wavefront: ") + what + ": " + cudaGetErrorName(e) + " (" +
                             cudaGetErrorString(e) + ")");
}

// What every kernel of a render call reads, in constant memory (broadcast loads): the pool and queues, the scene,
// the camera, the settings, the launch sums. Raw storage, as the OptiX programs' params: core types have
// user-provided constructors, which a __constant__ variable cannot have.
struct WaveParams {
  WavefrontView view;
  SceneView scene;
  Camera camera;
  IntegratorSettings integrator;
  float4* sum = nullptr;
  float4* sum_sq = nullptr;
  DeviceFilm film;  // film.sum set: one wave holds the launch, whose samples go straight into the film
};
__constant__ __align__(16) unsigned char g_params[sizeof(WaveParams)];

__device__ __forceinline__ const WaveParams& WP() { return *reinterpret_cast<const WaveParams*>(g_params); }

// g_params is one per device and process, not one per WavefrontGpu. Where several share a device (two backends of
// one GPU: MultiBackend's parts, or two renderers of one program, each on its own stream), a render call's kernels
// must read the parameters it wrote, not another's: each render call takes the device's turn (ParamsTurn), in
// which its stream first waits for the work of the previous holder (an event), then writes g_params and queues
// its kernels, and records its own event on leaving. The host lock is held while queuing, which includes the
// pageable copy of the parameters (it waits for its own stream, and so for the previous holder's kernels); a single
// WavefrontGpu never waits for another.
struct DeviceParams {
  std::mutex mutex;
  const WavefrontGpu* holder = nullptr;  // whose kernels read g_params last
  cudaEvent_t done = nullptr;            // recorded after them
};

DeviceParams& device_params(int device) {
  // Never destroyed, so that a WavefrontGpu destroyed late in the process's exit still finds them; map nodes stay
  // put, so references outlive the lock.
  static auto* mutex = new std::mutex;
  static auto* devices = new std::map<int, DeviceParams>;
  std::lock_guard<std::mutex> lock(*mutex);
  return (*devices)[device];
}

__device__ __forceinline__ uint32_t stride() { return gridDim.x * blockDim.x; }
__device__ __forceinline__ uint32_t first_index() { return blockIdx.x * blockDim.x + threadIdx.x; }

__global__ void __launch_bounds__(kBlock) camera_kernel() {
  const WaveParams& p = WP();
  const Camera camera = p.camera;
  for (uint32_t i = first_index(); i < p.view.capacity; i += stride())
    generate_camera_ray(i, p.view, camera, p.integrator);
}

__global__ void __launch_bounds__(kBlock) apply_kernel() {
  const WavefrontView& w = WP().view;
  const uint32_t n = *w.shadow.count;
  for (uint32_t j = first_index(); j < n; j += stride()) apply_shadow_result(j, w);
}

__global__ void begin_bounce_kernel(int next) { begin_bounce(WP().view, next); }

// A queue order's cell counts to their first positions in the traced order (exclusive prefix sums, one block;
// each warp's loads and stores are 32 consecutive words: the first form, 16 consecutive cells a thread, took 32 us
// on the H200), the counts emptied for the next queue; then each entry to its place (wavefront.h's QueueOrder).
constexpr int kScanThreads = 1024;
__device__ __forceinline__ uint32_t warp_inclusive_sum(uint32_t v, uint32_t lane) {
  for (uint32_t d = 1; d < 32; d <<= 1) {
    const uint32_t u = __shfl_up_sync(~0u, v, d);
    if (lane >= d) v += u;
  }
  return v;
}
template <uint32_t kCells>
__device__ void scan_cells(const QueueOrder& o) {
  constexpr uint32_t kWarps = kScanThreads / 32, kPerWarp = kCells / kWarps, kRounds = kPerWarp / 32;
  static_assert(kWarps == 32 && kPerWarp % 32 == 0, "a warp's totals scanned by one warp; whole rounds of 32");
  __shared__ uint32_t warp_first[kWarps];
  const uint32_t lane = threadIdx.x & 31u, warp = threadIdx.x >> 5, base = warp * kPerWarp;
  uint32_t start[kRounds];
  uint32_t running = 0;
#pragma unroll
  for (uint32_t k = 0; k < kRounds; ++k) {
    const uint32_t i = base + k * 32u + lane;
    const uint32_t n = o.cell_count[i];
    o.cell_count[i] = 0;
    const uint32_t inclusive = warp_inclusive_sum(n, lane);
    start[k] = running + inclusive - n;
    running += __shfl_sync(~0u, inclusive, 31);
  }
  if (lane == 0) warp_first[warp] = running;
  __syncthreads();
  if (warp == 0) {
    const uint32_t n = warp_first[lane];
    warp_first[lane] = warp_inclusive_sum(n, lane) - n;
  }
  __syncthreads();
  const uint32_t first = warp_first[warp];
#pragma unroll
  for (uint32_t k = 0; k < kRounds; ++k) o.cell_start[base + k * 32u + lane] = first + start[k];
}

// The orders of the queues shade just filled, where they are ordered (null cells: not): block 0 scans the ray
// queue's cells, block 1 the shadow queue's, at once.
__global__ void __launch_bounds__(kScanThreads) orders_scan_kernel(QueueOrder rays, QueueOrder shadows) {
  if (blockIdx.x == 0 && rays.cell_count) scan_cells<kRayCells>(rays);
  if (blockIdx.x == 1 && shadows.cell_count) scan_cells<kShadowCells>(shadows);
}

__global__ void __launch_bounds__(kBlock) orders_place_kernel(int next, bool rays, bool shadows) {
  const WavefrontView& w = WP().view;
  const uint32_t nr = rays ? *w.ray[next].count : 0u, ns = shadows ? *w.shadow.count : 0u;
  for (uint32_t j = first_index(); j < max(nr, ns); j += stride()) {
    if (j < nr) queue_order_place(j, w.ray_order);
    if (j < ns) queue_order_place(j, w.shadow_order);
  }
}

// Two resident blocks per SM: at most 128 registers a thread (the shading alone would take 181 and leave one
// block of 8 warps per SM). Measured on the H200 (bench, 1080p, solid-angle): cornell-sphere 2.71 -> 2.59 ms,
// sponza 13.47 -> 13.07 ms a sample. Three blocks (80 registers, 1.9 KB of spill stores) lost (commit a6913f3:
// cornell-sphere 1.86 -> 2.38, sponza 9.35 -> 10.34).
//
// Each kernel is compiled for one integrator configuration where lights are chosen simply (uniformly or by power):
// its strategy, and MIS off or on (balance or power), are constants, so the code of every other strategy, of the
// light BVH and restir, and of MIS where it is off, is not there to take registers. Sponza's shading kernel spilled
// 572 bytes a thread; compiled for solid-angle without MIS, 152 (commit a6913f3, H200: Sponza's shading 2.47 -> 1.76 ms
// a sample; sponza 8.82 -> 8.11 ms, cornell-sphere 1.84 -> 1.69, with MIS 9.28 -> 8.53 and 1.98 -> 1.83). Other
// configurations (the light BVH, restir) take the kernel compiled for any (kAnyStrategy), and so does ltc: its code
// (two polygon form factors, two samplers and their pdfs) in six kernels of its own, all inlined, took this file's
// compilation from 36 s to 174 s on a two-core machine, on CI's critical path; with ltc's mixture and sg-bvh's
// importance called rather than inlined (PN_FN_CALLED), 71 s. Those calls then cost every other kernel: their
// stack and the registers saved around them (H200, 1080p, MIS power: many-spheres 3.31 -> 4.81 ms a sample with
// power selection, 4.04 -> 5.12 with bvh; cornell-sphere with bvh 2.14 -> 3.24). So the light sampling of ltc,
// sg-bvh and slc (core/features.h) is compiled only into the kernels of the configurations that run it (kExtra):
// ltc's kernels per MIS class, as the other strategies', and a kernel for any configuration with sg-bvh, one with
// slc and one with all three, at the full feature level only (kExtraLevel). One kernel holding the three had cost
// slc with a cut of one node, bvh's estimator exactly, 74% more than bvh's kernel (many-spheres-glossy, 10,000
// lights: 7.81 against 4.50 ms a sample). 29 kernels.
constexpr uint32_t kAnyStrategy = ~0u;
enum ShadeMis : uint32_t { kShadeMisNone, kShadeMisWeighted, kShadeMisAny };

template <uint32_t kStrategy, uint32_t kMis>
__device__ __forceinline__ IntegratorSettings shade_settings(IntegratorSettings s) {
  if constexpr (kStrategy != kAnyStrategy) {
    s.strategy = Strategy(kStrategy);
    if (s.light_selection != LightSelection::Uniform) s.light_selection = LightSelection::Power;
  }
  if constexpr (kMis == kShadeMisNone) s.mis = Mis::None;
  if constexpr (kMis == kShadeMisWeighted) {
    if (s.mis != Mis::Balance) s.mis = Mis::Power;
  }
  return s;
}

template <uint32_t kLevel, uint32_t kStrategy, uint32_t kMis, uint32_t kExtra = 0>
__global__ void __launch_bounds__(kBlock, 2) shade_kernel(int cur) {
  constexpr uint32_t kFeatures = (gpu::kFeatureLevels[kLevel] & ~kExtraLightSampling) | kExtra;
  const WaveParams& p = WP();
  const IntegratorSettings s = shade_settings<kStrategy, kMis>(p.integrator);
  const uint32_t n = *p.view.ray[cur].count;
  for (uint32_t j = first_index(); j < n; j += stride()) shade<kFeatures>(j, p.view, cur, p.scene, s);
}

// Which shading kernel a configuration takes: its strategy and MIS class where lights are chosen simply, else any;
// with the code of the extra light sampling it runs (extra_light_sampling: ltc, sg-bvh, slc).
ShadeKernelKey shade_kernel_key(const IntegratorSettings& s) {
  const uint32_t extra = extra_light_sampling(s);
  const bool simple = s.light_selection == LightSelection::Uniform || s.light_selection == LightSelection::Power;
  if (!simple || (extra & ~uint32_t(kFeatureLtc))) return {kAnyStrategy, kShadeMisAny, extra};
  if (!strategy_uses_nee(s.strategy)) return {uint32_t(s.strategy), kShadeMisAny};
  return {uint32_t(s.strategy), s.mis == Mis::None ? kShadeMisNone : kShadeMisWeighted, extra};
}

// The extra light sampling a strategy's own kernels hold: ltc's for ltc.
template <Strategy kS>
struct StrategyExtra : std::integral_constant<uint32_t, kS == Strategy::Ltc ? uint32_t(kFeatureLtc) : 0u> {};
// Kernels with extra light sampling are compiled at the full feature level alone, which covers every scene: each
// such kernel is as large as all the others of its level, and at three levels they doubled this file's compile
// time (to 457 s on CI's two cores, for two architectures). A Lambertian scene pays the full level's code there.
constexpr uint32_t kExtraLevel = gpu::kFeatureLevel_full;
template <Strategy kS, uint32_t kLevel>
struct StrategyLevel : std::integral_constant<uint32_t, StrategyExtra<kS>::value ? kExtraLevel : kLevel> {};

template <uint32_t kLevel>
void launch_shade(const ShadeKernelKey& k, unsigned grid, cudaStream_t stream, int cur) {
  if (k.strategy == kAnyStrategy) {
    switch (k.extra) {
      case 0:
        shade_kernel<kLevel, kAnyStrategy, kShadeMisAny><<<grid, kBlock, 0, stream>>>(cur);
        break;
      case kFeatureSgBvh:
        shade_kernel<kExtraLevel, kAnyStrategy, kShadeMisAny, kFeatureSgBvh><<<grid, kBlock, 0, stream>>>(cur);
        break;
      case kFeatureSlc:
        shade_kernel<kExtraLevel, kAnyStrategy, kShadeMisAny, kFeatureSlc><<<grid, kBlock, 0, stream>>>(cur);
        break;
      default:  // two or three of them (ltc with sg-bvh or slc, ...)
        shade_kernel<kExtraLevel, kAnyStrategy, kShadeMisAny, kExtraLightSampling><<<grid, kBlock, 0, stream>>>(cur);
    }
    return;
  }
  switch (Strategy(k.strategy)) {
#define PN_X(e, name, impl, nee, desc)                                                                  \
  case Strategy::e:                                                                                     \
    if constexpr (!(nee)) {                                                                             \
      shade_kernel<kLevel, uint32_t(Strategy::e), kShadeMisAny><<<grid, kBlock, 0, stream>>>(cur);      \
    } else if (k.mis == kShadeMisNone) {                                                                \
      shade_kernel<StrategyLevel<Strategy::e, kLevel>::value, uint32_t(Strategy::e), kShadeMisNone,     \
                   StrategyExtra<Strategy::e>::value><<<grid, kBlock, 0, stream>>>(cur);                \
    } else {                                                                                            \
      shade_kernel<StrategyLevel<Strategy::e, kLevel>::value, uint32_t(Strategy::e), kShadeMisWeighted, \
                   StrategyExtra<Strategy::e>::value><<<grid, kBlock, 0, stream>>>(cur);                \
    }                                                                                                   \
    break;
    PN_STRATEGIES(PN_X)
#undef PN_X
    default:
      shade_kernel<kLevel, kAnyStrategy, kShadeMisAny><<<grid, kBlock, 0, stream>>>(cur);
  }
}

// The accumulation's sink: a pixel's launch sums, as render_pixels (device_programs.cu) writes them.
struct LaunchSink {
  SampleSums<float> sums;
  float rays = 0.f;
  __device__ void begin(uint32_t pixel, bool first) {
    if (first) {
      sums = SampleSums<float>();
      rays = 0.f;
    } else {
      sums = load_launch_sums(WP().sum, WP().sum_sq, pixel, &rays);
    }
  }
  __device__ void add(const Vec3& L, uint32_t path_rays) {
    rays += float(path_rays);
    sums.add(L);
  }
  __device__ void end(uint32_t pixel) { store_launch_sums(WP().sum, WP().sum_sq, pixel, sums, rays); }
};

// restir's primary pass: the path's radiance (its first vertex's direct light left out) and its rays to the
// launch sums, where the reuse passes add their rays and the shading pass the direct light (dense float4s, not
// a field of the records: the strided write cost 0.2 ms a 1080p frame).
struct RestirRadianceSink {
  Vec3 L;
  float rays = 0.f;
  __device__ void begin(uint32_t, bool) {}
  __device__ void add(const Vec3& radiance, uint32_t path_rays) {
    L = radiance;
    rays = float(path_rays);
  }
  __device__ void end(uint32_t pixel) {
    WP().sum[pixel] = make_float4(L.x, L.y, L.z, rays);
  }
};

// A launch that one wave holds: each pixel's samples summed in floats as into the launch sums (every pixel's first
// sample of the launch is in the wave), then added to the film as launch_accumulate adds the launch sums, with no
// launch sums between.
struct FilmSink : LaunchSink {
  unsigned long long total_rays = 0, total_bad = 0;  // the thread's pixels', for add_block_counters
  __device__ void begin(uint32_t pixel, bool) { LaunchSink::begin(pixel, true); }
  __device__ void end(uint32_t pixel) {
    float4 s, q;
    launch_sums_words(sums, rays, &s, &q);
    film_add(WP().film, pixel, s, q, &total_rays, &total_bad);
  }
};

__global__ void __launch_bounds__(kBlock) accumulate_kernel() {
  const WavefrontView& w = WP().view;
  const uint32_t n = min(w.wave->count, w.wave->pixels);
  if (WP().film.sum) {  // the same for every thread: the block reaches add_block_counters together
    FilmSink sink;
    for (uint32_t i = first_index(); i < n; i += stride()) accumulate(i, w, sink);
    add_block_counters<kBlock>(WP().film, sink.total_rays, sink.total_bad);
    return;
  }
  for (uint32_t i = first_index(); i < n; i += stride()) {
    if (w.restir.pixels) {
      RestirRadianceSink sink;
      accumulate(i, w, sink);
    } else {
      LaunchSink sink;
      accumulate(i, w, sink);
    }
  }
}

// restir's frame passes after the primary pass (wavefront.h): chunks recorded, traced by the trace stage,
// replayed. Every scene feature compiled in.
__global__ void begin_shadow_batch_kernel() { begin_shadow_batch(WP().view); }

__global__ void __launch_bounds__(kBlock) reuse_record_kernel(RestirChunk c, RestirReuse r) {
  const WaveParams& p = WP();
  for (uint32_t i = first_index(); i < c.count; i += stride())
    restir_reuse_record(i, p.view, c, p.scene, p.integrator.restir, r);
}

__global__ void __launch_bounds__(kBlock) reuse_replay_kernel(RestirChunk c, RestirReuse r, Reservoir* out) {
  const WaveParams& p = WP();
  for (uint32_t i = first_index(); i < c.count; i += stride()) {
    const uint32_t rays = restir_reuse_replay(i, p.view, c, p.scene, p.integrator.restir, r, out);
    p.sum[c.first + i].w += float(rays);
  }
}

__global__ void __launch_bounds__(kBlock) shade_record_kernel(RestirChunk c, const RestirPixel* pixels,
                                                             const Reservoir* final_reservoirs) {
  const WaveParams& p = WP();
  for (uint32_t i = first_index(); i < c.count; i += stride())
    restir_shade_record(i, p.view, c, p.scene, p.integrator, pixels, final_reservoirs);
}

// The frame's sample into the launch sums (as the megakernel's raygens write theirs); with temporal
// reuse, the next sample's history kept.
__global__ void __launch_bounds__(kBlock) shade_replay_kernel(RestirChunk c, const RestirPixel* pixels,
                                                             const Reservoir* final_reservoirs,
                                                             RestirPixel* history_pixels, Reservoir* history) {
  const WaveParams& p = WP();
  for (uint32_t i = first_index(); i < c.count; i += stride()) {
    uint32_t rays = 0;
    const uint32_t pixel = c.first + i;
    const float4 path = p.sum[pixel];  // the primary pass's radiance and every pass's rays
    const Vec3 direct = restir_shade_replay(i, p.view, c, p.scene, p.integrator, pixels, final_reservoirs, &rays);
    const Vec3 L = Vec3(path.x, path.y, path.z) + direct;
    if (history) {
      history_pixels[pixel] = pixels[pixel];
      history[pixel] = final_reservoirs[pixel];
    }
    SampleSums<float> sums;
    sums.add(L);
    store_launch_sums(p.sum, p.sum_sq, pixel, sums, path.w + float(rays));
  }
}

// The cuda traversal as the trace stage.
class CudaTraceStage final : public WavefrontTraceStage {
 public:
  CudaTraceStage(const Scene& scene, const SceneView& device_scene, const GpuTuning& tuning)
      : tuning_(tuning), bvh_(build_bvh(scene, tuning.bvh)), traversal_(std::make_unique<CudaTraversal>(bvh_, tuning)),
        scene_(device_scene), box_(scene_bounds(scene)) {}
  void bind(const Queues& q) override { q_ = q; }
  void closest(int queue, void* stream) override {
    traversal_->trace_closest(q_.closest_rays[queue], q_.closest_count[queue], q_.capacity, q_.hits, scene_, stream);
  }
  void shadow(void* stream) override {
    traversal_->trace_shadow(q_.shadow_rays, q_.shadow_count, q_.capacity, q_.blocked_bits, scene_, stream);
  }
  bool shadow_apply(const WavefrontView* view, bool ordered, void* stream) override {
    launch_shadow_apply(traversal_->device_view(), traversal_->forms().shadow, traversal_->shape().min_blocks,
                        traversal_->shape().block_size, scene_, view, q_.capacity, ordered, stream);
    return true;
  }
  bool offers_shadow_apply() const override { return true; }
  bool closest_ordered(int queue, const uint32_t* order, void* stream) override {
    traversal_->trace_closest(q_.closest_rays[queue], q_.closest_count[queue], q_.capacity, q_.hits, scene_, stream,
                              order);
    return true;
  }
  // The top level built again over the meshes' trees (rebuild_bvh_top) and the BVH uploaded anew. The scene's box,
  // which only places the ray order's cells, is kept.
  bool update_scene(const Scene& scene, const SceneView& device_scene) override {
    rebuild_bvh_top(scene, bvh_);
    traversal_.reset();  // its device memory first
    traversal_ = std::make_unique<CudaTraversal>(bvh_, tuning_);
    scene_ = device_scene;
    return true;
  }
  bool offers_closest_order(Vec3* lo, Vec3* hi) const override {
    *lo = box_.lo;
    *hi = box_.hi;
    return true;
  }
  double sah_visits_per_ray() const override { return traversal_->stats().sah_visits_per_ray; }
  std::string traversal_form() const override { return traversal_->forms().reason; }
  std::string name() const override { return "cuda"; }

 private:
  GpuTuning tuning_;
  BvhHost bvh_;  // kept on the host for update_scene
  std::unique_ptr<CudaTraversal> traversal_;
  SceneView scene_;
  Bounds3 box_;
  Queues q_;
};

// Carves the pool's arrays out of one allocation, each 256-byte aligned.
class Carver {
 public:
  explicit Carver(char* base) : base_(base) {}
  template <class T>
  T* take(uint64_t n) {
    T* p = base_ ? reinterpret_cast<T*>(base_ + used_) : nullptr;
    used_ += (n * sizeof(T) + 255u) & ~uint64_t(255u);
    return p;
  }
  uint64_t used() const { return used_; }

 private:
  char* base_;
  uint64_t used_ = 0;
};

WavefrontView carve(char* base, uint32_t capacity, uint64_t* bytes) {
  Carver c(base);
  WavefrontView w;
  w.capacity = capacity;
  w.pool.beta = c.take<Vec3>(capacity);
  w.pool.L = c.take<Vec3>(capacity);
  w.pool.rng = c.take<Rng>(capacity);
  w.pool.prev = c.take<PrevWords>(capacity);
  w.pool.prev_lobes = c.take<PrevWords>(capacity);
  w.pool.depth = c.take<int32_t>(capacity);
  w.pool.rays = c.take<uint32_t>(capacity);
  uint32_t* counts = c.take<uint32_t>(3);
  for (int q = 0; q < 2; ++q) {
    w.ray[q].rays = c.take<TraceRay>(capacity);
    w.ray[q].slot = c.take<uint32_t>(capacity);
    w.ray[q].count = counts ? counts + q : nullptr;
  }
  w.shadow.rays = c.take<TraceRay>(capacity);
  w.shadow.slot = c.take<uint32_t>(capacity);
  w.shadow.contribution = c.take<Vec3>(capacity);
  w.shadow.count = counts ? counts + 2 : nullptr;
  w.hits = c.take<HitRecord>(capacity);
  w.blocked_bits = c.take<uint32_t>(trace_bit_words(capacity));
  w.shadow_order.cell_count = c.take<uint32_t>(kShadowCells);
  w.shadow_order.cell_start = c.take<uint32_t>(kShadowCells);
  w.shadow_order.cell = c.take<uint32_t>(capacity);
  w.shadow_order.rank = c.take<uint32_t>(capacity);
  w.shadow_order.order = c.take<uint32_t>(capacity);
  w.ray_order.cell_count = c.take<uint32_t>(kRayCells);
  w.ray_order.cell_start = c.take<uint32_t>(kRayCells);
  w.ray_order.cell = c.take<uint32_t>(capacity);
  w.ray_order.rank = c.take<uint32_t>(capacity);
  w.ray_order.order = c.take<uint32_t>(capacity);
  *bytes = c.used();
  return w;
}

}  // namespace

std::unique_ptr<WavefrontTraceStage> make_cuda_trace_stage(const Scene& scene, const SceneView& device_scene,
                                                           const GpuTuning& tuning) {
  return std::make_unique<CudaTraceStage>(scene, device_scene, tuning);
}

WavefrontGpu::WavefrontGpu(std::unique_ptr<WavefrontTraceStage> trace, const GpuTuning& tuning, int num_sms)
    : trace_(std::move(trace)), capacity_(tuning.wavefront_paths), num_sms_(num_sms > 0 ? num_sms : 1),
      fuse_shadow_(tuning.wavefront_fuse), film_direct_(tuning.wavefront_film), graph_allowed_(tuning.wavefront_graph) {
  if (capacity_ < 1024 || capacity_ > (1u << 26))
    throw std::runtime_error("wavefront_paths must be a number of paths in 1024..67108864, not " +
                             std::to_string(capacity_));
  carve(nullptr, capacity_, &bytes_);
  size_t free_bytes = 0, total = 0;
  check(cudaMemGetInfo(&free_bytes, &total), "cudaMemGetInfo");
  if (bytes_ + sizeof(WaveSpec) > free_bytes)
    throw std::runtime_error("wavefront: the pool of " + std::to_string(capacity_) + " paths needs " +
                             std::to_string(bytes_ >> 20) + " MiB, the GPU has " + std::to_string(free_bytes >> 20) +
                             " MiB free (--tune wavefront_paths sets a smaller pool)");
  check(cudaGetDevice(&device_), "cudaGetDevice");
  check(cudaMalloc(&memory_, bytes_), "allocating the path pool");
  if (cudaMalloc(&wave_, sizeof(WaveSpec)) != cudaSuccess ||
      cudaMalloc(&view_device_, sizeof(WavefrontView)) != cudaSuccess ||
      cudaEventCreateWithFlags(reinterpret_cast<cudaEvent_t*>(&params_done_), cudaEventDisableTiming) != cudaSuccess) {
    cudaFree(view_device_);
    cudaFree(wave_);
    cudaFree(memory_);
    throw std::runtime_error("wavefront: out of GPU memory for the wave's parameters and their event");
  }
  view_ = carve(static_cast<char*>(memory_), capacity_, &bytes_);
  view_.wave = static_cast<const WaveSpec*>(wave_);
  bytes_ += sizeof(WaveSpec) + sizeof(WavefrontView);
  // The shadow queue traced in direction order where rays are long (kShadowOrderMinVisits), always, or never
  // (tuning.shadow_order). Only the fused shadow stage reads the order.
  const double visits = trace_->sah_visits_per_ray();
  order_shadow_ = choose_order(fuse_shadow_ && trace_->offers_shadow_apply(),
                               "the trace stage does not fuse tracing and applying shadow rays", tuning.shadow_order,
                               "shadow_order", "direction", visits, kShadowOrderMinVisits, &order_reason_);
  if (order_shadow_ && tuning.shadow_reverse) order_reason_ += ", traced from the light (shadow_reverse)";
  view_.shadow_order.reverse = tuning.shadow_reverse ? 1u : 0u;
  if (order_shadow_) {
    check(cudaMemset(view_.shadow_order.cell_count, 0, kShadowCells * sizeof(uint32_t)), "the direction cells");
  } else {
    view_.shadow_order = ShadowOrder();
  }
  // The bounces' rays traced by direction and origin where rays are long (kRayOrderMinVisits), always, or never.
  Vec3 lo, hi;
  order_rays_ = choose_order(trace_->offers_closest_order(&lo, &hi), "the trace stage traces no other order",
                             tuning.ray_order, "ray_order", "cell", visits, kRayOrderMinVisits,
                             &ray_order_reason_);
  if (order_rays_) {
    view_.ray_order.lo = lo;
    const Vec3 ext = hi - lo;
    constexpr float kSide = float(1u << kRayOriginBits);
    view_.ray_order.scale = Vec3(ext.x > 0.f ? kSide / ext.x : 0.f, ext.y > 0.f ? kSide / ext.y : 0.f,
                                 ext.z > 0.f ? kSide / ext.z : 0.f);
    check(cudaMemset(view_.ray_order.cell_count, 0, kRayCells * sizeof(uint32_t)), "the ray cells");
  } else {
    view_.ray_order = RayOrder();
  }
  WavefrontTraceStage::Queues q;
  for (int k = 0; k < 2; ++k) {
    q.closest_rays[k] = view_.ray[k].rays;
    q.closest_count[k] = view_.ray[k].count;
  }
  q.hits = view_.hits;
  q.shadow_rays = view_.shadow.rays;
  q.shadow_count = view_.shadow.count;
  q.blocked_bits = view_.blocked_bits;
  q.capacity = capacity_;
  trace_->bind(q);
}

void WavefrontGpu::drop_graph() {
  if (exec_) cudaGraphExecDestroy(static_cast<cudaGraphExec_t>(exec_));
  if (graph_) cudaGraphDestroy(static_cast<cudaGraph_t>(graph_));
  exec_ = graph_ = nullptr;
}

bool WavefrontGpu::update_scene(const Scene& scene, const SceneView& device_scene) {
  drop_graph();
  return trace_->update_scene(scene, device_scene);
}

WavefrontGpu::~WavefrontGpu() {
  {
    DeviceParams& d = device_params(device_);
    std::lock_guard<std::mutex> lock(d.mutex);
    if (d.holder == this) d.holder = nullptr, d.done = nullptr;
  }
  // A stream that already waits for the event keeps waiting: CUDA frees it once it has completed.
  if (params_done_) cudaEventDestroy(static_cast<cudaEvent_t>(params_done_));
  drop_graph();
  cudaFree(view_device_);
  cudaFree(wave_);
  cudaFree(memory_);
}

// One wave's launches: the camera, max_depth + 1 iterations (wavefront.h says why that many suffice), the
// accumulation. Every kernel's grid is fixed (a few blocks per SM, grid-stride loops) and reads its queue's length
// on the device, so the graph holds for every wave of every render call with this depth and level.
void WavefrontGpu::record(uint32_t feature_level, int max_depth, const ShadeKernelKey& shade, void* stream_ptr) {
  cudaStream_t stream = static_cast<cudaStream_t>(stream_ptr);
  drop_graph();
  check(cudaStreamBeginCapture(stream, cudaStreamCaptureModeThreadLocal), "cudaStreamBeginCapture");
  cudaGraph_t graph = nullptr;
  try {
    enqueue(feature_level, max_depth, shade, stream);
  } catch (...) {
    cudaStreamEndCapture(stream, &graph);
    if (graph) cudaGraphDestroy(graph);
    throw;
  }
  check(cudaStreamEndCapture(stream, &graph), "recording the wave's graph");
  graph_ = graph;
  cudaGraphExec_t exec = nullptr;
  check(cudaGraphInstantiate(&exec, graph, 0), "instantiating the wave's graph");
  exec_ = exec;
  graph_level_ = feature_level;
  graph_depth_ = max_depth;
  graph_shade_ = shade;
}

// The launches of one wave, on `stream` (recorded by record(), or run directly).
void WavefrontGpu::enqueue(uint32_t feature_level, int max_depth, const ShadeKernelKey& shade, void* stream_ptr) {
  cudaStream_t stream = static_cast<cudaStream_t>(stream_ptr);
  const unsigned grid = unsigned(num_sms_) * 8u;
  {
    camera_kernel<<<grid, kBlock, 0, stream>>>();
    check(cudaGetLastError(), "the camera kernel");
    for (int it = 0, cur = 0; it <= max_depth; ++it, cur ^= 1) {
      // The bounces' rays (iteration 1 on; the camera's stay in pixel order) in the order shade counted them into.
      if (!(order_rays_ && it >= 1 && trace_->closest_ordered(cur, view_.ray_order.order, stream)))
        trace_->closest(cur, stream);
      // The queries shade made at depth it - 1 (all of this iteration's: a wave's paths move in step), their
      // order placed after that shade.
      const bool ordered = order_shadow_ && it - 1 >= kShadowOrderDepth;
      if (!(fuse_shadow_ && trace_->shadow_apply(view_device_, ordered, stream))) {
        trace_->shadow(stream);
        apply_kernel<<<grid, kBlock, 0, stream>>>();
      }
      begin_bounce_kernel<<<1, 1, 0, stream>>>(cur ^ 1);
      switch (feature_level) {
        case gpu::kFeatureLevel_basic:
          launch_shade<gpu::kFeatureLevel_basic>(shade, grid, stream, cur);
          break;
        case gpu::kFeatureLevel_textured:
          launch_shade<gpu::kFeatureLevel_textured>(shade, grid, stream, cur);
          break;
        default:
          launch_shade<gpu::kFeatureLevel_full>(shade, grid, stream, cur);
          break;
      }
      check(cudaGetLastError(), "the shading kernels");
      // The orders of what shade made for the next iteration (at max_depth it makes neither rays nor queries).
      const bool rays = order_rays_ && it < max_depth;
      const bool shadows = order_shadow_ && it >= kShadowOrderDepth && it < max_depth;
      if (rays || shadows) {
        const QueueOrder none;
        orders_scan_kernel<<<2, kScanThreads, 0, stream>>>(rays ? QueueOrder(view_.ray_order) : none,
                                                            shadows ? QueueOrder(view_.shadow_order) : none);
        orders_place_kernel<<<grid, kBlock, 0, stream>>>(cur ^ 1, rays, shadows);
        check(cudaGetLastError(), "the queues' orders");
      }
    }
    accumulate_kernel<<<grid, kBlock, 0, stream>>>();
    check(cudaGetLastError(), "the accumulation kernel");
  }
}

// The device's turn at g_params for the life of this object (DeviceParams says why).
class WavefrontGpu::ParamsTurn {
 public:
  ParamsTurn(const WavefrontGpu& w, cudaStream_t stream)
      : w_(w), stream_(stream), d_(device_params(w.device_)), lock_(d_.mutex) {
    if (d_.holder && d_.holder != &w_)
      check(cudaStreamWaitEvent(stream_, d_.done, 0), "waiting for another render's kernels on this GPU");
  }
  ~ParamsTurn() {  // also where a launch failed: whatever was queued is ordered before the next holder
    if (cudaEventRecord(static_cast<cudaEvent_t>(w_.params_done_), stream_) == cudaSuccess) {
      d_.holder = &w_;
      d_.done = static_cast<cudaEvent_t>(w_.params_done_);
    }
  }
  ParamsTurn(const ParamsTurn&) = delete;
  ParamsTurn& operator=(const ParamsTurn&) = delete;

 private:
  const WavefrontGpu& w_;
  cudaStream_t stream_;
  DeviceParams& d_;
  std::lock_guard<std::mutex> lock_;
};

bool WavefrontGpu::render(const FrameSpec& frame, const SceneView& device_scene, uint32_t feature_level,
                          uint32_t first_sample, uint32_t spp, void* sum, void* sum_sq, const DeviceFilm* film,
                          void* stream) {
  ParamsTurn turn(*this, static_cast<cudaStream_t>(stream));
  return run(frame, device_scene, feature_level, first_sample, spp, RestirFrame(), sum, sum_sq, film, stream);
}

void WavefrontGpu::render_restir(const FrameSpec& frame, const SceneView& device_scene, uint32_t feature_level,
                                 uint32_t sample, const RestirFrameBuffers& b, void* sum, void* sum_sq,
                                 void* stream_ptr) {
  cudaStream_t stream = static_cast<cudaStream_t>(stream_ptr);
  ParamsTurn turn(*this, stream);  // the reuse and shading passes read g_params too
  run(frame, device_scene, feature_level, sample, 1, RestirFrame{b.pixels, b.reservoirs[0]}, sum, sum_sq, nullptr,
      stream_ptr);
  const IntegratorSettings& s = frame.integrator;
  const uint32_t pixels = uint32_t(frame.camera.width) * uint32_t(frame.camera.height);
  const unsigned grid = unsigned(num_sms_) * 8u;
  // Chunks of the frame: recorded and traced where the pass makes queries, then replayed (wavefront.h).
  auto frame_pass = [&](uint32_t max_rays, auto&& record, auto&& replay) {
    restir_frame_pass(
        view_, pixels, max_rays, [&](const RestirChunk&) { begin_shadow_batch_kernel<<<1, 1, 0, stream>>>(); },
        record, [&](const RestirChunk&) { trace_->shadow(stream); },
        [&](const RestirChunk& c) {
          replay(c);
          check(cudaGetLastError(), "restir's frame passes");
        });
  };
  RestirReuse r;
  r.pixels = b.pixels;
  r.history_pixels = b.history_pixels;
  r.history = b.history;
  r.width = frame.camera.width;
  r.height = frame.camera.height;
  r.sample = sample;
  r.seed = frame.seed;
  int cur = 0;  // b.reservoirs[cur]: the latest
  for (uint32_t step = 0; step < restir_reuse_steps(s.restir); ++step) {
    r.pass = restir_reuse_pass(s.restir, step);
    r.in = b.reservoirs[cur];
    Reservoir* out = b.reservoirs[cur ^ 1];
    frame_pass(
        restir_reuse_max_rays(s.restir, r.pass),
        [&](const RestirChunk& c) { reuse_record_kernel<<<grid, kBlock, 0, stream>>>(c, r); },
        [&](const RestirChunk& c) { reuse_replay_kernel<<<grid, kBlock, 0, stream>>>(c, r, out); });
    cur ^= 1;
  }
  const Reservoir* final_reservoirs = b.reservoirs[cur];
  frame_pass(
      restir_shade_max_rays(s.restir),
      [&](const RestirChunk& c) { shade_record_kernel<<<grid, kBlock, 0, stream>>>(c, b.pixels, final_reservoirs); },
      [&](const RestirChunk& c) {
        shade_replay_kernel<<<grid, kBlock, 0, stream>>>(c, b.pixels, final_reservoirs, b.history_pixels, b.history);
      });
}

bool WavefrontGpu::run(const FrameSpec& frame, const SceneView& device_scene, uint32_t feature_level,
                       uint32_t first_sample, uint32_t spp, const RestirFrame& restir, void* sum, void* sum_sq,
                       const DeviceFilm* film, void* stream_ptr) {
  cudaStream_t stream = static_cast<cudaStream_t>(stream_ptr);
  const uint32_t pixels = uint32_t(frame.camera.width) * uint32_t(frame.camera.height);
  const uint64_t items = uint64_t(pixels) * spp;
  if (items == 0) return false;
  // wavefront_graph=false: launch each wave's kernels directly (to tell a graph's fault from a kernel's).
  const bool use_graph = graph_allowed_ && trace_->capturable();
  const ShadeKernelKey shade = shade_kernel_key(frame.integrator);
  if (use_graph && (!exec_ || graph_level_ != feature_level || graph_depth_ != frame.integrator.max_depth ||
                    !(graph_shade_ == shade)))
    record(feature_level, frame.integrator.max_depth, shade, stream);
  WaveParams p;
  p.view = view_;
  p.view.restir = restir;
  const WaveShape shape = wave_shape(capacity_, frame.integrator, device_scene.selection.infinite_light >= 0);
  p.view.shared_slots = shape.shared_slots;
  const uint32_t paths = shape.paths;
  p.scene = device_scene;
  p.camera = frame.camera;
  p.integrator = frame.integrator;
  p.sum = static_cast<float4*>(sum);
  p.sum_sq = static_cast<float4*>(sum_sq);
  // One wave holding every sample of every pixel: the accumulation adds them to the film.
  const bool into_film = film_direct_ && film && film->sum && items <= paths;
  if (into_film) p.film = *film;
  // Pageable copies: staged before they return, ordered on the stream before the graph's kernels read them.
  check(cudaMemcpyToSymbolAsync(g_params, &p, sizeof p, 0, cudaMemcpyHostToDevice, stream), "the parameters");
  check(cudaMemcpyAsync(view_device_, &p.view, sizeof p.view, cudaMemcpyHostToDevice, stream), "the pool's view");
  for (uint64_t k0 = 0; k0 < items; k0 += paths) {
    WaveSpec wave;
    wave.first_item = k0;
    wave.count = uint32_t(items - k0 < paths ? items - k0 : paths);
    wave.first_sample = first_sample;
    wave.pixels = pixels;
    wave.seed = frame.seed;
    check(cudaMemcpyAsync(wave_, &wave, sizeof wave, cudaMemcpyHostToDevice, stream), "the wave's items");
    if (use_graph) check(cudaGraphLaunch(static_cast<cudaGraphExec_t>(exec_), stream), "cudaGraphLaunch");
    else enqueue(feature_level, frame.integrator.max_depth, shade, stream);
  }
  return into_film;
}

}  // namespace pn
