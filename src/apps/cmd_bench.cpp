// `penumbra bench`: time every built-in scene with every strategy and MIS mode (and,
// with --selections, light-selection method), one sample per pixel per launch,
// and report the median and spread of the launch times as a table and as JSON.
//
// GPU: each launch's time comes from CUDA events (path tracing, then the
// accumulation and, as a viewer does, the tone-map), over many launches after
// a warm-up. CPU: each launch is one render() call of spp-per-launch samples,
// timed by the wall clock. For each scene the GPU backend also reports what
// building it cost: acceleration-structure build times and device memory; on
// either, the light BVH's host build time and size.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <ctime>
#include <fstream>
#include <memory>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "apps/commands.h"
#include "apps/exit_status.h"
#include "apps/options.h"
#include "io/output.h"
#include "render/backend.h"
#include "render/resources.h"
#include "render/technique.h"
#include "scene/scene.h"
#if PN_HAVE_OPTIX
#include "backends/optix/optix_backend.h"
#endif
#if PN_HAVE_CUDA_TRACE
#include "backends/cuda/trace_probe.h"
#endif

#ifndef PENUMBRA_GIT_COMMIT
#define PENUMBRA_GIT_COMMIT "unknown"
#endif

namespace pn {
namespace {

using json = nlohmann::json;

struct BenchArgs {
  std::string backend = "auto";
  std::vector<std::string> scenes, strategies, mis, selections, sets;
  int width = 0, height = 0;  // 0: 1920x1080 on the GPU, 320x180 on the CPU
  int launches = 0;           // 0: 100 on the GPU, 10 on the CPU
  int warmup = -1;            // -1: 10 on the GPU, 1 on the CPU
  int spp_per_launch = 1;
  int max_depth = 8;
  int threads = 0;
  bool wavefront = true;  // GPU: the wavefront; --megakernel: false
  std::string traversal = "auto";
  std::string json_path;
  bool probe = false;              // the trace stage alone (run_probe)
  uint32_t probe_rays = 1u << 22;  // per launch and ray kind
};

struct Spread {
  double median = 0, min = 0, p10 = 0, p90 = 0, max = 0;
};

// Nearest-rank-with-interpolation percentile of sorted values.
double percentile(const std::vector<double>& sorted, double q) {
  if (sorted.empty()) return 0.0;
  double pos = q * double(sorted.size() - 1);
  size_t i = size_t(pos);
  double f = pos - double(i);
  return i + 1 < sorted.size() ? sorted[i] * (1 - f) + sorted[i + 1] * f : sorted[i];
}

Spread spread(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  Spread s;
  if (v.empty()) return s;
  s.median = percentile(v, 0.5);
  s.min = v.front();
  s.p10 = percentile(v, 0.1);
  s.p90 = percentile(v, 0.9);
  s.max = v.back();
  return s;
}

json spread_json(const Spread& s) {
  return {{"median", s.median}, {"min", s.min}, {"p10", s.p10}, {"p90", s.p90}, {"max", s.max}};
}

std::string utc_now() {
  std::time_t t = std::time(nullptr);
  char buf[64];
  std::tm tm_utc;
  gmtime_r(&t, &tm_utc);
  std::strftime(buf, sizeof buf, "%Y-%m-%dT%H:%M:%SZ", &tm_utc);
  return buf;
}

std::string cpu_model() {
  std::ifstream f("/proc/cpuinfo");
  std::string line;
  while (std::getline(f, line))
    if (line.rfind("model name", 0) == 0) {
      size_t colon = line.find(':');
      if (colon != std::string::npos) return line.substr(line.find_first_not_of(" \t", colon + 1));
    }
  return "unknown";
}

// The head of bench's JSON files: the tool, when, which build, on what.
json bench_json(const char* tool, const std::string& device,
                const std::vector<std::pair<std::string, std::string>>& info) {
  json j;
  j["tool"] = tool;
  j["date"] = utc_now();
  j["git_commit"] = PENUMBRA_GIT_COMMIT;
  j["device"] = device;
  json dev = json::object();
  for (const auto& kv : info) dev[kv.first] = kv.second;
  dev["host_cpu"] = cpu_model();
  j["device_info"] = dev;
  return j;
}

std::vector<std::string> split_list(const std::vector<std::string>& items) {
  std::vector<std::string> out;
  for (const std::string& item : items) {
    std::stringstream ss(item);
    std::string part;
    while (std::getline(ss, part, ','))
      if (!part.empty()) out.push_back(part);
  }
  return out;
}

struct Result {
  std::string scene, strategy;  // strategy: the technique's name ("area", "area+power")
  std::string mis;
  std::string selection;        // the light-selection method's label (light_selection_label)
  Spread ms;             // per launch: trace + accumulate (GPU), wall (CPU)
  Spread trace_ms, accumulate_ms;
  double wall_ms_per_launch = 0;  // end-to-end, host clock, over the timed launches
  double msamples_per_s = 0;      // at the median launch time
  uint64_t rays = 0;              // over the timed launches; 0 = not counted
  double rays_per_s = 0;          // rays / GPU time of the timed launches
};

// One scene's size and, on the GPU, the cost of building it.
struct SceneBuild {
  std::string scene;
  size_t triangles = 0, instances = 0, spheres = 0, textures = 0, lights = 0;
  double light_bvh_ms = 0, light_bvh_mib = 0;  // host build of the light BVH, its size
  SceneBuildStats stats;
};

double mib(uint64_t bytes) { return double(bytes) / (1024.0 * 1024.0); }

// ---- The trace stage alone (--probe) ----
//
// Random incoherent rays inside each scene's bounds (closest hits; shadow rays
// between two random points), traced by both implementations of the trace
// stage on the same device buffers: trace-only OptiX launches and the cuda
// traversal (backends/cuda). Grays/s at the median launch time, and how often
// the two disagree (exit status kExitDiffer beyond the CPU tests' bounds: ties
// 1 in 100, other disagreements 1 in 5,000).
int run_probe(const BenchArgs& a) {
#if !PN_HAVE_CUDA_TRACE
  (void)a;
  throw std::runtime_error("bench --probe needs the GPU build (CUDA and OptiX), which this penumbra was built without");
#else
  if (!a.json_path.empty()) check_output_file(a.json_path, "--json");
  if (a.backend == "cpu") throw std::runtime_error("bench --probe traces on the GPU: --backend cpu does not apply");
  std::string why;
  if (!optix_available(&why)) throw std::runtime_error("bench --probe: " + why);
  std::vector<std::string> scene_names = split_list(a.scenes);
  const bool all_builtins = scene_names.empty();
  if (all_builtins)
    for (const auto& s : builtin_scenes()) scene_names.push_back(s.name);
  ProbeSettings ps;
  ps.rays = a.probe_rays;
  ps.launches = a.launches ? a.launches : 20;
  ps.warmup = a.warmup >= 0 ? a.warmup : 3;
  struct Row {
    std::string scene;
    size_t triangles = 0, instances = 0, spheres = 0;
    ProbeResult r;
  };
  std::vector<Row> rows;
  std::string device, choice;
  std::vector<std::pair<std::string, std::string>> info;
  for (const std::string& name : scene_names) {
    Scene scene;
    try {
      scene = load_scene(name, a.sets);
    } catch (const SceneError& e) {
      if (!all_builtins) throw;
      std::fprintf(stderr, "bench: skipping %s: %s\n", name.c_str(), e.what());
      continue;
    }
    std::unique_ptr<Backend> backend = make_optix_backend(scene);
    auto* ob = dynamic_cast<OptixBackend*>(backend.get());
    if (device.empty()) {
      device = backend->device_name();
      info = backend->device_info();
      const unsigned rt = ob->rtcore_version();
      choice = rt > 0 ? "optix" : "cuda";
      std::fprintf(stderr, "traversal auto: %s (OPTIX_DEVICE_PROPERTY_RTCORE_VERSION %u: %s)\n", choice.c_str(), rt,
                   rt > 0 ? "RT cores" : "no RT cores, OptiX traverses in software");
      std::fprintf(stderr, "bench --probe: %u closest + %u shadow rays a launch, %d warm-up + %d timed launches\n",
                   ps.rays, ps.rays, ps.warmup, ps.launches);
    }
    Row row;
    row.scene = name;
    row.triangles = scene.triangle_count();
    row.instances = scene.instances.size();
    row.spheres = scene.spheres.size();
    row.r = run_trace_probe(scene, *ob, ps);
    std::fprintf(stderr, "  %-16s optix %.3f / %.3f ms, cuda %.3f / %.3f ms (closest / shadow)\n", name.c_str(),
                 row.r.optix.closest_ms, row.r.optix.shadow_ms, row.r.cuda.closest_ms, row.r.cuda.shadow_ms);
    rows.push_back(row);
  }
  auto grays = [](uint32_t rays, double ms) { return ms > 0 ? double(rays) / (ms * 1e-3) * 1e-9 : 0.0; };
  auto both = [](uint32_t rays, const ProbeTimes& t) {
    const double ms = t.closest_ms + t.shadow_ms;
    return ms > 0 ? 2.0 * double(rays) / (ms * 1e-3) * 1e-9 : 0.0;
  };
  std::printf("\npenumbra bench --probe: %s; traversal auto: %s\n", device.c_str(), choice.c_str());
  std::printf("Grays/s at the median launch time; closest = closest-hit rays, shadow = any-hit rays, c+s = both\n");
  std::printf("%-16s %10s %9s | %7s %7s %7s | %7s %7s %7s | %6s %6s | %6s %6s %6s\n", "scene", "triangles", "rays",
              "optix c", "shadow", "c+s", "cuda c", "shadow", "c+s", "x clos", "x shad", "ties", "other", "shadow");
  bool differ = false;
  for (const Row& w : rows) {
    const ProbeResult& r = w.r;
    const double oc = grays(r.rays, r.optix.closest_ms), os = grays(r.rays, r.optix.shadow_ms);
    const double cc = grays(r.rays, r.cuda.closest_ms), cs = grays(r.rays, r.cuda.shadow_ms);
    std::printf("%-16s %10zu %9u | %7.2f %7.2f %7.2f | %7.2f %7.2f %7.2f | %6.2f %6.2f | %6llu %6llu %6llu\n",
                w.scene.c_str(), w.triangles, r.rays, oc, os, both(r.rays, r.optix), cc, cs, both(r.rays, r.cuda),
                oc > 0 ? cc / oc : 0.0, os > 0 ? cs / os : 0.0, (unsigned long long)r.closest_ties,
                (unsigned long long)(r.closest_other + r.closest_t_off), (unsigned long long)r.shadow_mismatched);
    differ = differ || r.closest_ties > r.rays / 100 || r.closest_other + r.closest_t_off > r.rays / 5000 ||
             r.shadow_mismatched > r.rays / 5000;
  }
  if (!a.json_path.empty()) {
    json j = bench_json("penumbra bench --probe", device, info);
    j["traversal_auto"] = choice;
    j["settings"] = {{"rays_per_launch", ps.rays}, {"warmup_launches", ps.warmup}, {"timed_launches", ps.launches},
                     {"seed", ps.seed}, {"sets", a.sets}};
    j["rays"] = "closest: origin uniform in the scene's bounds, direction uniform on the sphere, tmax infinite; "
                "shadow: between two points uniform in the bounds, tmax their distance";
    j["timing"] = "CUDA events around each launch; rounds of optix closest, optix shadow, cuda closest, cuda shadow";
    json rs = json::array();
    for (const Row& w : rows) {
      const ProbeResult& r = w.r;
      auto side = [&](const ProbeTimes& t) {
        return json{{"closest_ms", {{"median", t.closest_ms}, {"min", t.closest_min_ms}, {"max", t.closest_max_ms}}},
                    {"shadow_ms", {{"median", t.shadow_ms}, {"min", t.shadow_min_ms}, {"max", t.shadow_max_ms}}},
                    {"closest_grays", grays(r.rays, t.closest_ms)},
                    {"shadow_grays", grays(r.rays, t.shadow_ms)},
                    {"closest_plus_shadow_grays", both(r.rays, t)}};
      };
      rs.push_back({{"scene", w.scene},
                    {"triangles", w.triangles},
                    {"instances", w.instances},
                    {"spheres", w.spheres},
                    {"rays", r.rays},
                    {"optix", side(r.optix)},
                    {"cuda", side(r.cuda)},
                    {"cuda_over_optix_closest", r.optix.closest_ms > 0 ? r.optix.closest_ms / r.cuda.closest_ms : 0.0},
                    {"cuda_over_optix_shadow", r.optix.shadow_ms > 0 ? r.optix.shadow_ms / r.cuda.shadow_ms : 0.0},
                    {"agreement",
                     {{"hits_optix", r.hits_optix},
                      {"hits_cuda", r.hits_cuda},
                      {"closest_ties", r.closest_ties},
                      {"closest_other", r.closest_other},
                      {"closest_t_off", r.closest_t_off},
                      {"blocked_optix", r.blocked_optix},
                      {"blocked_cuda", r.blocked_cuda},
                      {"shadow_mismatched", r.shadow_mismatched}}},
                    {"cuda_bvh",
                     {{"build_ms", r.bvh.build_ms},
                      {"upload_ms", r.upload_ms},
                      {"mib", mib(r.bvh_bytes)},
                      {"meshes", r.bvh.meshes},
                      {"top_depth", r.bvh.top_depth},
                      {"max_mesh_depth", r.bvh.max_mesh_depth},
                      {"mean_leaf_size", r.bvh.mean_leaf_size},
                      {"triangles", r.bvh.mesh_triangles},
                      {"triangle_references", r.bvh.triangle_references}}}});
    }
    j["results"] = rs;
    write_file_atomic(a.json_path, j.dump(2) + "\n");
    std::fprintf(stderr, "wrote %s\n", a.json_path.c_str());
  }
  if (differ) {
    std::fprintf(stderr, "bench --probe: the two traversals disagree on more rays than ties and edges explain "
                         "(exit status %d)\n", int(kExitDiffer));
    return kExitDiffer;
  }
  return kExitOk;
#endif
}

int run_bench(const BenchArgs& a) {
  if (a.probe) return run_probe(a);
  if (!a.json_path.empty()) check_output_file(a.json_path, "--json");  // before any work
  std::vector<std::string> scene_names = split_list(a.scenes);
  const bool all_builtins = scene_names.empty();
  if (all_builtins)
    for (const auto& s : builtin_scenes()) scene_names.push_back(s.name);
  std::vector<Strategy> strategies;
  for (const std::string& s : split_list(a.strategies)) strategies.push_back(parse_strategy(s, "--strategies"));
  if (strategies.empty())
    for (int i = 0; i < kNumStrategies; ++i) strategies.push_back(Strategy(i));
  std::vector<Mis> modes;
  for (const std::string& m : split_list(a.mis)) modes.push_back(parse_mis(m, "--mis"));
  if (modes.empty())
    for (int i = 0; i < kNumMisModes; ++i) modes.push_back(Mis(i));
  const std::vector<Technique> techniques = cross_techniques(strategies, modes);
  // Light-selection methods: the scene's own when none are given.
  std::vector<LightSelection> selections;
  for (const std::string& m : split_list(a.selections)) selections.push_back(parse_light_selection(m, "--selections"));
  if (a.spp_per_launch < 1) throw std::runtime_error("--spp-per-launch must be at least 1");

  std::vector<Result> results;
  std::vector<SceneBuild> builds;
  uint64_t nonfinite = 0;  // samples left out, over every render
  std::string backend_name, device_name;
  std::vector<std::pair<std::string, std::string>> info;
  int W = 0, H = 0, launches = 0, warmup = 0;

  for (const std::string& scene_name : scene_names) {
    // The backend is chosen with the first scene; the size defaults follow it.
    std::vector<std::string> overrides = a.sets;
    overrides.push_back("render.max_depth=" + std::to_string(a.max_depth));
    bool gpu = backend_name.empty() ? a.backend != "cpu" : backend_name != "cpu";
    W = a.width ? a.width : (gpu ? 1920 : 320);
    H = a.height ? a.height : (gpu ? 1080 : 180);
    overrides.push_back("render.width=" + std::to_string(W));
    overrides.push_back("render.height=" + std::to_string(H));
    Scene scene;
    try {
      scene = load_scene(scene_name, overrides);
    } catch (const SceneError& e) {
      // By default every built-in scene: one whose data is not on this machine
      // (sponza, bunnies) is left out with the reason; a named one is an error.
      if (!all_builtins) throw;
      std::fprintf(stderr, "bench: skipping %s: %s\n", scene_name.c_str(), e.what());
      continue;
    }

    check_memory(scene.source + ": bench at " + std::to_string(W) + "x" + std::to_string(H),
                 {{"film", film_bytes(W, H)},
                  {"acceleration structures", (backend_name.empty() ? a.backend : backend_name) == "optix"
                                                  ? 0
                                                  : cpu_backend_bytes(scene)}});
    BackendOptions opts;
    opts.threads = a.threads;
    opts.spp_per_launch = a.spp_per_launch;
    opts.wavefront = a.wavefront;
    opts.traversal = a.traversal;
    std::string note;
    std::unique_ptr<Backend> backend = make_backend(backend_name.empty() ? a.backend : backend_name, scene, opts, &note);
    if (backend_name.empty()) {
      std::fprintf(stderr, "%s\n", note.c_str());
      backend_name = backend->name();
      device_name = backend->device_name();
      info = backend->device_info();
      if (backend_name == "cpu" && gpu && !a.width) {  // auto fell back: CPU sizes
        W = 320, H = 180;
        overrides[overrides.size() - 2] = "render.width=" + std::to_string(W);
        overrides.back() = "render.height=" + std::to_string(H);
        backend.reset();
        scene = load_scene(scene_name, overrides);
        backend = make_backend("cpu", scene, opts, &note);
      }
      gpu = backend_name != "cpu";
      launches = a.launches ? a.launches : (gpu ? 100 : 10);
      warmup = a.warmup >= 0 ? a.warmup : (gpu ? 10 : 1);
      std::fprintf(stderr, "bench: %dx%d, %d spp per launch, max depth %d, %d warm-up + %d timed launches\n", W, H,
                   a.spp_per_launch, a.max_depth, warmup, launches);
    }
    {
      SceneBuild b;
      b.scene = scene_name;
      b.triangles = scene.triangle_count();
      b.instances = scene.instances.size();
      b.spheres = scene.spheres.size();
      b.textures = scene.textures.size();
      b.lights = scene.lights.size();
      b.light_bvh_ms = scene.light_bvh.build_ms;
      b.light_bvh_mib = mib(scene.light_bvh.bytes());
      b.stats = backend->scene_build_stats();
      builds.push_back(b);
    }

    std::vector<LightSelection> scene_selections = selections;
    if (scene_selections.empty()) scene_selections.push_back(scene.render.light_selection);
    for (const LightSelection selection : scene_selections) {
      for (const Technique& technique : techniques) {
        FrameSpec frame = frame_spec(scene);
        frame.integrator.strategy = technique.strategy;
        frame.integrator.mis = technique.mis;
        frame.integrator.light_selection = selection;
        Film film(W, H);
        const double pixels = double(W) * double(H);
        Result r;
        r.scene = scene_name;
        r.strategy = technique_name(technique);
        r.mis = mis_name(technique.mis);
        r.selection = light_selection_label(selection, scene.render.restir);
        if (warmup > 0) backend->render(frame, film, 0, uint32_t(warmup * a.spp_per_launch));
        const uint32_t first = uint32_t(warmup * a.spp_per_launch);
        std::vector<double> total, trace, acc;
        double gpu_ms = 0;
        auto t0 = std::chrono::steady_clock::now();
        if (gpu) {
          backend->render(frame, film, first, uint32_t(launches * a.spp_per_launch));
          RenderStats st = backend->last_render_stats();
          for (const LaunchTiming& l : st.launches) {
            total.push_back(double(l.trace_ms) + double(l.accumulate_ms));
            trace.push_back(l.trace_ms);
            acc.push_back(l.accumulate_ms);
            gpu_ms += total.back();
          }
          r.rays = st.rays;
          nonfinite += st.nonfinite;
        } else {
          for (int i = 0; i < launches; ++i) {
            auto s = std::chrono::steady_clock::now();
            backend->render(frame, film, first + uint32_t(i * a.spp_per_launch), uint32_t(a.spp_per_launch));
            total.push_back(std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - s).count());
            nonfinite += backend->last_render_stats().nonfinite;
          }
        }
        double wall = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
        r.wall_ms_per_launch = wall / std::max(1, launches);
        r.ms = spread(total);
        r.trace_ms = spread(trace);
        r.accumulate_ms = spread(acc);
        r.msamples_per_s = r.ms.median > 0 ? pixels * a.spp_per_launch / (r.ms.median * 1e-3) * 1e-6 : 0;
        r.rays_per_s = (r.rays && gpu_ms > 0) ? double(r.rays) / (gpu_ms * 1e-3) : 0;
        std::fprintf(stderr, "  %-16s %-28s %-8s %9.3f ms/launch (median of %zu)\n", r.scene.c_str(),
                     r.strategy.c_str(), light_selection_name(selection), r.ms.median, total.size());
        results.push_back(r);
      }
    }
  }

