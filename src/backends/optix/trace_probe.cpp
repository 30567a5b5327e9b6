#include "backends/optix/trace_probe.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <stdexcept>
#include <string>
#include <vector>

#include <cuda_runtime.h>

#include "backends/cuda/trace_kernels.h"
#include "backends/probe_rays.h"

namespace pn {
namespace {

void check(cudaError_t e, const char* what) {
  if (e != cudaSuccess) throw std::runtime_error(std::string("bench --probe: ") + what + ": " + cudaGetErrorString(e));
}

// A device allocation freed on scope exit.
struct DeviceArray {
  void* p = nullptr;
  explicit DeviceArray(size_t bytes) { check(cudaMalloc(&p, std::max<size_t>(bytes, 1)), "cudaMalloc"); }
  ~DeviceArray() { cudaFree(p); }
  template <class T>
  T* as() const { return static_cast<T*>(p); }
};

struct Events {
  std::vector<cudaEvent_t> e;
  explicit Events(size_t n) : e(n, nullptr) {
    for (cudaEvent_t& x : e) check(cudaEventCreate(&x), "cudaEventCreate");
  }
  ~Events() {
    for (cudaEvent_t x : e) cudaEventDestroy(x);
  }
};

double median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  const size_t n = v.size();
  return n == 0 ? 0.0 : (n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]));
}

// How two closest-hit answers to one ray compare.
enum class HitAgreement { BothMiss, Same, TOff, Tie, Other };
HitAgreement compare_hits(const TraceRay& ray, const HitRecord& a, const HitRecord& b) {
  const bool ha = a.instance != kTraceMiss, hb = b.instance != kTraceMiss;
  if (!ha && !hb) return HitAgreement::BothMiss;
  if (ha != hb) return HitAgreement::Other;
  const float scale = 1.f + max_component(vmax(ray.o, -ray.o)) + std::fabs(a.t);
  if (a.instance == b.instance && a.prim == b.prim)
    return std::fabs(a.t - b.t) > 2e-5f * scale ? HitAgreement::TOff : HitAgreement::Same;
  return std::fabs(a.t - b.t) <= 1e-4f * scale ? HitAgreement::Tie : HitAgreement::Other;
}

// Counts one comparison into the t_off, ties and other counters of a result.
void tally(HitAgreement h, uint64_t* t_off, uint64_t* ties, uint64_t* other) {
  *t_off += h == HitAgreement::TOff;
  *ties += h == HitAgreement::Tie;
  *other += h == HitAgreement::Other;
}

std::string describe_hit(const HitRecord& h) {
  if (h.instance == kTraceMiss) return "miss";
  char buf[96];
  std::snprintf(buf, sizeof buf, "t %.9g instance %u prim %u", h.t, h.instance, h.prim);
  return buf;
}

}  // namespace

