// CPU backend. Embree answers the integrator's two questions (closest hit, any
// hit); spheres are Embree user geometry intersected by core/geometry.h so that
// CPU and GPU compute the same hits, and alpha-masked triangles are skipped by
// Embree filter functions that ask core/scene_view.h's alpha_discards(), as the
// GPU's any-hit program does. Work is split into 16x16 tiles taken by a
// pool of threads; every pixel sample has its own RNG stream, so the image does
// not depend on the number of threads or on the order tiles are taken. Paths
// run depth-first (trace_path) or, as an option, breadth-first: a pool of a
// tile's paths advanced a step at a time in the order of a wavefront GPU's
// kernels (trace_pool), which gives the same image; or as the GPU wavefront does: its stage functions
// (backends/wavefront/wavefront.h) in loops over a whole-frame pool (render_wavefront), the same image again.
#include "backends/cpu/cpu_backend.h"

#include <algorithm>
#include <atomic>
#include <condition_variable>
#include <exception>
#include <mutex>
#include <stdexcept>
#include <thread>
#include <vector>

#include <embree3/rtcore.h>

#include "core/aov.h"
#include "core/geometry.h"
#include "core/integrator.h"
#include "core/restir.h"
#include "core/sample_sums.h"
#include "backends/wavefront/restir_passes.h"

namespace pn {
namespace {

// --- Sphere user geometry ------------------------------------------------------

void sphere_bounds(const RTCBoundsFunctionArguments* args) {
  const auto* spheres = static_cast<const std::vector<Sphere>*>(args->geometryUserPtr);
  const Sphere& s = (*spheres)[args->primID];
  float r = sphere_bounds_radius(s.radius);
  args->bounds_o->lower_x = s.center.x - r;
  args->bounds_o->lower_y = s.center.y - r;
  args->bounds_o->lower_z = s.center.z - r;
  args->bounds_o->upper_x = s.center.x + r;
  args->bounds_o->upper_y = s.center.y + r;
  args->bounds_o->upper_z = s.center.z + r;
}

void sphere_intersect(const RTCIntersectFunctionNArguments* args) {
  if (!args->valid[0]) return;
  const auto* spheres = static_cast<const std::vector<Sphere>*>(args->geometryUserPtr);
  const Sphere& s = (*spheres)[args->primID];
  RTCRayHit* rh = reinterpret_cast<RTCRayHit*>(args->rayhit);  // N == 1: rtcIntersect1 only
  Ray ray(Vec3(rh->ray.org_x, rh->ray.org_y, rh->ray.org_z), Vec3(rh->ray.dir_x, rh->ray.dir_y, rh->ray.dir_z));
  float t;
  if (!intersect_sphere(ray, s.center, s.radius, rh->ray.tnear, rh->ray.tfar, &t)) return;
  rh->ray.tfar = t;
  rh->hit.geomID = args->geomID;
  rh->hit.primID = args->primID;
  rh->hit.instID[0] = args->context->instID[0];
  rh->hit.u = rh->hit.v = 0.f;
  rh->hit.Ng_x = rh->hit.Ng_y = rh->hit.Ng_z = 0.f;  // recomputed by the integrator side
}

void sphere_occluded(const RTCOccludedFunctionNArguments* args) {
  if (!args->valid[0]) return;
  const auto* spheres = static_cast<const std::vector<Sphere>*>(args->geometryUserPtr);
  const Sphere& s = (*spheres)[args->primID];
  RTCRay* r = reinterpret_cast<RTCRay*>(args->ray);
  Ray ray(Vec3(r->org_x, r->org_y, r->org_z), Vec3(r->dir_x, r->dir_y, r->dir_z));
  float t;
  if (intersect_sphere(ray, s.center, s.radius, r->tnear, r->tfar, &t)) r->tfar = -kInf;  // Embree: occluded
}

// --- Alpha masks ------------------------------------------------------------------

// What a mesh's filter function needs: the scene view and, by instance ID, the instance.
struct FilterData {
  const SceneView* view = nullptr;
  const std::vector<int>* instance_of_geom = nullptr;  // top-level geometry ID -> instance index
};

void alpha_filter(const RTCFilterFunctionNArguments* args) {
  const auto* fd = static_cast<const FilterData*>(args->geometryUserPtr);
  for (unsigned i = 0; i < args->N; ++i) {
    if (args->valid[i] == 0) continue;
    const unsigned inst_id = RTCHitN_instID(args->hit, args->N, i, 0);
    const unsigned prim = RTCHitN_primID(args->hit, args->N, i);
    const float b1 = RTCHitN_u(args->hit, args->N, i), b2 = RTCHitN_v(args->hit, args->N, i);
    if (inst_id >= fd->instance_of_geom->size()) continue;
    const int idx = (*fd->instance_of_geom)[inst_id];
    if (idx < 0) continue;
    if (alpha_discards(*fd->view, fd->view->instances[idx], prim, b1, b2)) args->valid[i] = 0;
  }
}

// Threads wait here until all of them have arrived (C++17 has no std::barrier).
class Barrier {
 public:
  explicit Barrier(int n) : n_(n) {}
  void wait() {
    std::unique_lock<std::mutex> lock(mutex_);
    const uint64_t generation = generation_;
    if (++arrived_ == n_) {
      arrived_ = 0;
      ++generation_;
      cv_.notify_all();
      return;
    }
    cv_.wait(lock, [&] { return generation != generation_; });
  }