  // ---- Table ----
  const bool gpu = backend_name != "cpu";
  std::printf("\npenumbra bench: %s (%s), %dx%d, %d spp/launch, max depth %d, median of %d launches after %d warm-up\n",
              backend_name.c_str(), device_name.c_str(), W, H, a.spp_per_launch, a.max_depth, launches, warmup);
  {  // the wavefront's path state (issue 11: under 1 GiB at 1080p)
    std::string tracer, paths, bytes, pool;
    for (const auto& kv : info) {
      if (kv.first == "path_tracer") tracer = kv.second;
      if (kv.first == "wavefront_paths") paths = kv.second;
      if (kv.first == "wavefront_path_bytes") bytes = kv.second;
      if (kv.first == "wavefront_pool") pool = kv.second;
    }
    if (tracer == "wavefront")
      std::printf("wavefront: %s paths in the pool, %s bytes of state and queues a path, %s on the GPU\n",
                  paths.c_str(), bytes.c_str(), pool.c_str());
  }
  std::printf("%-16s %-28s %-8s %9s %9s %9s %9s %9s %8s %8s %10s %9s %8s\n", "scene", "technique", "select",
              "ms/launch", "min", "p10", "p90", "max", "trace", "accum", "Msamples/s", "Grays/s", "vs area");
  for (const Result& r : results) {
    double area_ms = 0;
    for (const Result& o : results)
      if (o.scene == r.scene && o.strategy == "area" && o.selection == r.selection) area_ms = o.ms.median;
    char vs[32] = "-";
    if (area_ms > 0) std::snprintf(vs, sizeof vs, "%+.1f%%", (r.ms.median / area_ms - 1.0) * 100.0);
    char rays[32] = "-";
    if (r.rays_per_s > 0) std::snprintf(rays, sizeof rays, "%.2f", r.rays_per_s * 1e-9);
    char trace[32] = "-", accum[32] = "-";
    if (gpu) {
      std::snprintf(trace, sizeof trace, "%.3f", r.trace_ms.median);
      std::snprintf(accum, sizeof accum, "%.3f", r.accumulate_ms.median);
    }
    const std::string select = r.selection.substr(0, r.selection.find(' '));
    std::printf("%-16s %-28s %-8s %9.3f %9.3f %9.3f %9.3f %9.3f %8s %8s %10.2f %9s %8s\n", r.scene.c_str(),
                r.strategy.c_str(), select.c_str(), r.ms.median, r.ms.min, r.ms.p10, r.ms.p90, r.ms.max, trace, accum,
                r.msamples_per_s, rays, vs);
  }
  for (const Result& r : results)
    if (r.selection.find(' ') != std::string::npos) {
      std::printf("(restir: %s)\n", r.selection.c_str());
      break;
    }