ProbeResult run_trace_probe(const Scene& scene, OptixBackend& optix, const ProbeSettings& s) {
  if (s.rays == 0 || s.launches < 1) throw std::runtime_error("bench --probe: needs rays and at least one launch");
  ProbeResult r;
  r.rays = s.rays;
  const BvhHost host = build_bvh(scene, s.tuning.bvh);
  r.bvh = host.stats;
  r.bvh_bytes = host.bytes();
  const auto t1 = std::chrono::steady_clock::now();
  CudaTraversal cuda(host, s.tuning);
  r.cuda_form = cuda.forms().reason;
  r.upload_ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t1).count();

  const Bounds3 bounds = scene_bounds(scene);
  if (bounds.empty()) throw std::runtime_error("bench --probe: " + scene.source + " has nothing to hit");
  const std::vector<TraceRay> closest = probe_closest_rays(bounds, s.rays, s.seed);
  const std::vector<TraceRay> shadow = probe_shadow_rays(bounds, s.rays, s.seed);
  const size_t n = s.rays, words = trace_bit_words(s.rays);
  DeviceArray d_closest(n * sizeof(TraceRay)), d_shadow(n * sizeof(TraceRay));
  DeviceArray hits_o(n * sizeof(HitRecord)), hits_c(n * sizeof(HitRecord));
  DeviceArray bits_o(words * sizeof(uint32_t)), bits_c(words * sizeof(uint32_t));
  check(cudaMemcpy(d_closest.p, closest.data(), n * sizeof(TraceRay), cudaMemcpyHostToDevice), "uploading rays");
  check(cudaMemcpy(d_shadow.p, shadow.data(), n * sizeof(TraceRay), cudaMemcpyHostToDevice), "uploading rays");
  // Poison the outputs: every element must be written.
  check(cudaMemset(hits_o.p, 0xAB, n * sizeof(HitRecord)), "cudaMemset");
  check(cudaMemset(hits_c.p, 0xAB, n * sizeof(HitRecord)), "cudaMemset");
  check(cudaMemset(bits_c.p, 0xAB, words * sizeof(uint32_t)), "cudaMemset");

  // Each round: optix closest, optix shadow, cuda closest, cuda shadow, each
  // between two events on the backend's stream (interleaved, so that clock
  // changes fall on both alike). The warm-up rounds are not timed.
  cudaStream_t stream = static_cast<cudaStream_t>(optix.cuda_stream());
  const SceneView scene_view = optix.device_scene_view();
  const int rounds = s.warmup + s.launches;
  Events ev(size_t(rounds) * 8);
  for (int j = 0; j < rounds; ++j) {
    cudaEvent_t* e = ev.e.data() + size_t(j) * 8;
    check(cudaEventRecord(e[0], stream), "cudaEventRecord");
    optix.trace_closest(d_closest.as<TraceRay>(), s.rays, hits_o.as<HitRecord>());
    check(cudaEventRecord(e[1], stream), "cudaEventRecord");
    optix.trace_shadow(d_shadow.as<TraceRay>(), s.rays, bits_o.as<uint32_t>());  // zeroes the bits first
    check(cudaEventRecord(e[2], stream), "cudaEventRecord");
    check(cudaEventRecord(e[3], stream), "cudaEventRecord");
    cuda.trace_closest(d_closest.as<TraceRay>(), s.rays, hits_c.as<HitRecord>(), scene_view, stream);
    check(cudaEventRecord(e[4], stream), "cudaEventRecord");
    check(cudaEventRecord(e[5], stream), "cudaEventRecord");
    cuda.trace_shadow(d_shadow.as<TraceRay>(), s.rays, bits_c.as<uint32_t>(), scene_view, stream);
    check(cudaEventRecord(e[6], stream), "cudaEventRecord");
  }
  check(cudaStreamSynchronize(stream), "tracing");
  std::vector<double> oc, os, cc, cs;
  for (int j = s.warmup; j < rounds; ++j) {
    cudaEvent_t* e = ev.e.data() + size_t(j) * 8;
    float ms[4];
    check(cudaEventElapsedTime(&ms[0], e[0], e[1]), "cudaEventElapsedTime");
    check(cudaEventElapsedTime(&ms[1], e[1], e[2]), "cudaEventElapsedTime");
    check(cudaEventElapsedTime(&ms[2], e[3], e[4]), "cudaEventElapsedTime");
    check(cudaEventElapsedTime(&ms[3], e[5], e[6]), "cudaEventElapsedTime");
    oc.push_back(ms[0]), os.push_back(ms[1]), cc.push_back(ms[2]), cs.push_back(ms[3]);
  }
  auto times = [](const std::vector<double>& c, const std::vector<double>& sh) {
    ProbeTimes t;
    t.closest_ms = median(c);
    t.shadow_ms = median(sh);
    t.closest_min_ms = *std::min_element(c.begin(), c.end());
    t.closest_max_ms = *std::max_element(c.begin(), c.end());
    t.shadow_min_ms = *std::min_element(sh.begin(), sh.end());
    t.shadow_max_ms = *std::max_element(sh.begin(), sh.end());
    return t;
  };
  r.optix = times(oc, os);
  r.cuda = times(cc, cs);

  // ---- The same answers? ----
  std::vector<HitRecord> ho(n), hc(n);
  std::vector<uint32_t> bo(words), bc(words);
  check(cudaMemcpy(ho.data(), hits_o.p, n * sizeof(HitRecord), cudaMemcpyDeviceToHost), "downloading hits");
  check(cudaMemcpy(hc.data(), hits_c.p, n * sizeof(HitRecord), cudaMemcpyDeviceToHost), "downloading hits");
  check(cudaMemcpy(bo.data(), bits_o.p, words * sizeof(uint32_t), cudaMemcpyDeviceToHost), "downloading bits");
  check(cudaMemcpy(bc.data(), bits_c.p, words * sizeof(uint32_t), cudaMemcpyDeviceToHost), "downloading bits");
  for (size_t i = 0; i < n; ++i) {
    r.hits_optix += ho[i].instance != kTraceMiss;
    r.hits_cuda += hc[i].instance != kTraceMiss;
    tally(compare_hits(closest[i], ho[i], hc[i]), &r.closest_t_off, &r.closest_ties, &r.closest_other);
  }
  for (size_t i = 0; i < n; ++i) {
    const bool a = (bo[i / 32] >> (i % 32)) & 1u, b = (bc[i / 32] >> (i % 32)) & 1u;
    r.blocked_optix += a;
    r.blocked_cuda += b;
    r.shadow_mismatched += a != b;
  }
  // The last word's unused bits: the kernel writes them 0 (a word per warp).
  if (n % 32 && (bc.back() >> (n % 32)) != 0u) throw std::runtime_error("bench --probe: stray shadow bits");

  // ---- Rays that leave surfaces: once each, the same comparison ----
  const SurfaceRays sr = probe_surface_rays(scene, s.rays, s.seed);
  if (sr.closest.size() == n) {
    ProbeResult::Surface& f = r.surface;
    check(cudaMemcpy(d_closest.p, sr.closest.data(), n * sizeof(TraceRay), cudaMemcpyHostToDevice), "uploading rays");
    check(cudaMemcpy(d_shadow.p, sr.shadow.data(), n * sizeof(TraceRay), cudaMemcpyHostToDevice), "uploading rays");
    optix.trace_closest(d_closest.as<TraceRay>(), s.rays, hits_o.as<HitRecord>());
    optix.trace_shadow(d_shadow.as<TraceRay>(), s.rays, bits_o.as<uint32_t>());
    cuda.trace_closest(d_closest.as<TraceRay>(), s.rays, hits_c.as<HitRecord>(), scene_view, stream);
    cuda.trace_shadow(d_shadow.as<TraceRay>(), s.rays, bits_c.as<uint32_t>(), scene_view, stream);
    check(cudaStreamSynchronize(stream), "tracing");
    check(cudaMemcpy(ho.data(), hits_o.p, n * sizeof(HitRecord), cudaMemcpyDeviceToHost), "downloading hits");
    check(cudaMemcpy(hc.data(), hits_c.p, n * sizeof(HitRecord), cudaMemcpyDeviceToHost), "downloading hits");
    check(cudaMemcpy(bo.data(), bits_o.p, words * sizeof(uint32_t), cudaMemcpyDeviceToHost), "downloading bits");
    check(cudaMemcpy(bc.data(), bits_c.p, words * sizeof(uint32_t), cudaMemcpyDeviceToHost), "downloading bits");
    auto self = [&](const HitRecord& h, size_t i) {
      return h.instance == sr.origin_instance[i] && h.prim == sr.origin_prim[i];
    };
    auto example = [&](const char* what, size_t i, const std::string& a, const std::string& b) {
      if (f.examples.size() >= 12) return;
      const TraceRay& ray = what[0] == 's' ? sr.shadow[i] : sr.closest[i];
      char buf[320];
      std::snprintf(buf, sizeof buf, "%s ray %zu from instance %u prim %u: o (%.9g, %.9g, %.9g) d (%.7g, %.7g, %.7g) "
                    "tmax %.9g; optix: %s; cuda: %s", what, i, sr.origin_instance[i], sr.origin_prim[i], ray.o.x,
                    ray.o.y, ray.o.z, ray.d.x, ray.d.y, ray.d.z, ray.tmax, a.c_str(), b.c_str());
      f.examples.push_back(buf);
    };
    for (size_t i = 0; i < n; ++i) {
      f.hits_optix += ho[i].instance != kTraceMiss;
      f.hits_cuda += hc[i].instance != kTraceMiss;
      f.self_optix += self(ho[i], i);
      f.self_cuda += self(hc[i], i);
      const HitAgreement h = compare_hits(sr.closest[i], ho[i], hc[i]);
      tally(h, &f.closest_t_off, &f.closest_ties, &f.closest_other);
      if (h == HitAgreement::Other || self(ho[i], i) || self(hc[i], i))
        example("closest", i, describe_hit(ho[i]), describe_hit(hc[i]));
      const bool a = (bo[i / 32] >> (i % 32)) & 1u, b = (bc[i / 32] >> (i % 32)) & 1u;
      f.blocked_optix += a;
      f.blocked_cuda += b;
      f.shadow_mismatched += a != b;
      if (a != b) example("shadow", i, a ? "blocked" : "clear", b ? "blocked" : "clear");
    }
  }
  return r;
}

}  // namespace pn