 private:
  std::mutex mutex_;
  std::condition_variable cv_;
  const int n_;
  int arrived_ = 0;
  uint64_t generation_ = 0;
};

class CpuBackend final : public Backend {
 public:
  // The scene must outlive the backend: its arrays are traced in place.
  CpuBackend(const Scene& scene, int threads, CpuSchedule schedule, uint32_t wavefront_paths = 0)
      : scene_(scene), host_(make_host_view(scene)), view_(host_->view), schedule_(schedule),
        wavefront_paths_(wavefront_paths > 0 ? wavefront_paths : (1u << 20)) {
    filter_.view = &view_;
    filter_.instance_of_geom = &instance_of_geom_;
    threads_ = threads > 0 ? threads : int(std::max(1u, std::thread::hardware_concurrency()));
    device_ = rtcNewDevice("threads=1");  // Embree's own threads only build; we trace
    if (!device_) throw std::runtime_error("cannot create Embree device (error " + std::to_string(rtcGetDeviceError(nullptr)) + ")");
    // One Embree scene per mesh (its BVH built once) and one instance per
    // placement: the same structure as the GPU's GAS-per-mesh plus IAS.
    // Meshes with any alpha-masked material get the filter (it is per geometry).
    std::vector<bool> masked(scene.meshes.size(), false);
    for (const Instance& inst : scene.instances)
      if (scene.instance_alpha_masked(inst)) masked[inst.mesh] = true;
    for (size_t mi = 0; mi < scene.meshes.size(); ++mi) {
      const TriangleMesh& m = scene.meshes[mi];
      RTCScene ms = rtcNewScene(device_);
      rtcSetSceneFlags(ms, RTC_SCENE_FLAG_ROBUST);  // watertight: no ray slips between two triangles of a mesh
      rtcSetSceneBuildQuality(ms, RTC_BUILD_QUALITY_HIGH);
      RTCGeometry g = rtcNewGeometry(device_, RTC_GEOMETRY_TYPE_TRIANGLE);
      auto* v = static_cast<float*>(rtcSetNewGeometryBuffer(g, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3,
                                                            3 * sizeof(float), m.positions.size()));
      for (size_t i = 0; i < m.positions.size(); ++i) {
        v[3 * i] = m.positions[i].x;
        v[3 * i + 1] = m.positions[i].y;
        v[3 * i + 2] = m.positions[i].z;
      }
      auto* idx = static_cast<uint32_t*>(rtcSetNewGeometryBuffer(g, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3,
                                                                 3 * sizeof(uint32_t), m.indices.size()));
      for (size_t i = 0; i < m.indices.size(); ++i)
        for (int k = 0; k < 3; ++k) idx[3 * i + k] = m.indices[i][k];
      if (masked[mi]) {
        rtcSetGeometryUserData(g, &filter_);
        rtcSetGeometryIntersectFilterFunction(g, alpha_filter);
        rtcSetGeometryOccludedFilterFunction(g, alpha_filter);
      }
      rtcCommitGeometry(g);
      rtcAttachGeometry(ms, g);
      rtcReleaseGeometry(g);
      rtcCommitScene(ms);
      mesh_scenes_.push_back(ms);
    }
    rtc_ = rtcNewScene(device_);
    rtcSetSceneFlags(rtc_, RTC_SCENE_FLAG_ROBUST);
    rtcSetSceneBuildQuality(rtc_, RTC_BUILD_QUALITY_HIGH);
    for (size_t ii = 0; ii < scene.instances.size(); ++ii) {
      const Instance& inst = scene.instances[ii];
      RTCGeometry g = rtcNewGeometry(device_, RTC_GEOMETRY_TYPE_INSTANCE);
      rtcSetGeometryInstancedScene(g, mesh_scenes_[inst.mesh]);
      rtcSetGeometryTransform(g, 0, RTC_FORMAT_FLOAT3X4_ROW_MAJOR, inst.to_world.m);
      rtcCommitGeometry(g);
      unsigned id = rtcAttachGeometry(rtc_, g);
      rtcReleaseGeometry(g);
      instance_of_geom_.resize(id + 1, -1);
      instance_of_geom_[id] = int(ii);
    }
    if (!scene.spheres.empty()) {
      RTCGeometry g = rtcNewGeometry(device_, RTC_GEOMETRY_TYPE_USER);
      rtcSetGeometryUserPrimitiveCount(g, unsigned(scene.spheres.size()));
      rtcSetGeometryUserData(g, const_cast<std::vector<Sphere>*>(&scene.spheres));
      rtcSetGeometryBoundsFunction(g, sphere_bounds, nullptr);
      rtcSetGeometryIntersectFunction(g, sphere_intersect);
      rtcSetGeometryOccludedFunction(g, sphere_occluded);
      rtcCommitGeometry(g);
      sphere_geom_ = rtcAttachGeometry(rtc_, g);
      rtcReleaseGeometry(g);
      instance_of_geom_.resize(sphere_geom_ + 1, -1);
    }
    rtcCommitScene(rtc_);
    if (rtcGetDeviceError(device_) != RTC_ERROR_NONE)
      throw std::runtime_error(scene.source + ": Embree failed to build the scene (error " +
                               std::to_string(rtcGetDeviceError(device_)) + ")");
  }
  ~CpuBackend() override {
    rtcReleaseScene(rtc_);
    for (RTCScene ms : mesh_scenes_) rtcReleaseScene(ms);
    rtcReleaseDevice(device_);
  }