  // ---- Light BVHs (host) ----
  std::printf("\nlight BVH (host build, one thread per subtree of 8192+ lights)\n%-16s %9s %9s %9s\n", "scene", "lights",
              "build ms", "MiB");
  for (const SceneBuild& b : builds)
    std::printf("%-16s %9zu %9.2f %9.3f\n", b.scene.c_str(), b.lights, b.light_bvh_ms, b.light_bvh_mib);

  // ---- Scene builds (GPU) ----
  bool any_build = false;
  for (const SceneBuild& b : builds) any_build = any_build || b.stats.valid;
  if (any_build) {
    std::printf("\nscene build (GPU): acceleration structures (host clock, build + compaction) and device memory (MiB)\n");
    std::printf("%-16s %11s %11s %5s %9s %9s %9s %9s %9s %11s %11s\n", "scene", "triangles", "programs ms", "GAS",
                "GAS ms", "IAS ms", "accel", "buffers", "textures", "used before", "used after");
    for (const SceneBuild& b : builds) {
      if (!b.stats.valid) continue;
      const SceneBuildStats& s = b.stats;
      std::printf("%-16s %11zu %11.1f %5u %9.2f %9.2f %9.2f %9.2f %9.2f %11.1f %11.1f\n", b.scene.c_str(),
                  b.triangles, s.pipeline_ms, s.gas_count, s.gas_build_ms, s.ias_build_ms, mib(s.accel_bytes), mib(s.scene_bytes),
                  mib(s.texture_bytes), mib(s.device_used_before), mib(s.device_used_after));
    }
  }

