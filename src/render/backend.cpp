#include "render/backend.h"

#include <algorithm>
#include <cctype>
#include <stdexcept>
#include <vector>

#include "core/enum_names.h"

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

const char* traversal_name(Traversal t) {
  switch (t) {
    case Traversal::Auto: return "auto";
    case Traversal::Optix: return "optix";
    case Traversal::Cuda: return "cuda";
  }
  return "?";
}

bool find_traversal(const std::string& name, Traversal* out) {
  return find_enum(name, kNumTraversals, traversal_name, out);
}

std::string traversal_names() { return enum_names(kNumTraversals, traversal_name); }

FrameSpec frame_spec(const Scene& scene) {
  FrameSpec f;
  f.camera = scene.make_camera();
  f.integrator = scene.integrator();
  f.seed = scene.render.seed;
  return f;
}

bool same_frame(const FrameSpec& a, const FrameSpec& b) {
  auto same = [](Vec3 x, Vec3 y) { return x.x == y.x && x.y == y.y && x.z == y.z; };
  const Camera &c = a.camera, &d = b.camera;
  return same(c.eye, d.eye) && same(c.forward, d.forward) && same(c.right, d.right) && same(c.up, d.up) &&
         c.width == d.width && c.height == d.height && a.integrator == b.integrator && a.seed == b.seed;
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

}  // namespace pn
