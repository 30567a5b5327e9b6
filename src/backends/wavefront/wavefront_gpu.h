// The wavefront path tracer on the GPU (issue 11, part 2; backends/optix/WAVEFRONT.md): the stage functions of
// wavefront.h in CUDA kernels over a device pool, the trace stage through either implementation (trace-only
// OptiX launches or the cuda traversal), the launches of one wave recorded once in a CUDA graph and replayed.
// The OptiX backend runs it in place of its megakernel with --wavefront (BackendOptions::wavefront).
//
// This header has no CUDA types, so any C++ code may include it.
#pragma once

#include <cstdint>
#include <memory>
#include <string>

#include "backends/gpu/device_film.h"
#include "backends/trace_stage.h"
#include "backends/wavefront/wavefront.h"
#include "render/backend.h"

namespace pn {

// The trace stage as a wavefront calls it: launches over queues that stay where they are for the pool's life,
// their lengths in device memory, so that a CUDA graph can record them (nothing synchronous in closest / shadow).
class WavefrontTraceStage {
 public:
  virtual ~WavefrontTraceStage() = default;
  struct Queues {
    const TraceRay* closest_rays[2] = {nullptr, nullptr};
    const uint32_t* closest_count[2] = {nullptr, nullptr};
    HitRecord* hits = nullptr;
    const TraceRay* shadow_rays = nullptr;
    const uint32_t* shadow_count = nullptr;
    uint32_t* blocked_bits = nullptr;
    uint32_t capacity = 0;
  };
  // The queues every later call traces; before the first of them (may upload launch parameters).
  virtual void bind(const Queues& q) = 0;
  virtual void closest(int queue, void* stream) = 0;  // ray queue `queue` -> hits; stream: a cudaStream_t
  virtual void shadow(void* stream) = 0;              // the shadow queue -> blocked bits
  virtual std::string name() const = 0;               // "optix" or "cuda"
  // The shadow queue traced and each answer applied to its path (apply_shadow_result) by one launch, `view`
  // being the wavefront's WavefrontView in device memory; false: not offered (shadow, then the apply kernel).
  // `ordered`: the view's ShadowOrder holds this queue's order (wavefront.h), to trace it in.
  virtual bool shadow_apply(const WavefrontView* view, bool ordered, void* stream) {
    (void)view, (void)ordered, (void)stream;
    return false;
  }
  virtual bool offers_shadow_apply() const { return false; }  // whether shadow_apply does (and returns true)
  // Ray queue `queue` traced in the order `order` (device memory: a permutation of its positions), each hit written
  // at its ray's queue position; false: not offered (closest, in queue order). The same hits either way.
  virtual bool closest_ordered(int queue, const uint32_t* order, void* stream) {
    (void)queue, (void)order, (void)stream;
    return false;
  }
  // Whether closest_ordered does (and returns true); then [*lo, *hi] is the scene's box (the ray order's origin
  // cells).
  virtual bool offers_closest_order(Vec3* lo, Vec3* hi) const {
    (void)lo, (void)hi;
    return false;
  }
  // BvhStats::sah_visits_per_ray of the stage's scene, where it knows it (0: not known).
  virtual double sah_visits_per_ray() const { return 0.0; }
  // How the stage's traversal traces this scene, in a few words, where it has a choice ("": none).
  virtual std::string traversal_form() const { return ""; }
  // The scene's sphere lights moved or resized (Backend::update_lights): the stage traces `scene` from now on
  // (device_scene: the device SceneView, its arrays where they were), its meshes' structures kept as they are.
  // false: the stage cannot (the backend is then made again).
  virtual bool update_scene(const Scene& scene, const SceneView& device_scene) {
    (void)scene, (void)device_scene;
    return false;
  }
  // Whether closest / shadow may be recorded in a CUDA graph. optixLaunch may not: under stream capture OptiX
  // syncs on an event of its own, which fails ("Error synching on OptixPipeline event", measured on the H200),
  // so a wave with the optix stage launches its kernels directly.
  virtual bool capturable() const { return true; }
};

// A frame's restir buffers in device memory, one entry a pixel.
struct RestirFrameBuffers {
  RestirPixel* pixels = nullptr;                  // the primary pass's records
  Reservoir* reservoirs[2] = {nullptr, nullptr};  // [0]: the primary pass's; the passes ping-pong between them
  RestirPixel* history_pixels = nullptr;          // temporal reuse (null without it): the previous sample's
  Reservoir* history = nullptr;
};

// The cuda traversal (backends/cuda) as a wavefront's trace stage: builds and uploads the scene's BVH (as `tuning`
// says: its bvh, the cuda_* keys). device_scene: the device SceneView (alpha masks). Throws std::runtime_error with
// one line.
std::unique_ptr<WavefrontTraceStage> make_cuda_trace_stage(const Scene& scene, const SceneView& device_scene,
                                                           const GpuTuning& tuning);

// Which shading kernel a wave launches (wavefront_gpu.cu: one compiled per strategy and MIS class where lights are
// chosen simply, one for any configuration, and one for any with light sampling that weighs by the BSDF's lobes).
struct ShadeKernelKey {
  uint32_t strategy = 0, mis = 0;
  uint32_t extra = 0;  // the bits of kExtraLightSampling the configuration needs (core/features.h)
  bool operator==(const ShadeKernelKey& o) const {
    return strategy == o.strategy && mis == o.mis && extra == o.extra;
  }
};

// A wavefront of tuning.wavefront_paths paths on the current CUDA device, run as `tuning` says (its wavefront_*,
// shadow_order, shadow_reverse and ray_order keys). Throws std::runtime_error with one line (out of memory: the
// pool's size and --tune wavefront_paths named).
class WavefrontGpu {
 public:
  WavefrontGpu(std::unique_ptr<WavefrontTraceStage> trace, const GpuTuning& tuning, int num_sms);
  ~WavefrontGpu();
  WavefrontGpu(const WavefrontGpu&) = delete;
  WavefrontGpu& operator=(const WavefrontGpu&) = delete;