  // ---- JSON ----
  if (!a.json_path.empty()) {
    json j = bench_json("penumbra bench", device_name, info);
    j["backend"] = backend_name;
    j["settings"] = {{"width", W},
                     {"height", H},
                     {"spp_per_launch", a.spp_per_launch},
                     {"max_depth", a.max_depth},
                     {"warmup_launches", warmup},
                     {"timed_launches", launches},
                     {"sets", a.sets}};
    j["timing"] = gpu ? "GPU time per launch from CUDA events: path tracing (optixLaunch) + the accumulation kernel"
                      : "wall-clock time per render() call of spp_per_launch samples";
    j["rays"] = gpu ? "exact count of optixTrace calls (path + shadow rays), summed per pixel on the device"
                    : "not counted on the CPU";
    json rs = json::array();
    for (const Result& r : results) {
      json o = {{"scene", r.scene},
                {"strategy", r.strategy},
                {"mis", r.mis},
                {"light_selection", r.selection},
                {"ms_per_launch", spread_json(r.ms)},
                {"msamples_per_s", r.msamples_per_s},
                {"wall_ms_per_launch", r.wall_ms_per_launch}};
      if (gpu) {
        o["trace_ms"] = spread_json(r.trace_ms);
        o["accumulate_ms"] = spread_json(r.accumulate_ms);
        o["rays"] = r.rays;
        o["rays_per_launch"] = launches ? double(r.rays) / launches : 0.0;
        o["rays_per_s"] = r.rays_per_s;
      }
      rs.push_back(o);
    }
    j["results"] = rs;
    json sb = json::array();
    for (const SceneBuild& b : builds) {
      json o = {{"scene", b.scene},
                {"triangles", b.triangles},
                {"instances", b.instances},
                {"spheres", b.spheres},
                {"textures", b.textures},
                {"lights", b.lights},
                {"light_bvh_build_ms", b.light_bvh_ms},
                {"light_bvh_mib", b.light_bvh_mib},
                // restir's frame buffers (shading points, two reservoirs a pixel) at this resolution
                {"restir_frame_mib", mib(uint64_t(W) * uint64_t(H) * (sizeof(RestirPixel) + 2 * sizeof(Reservoir)))}};
      if (b.stats.valid) {
        const SceneBuildStats& s = b.stats;
        o["pipeline_ms"] = s.pipeline_ms;
        o["gas_count"] = s.gas_count;
        o["gas_build_ms"] = s.gas_build_ms;
        o["ias_build_ms"] = s.ias_build_ms;
        o["accel_mib"] = mib(s.accel_bytes);
        o["scene_buffers_mib"] = mib(s.scene_bytes);
        o["textures_mib"] = mib(s.texture_bytes);
        o["scene_total_mib"] = mib(s.accel_bytes + s.scene_bytes + s.texture_bytes);
        o["device_used_before_mib"] = mib(s.device_used_before);
        o["device_used_after_mib"] = mib(s.device_used_after);
        o["device_used_delta_mib"] = mib(s.device_used_after) - mib(s.device_used_before);
        o["estimated_mib"] = mib(s.estimated_bytes);  // checked against free memory before building
      }
      sb.push_back(o);
    }
    j["scene_builds"] = sb;
    j["scene_build_notes"] =
        "triangles counted per instance; build times by the host clock around synchronised optixAccelBuild (+ "
        "compaction) calls; device memory used = cudaMemGetInfo total - free (device-wide), before the scene was "
        "built (CUDA and OptiX contexts exist) and after the pipeline, acceleration structures, buffers and textures";
    j["nonfinite_samples"] = nonfinite;
    write_file_atomic(a.json_path, j.dump(2) + "\n");
    std::fprintf(stderr, "wrote %s\n", a.json_path.c_str());
  }
  if (nonfinite > 0) {
    std::fprintf(stderr,
                 "warning: %llu samples were NaN or infinite and left out (counted as black) (exit status %d)\n",
                 (unsigned long long)nonfinite, int(kExitNonFinite));
    return kExitNonFinite;
  }
  return kExitOk;
}

}  // namespace

