#include "render/backend.h"

#include <algorithm>
#include <cctype>
#include <exception>
#include <stdexcept>
#include <thread>
#include <vector>

#include "backends/cpu/cpu_backend.h"
#include "render/multi_backend.h"
#if PN_HAVE_OPTIX
#include "backends/optix/optix_backend.h"
#endif

namespace pn {

std::string describe_nonfinite(const RenderStats& stats) {
  std::string s = std::to_string(stats.nonfinite) + (stats.nonfinite == 1 ? " sample was" : " samples were") +
                  " NaN or infinite and left out (counted as black)";
  for (size_t i = 0; i < stats.nonfinite_pixels.size(); ++i)
    s += (i ? ", (" : ", at pixel" + std::string(stats.nonfinite_pixels.size() > 1 ? "s (" : " (")) +
         std::to_string(stats.nonfinite_pixels[i][0]) + ", " + std::to_string(stats.nonfinite_pixels[i][1]) + ")";
  if (stats.nonfinite_pixels.size() == RenderStats::kMaxNonfinitePixels) s += ", ...";
  return s;
}

void note_nonfinite_pixel(RenderStats& stats, int x, int y, int width) {
  auto& v = stats.nonfinite_pixels;
  auto index = [width](const std::array<int, 2>& p) { return int64_t(p[1]) * width + p[0]; };
  const std::array<int, 2> p = {x, y};
  auto it = std::lower_bound(v.begin(), v.end(), p, [&](const auto& a, const auto& b) { return index(a) < index(b); });
  if (it != v.end() && *it == p) return;
  if (v.size() == RenderStats::kMaxNonfinitePixels && it == v.end()) return;
  v.insert(it, p);
  if (v.size() > RenderStats::kMaxNonfinitePixels) v.pop_back();
}

GuideImages Backend::render_guides(const FrameSpec&, uint32_t) {
  throw std::logic_error("the " + name() + " backend renders no denoiser guides");
}

FrameSpec frame_spec(const Scene& scene) {
  FrameSpec f;
  f.camera = scene.make_camera();
  f.integrator = scene.integrator();
  f.seed = scene.render.seed;
  return f;
}

namespace {

// --gpus as "all" (an empty list) or the numbers it holds: a count, or a list.
// Throws std::invalid_argument for anything else.
struct GpuSpec {
  bool all = false;
  bool is_count = false;
  std::vector<int> numbers;
};

GpuSpec parse_gpus(const std::string& spec) {
  GpuSpec g;
  if (spec == "all") {
    g.all = true;
    return g;
  }
  auto bad = [&](const std::string& why) {
    return std::invalid_argument("--gpus " + spec + ": " + why +
                                 " (expected all, a number of GPUs such as 2, or a list of GPU indices such as 0,2 "
                                 "or 1, for GPU 1 alone)");
  };
  size_t pos = 0;
  while (true) {
    size_t end = spec.find(',', pos);
    std::string item = spec.substr(pos, end == std::string::npos ? std::string::npos : end - pos);
    if (item.empty() || item.size() > 4 || !std::all_of(item.begin(), item.end(), [](unsigned char c) { return std::isdigit(c); }))
      throw bad(item.empty() ? "an empty entry" : "'" + item + "' is not a GPU number");
    g.numbers.push_back(std::stoi(item));
    if (end == std::string::npos || end + 1 == spec.size()) break;  // "1,": a list of one
    pos = end + 1;
  }
  g.is_count = g.numbers.size() == 1 && spec.find(',') == std::string::npos;
  if (g.is_count && g.numbers[0] == 0) throw bad("at least one GPU");
  auto sorted = g.numbers;
  std::sort(sorted.begin(), sorted.end());
  if (std::adjacent_find(sorted.begin(), sorted.end()) != sorted.end()) throw bad("a GPU is listed twice");
  return g;
}

}  // namespace

void check_gpus(const std::string& spec) {
  if (!spec.empty()) parse_gpus(spec);
}

std::vector<int> select_gpus(const std::string& spec, int available) {
  if (spec.empty()) return {0};
  const GpuSpec g = parse_gpus(spec);
  const std::string have = "this machine has " + std::to_string(available) + " GPU" + (available == 1 ? "" : "s");
  std::vector<int> out;
  if (g.all) {
    for (int i = 0; i < available; ++i) out.push_back(i);
  } else if (g.is_count) {
    if (g.numbers[0] > available) throw std::invalid_argument("--gpus " + spec + ": " + have);
    for (int i = 0; i < g.numbers[0]; ++i) out.push_back(i);
  } else {
    for (int i : g.numbers)
      if (i >= available)
        throw std::invalid_argument("--gpus " + spec + ": no GPU " + std::to_string(i) + " (" + have +
                                    (available ? ", numbered from 0" : "") + ")");
    out = g.numbers;
  }
  if (out.empty()) throw std::invalid_argument("--gpus " + spec + ": " + have);
  return out;
}

#if PN_HAVE_OPTIX
namespace {

// The GPU backend on the GPUs options.gpus selects: one OptiX backend, or a
// MultiBackend over one per GPU (built concurrently: each builds its own
// acceleration structures).
std::unique_ptr<Backend> make_gpu_backend(const Scene& scene, const BackendOptions& options) {
  check_gpus(options.gpus);
  const std::vector<int> gpus = select_gpus(options.gpus, options.gpus.empty() ? 1 : optix_device_count());
  if (gpus.size() == 1) {
    BackendOptions one = options;
    one.device = gpus[0];
    return make_optix_backend(scene, one);
  }
  std::vector<std::unique_ptr<Backend>> devices(gpus.size());
  std::vector<std::exception_ptr> errors(gpus.size());
  std::vector<std::thread> threads;
  for (size_t i = 0; i < gpus.size(); ++i)
    threads.emplace_back([&, i] {
      try {
        BackendOptions one = options;
        one.device = gpus[i];
        devices[i] = make_optix_backend(scene, one);
      } catch (...) {
        errors[i] = std::current_exception();
      }
    });
  for (std::thread& t : threads) t.join();
  for (size_t i = 0; i < gpus.size(); ++i)
    if (errors[i]) {
      try {
        std::rethrow_exception(errors[i]);
      } catch (const std::exception& e) {
        throw std::runtime_error("GPU " + std::to_string(gpus[i]) + ": " + e.what());
      }
    }
  std::vector<std::string> labels;
  for (int g : gpus) labels.push_back("GPU " + std::to_string(g));
  return std::make_unique<MultiBackend>(std::move(devices), std::move(labels));
}

}  // namespace
#endif

std::unique_ptr<Backend> make_backend(const std::string& which, const Scene& scene,
                                      const BackendOptions& options, std::string* note) {
  check_gpus(options.gpus);  // a malformed --gpus is an error on any machine
  if (which == "cpu") {
    auto b = make_cpu_backend(scene, options.threads);
    *note = "backend: cpu (" + b->device_name() + ")";
    return b;
  }
  if (which == "optix") {
#if PN_HAVE_OPTIX
    std::string why;
    if (!optix_available(&why)) throw std::runtime_error(why);
    auto b = make_gpu_backend(scene, options);
    *note = "backend: optix (" + b->device_name() + ")";
    return b;
#else
    throw std::runtime_error(
        "this penumbra was built without the OptiX backend: reconfigure with OptiX headers "
        "(cmake -DOptiX_ROOT=/path/to/optix, the folder that holds include/optix.h) and CUDA");
#endif
  }
  if (which == "auto") {
#if PN_HAVE_OPTIX
    std::string why;
    if (optix_available(&why)) {
      auto b = make_gpu_backend(scene, options);
      *note = "backend: optix (" + b->device_name() + "), chosen by --backend auto";
      return b;
    }
    auto b = make_cpu_backend(scene, options.threads);
    *note = "backend: cpu (" + b->device_name() + "), chosen by --backend auto: " + why;
    return b;
#else
    auto b = make_cpu_backend(scene, options.threads);
    *note = "backend: cpu (" + b->device_name() + "), chosen by --backend auto: built without OptiX";
    return b;
#endif
  }
  throw std::runtime_error("unknown backend '" + which + "' (expected cpu, optix or auto)");
}

}  // namespace pn