  // The lights and the sphere records are read from the scene's arrays through a new host view (the light BVH's
  // nodes were reallocated); the sphere set's bounds are recomputed and the top level rebuilt over the meshes'
  // BVHs as they are (rtcCommitScene), which are not touched.
  bool update_lights() override {
    restir_history_.clear();  // of the old lights
    host_ = make_host_view(scene_);
    view_ = host_->view;
    if (sphere_geom_ != RTC_INVALID_GEOMETRY_ID) {
      rtcCommitGeometry(rtcGetGeometry(rtc_, sphere_geom_));
      rtcCommitScene(rtc_);
    }
    return rtcGetDeviceError(device_) == RTC_ERROR_NONE;
  }

  std::string name() const override { return "cpu"; }
  std::string device_name() const override {
    return std::to_string(threads_) + " CPU thread" + (threads_ > 1 ? "s" : "") + " (Embree " +
           std::to_string(RTC_VERSION_MAJOR) + "." + std::to_string(RTC_VERSION_MINOR) + "." +
           std::to_string(RTC_VERSION_PATCH) + (schedule_ == CpuSchedule::BreadthFirst ? ", breadth-first"
            : schedule_ == CpuSchedule::Wavefront  ? ", wavefront"
                                                   : "") + ")";
  }

  // The integrator's view of Embree.
  struct Tracer {
    const CpuBackend* self;
    bool intersect(const Ray& ray, float tmax, HitRecord* hit) const {
      RTCIntersectContext ctx;
      rtcInitIntersectContext(&ctx);
      RTCRayHit rh;
      rh.ray.org_x = ray.o.x; rh.ray.org_y = ray.o.y; rh.ray.org_z = ray.o.z;
      rh.ray.dir_x = ray.d.x; rh.ray.dir_y = ray.d.y; rh.ray.dir_z = ray.d.z;
      rh.ray.tnear = 0.f;
      rh.ray.tfar = tmax;
      rh.ray.mask = 0xFFFFFFFFu;
      rh.ray.flags = 0;
      rh.ray.time = 0.f;
      rh.hit.geomID = RTC_INVALID_GEOMETRY_ID;
      rh.hit.instID[0] = RTC_INVALID_GEOMETRY_ID;
      rtcIntersect1(self->rtc_, &ctx, &rh);
      if (rh.hit.geomID == RTC_INVALID_GEOMETRY_ID) return false;
      hit->t = rh.ray.tfar;
      hit->prim = rh.hit.primID;
      if (rh.hit.instID[0] != RTC_INVALID_GEOMETRY_ID) {
        hit->instance = uint32_t(self->instance_of_geom_[rh.hit.instID[0]]);
        hit->b1 = rh.hit.u;
        hit->b2 = rh.hit.v;
      } else {
        hit->instance = kSphereInstance;
      }
      return true;
    }
    bool occluded(const Ray& ray, float tmax) const {
      RTCIntersectContext ctx;
      rtcInitIntersectContext(&ctx);
      RTCRay r;
      r.org_x = ray.o.x; r.org_y = ray.o.y; r.org_z = ray.o.z;
      r.dir_x = ray.d.x; r.dir_y = ray.d.y; r.dir_z = ray.d.z;
      r.tnear = 0.f;
      r.tfar = tmax;
      r.mask = 0xFFFFFFFFu;
      r.flags = 0;
      r.time = 0.f;
      rtcOccluded1(self->rtc_, &ctx, &r);
      return r.tfar < 0.f;
    }
  };

  void render(const FrameSpec& frame, Film& film, uint32_t first_sample, uint32_t count,
              const ProgressFn& progress) override {
    const int W = frame.camera.width, H = frame.camera.height;
    if (film.width() != W || film.height() != H) throw std::logic_error("film size differs from the camera's");
    stats_ = RenderStats();
    if (restir_frame_passes(frame.integrator)) return render_restir(frame, film, first_sample, count, progress);
    if (schedule_ == CpuSchedule::Wavefront) return render_wavefront(frame, film, first_sample, count, progress);
    const uint64_t total = uint64_t(W) * H * count;
    std::atomic<uint64_t> done{0};
    Tracer tracer{this};
    const bool breadth_first = schedule_ == CpuSchedule::BreadthFirst;
    for_each_tile(W, H, 1, progress, [&](uint32_t, int x0, int y0, int x1, int y1) {
      const int tw = x1 - x0, th = y1 - y0;
      std::vector<PixelSum> sums(size_t(tw) * th);
      if (!breadth_first) {
        for (int y = y0; y < y1; ++y)
          for (int x = x0; x < x1; ++x)
            for (uint32_t i = 0; i < count; ++i)
              sums[size_t(y - y0) * tw + (x - x0)].add(
                  render_sample(tracer, view_, frame.camera, frame.integrator, x, y, first_sample + i, frame.seed));
      } else {
        // Pools of at most kPoolPaths paths: every pixel of the tile, a run of its samples.
        const uint32_t run = std::max<uint32_t>(1, uint32_t(kPoolPaths / sums.size()));
        std::vector<PathState> pool;
        for (uint32_t i0 = 0; i0 < count; i0 += run) {
          const uint32_t n = std::min(run, count - i0);
          pool.clear();
          for (int y = y0; y < y1; ++y)
            for (int x = x0; x < x1; ++x)
              for (uint32_t i = 0; i < n; ++i)
                pool.push_back(start_path(frame.camera, x, y, first_sample + i0 + i, frame.seed));
          trace_pool(tracer, frame.integrator, pool, nullptr);
          for (size_t k = 0; k < pool.size(); ++k) sums[k / n].add(pool[k].L);  // each pixel's samples in order
        }
      }
      for (int y = y0; y < y1; ++y)
        for (int x = x0; x < x1; ++x) add_to_film(film, x, y, W, sums[size_t(y - y0) * tw + (x - x0)]);
      return std::make_pair(done += uint64_t(tw) * th * count, total);
    });
    film.add_samples(count);
  }

