// CPU backend. Embree answers the integrator's two questions (closest hit, any
// hit); spheres are Embree user geometry intersected by core/geometry.h so that
// CPU and GPU compute the same hits, and alpha-masked triangles are skipped by
// Embree filter functions that ask core/scene_view.h's alpha_discards(), as the
// GPU's any-hit program does. Work is split into 16x16 tiles taken by a
// pool of threads; every pixel sample has its own RNG stream, so the image does
// not depend on the number of threads or on the order tiles are taken.
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
  CpuBackend(const Scene& scene, int threads) : host_(make_host_view(scene)), view_(host_->view) {
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

  std::string name() const override { return "cpu"; }
  std::string device_name() const override {
    return std::to_string(threads_) + " CPU thread" + (threads_ > 1 ? "s" : "") + " (Embree " +
           std::to_string(RTC_VERSION_MAJOR) + "." + std::to_string(RTC_VERSION_MINOR) + "." +
           std::to_string(RTC_VERSION_PATCH) + ")";
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
    const uint64_t total = uint64_t(W) * H * count;
    std::atomic<uint64_t> done{0};
    Tracer tracer{this};
    double* sum = film.sum();
    double* sum_sq = film.sum_sq();
    for_each_tile(W, H, 1, progress, [&](uint32_t, int x0, int y0, int x1, int y1) {
      for (int y = y0; y < y1; ++y)
        for (int x = x0; x < x1; ++x) {
          double s[3] = {0, 0, 0}, s2[3] = {0, 0, 0};
          uint64_t bad = 0;
          for (uint32_t i = 0; i < count; ++i) {
            Vec3 L = render_sample(tracer, view_, frame.camera, frame.integrator, x, y, first_sample + i, frame.seed);
            if (!is_finite(L)) {  // never let one bad sample poison a pixel silently
              ++bad;
              continue;
            }
            for (int c = 0; c < 3; ++c) {
              s[c] += L[c];
              s2[c] += double(L[c]) * L[c];
            }
          }
          size_t o = (size_t(y) * W + x) * 3;
          for (int c = 0; c < 3; ++c) {
            sum[o + c] += s[c];
            sum_sq[o + c] += s2[c];
          }
          if (bad > 0) note_nonfinite(x, y, W, bad);
        }
      return std::make_pair(done += uint64_t(x1 - x0) * (y1 - y0) * count, total);
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

  // restir with spatial reuse (core/restir.h): per camera sample, the primary
  // pass over every pixel, the spatial passes (reading one reservoir buffer,
  // writing the other), then shading and accumulation; all as phases of one
  // pool of threads.
  void render_restir(const FrameSpec& frame, Film& film, uint32_t first_sample, uint32_t count,
                     const ProgressFn& progress) {
    const int W = frame.camera.width, H = frame.camera.height;
    const size_t pixels = size_t(W) * H;
    const IntegratorSettings& s = frame.integrator;
    const uint32_t passes = s.restir.spatial_passes, phases_per_sample = passes + 2;
    std::vector<RestirPixel> gbuffer(pixels);
    std::vector<Reservoir> reservoirs[2] = {std::vector<Reservoir>(pixels), std::vector<Reservoir>(pixels)};
    const uint64_t total = uint64_t(pixels) * count;
    std::atomic<uint64_t> done{0};
    Tracer tracer{this};
    double* sum = film.sum();
    double* sum_sq = film.sum_sq();
    for_each_tile(W, H, count * phases_per_sample, progress, [&](uint32_t phase, int x0, int y0, int x1, int y1) {
      const uint32_t sample = first_sample + phase / phases_per_sample, step = phase % phases_per_sample;
      if (step == 0) {  // primary: the paths, their first vertex's reservoir into reservoirs[0]
        for (int y = y0; y < y1; ++y)
          for (int x = x0; x < x1; ++x) {
            const size_t p = size_t(y) * W + x;
            RestirPrimaryOut primary{&gbuffer[p], &reservoirs[0][p]};
            gbuffer[p].L = render_sample(tracer, view_, frame.camera, s, x, y, sample, frame.seed, &primary);
          }
        return std::make_pair(uint64_t(0), uint64_t(0));
      }
      if (step <= passes) {  // spatial pass step - 1: reservoirs[(step - 1) % 2] -> reservoirs[step % 2]
        const Reservoir* in = reservoirs[(step - 1) % 2].data();
        Reservoir* out = reservoirs[step % 2].data();
        for (int y = y0; y < y1; ++y)
          for (int x = x0; x < x1; ++x)
            out[size_t(y) * W + x] = restir_spatial_reuse(tracer, view_, s.restir, gbuffer.data(), in, W, H, x, y,
                                                          sample, frame.seed, step - 1);
        return std::make_pair(uint64_t(0), uint64_t(0));
      }
      const Reservoir* final_reservoirs = reservoirs[passes % 2].data();  // shading
      for (int y = y0; y < y1; ++y)
        for (int x = x0; x < x1; ++x) {
          const size_t p = size_t(y) * W + x;
          const Vec3 L = gbuffer[p].L + restir_shade(tracer, view_, s, gbuffer[p], final_reservoirs[p]);
          if (!is_finite(L)) {
            note_nonfinite(x, y, W, 1);
            continue;
          }
          for (int c = 0; c < 3; ++c) {
            sum[3 * p + c] += L[c];
            sum_sq[3 * p + c] += double(L[c]) * L[c];
          }
        }
      return std::make_pair(done += uint64_t(x1 - x0) * (y1 - y0), total);
    });
    film.add_samples(count);
  }

  std::unique_ptr<HostSceneView> host_;
  SceneView view_;
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

}  // namespace

std::unique_ptr<Backend> make_cpu_backend(const Scene& scene, int threads) {
  return std::make_unique<CpuBackend>(scene, threads);
}

}  // namespace pn
