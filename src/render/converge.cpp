// One convergence experiment: see converge.h. Moved from `penumbra converge`
// (apps/cmd_converge.cpp), which now parses its options and calls run_converge().
#include "render/converge.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <memory>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

#include "apps/progress.h"
#include "io/image.h"
#include "io/npy.h"
#include "io/output.h"
#include "render/resources.h"
#include "render/metrics.h"
#include "render/technique.h"
#include "scene/scene.h"

#ifndef PENUMBRA_GIT_COMMIT
#define PENUMBRA_GIT_COMMIT "unknown"
#endif

namespace pn {
namespace {
namespace fs = std::filesystem;
using json = nlohmann::json;

// FNV-1a: a stable hash for cache keys (std::hash is not stable across builds).
uint64_t fnv1a(const std::string& s) {
  uint64_t h = 1469598103934665603ull;
  for (unsigned char c : s) h = (h ^ c) * 1099511628211ull;
  return h;
}

// Renders `spp` samples (from sample `first`) and returns the GPU time of the
// launches when the backend measures it, else the wall time, in milliseconds;
// split across devices, the time of the slowest device.
double timed_render(Backend& b, const FrameSpec& f, Film& film, uint32_t first, uint32_t spp,
                    const ProgressFn& progress = nullptr) {
  auto t0 = std::chrono::steady_clock::now();
  b.render(f, film, first, spp, progress);
  double wall = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
  RenderStats st = b.last_render_stats();
  if (!st.devices.empty()) {
    double slowest = 0;
    for (const DeviceTiming& d : st.devices) slowest = std::max(slowest, d.gpu_ms > 0 ? d.gpu_ms : d.wall_ms);
    return slowest;
  }
  if (st.launches.empty()) return wall;
  double gpu = 0;
  for (const auto& l : st.launches) gpu += l.trace_ms + l.accumulate_ms;
  return gpu;
}

// The pixel rectangle of the figure-4.1 crop: a square around the projection of
// the first light's centre, a third of the image high, clamped to the image.
std::vector<int> auto_crop(const Scene& s) {
  const int W = s.render.width, H = s.render.height;
  int size = std::max(8, H / 3);
  int cx = W / 2, cy = H / 2;
  if (!s.lights.empty()) {
    Camera cam = s.make_camera();
    Vec3 d = s.lights[0].p - cam.eye;
    float z = dot(d, cam.forward);
    if (z > 0) {
      float sx = dot(d, cam.right) / length_sq(cam.right) / z, sy = dot(d, cam.up) / length_sq(cam.up) / z;
      cx = int((sx + 1) * 0.5f * W);
      cy = int((1 - sy) * 0.5f * H);
    }
  }
  int x = std::clamp(cx - size / 2, 0, std::max(0, W - size)), y = std::clamp(cy - size / 2, 0, std::max(0, H - size));
  return {x, y, std::min(size, W), std::min(size, H)};
}

void write_crop(const std::string& path, const std::vector<float>& img, int W, const std::vector<int>& c) {
  std::vector<float> out(size_t(c[2]) * c[3] * 3);
  for (int y = 0; y < c[3]; ++y)
    for (int x = 0; x < c[2]; ++x)
      for (int k = 0; k < 3; ++k) out[(size_t(y) * c[2] + x) * 3 + k] = img[(size_t(c[1] + y) * W + c[0] + x) * 3 + k];
  write_npy(path, c[3], c[2], 3, out.data());
}

// What a converge run costs, measured before it starts: one render call of n
// spp takes about overhead + n * per_spp seconds (per technique).
struct CallCost {
  double overhead = 0, per_spp = 0;
  double seconds(double calls, double spp) const { return calls * overhead + spp * per_spp; }
};

// Times a 1-spp and (when that was quick) an 8-spp render of the frame.
CallCost measure_cost(Backend& b, const FrameSpec& f, int W, int H) {
  auto timed = [&](uint32_t spp) {
    Film film(W, H);
    auto t0 = std::chrono::steady_clock::now();
    b.render(f, film, 0, spp);
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  };
  timed(1);  // warm-up (first launches, caches)
  const double one = timed(1);
  CallCost c;
  if (one > 0.5) {
    c.per_spp = one;
    return c;
  }
  const double eight = timed(8);
  c.per_spp = std::max((eight - one) / 7, 0.0);
  c.overhead = std::max(one - c.per_spp, 0.0);
  if (c.per_spp == 0) c.per_spp = one / 8;
  return c;
}

// Seed of every ground truth (never used by the measured renders: 1..seeds).
constexpr uint32_t kRefSeed = 0x5EED;

// An experiment's scene, techniques and ground truth, checked: what every entry
// point below starts from.
struct Setup {
  json doc;  // the scene document after overrides
  std::string source;
  Scene scene;
  int W = 0, H = 0;
  std::vector<Technique> techniques;
  Technique ref_technique;
  std::vector<int> crop;
  ReferencePlan ref;
};

Setup prepare(const ConvergeOptions& a) {
  Setup s;
  std::vector<std::string> overrides = a.sets;
  if (a.width) overrides.push_back("render.width=" + std::to_string(a.width));
  if (a.height) overrides.push_back("render.height=" + std::to_string(a.height));
  s.doc = load_scene_json(a.scene, overrides, &s.source);
  s.scene = load_scene(a.scene, overrides);
  const int W = s.W = s.scene.render.width, H = s.H = s.scene.render.height;
  std::vector<Strategy> strategy_list;
  for (const auto& st : a.strategies) strategy_list.push_back(parse_strategy(st, "--strategies"));
  std::vector<Mis> modes;
  for (const auto& m : a.mis) modes.push_back(parse_mis(m, "--mis"));
  s.techniques = cross_techniques(strategy_list, modes);
  s.ref_technique = {parse_strategy(a.reference_strategy, "--reference-strategy"),
                     parse_mis(a.reference_mis, "--reference-mis")};
  if (a.max_spp < 1 || a.seeds < 1 || a.reference_spp < 1 || a.crop_spp < 1 || a.reference_chunk < 1)
    throw std::invalid_argument(
        "converge: --max-spp, --seeds, --reference-spp, --reference-chunk and --crop-spp must be >= 1");
  s.crop = a.crop.empty() ? auto_crop(s.scene) : a.crop;
  const std::vector<int>& crop = s.crop;
  if (crop.size() != 4 || crop[2] < 1 || crop[3] < 1 || crop[0] < 0 || crop[1] < 0 || crop[0] + crop[2] > W ||
      crop[1] + crop[3] > H)
    throw std::invalid_argument("converge: --crop must be x,y,w,h inside the " + std::to_string(W) + "x" +
                                std::to_string(H) + " image");
  check_gpus(a.gpus);

  // The ground truth's cache key covers everything that changes the expected
  // image and its noise: the scene document after overrides (geometry, camera,
  // resolution, depth), the reference spp and technique. Seed kRefSeed is kept
  // for references only. (Not the chunk size: it changes the order of double
  // additions only.) References select lights by power whatever the runs do (an
  // unbiased method, and the same reference for every method compared).
  json key_doc = s.doc;
  if (key_doc.contains("render") && key_doc["render"].is_object())
    for (const char* k : {"spp", "strategy", "mis", "seed", "light_selection", "restir"}) key_doc["render"].erase(k);
  std::ostringstream key;
  key << std::hex
      << fnv1a(key_doc.dump() + "|" + std::to_string(a.reference_spp) + "|" + technique_name(s.ref_technique));
  const std::string cache = a.cache.empty() ? default_cache_dir() : a.cache;
  ReferencePlan& r = s.ref;
  r.key = key.str();
  r.path = cache + "/ref-" + r.key + ".exr";
  r.var_path = cache + "/ref-" + r.key + "_var.exr";
  r.width = W;
  r.height = H;
  r.spp = a.reference_spp;
  r.chunk_spp = std::min(a.reference_chunk, a.reference_spp);
  r.chunks = (r.spp + r.chunk_spp - 1) / r.chunk_spp;
  r.cached = fs::exists(r.path) && fs::exists(r.var_path);
  return s;
}

std::unique_ptr<Backend> backend_for(const ConvergeOptions& a, const Scene& scene, std::string* note) {
  BackendOptions opts;
  opts.threads = a.threads;
  opts.gpus = a.gpus;
  opts.wavefront = a.wavefront;
  opts.traversal = a.traversal;
  return make_backend(a.backend, scene, opts, note);
}

// How the ground truth is rendered: the reference technique, lights selected by
// power, seed kRefSeed.
FrameSpec reference_frame(const Setup& s) {
  FrameSpec f = frame_spec(s.scene);
  f.integrator.strategy = s.ref_technique.strategy;
  f.integrator.mis = s.ref_technique.mis;
  f.integrator.light_selection = LightSelection::Power;
  f.seed = kRefSeed;
  return f;
}

// Chunk k of the ground truth into `film` (from zero).
void render_chunk(Backend& backend, const Setup& s, int k, Film& film, const ProgressFn& progress) {
  if (k < 0 || k >= s.ref.chunks)
    throw std::invalid_argument("converge: reference chunk " + std::to_string(k) + " does not exist (the reference has " +
                                std::to_string(s.ref.chunks) + ")");
  const FrameSpec f = reference_frame(s);
  const uint32_t first = uint32_t(k) * uint32_t(s.ref.chunk_spp);
  film.reset(s.W, s.H);
  backend.render(f, film, first, std::min<uint32_t>(uint32_t(s.ref.chunk_spp), uint32_t(s.ref.spp) - first), progress);
}

// The reference's files from the sums of all its samples (each written
// atomically; the mean last: a reference exists when its mean does).
void write_reference(const ReferencePlan& r, const Film& film, std::vector<float>* mean, std::vector<float>* var) {
  if (film.width() != r.width || film.height() != r.height || film.samples() != uint64_t(r.spp))
    throw std::invalid_argument("converge: the reference's sums must be " + std::to_string(r.width) + "x" +
                                std::to_string(r.height) + " with " + std::to_string(r.spp) + " samples, not " +
                                std::to_string(film.width()) + "x" + std::to_string(film.height()) + " with " +
                                std::to_string(film.samples()));
  fs::create_directories(fs::path(r.path).parent_path());
  *mean = film.mean();
  *var = film.variance_of_mean();
  write_image(r.var_path, r.width, r.height, *var);
  write_image(r.path, r.width, r.height, *mean);
}

}  // namespace

ConvergePlan plan_converge(const ConvergeOptions& options) {
  Setup s = prepare(options);
  ConvergePlan p;
  p.reference = s.ref;
  for (const Technique& t : s.techniques) {
    p.techniques.push_back(technique_name(t));
    p.technique_parts.emplace_back(strategy_name(t.strategy), mis_name(t.mis));
  }
  return p;
}

ReferenceChunk render_reference_chunk(const ConvergeOptions& options, int index) {
  Setup s = prepare(options);
  std::string note;
  std::unique_ptr<Backend> backend = backend_for(options, s.scene, &note);
  if (options.verbose) std::fprintf(stderr, "%s\n", note.c_str());
  ReferenceChunk c;
  render_chunk(*backend, s, index, c.film, options.progress);
  c.nonfinite = backend->last_render_stats().nonfinite;
  return c;
}

void store_reference(const ConvergeOptions& options, const Film& film) {
  Setup s = prepare(options);
  check_output_folder(options.cache.empty() ? default_cache_dir() : options.cache, "--cache");
  std::vector<float> mean, var;
  write_reference(s.ref, film, &mean, &var);
}

ConvergeResult run_converge(const ConvergeOptions& a) {
  // Outputs first: a folder that cannot be written is found before any work.
  const std::string& out = a.out;  // "": write no files but the cached reference
  const std::string cache = a.cache.empty() ? default_cache_dir() : a.cache;
  if (!a.estimate_only) {
    if (!out.empty()) check_output_folder(out, "--out");
    check_output_folder(cache, "--cache");
  }
  Setup setup = prepare(a);
  const Scene& scene = setup.scene;
  if (a.verbose)
    for (const std::string& w : scene.warnings) std::fprintf(stderr, "warning: %s\n", w.c_str());
  const int W = setup.W, H = setup.H;
  const std::vector<Technique>& techniques = setup.techniques;
  const Technique ref_technique = setup.ref_technique;
  const std::vector<int>& crop = setup.crop;
  const ReferencePlan& plan = setup.ref;

  // Three films (a render, the reference's and one chunk of it), four float
  // images (reference, its variance, a render's mean, the mask's) and one image
  // being written.
  check_memory(scene.source + ": converge at " + std::to_string(W) + "x" + std::to_string(H),
               {{"films", 3 * film_bytes(W, H)},
                {"images", 4 * uint64_t(W) * uint64_t(H) * 12},
                {"writing images", image_write_bytes(W, H)},
                {"acceleration structures", a.backend == "optix" ? 0 : cpu_backend_bytes(scene)}});

  std::string note;
  std::unique_ptr<Backend> backend = backend_for(a, scene, &note);
  auto log = [&](const char* fmt, auto... args) {
    if (a.verbose) std::fprintf(stderr, fmt, args...);
  };
  log("%s\n", note.c_str());
  // Progress of one render to a bar (when verbose) and to the caller's hook.
  auto progress_to = [&](ProgressBar& bar, uint64_t base, uint64_t total) -> ProgressFn {
    return [&bar, &a, base, total](uint64_t done, uint64_t) {
      if (a.verbose) bar.update(base + done, total);
      if (a.progress) a.progress(base + done, total);
    };
  };

  const std::string& ref_path = plan.path;
  const std::string& ref_var_path = plan.var_path;
  const bool cached = plan.cached;

  std::vector<int> spps;
  for (int s = 1; s <= a.max_spp; s *= 2) spps.push_back(s);

  // --- How long it will take -----------------------------------------------------
  // Each technique's cost per render call, measured; then the reference (a
  // call per chunk), the 16-spp light mask, and every technique x seed x spp.
  double estimate = 0;
  {
    const CallCost ref_cost = measure_cost(*backend, reference_frame(setup), W, H);
    if (!cached) estimate += ref_cost.seconds(plan.chunks, a.reference_spp);
    estimate += ref_cost.seconds(1, 16);
    double spp_total = 0;
    for (int s : spps) spp_total += s;
    FrameSpec f = frame_spec(scene);
    for (const Technique& tq : techniques) {
      f.integrator.strategy = tq.strategy;
      f.integrator.mis = tq.mis;
      const bool same = tq.strategy == ref_technique.strategy && tq.mis == ref_technique.mis &&
                        f.integrator.light_selection == LightSelection::Power;
      const CallCost c = same ? ref_cost : measure_cost(*backend, f, W, H);
      estimate += c.seconds(double(spps.size()) * a.seeds, spp_total * a.seeds);
    }
  }
  log("converge: estimated run time %s on %s (%s): reference %d spp (%s), %zu techniques x %d seeds x 1..%d spp at "
      "%dx%d\n",
      format_duration(estimate).c_str(), backend->name().c_str(), backend->device_name().c_str(), a.reference_spp,
      cached ? "cached" : "to render", techniques.size(), a.seeds, spps.back(), W, H);
  if (a.estimate_only) {
    ConvergeResult r;
    r.summary = {{"estimated_seconds", estimate}, {"backend", backend->name()}, {"device", backend->device_name()},
                 {"reference_cached", cached}};
    return r;
  }
  if (backend->name() == "cpu" && estimate > kConvergeConfirmSeconds && !a.yes)
    throw std::invalid_argument("converge: the estimated run time, " + format_duration(estimate) +
                                " on the CPU, is more than an hour: pass --yes to run it (or lower --reference-spp, "
                                "--max-spp, --seeds or the resolution)");
  if (!out.empty()) fs::create_directories(out);
  fs::create_directories(cache);
  // Samples left out (NaN or infinite): of the reference, the light mask, the measured renders.
  uint64_t nonfinite_reference = 0, nonfinite_mask = 0, nonfinite_renders = 0;
  auto count_nonfinite = [&](uint64_t& part) { part += backend->last_render_stats().nonfinite; };

  // --- Ground truth (cached) --------------------------------------------------
  std::vector<float> ref, ref_var;
  double ref_seconds = 0;
  if (cached) {
    int w, h, wv, hv;
    ref = read_exr(ref_path, &w, &h);
    ref_var = read_exr(ref_var_path, &wv, &hv);
    if (w != W || h != H || wv != W || hv != H)
      throw std::runtime_error(ref_path + ": cached reference has the wrong size");
    log("reference: %s (cached)\n", ref_path.c_str());
  } else {
    // In chunks of plan.chunk_spp samples, each rendered from zero and added in
    // chunk order: the sums render_reference_chunk() and store_reference() give.
    Film film(W, H), chunk;
    ProgressBar bar("reference " + std::to_string(a.reference_spp) + " spp");
    const uint64_t total = uint64_t(W) * H * a.reference_spp;
    for (int k = 0; k < plan.chunks; ++k) {
      render_chunk(*backend, setup, k, chunk, progress_to(bar, uint64_t(W) * H * k * plan.chunk_spp, total));
      count_nonfinite(nonfinite_reference);
      film.add(chunk);
    }
    ref_seconds = bar.finish();
    write_reference(plan, film, &ref, &ref_var);
    log("reference: %s (%d spp in %d chunk%s, %s)\n", ref_path.c_str(), a.reference_spp, plan.chunks,
        plan.chunks == 1 ? "" : "s", format_duration(ref_seconds).c_str());
  }
  if (!out.empty()) write_image(out + "/reference.png", W, H, ref);

  // --- Pixels that see a light directly -----------------------------------------
  // A render with max depth 0 holds only emission seen by camera rays; any
  // pixel with some of it (also partially covered ones) is left out of the
  // "no light" metrics.
  std::vector<uint8_t> mask(size_t(W) * H, 1);
  {
    FrameSpec f = frame_spec(scene);
    f.integrator.max_depth = 0;
    Film film(W, H);
    backend->render(f, film, 0, 16, a.progress);
    count_nonfinite(nonfinite_mask);
    auto m = film.mean();
    for (size_t p = 0; p < mask.size(); ++p)
      if (m[3 * p] + m[3 * p + 1] + m[3 * p + 2] > 0.f) mask[p] = 0;
  }
  size_t light_pixels = std::count(mask.begin(), mask.end(), 0);

  // The reference is itself noisy: its expected squared error, the mean of its
  // per-pixel variance, is added to every measured MSE. Reported so that the
  // reader can tell where measured errors reach that floor.
  double floor_all = 0, floor_nolight = 0;
  size_t n_nolight = 0;
  for (size_t p = 0; p < mask.size(); ++p) {
    double v = (double(ref_var[3 * p]) + ref_var[3 * p + 1] + ref_var[3 * p + 2]) / 3;
    floor_all += v;
    if (mask[p]) {
      floor_nolight += v;
      ++n_nolight;
    }
  }
  floor_all = std::sqrt(floor_all / double(mask.size()));
  floor_nolight = n_nolight ? std::sqrt(floor_nolight / double(n_nolight)) : 0.0;

  // --- Convergence runs ------------------------------------------------------------
  ConvergeResult result;
  json& summary = result.summary;
  summary["scene"] = a.scene;
  summary["source"] = setup.source;
  summary["width"] = W;
  summary["height"] = H;
  summary["max_depth"] = scene.render.max_depth;
  summary["overrides"] = a.sets;
  // Image means, over all pixels and over those that see no light (the bias of
  // a method shows in them, within the noise of both).
  auto image_mean = [&](const std::vector<float>& img, bool nolight) {
    double m = 0;
    size_t n = 0;
    for (size_t p = 0; p < mask.size(); ++p)
      if (!nolight || mask[p]) {
        m += double(img[3 * p]) + img[3 * p + 1] + img[3 * p + 2];
        n += 3;
      }
    return n ? m / double(n) : 0.0;
  };
  summary["light_selection"] = light_selection_label(scene.render.light_selection, scene.render.restir);
  summary["reference"] = {{"spp", a.reference_spp}, {"strategy", technique_name(ref_technique)},
                          {"light_selection", "power"}, {"mean", image_mean(ref, false)},
                          {"mean_nolight", image_mean(ref, true)}, {"file", ref_path},
                          {"cached", cached}, {"seconds", ref_seconds}, {"seed", kRefSeed},
                          {"chunk_spp", plan.chunk_spp},
                          {"rmse_floor", floor_all}, {"rmse_floor_nolight", floor_nolight}};
  summary["git_commit"] = PENUMBRA_GIT_COMMIT;  // of the binary that made the runs
  summary["backend"] = backend->name();
  summary["device"] = backend->device_name();
  json info = json::object();
  for (const auto& [k, v] : backend->device_info()) info[k] = v;
  summary["device_info"] = info;
  summary["light_pixels"] = light_pixels;
  summary["threshold_rmse"] = a.threshold;
  summary["fit_min_spp"] = a.fit_min_spp;
  summary["crop"] = crop;
  summary["crop_spp"] = a.crop_spp;
  summary["metrics"] =
      "RMSE: sqrt(mean over pixels and RGB channels of (test - ref)^2), linear radiance, unclamped (thesis eq. 4.1); "
      "relMSE: mean of (test - ref)^2 / (ref^2 + 0.01) (pbrt); *_nolight: without pixels that see a light directly";
  if (!out.empty()) write_crop(out + "/crop_reference.npy", ref, W, crop);

  uint64_t per_strategy = 0;
  for (int s : spps) per_strategy += uint64_t(s) * a.seeds;
  ProgressBar bar("converging");
  uint64_t done_spp = 0, total_spp = per_strategy * techniques.size();
  for (const Technique& tq : techniques) {
    const std::string name = technique_name(tq);
    FrameSpec f = frame_spec(scene);
    f.integrator.strategy = tq.strategy;
    f.integrator.mis = tq.mis;
    std::vector<double> lx, ly, lyn;
    json points = json::array();
    double ms_per_spp = 0;
    for (int spp : spps) {
      double rm = 0, rmn = 0, rel = 0, reln = 0, ms = 0, mean = 0, mean_nolight = 0;
      for (int seed = 1; seed <= a.seeds; ++seed) {
        f.seed = uint32_t(seed);
        Film film(W, H);
        double t = timed_render(*backend, f, film, 0, uint32_t(spp), a.progress);
        count_nonfinite(nonfinite_renders);
        auto img = film.mean();
        ErrorMetrics all = error_metrics(img, ref), nolight = error_metrics(img, ref, &mask);
        result.measurements.push_back(
            {name, spp, seed, t, all.rmse, nolight.rmse, all.relmse, nolight.relmse});
        mean += image_mean(img, false) / a.seeds;
        mean_nolight += image_mean(img, true) / a.seeds;
        rm += all.rmse / a.seeds;
        rmn += nolight.rmse / a.seeds;
        rel += all.relmse / a.seeds;
        reln += nolight.relmse / a.seeds;
        ms += t / a.seeds;
        done_spp += spp;
        if (a.verbose) bar.update(done_spp, total_spp);
        if (spp == a.crop_spp && seed == 1 && !out.empty()) {
          write_crop(out + "/crop_" + name + ".npy", img, W, crop);
          write_image(out + "/image_" + name + "_" + std::to_string(spp) + "spp.png", W, H, img);
        }
      }
      points.push_back({{"spp", spp}, {"rmse", rm}, {"rmse_nolight", rmn}, {"relmse", rel}, {"relmse_nolight", reln},
                        {"time_ms", ms}, {"mean", mean}, {"mean_nolight", mean_nolight}});
      if (spp >= a.fit_min_spp) {
        lx.push_back(std::log(double(spp)));
        ly.push_back(std::log(rm));
        lyn.push_back(std::log(rmn));
      }
      ms_per_spp = ms / spp;  // from the largest spp: launch overheads amortised
    }
    json js = {{"points", points}, {"ms_per_spp", ms_per_spp}, {"strategy", strategy_name(tq.strategy)},
               {"mis", mis_name(tq.mis)}};
    auto fit_json = [&](const std::vector<double>& y, const char* name) {
      if (lx.size() < 2) return;
      LineFit fit = fit_line(lx, y);
      // Time to reach the threshold, from the fitted line: N = exp((ln t - a) / b).
      double n = fit.b < 0 ? std::exp((std::log(a.threshold) - fit.a) / fit.b) : INFINITY;
      js[name] = {{"slope", fit.b}, {"intercept", fit.a}, {"spp_to_threshold", n},
                  {"ms_to_threshold", n * ms_per_spp}};
    };
    fit_json(ly, "fit_rmse");
    fit_json(lyn, "fit_rmse_nolight");
    // Efficiency 1 / (MSE x time) at the largest spp.
    const json& last = points.back();
    double mse = std::pow(last["rmse"].get<double>(), 2), mse_n = std::pow(last["rmse_nolight"].get<double>(), 2);
    double secs = last["time_ms"].get<double>() * 1e-3;
    js["efficiency"] = mse > 0 && secs > 0 ? 1.0 / (mse * secs) : 0.0;
    js["efficiency_nolight"] = mse_n > 0 && secs > 0 ? 1.0 / (mse_n * secs) : 0.0;
    summary["strategies"][name] = js;
  }
  double secs = bar.finish();
  summary["seconds"] = secs;
  summary["estimated_seconds"] = estimate;
  summary["nonfinite_samples"] = nonfinite_reference + nonfinite_mask + nonfinite_renders;
  summary["nonfinite_by_part"] = {
      {"reference", nonfinite_reference}, {"mask", nonfinite_mask}, {"renders", nonfinite_renders}};
  if (!out.empty()) {
    std::string csv = converge_csv_header();
    for (const ConvergeMeasurement& m : result.measurements) csv += converge_csv_row(a.scene, m);
    write_file_atomic(out + "/measurements.csv", csv);
    write_file_atomic(out + "/summary.json", summary.dump(2) + "\n");
  }

  // One line per strategy: what a person wants to know first.
  for (const Technique& tq : techniques) {
    const std::string name = technique_name(tq);
    const json& js = summary["strategies"][name];
    if (!js.contains("fit_rmse")) continue;
    log("%-28s slope %.3f (no-light %.3f), %.3f ms/spp, RMSE %.3g reached in %.3g spp = %.4g ms\n", name.c_str(),
        js["fit_rmse"]["slope"].get<double>(), js["fit_rmse_nolight"]["slope"].get<double>(),
        js["ms_per_spp"].get<double>(), a.threshold, js["fit_rmse"]["spp_to_threshold"].get<double>(),
        js["fit_rmse"]["ms_to_threshold"].get<double>());
  }
  return result;
}

std::string default_cache_dir() {
  if (const char* x = std::getenv("XDG_CACHE_HOME"); x && *x) return std::string(x) + "/penumbra";
  if (const char* h = std::getenv("HOME"); h && *h) return std::string(h) + "/.cache/penumbra";
  return ".penumbra-cache";
}

std::string converge_csv_header() {
  return "scene,strategy,spp,seed,time_ms,rmse,rmse_nolight,relmse,relmse_nolight\n";
}

std::string converge_csv_row(const std::string& scene, const ConvergeMeasurement& m) {
  std::ostringstream row;
  row << scene << "," << m.strategy << "," << m.spp << "," << m.seed << "," << m.time_ms << "," << m.rmse << ","
      << m.rmse_nolight << "," << m.relmse << "," << m.relmse_nolight << "\n";
  return row.str();
}

}  // namespace pn