  RenderStats last_render_stats() const override { return stats_; }

  GuideImages render_guides(const FrameSpec& frame, uint32_t samples) override {
    const int W = frame.camera.width, H = frame.camera.height;
    GuideImages g;
    g.width = W;
    g.height = H;
    g.albedo.assign(size_t(W) * H * 3, 0.f);
    g.normal.assign(size_t(W) * H * 3, 0.f);
    Tracer tracer{this};
    for_each_tile(W, H, 1, nullptr, [&](uint32_t, int x0, int y0, int x1, int y1) {
      for (int y = y0; y < y1; ++y)
        for (int x = x0; x < x1; ++x) {
          const GuideSample s = render_guides_pixel(tracer, view_, frame.camera, x, y, samples, frame.seed);
          const size_t o = (size_t(y) * W + x) * 3;
          for (int c = 0; c < 3; ++c) {
            g.albedo[o + c] = s.albedo[c];
            g.normal[o + c] = s.normal[c];
          }
        }
      return std::make_pair(uint64_t(0), uint64_t(0));
    });
    return g;
  }

 private:
  // One pixel's samples, summed in sample order (the same order for every schedule).
  using PixelSum = SampleSums<double>;

  static constexpr size_t kPoolPaths = 4096;

  // The breadth-first schedule: the paths of a pool (started by start_path)
  // advanced to their ends one step at a time, in the order of a wavefront
  // GPU's kernels:
  //   1. the closest hit of every active path's ray;
  //   2. the shadow rays of every query the last step made, traced, then
  //      consumed (on_shadow_result): after the closest hits of the paths'
  //      next rays, and from the pool's last path to its first;
  //   3. every hit or miss consumed (on_hit / on_miss): new queries, next rays.
  // primary: restir's primary pass, one output per path (else null).
  void trace_pool(const Tracer& tracer, const IntegratorSettings& s, std::vector<PathState>& pool,
                  RestirPrimaryOut* primary) const {
    const size_t n = pool.size();
    std::vector<HitRecord> hits(n);
    std::vector<uint8_t> found(n), blocked(n);
    std::vector<ShadowQuery> queries(n);  // kind None: nothing pending
    // slc's queries (on_hit's `more`), each with its path.
    struct MoreQueries {
      std::vector<std::pair<size_t, ShadowQuery>> queries;
      size_t path = 0;
      void push(const ShadowQuery& q) { queries.emplace_back(path, q); }
    } more;
    for (bool shaded = true; shaded;) {
      for (size_t i = 0; i < n; ++i)
        if (pool[i].active) found[i] = tracer.intersect(pool[i].ray, kInf, &hits[i]);
      for (size_t i = n; i-- > 0;)
        if (queries[i].kind != ShadowKind::None) blocked[i] = tracer.occluded(queries[i].ray, queries[i].tmax);
      for (size_t i = n; i-- > 0;)
        if (queries[i].kind != ShadowKind::None) {
          on_shadow_result(pool[i], queries[i], blocked[i] != 0, primary ? &primary[i] : nullptr);
          queries[i] = ShadowQuery();
        }
      for (const auto& [i, q] : more.queries) on_shadow_result(pool[i], q, tracer.occluded(q.ray, q.tmax));
      more.queries.clear();
      shaded = false;
      for (size_t i = 0; i < n; ++i) {
        if (!pool[i].active) continue;
        shaded = true;
        more.path = i;
        if (found[i])
          queries[i] = on_hit(pool[i], view_, s, hits[i], primary ? &primary[i] : nullptr,
                              static_cast<const NoShadowTracer*>(nullptr), &more);
        else on_miss(pool[i], view_, s);
      }
    }
  }

  // Calls fn(i) for i in [0, n) on the backend's threads (chunks taken from a counter).
  template <class Fn>
  void parallel_for(uint32_t n, Fn&& fn) const {
    constexpr uint32_t kChunk = 64;
    const int threads = int(std::min<uint32_t>(uint32_t(threads_), (n + kChunk - 1) / kChunk));
    std::atomic<uint32_t> next{0};
    auto work = [&] {
      for (uint32_t i0; (i0 = next.fetch_add(kChunk)) < n;)
        for (uint32_t i = i0; i < std::min(n, i0 + kChunk); ++i) fn(i);
    };
    std::vector<std::thread> pool;
    for (int t = 1; t < threads; ++t) pool.emplace_back(work);
    work();
    for (auto& th : pool) th.join();
  }