  // Samples [first_sample, first_sample + spp) of every pixel, as waves of at most capacity() paths, into the
  // launch sums the megakernel's raygen writes (float4 a pixel; sum: the samples' sum in xyz and the rays traced
  // in w, sum_sq: their squares in xyz and the non-finite samples in w), queued on `stream` (a cudaStream_t).
  // Where one wave holds them all and `film` is given, they go into the film instead, as launch_accumulate would
  // add the launch sums (the same doubles; no launch sums written), and it returns true.
  // feature_level indexes gpu::kFeatureLevels (the smallest level covering the scene, as the megakernel's).
  // The graph of one wave is recorded at the first call and again where max_depth or the level changes.
  bool render(const FrameSpec& frame, const SceneView& device_scene, uint32_t feature_level, uint32_t first_sample,
              uint32_t spp, void* sum, void* sum_sq, const DeviceFilm* film, void* stream);

  // One sample of every pixel by restir's frame passes (core/restir.h), queued on `stream`: the primary pass as
  // waves (RestirFrame: each path's first vertex writes its record and reservoir to b, its radiance less that
  // vertex's direct light to the record, its rays to sum.w), then the reuse and shading passes in chunks, each
  // recorded, traced by the trace stage and replayed (wavefront.h), the shading writing the launch sums as render()
  // does. Either traversal.
  void render_restir(const FrameSpec& frame, const SceneView& device_scene, uint32_t feature_level, uint32_t sample,
                     const RestirFrameBuffers& b, void* sum, void* sum_sq, void* stream);

  // The scene's sphere lights changed (WavefrontTraceStage::update_scene); the wave's graph, which holds the
  // stage's old structures, is recorded again at the next render. false: the stage cannot.
  bool update_scene(const Scene& scene, const SceneView& device_scene);

  uint32_t capacity() const { return capacity_; }
  // In which order shadow queries from depth kShadowOrderDepth on are traced (wavefront.h's ShadowOrder), and why,
  // in a few words ("direction order (auto: rays visit 46.4 nodes, at least 24)").
  const std::string& shadow_order_reason() const { return order_reason_; }
  // The same for the closest-hit rays of the bounces (wavefront.h's RayOrder): "cell order (auto: ...)".
  const std::string& ray_order_reason() const { return ray_order_reason_; }
  uint64_t device_bytes() const { return bytes_; }
  std::string traversal() const { return trace_->name(); }
  std::string traversal_form() const { return trace_->traversal_form(); }

 private:
  bool run(const FrameSpec& frame, const SceneView& device_scene, uint32_t feature_level, uint32_t first_sample,
           uint32_t spp, const RestirFrame& restir, void* sum, void* sum_sq, const DeviceFilm* film, void* stream);
  void record(uint32_t feature_level, int max_depth, const ShadeKernelKey& shade, void* stream);
  void drop_graph();
  void enqueue(uint32_t feature_level, int max_depth, const ShadeKernelKey& shade, void* stream);
  class ParamsTurn;  // a render call's turn at the device's one copy of the kernels' parameters (wavefront_gpu.cu)

  std::unique_ptr<WavefrontTraceStage> trace_;
  uint32_t capacity_ = 0;
  int num_sms_ = 1;
  uint64_t bytes_ = 0;
  void* memory_ = nullptr;     // every array of the pool, one allocation
  void* wave_ = nullptr;       // the WaveSpec in device memory
  WavefrontView* view_device_ = nullptr;  // view_ in device memory, its RestirFrame the render call's
  bool fuse_shadow_ = true;    // the trace stage's shadow_apply where offered (wavefront_fuse=false: never)
  bool order_shadow_ = false;  // the shadow queue traced by direction (ShadowOrder): with shadow_apply only
  bool order_rays_ = false;    // the bounces' ray queues traced by direction and origin (RayOrder): closest_ordered
  bool film_direct_ = true;    // render()'s film where given (wavefront_film=false: never)
  bool graph_allowed_ = true;  // a wave's kernels through a CUDA graph where the stage is capturable (wavefront_graph)
  void* graph_ = nullptr;      // cudaGraph_t
  void* exec_ = nullptr;       // cudaGraphExec_t
  int device_ = 0;             // the CUDA device this pool lives on
  void* params_done_ = nullptr;  // cudaEvent_t: recorded after this object's last kernels that read the parameters
  uint32_t graph_level_ = 0;
  int graph_depth_ = -1;
  ShadeKernelKey graph_shade_;
  WavefrontView view_;         // device pointers into memory_
  std::string order_reason_;
  std::string ray_order_reason_;
};

// Where shadow_order is auto (its default), the shadow queries are ordered by direction when rays in the
// scene visit at least this many nodes (BvhStats::sah_visits_per_ray). Measured on the H200 (commit
// a01e762; its docs/results are in git history), ms a 1080p sample, queue -> direction order: sponza (46 visits)
// 10.56 -> 9.70,
// sponza-lanterns (50) 12.81 -> 12.11; cornell-sphere (9.4) 1.94 -> 2.09, glossy (2) +3%, bunnies (14) +0.4%,
// many-spheres (18, many lights) +2%; occlusion (16) -7%, a gain this rule misses.
constexpr double kShadowOrderMinVisits = 24.0;
// The same for the bounces' closest-hit rays (ray_order=auto).
constexpr double kRayOrderMinVisits = 24.0;

}  // namespace pn