Command add_bench_command(CLI::App& app) {
  auto a = std::make_shared<BenchArgs>();
  auto* sub = app.add_subcommand(
      "bench", "Time every built-in scene and strategy: median and spread of many 1-spp launches (table + JSON)");
  sub->add_option("--backend", a->backend, "cpu, optix, or auto")
      ->capture_default_str()
      ->check(CLI::IsMember({"cpu", "optix", "auto"}));
  sub->add_option("--scenes", a->scenes, "Scenes, comma-separated (default: every built-in scene)");
  sub->add_option("--strategies", a->strategies, "Strategies, comma-separated (default: " + strategy_names() + ")");
  sub->add_option("--mis", a->mis,
                  "MIS modes, comma-separated, each with every strategy that samples lights (default: " + mis_names() +
                      ")");
  sub->add_option("--selections", a->selections,
                  "Light-selection methods, comma-separated (" + light_selection_names() +
                      "; default: each scene's own); restir's settings are the scene's (--set render.restir.*)");
  sub->add_option("--width", a->width, "Image width (default: 1920 on the GPU, 320 on the CPU)")
      ->check(CLI::Range(1, 16384));
  sub->add_option("--height", a->height, "Image height (default: 1080 on the GPU, 180 on the CPU)")
      ->check(CLI::Range(1, 16384));
  sub->add_option("--launches", a->launches, "Timed launches (default: 100 on the GPU, 10 on the CPU, 20 with --probe)")
      ->check(CLI::Range(1, 1000000));
  sub->add_option("--warmup", a->warmup, "Warm-up launches (default: 10 on the GPU, 1 on the CPU, 3 with --probe)")
      ->check(CLI::Range(0, 1000000));
  sub->add_option("--spp-per-launch", a->spp_per_launch, "Samples per pixel per launch")
      ->capture_default_str()
      ->check(CLI::Range(1, 65536));
  sub->add_option("--max-depth", a->max_depth, "Maximum number of bounces")->capture_default_str()->check(CLI::Range(0, 64));
  sub->add_option("--threads", a->threads, "CPU threads (default: all)")->check(CLI::Range(0, 4096));
  add_wavefront_options(sub, &a->wavefront, &a->traversal);
  sub->add_option("--json", a->json_path, "Write the results as JSON to this file");
  sub->add_flag("--probe", a->probe,
                "The trace stage alone: random incoherent rays in each scene's bounds (closest; shadow), traced by "
                "OptiX and by the cuda traversal on the same rays, Grays/s and disagreements (GPU build)");
  sub->add_option("--probe-rays", a->probe_rays, "--probe: rays per launch of each kind")
      ->capture_default_str()
      ->check(CLI::Range(1u, 1u << 28));
  sub->add_option("--set", a->sets, "Override any scene value, e.g. --set light.radius=0.05")
      ->take_all()
      ->allow_extra_args(false);
  return {sub, [a]() { return run_bench(*a); }};
}

}  // namespace pn