  // The Wavefront schedule: the GPU wavefront's stages (backends/wavefront/wavefront.h), each a loop over its
  // queue on the backend's threads, Embree as the trace stage; the render call's pixels x samples in waves of
  // wavefront_paths_ slots. Every pixel's samples are summed in sample order (PixelSum), as depth-first.
  void render_wavefront(const FrameSpec& frame, Film& film, uint32_t first_sample, uint32_t count,
                        const ProgressFn& progress) {
    const int W = frame.camera.width, H = frame.camera.height;
    const uint32_t pixels = uint32_t(W) * uint32_t(H);
    // The accumulation's sink: the render call's PixelSums (a pixel's samples in order).
    std::vector<PixelSum> sums(pixels);
    struct Sink {
      PixelSum* sums;
      PixelSum* ps = nullptr;
      void begin(uint32_t pixel, bool) { ps = &sums[pixel]; }
      void add(const Vec3& radiance, uint32_t) { ps->add(radiance); }
      void end(uint32_t) {}
    };
    HostWavefront hw(uint32_t(std::min<uint64_t>(wavefront_paths_, std::max<uint64_t>(uint64_t(pixels) * count, 1))));
    run_waves(hw, frame, first_sample, count, RestirFrame(), [&] { return Sink{sums.data()}; }, progress);
    for (uint32_t p = 0; p < pixels; ++p) add_to_film(film, int(p % uint32_t(W)), int(p / uint32_t(W)), W, sums[p]);
    film.add_samples(count);
  }

  // A wavefront's arrays on the host, with the GPU's layout.
  struct HostWavefront {
    std::vector<Vec3> beta, L, contribution;
    std::vector<Rng> rng;
    std::vector<PrevWords> prev, prev_lobes;
    std::vector<int32_t> depth;
    std::vector<uint32_t> rays, slots[3], bits;
    std::vector<TraceRay> queue_rays[3];
    std::vector<HitRecord> hits;
    uint32_t counts[3] = {0, 0, 0};
    WaveSpec wave;
    WavefrontView w;

    explicit HostWavefront(uint32_t capacity)
        : beta(capacity), L(capacity), contribution(capacity), rng(capacity), prev(capacity), prev_lobes(capacity),
          depth(capacity), rays(capacity), bits(trace_bit_words(capacity)), hits(capacity) {
      for (int q = 0; q < 3; ++q) {
        slots[q].resize(capacity);
        queue_rays[q].resize(capacity);
      }
      w.wave = &wave;
      w.pool = PathPool{beta.data(), L.data(), rng.data(), prev.data(), prev_lobes.data(), depth.data(), rays.data()};
      for (int q = 0; q < 2; ++q) w.ray[q] = RayQueue{queue_rays[q].data(), slots[q].data(), &counts[q]};
      w.shadow = ShadowQueue{queue_rays[2].data(), slots[2].data(), contribution.data(), &counts[2]};
      w.hits = hits.data();
      w.blocked_bits = bits.data();
      w.capacity = capacity;
    }
    HostWavefront(const HostWavefront&) = delete;
    HostWavefront& operator=(const HostWavefront&) = delete;
  };

  // The trace stage's shadow half: the shadow queue's rays into blocked bits.
  void trace_shadow_queue(const Tracer& tracer, HostWavefront& hw) {
    const uint32_t n = hw.counts[2];
    parallel_for(trace_bit_words(n), [&](uint32_t word) {
      uint32_t b = 0;
      for (uint32_t j = 32 * word; j < std::min(n, 32 * word + 32); ++j) {
        const TraceRay& r = hw.w.shadow.rays[j];
        if (tracer.occluded(Ray(r.o, r.d), r.tmax)) b |= 1u << (j % 32);
      }
      hw.bits[word] = b;
    });
  }

  // The waves of the Wavefront schedule: samples [first_sample, first_sample + count) of every pixel, each
  // pixel's radiance handed to a sink from make_sink() (wavefront.h's accumulate). With `restir` (one sample:
  // restir's primary pass) the first vertices write their pixels' records and reservoirs there.
  template <class MakeSink>
  void run_waves(HostWavefront& hw, const FrameSpec& frame, uint32_t first_sample, uint32_t count,
                 RestirFrame restir, MakeSink&& make_sink, const ProgressFn& progress) {
    const uint32_t pixels = uint32_t(frame.camera.width) * uint32_t(frame.camera.height);
    const uint64_t items = uint64_t(pixels) * count;
    const IntegratorSettings& s = frame.integrator;
    WavefrontView& w = hw.w;
    w.restir = restir;
    const WaveShape shape = wave_shape(w.capacity, s, view_.selection.infinite_light >= 0);
    w.shared_slots = shape.shared_slots;
    const uint32_t capacity = w.capacity, paths = shape.paths;
    Tracer tracer{this};
    for (uint64_t k0 = 0; k0 < items; k0 += paths) {
      hw.wave = WaveSpec{k0, uint32_t(std::min<uint64_t>(paths, items - k0)), first_sample, pixels, frame.seed};
      parallel_for(capacity, [&](uint32_t i) { generate_camera_ray(i, w, frame.camera, s); });
      // max_depth + 1 iterations (wavefront.h); the GPU's graph runs exactly these, so more is an error here.
      for (int it = 0, cur = 0; hw.counts[cur] > 0 || hw.counts[2] > 0; ++it, cur ^= 1) {
        if (it > s.max_depth) throw std::logic_error("wavefront: paths left after max_depth + 1 iterations");
        const RayQueue& in = w.ray[cur];
        const uint32_t n_rays = hw.counts[cur], n_shadow = hw.counts[2];
        parallel_for(n_rays, [&](uint32_t j) {
          const TraceRay& r = in.rays[j];
          if (!tracer.intersect(Ray(r.o, r.d), r.tmax, &hw.hits[j])) hw.hits[j].instance = kTraceMiss;
        });
        trace_shadow_queue(tracer, hw);
        parallel_for(n_shadow, [&](uint32_t j) { apply_shadow_result(j, w); });
        begin_bounce(w, cur ^ 1);
        parallel_for(n_rays, [&](uint32_t j) { shade<kAllFeatures>(j, w, cur, view_, s); });
      }
      parallel_for(std::min(hw.wave.count, pixels), [&](uint32_t i) {
        auto sink = make_sink();
        accumulate(i, w, sink);
      });
      if (progress) progress(k0 + hw.wave.count, items);
    }
    w.restir = RestirFrame();
  }

  // A frame pass of restir through the trace stage (restir_passes.h's restir_frame_pass): record(i, chunk) and
  // replay(i, chunk) for each pixel i of each chunk, on all cores.
  template <class Record, class Replay>
  void run_restir_pass(HostWavefront& hw, uint32_t pixels, uint32_t max_rays, Record&& record, Replay&& replay) {
    Tracer tracer{this};
    pn::restir_frame_pass(
        hw.w, pixels, max_rays, [&](const RestirChunk&) { begin_shadow_batch(hw.w); },
        [&](const RestirChunk& c) { parallel_for(c.count, [&](uint32_t i) { record(i, c); }); },
        [&](const RestirChunk&) { trace_shadow_queue(tracer, hw); },
        [&](const RestirChunk& c) { parallel_for(c.count, [&](uint32_t i) { replay(i, c); }); });
  }

  // Runs fn(phase, x0, y0, x1, y1) over the W x H frame's 16x16 tiles for
  // phase = 0, 1, ..., phases - 1 in turn, on one pool of threads: every tile
  // of a phase is done before any tile of the next (restir's passes read what
  // the previous one wrote). fn returns (samples done, samples total) for
  // `progress` (total 0: nothing to report). An exception from `progress` (the
  // Python module's Ctrl-C) stops the work: no thread takes another tile, and
  // it is rethrown here (the film then holds part of the samples: callers
  // discard it).
  template <class Fn>
  void for_each_tile(int W, int H, uint32_t phases, const ProgressFn& progress, Fn&& fn) {
    constexpr int kTile = 16;
    const int tiles_x = (W + kTile - 1) / kTile, tiles_y = (H + kTile - 1) / kTile;
    const int num_tiles = tiles_x * tiles_y;
    std::atomic<int> next_tile[2];
    next_tile[0] = next_tile[1] = 0;
    std::mutex progress_mutex;
    std::exception_ptr stop;
    std::atomic<bool> stopped{false};
    Barrier barrier(threads_);
    auto worker = [&](int id) {
      for (uint32_t phase = 0; phase < phases; ++phase) {
        // The next phase's counter: no thread uses it since the last barrier.
        if (id == 0) next_tile[(phase + 1) % 2] = 0;
        std::atomic<int>& next = next_tile[phase % 2];
        for (int t; !stopped && (t = next.fetch_add(1)) < num_tiles;) {
          int x0 = (t % tiles_x) * kTile, y0 = (t / tiles_x) * kTile;
          int x1 = std::min(x0 + kTile, W), y1 = std::min(y0 + kTile, H);
          const std::pair<uint64_t, uint64_t> p = fn(phase, x0, y0, x1, y1);
          if (progress && p.second > 0) {
            std::lock_guard<std::mutex> lock(progress_mutex);
            if (stop) break;
            try {
              progress(p.first, p.second);
            } catch (...) {
              stop = std::current_exception();
              stopped = true;
            }
          }
        }
        if (phases > 1) barrier.wait();
      }
    };
    std::vector<std::thread> pool;
    for (int i = 1; i < threads_; ++i) pool.emplace_back(worker, i);
    worker(0);
    for (auto& th : pool) th.join();
    if (stop) std::rethrow_exception(stop);
  }

  // Non-finite samples are left out, counted and located (RenderStats).
  void note_nonfinite(int x, int y, int W, uint64_t bad) {
    std::lock_guard<std::mutex> lock(nonfinite_mutex_);
    stats_.nonfinite += bad;
    note_nonfinite_pixel(stats_, x, y, W);
  }

  // Pixel (x, y)'s sums into the film's, its non-finite samples noted.
  void add_to_film(Film& film, int x, int y, int W, const PixelSum& ps) {
    const size_t o = (size_t(y) * W + x) * 3;
    for (int c = 0; c < 3; ++c) {
      film.sum()[o + c] += ps.sum[c];
      film.sum_sq()[o + c] += ps.sum_sq[c];
    }
    if (ps.nonfinite > 0) note_nonfinite(x, y, W, ps.nonfinite);
  }

  // restir with spatial or temporal reuse (core/restir.h): per camera sample,
  // the primary pass over every pixel, temporal reuse with the previous
  // sample's final reservoirs (its history), the spatial passes (reading one
  // reservoir buffer, writing the other), then shading and accumulation, which
  // keep the history; all as phases of one pool of threads. The history
  // outlives the call (restir_history_): a call that continues a recent call's
  // frame where it stopped (the viewer's next frame) reuses it, so that samples
  // split over calls are those of one call; any other starts without one.
  void render_restir(const FrameSpec& frame, Film& film, uint32_t first_sample, uint32_t count,
                     const ProgressFn& progress) {
    const int W = frame.camera.width, H = frame.camera.height;
    const size_t pixels = size_t(W) * H;
    const IntegratorSettings& s = frame.integrator;
    const uint32_t temporal = s.restir.temporal ? 1u : 0u;
    const uint32_t steps = restir_reuse_steps(s.restir), phases_per_sample = steps + 2;
    std::vector<RestirPixel> gbuffer(pixels);
    std::vector<Vec3> path_L(pixels);  // each path's radiance without its first vertex's direct light
    std::vector<Reservoir> reservoirs[2] = {std::vector<Reservoir>(pixels), std::vector<Reservoir>(pixels)};
    std::vector<RestirPixel> history_pixels;  // valid = 0: no history yet
    std::vector<Reservoir> history;
    if (temporal) {
      auto it = std::find_if(restir_history_.begin(), restir_history_.end(), [&](const RestirHistory& h) {
        return h.next_sample == first_sample && h.pixels.size() == pixels && same_frame(h.frame, frame);
      });
      if (it != restir_history_.end()) {
        history_pixels = std::move(it->pixels);
        history = std::move(it->reservoirs);
        restir_history_.erase(it);
      } else {
        history_pixels.assign(pixels, RestirPixel{});
        history.assign(pixels, Reservoir{});
      }
    }
    const uint64_t total = uint64_t(pixels) * count;
    std::atomic<uint64_t> done{0};
    Tracer tracer{this};
    // Reuse pass `pass` of sample `sample` from reservoirs `in`.
    auto reuse = [&](uint32_t sample, uint32_t pass, const Reservoir* in) {
      RestirReuse r;
      r.pixels = gbuffer.data();
      r.in = in;
      r.history_pixels = history_pixels.data();
      r.history = history.data();
      r.width = W;
      r.height = H;
      r.sample = sample;
      r.seed = frame.seed;
      r.pass = pass;
      return r;
    };
    // Step `step` of sample `sample` over the tile [x0, x1) x [y0, y1); returns (samples done, samples total).
    auto run_step = [&](uint32_t sample, uint32_t step, int x0, int y0, int x1, int y1) {
      if (step == 0) {  // primary: the paths, their first vertex's reservoir into reservoirs[0]
        if (schedule_ == CpuSchedule::BreadthFirst) {
          std::vector<PathState> pool;
          std::vector<RestirPrimaryOut> primary;
          for (int y = y0; y < y1; ++y)
            for (int x = x0; x < x1; ++x) {
              const size_t p = size_t(y) * W + x;
              primary.push_back(RestirPrimaryOut{&gbuffer[p], &reservoirs[0][p]});
              pool.push_back(start_path(frame.camera, x, y, sample, frame.seed, &primary.back()));
            }
          trace_pool(tracer, s, pool, primary.data());
          for (const PathState& st : pool) path_L[st.pixel] = st.L;
          return std::make_pair(uint64_t(0), uint64_t(0));
        }
        for (int y = y0; y < y1; ++y)
          for (int x = x0; x < x1; ++x) {
            const size_t p = size_t(y) * W + x;
            RestirPrimaryOut primary{&gbuffer[p], &reservoirs[0][p]};
            path_L[p] = render_sample(tracer, view_, frame.camera, s, x, y, sample, frame.seed, &primary);
          }
        return std::make_pair(uint64_t(0), uint64_t(0));
      }
      if (step <= steps) {  // reuse step - 1 (temporal first): reservoirs[(step - 1) % 2] -> [step % 2]
        const RestirReuse r = reuse(sample, restir_reuse_pass(s.restir, step - 1), reservoirs[(step - 1) % 2].data());
        Reservoir* out = reservoirs[step % 2].data();
        for (int y = y0; y < y1; ++y)
          for (int x = x0; x < x1; ++x) {
            const uint32_t p = uint32_t(y) * uint32_t(W) + uint32_t(x);
            out[p] = restir_reuse(tracer, view_, s.restir, r, p);
          }
        return std::make_pair(uint64_t(0), uint64_t(0));
      }
      const Reservoir* final_reservoirs = reservoirs[steps % 2].data();  // shading
      for (int y = y0; y < y1; ++y)
        for (int x = x0; x < x1; ++x) {
          const size_t p = size_t(y) * W + x;
          const Vec3 L = path_L[p] + restir_shade(tracer, view_, s, gbuffer[p], final_reservoirs[p]);
          if (temporal) history_pixels[p] = gbuffer[p], history[p] = final_reservoirs[p];
          PixelSum ps;  // this sample's
          ps.add(L);
          add_to_film(film, x, y, W, ps);
        }
      return std::make_pair(done += uint64_t(x1 - x0) * (y1 - y0), total);
    };
    if (schedule_ != CpuSchedule::Wavefront) {
      for_each_tile(W, H, count * phases_per_sample, progress, [&](uint32_t phase, int x0, int y0, int x1, int y1) {
        return run_step(first_sample + phase / phases_per_sample, phase % phases_per_sample, x0, y0, x1, y1);
      });
    } else {  // every pass through the wavefront's stages: the primary pass as waves, the others as chunks
      struct RadianceSink {  // the path's radiance, its first vertex's direct light left out, to path_L
        Vec3* path_L;
        Vec3 L;
        void begin(uint32_t, bool) {}
        void add(const Vec3& radiance, uint32_t) { L = radiance; }
        void end(uint32_t pixel) { path_L[pixel] = L; }
      };
      // A pool of one path a pixel (at most wavefront_paths_), and at least one pixel's shadow queries of a pass.
      uint32_t queries = restir_shade_max_rays(s.restir);
      for (uint32_t step = 0; step < steps; ++step)
        queries = std::max(queries, restir_reuse_max_rays(s.restir, restir_reuse_pass(s.restir, step)));
      HostWavefront hw(uint32_t(std::min<uint64_t>(wavefront_paths_, std::max<uint64_t>(pixels, queries))));
      const uint32_t n = uint32_t(pixels);
      std::vector<Vec3> frame_L(pixels);
      for (uint32_t i = 0; i < count; ++i) {
        const uint32_t sample = first_sample + i;
        run_waves(hw, frame, sample, 1, RestirFrame{gbuffer.data(), reservoirs[0].data()},
                  [&] { return RadianceSink{path_L.data(), Vec3(0.f)}; }, nullptr);
        int cur = 0;  // reservoirs[cur]: the latest
        for (uint32_t step = 0; step < steps; ++step) {
          const RestirReuse r = reuse(sample, restir_reuse_pass(s.restir, step), reservoirs[cur].data());
          Reservoir* out = reservoirs[cur ^ 1].data();
          run_restir_pass(
              hw, n, restir_reuse_max_rays(s.restir, r.pass),
              [&](uint32_t k, const RestirChunk& c) { restir_reuse_record(k, hw.w, c, view_, s.restir, r); },
              [&](uint32_t k, const RestirChunk& c) { restir_reuse_replay(k, hw.w, c, view_, s.restir, r, out); });
          cur ^= 1;
        }
        const Reservoir* final_reservoirs = reservoirs[cur].data();
        run_restir_pass(
            hw, n, restir_shade_max_rays(s.restir),
            [&](uint32_t k, const RestirChunk& c) {
              restir_shade_record(k, hw.w, c, view_, s, gbuffer.data(), final_reservoirs);
            },
            [&](uint32_t k, const RestirChunk& c) {
              uint32_t rays = 0;
              const Vec3 direct = restir_shade_replay(k, hw.w, c, view_, s, gbuffer.data(), final_reservoirs, &rays);
              frame_L[c.first + k] = path_L[c.first + k] + direct;
            });
        for (uint32_t p = 0; p < n; ++p) {
          if (temporal) history_pixels[p] = gbuffer[p], history[p] = final_reservoirs[p];
          PixelSum ps;  // this sample's
          ps.add(frame_L[p]);
          add_to_film(film, int(p % uint32_t(W)), int(p / uint32_t(W)), W, ps);
        }
        if (progress) progress(uint64_t(i + 1) * pixels, total);
      }
    }
    film.add_samples(count);
    if (temporal) {
      restir_history_.insert(restir_history_.begin(),
                             RestirHistory{frame, first_sample + count, std::move(history_pixels), std::move(history)});
      if (restir_history_.size() > kRestirHistories) restir_history_.pop_back();
    }
  }

  // Temporal reuse's history after a restir render with it: the frame, the sample that comes next, and each
  // pixel's shading point and final reservoir. The latest first, at most two frames' (the viewer's split screen
  // renders two frames in turn).
  struct RestirHistory {
    FrameSpec frame;
    uint32_t next_sample = 0;
    std::vector<RestirPixel> pixels;
    std::vector<Reservoir> reservoirs;
  };
  static constexpr size_t kRestirHistories = 2;
  std::vector<RestirHistory> restir_history_;

  const Scene& scene_;
  std::unique_ptr<HostSceneView> host_;
  SceneView view_;
  CpuSchedule schedule_ = CpuSchedule::DepthFirst;
  uint32_t wavefront_paths_ = 1u << 20;
  FilterData filter_;
  std::vector<int> instance_of_geom_;  // top-level geometry ID -> instance index (-1: spheres)
  int threads_ = 1;
  RenderStats stats_;  // of the last render()
  std::mutex nonfinite_mutex_;
  RTCDevice device_ = nullptr;
  RTCScene rtc_ = nullptr;              // top level: instances and the sphere set
  std::vector<RTCScene> mesh_scenes_;  // one per TriangleMesh
  unsigned sphere_geom_ = RTC_INVALID_GEOMETRY_ID;
};

class CpuRayQueries final : public RayQueries {
 public:
  explicit CpuRayQueries(const Scene& scene) : backend_(scene, 1, CpuSchedule::DepthFirst), tracer_{&backend_} {}
  bool intersect(const Ray& ray, float tmax, HitRecord* hit) const override {
    return tracer_.intersect(ray, tmax, hit);
  }
  bool occluded(const Ray& ray, float tmax) const override { return tracer_.occluded(ray, tmax); }

 private:
  CpuBackend backend_;
  CpuBackend::Tracer tracer_;
};

}  // namespace

std::unique_ptr<Backend> make_cpu_backend(const Scene& scene, int threads, CpuSchedule schedule,
                                          uint32_t wavefront_paths) {
  return std::make_unique<CpuBackend>(scene, threads, schedule, wavefront_paths);
}

std::unique_ptr<RayQueries> make_cpu_ray_queries(const Scene& scene) {
  return std::make_unique<CpuRayQueries>(scene);
}

}  // namespace pn
