#include "render/gpu_tuning.h"

#include <cctype>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <iterator>
#include <stdexcept>

namespace pn {
namespace {

using json = nlohmann::json;

// A whole number in [lo, hi], all of `text`.
bool whole_number(const std::string& text, long long lo, long long hi, long long* out) {
  if (text.empty() || std::isspace(static_cast<unsigned char>(text[0]))) return false;
  char* end = nullptr;
  errno = 0;
  const long long v = std::strtoll(text.c_str(), &end, 10);
  if (*end != '\0' || errno != 0 || v < lo || v > hi) return false;
  *out = v;
  return true;
}

// true or false, also as 1 or 0.
bool boolean(const std::string& text, bool* out) {
  if (text == "true" || text == "1") return *out = true, true;
  if (text == "false" || text == "0") return *out = false, true;
  return false;
}

// The index of `text` among `names` (-1: none).
int choice(const std::string& text, std::initializer_list<const char*> names) {
  int i = 0;
  for (const char* n : names) {
    if (text == n) return i;
    ++i;
  }
  return -1;
}

constexpr const char* kBool = "true, false, 1 or 0";
constexpr const char* kMustBool = "must be true, false, 1 or 0";

template <bool GpuTuning::*F>
std::string parse_bool(GpuTuning& t, const std::string& text) {
  return boolean(text, &(t.*F)) ? "" : kMustBool;
}
template <bool GpuTuning::*F>
json bool_value(const GpuTuning& t) {
  return t.*F;
}

// An int key in lo..hi.
template <int GpuTuning::*F, int kLo, int kHi>
std::string parse_int(GpuTuning& t, const std::string& text) {
  long long v = 0;
  if (!whole_number(text, kLo, kHi, &v))
    return "must be a whole number in " + std::to_string(kLo) + ".." + std::to_string(kHi);
  t.*F = int(v);
  return "";
}
template <int GpuTuning::*F>
json int_value(const GpuTuning& t) {
  return t.*F;
}

// An enum's keys: kNames[i] names the value E(i).
constexpr const char* kLoopNames[] = {"auto", "while", "ifif"};
constexpr const char* kBoxNames[] = {"auto", "slab", "fma"};
constexpr const char* kLaunchNames[] = {"2d", "1d"};
constexpr const char* kSphereNames[] = {"custom", "builtin"};
constexpr const char* kShadowOrderNames[] = {"auto", "direction", "queue"};  // OrderMode: Ordered is the key's own
constexpr const char* kRayOrderNames[] = {"auto", "cells", "queue"};

template <class E, E GpuTuning::*F, const char* const* kNames, size_t kCount>
std::string parse_enum(GpuTuning& t, const std::string& text) {
  for (size_t i = 0; i < kCount; ++i)
    if (text == kNames[i]) {
      t.*F = E(i);
      return "";
    }
  std::string why = "must be ";
  for (size_t i = 0; i < kCount; ++i) why += std::string(i == 0 ? "" : i + 1 == kCount ? " or " : ", ") + kNames[i];
  return why;
}
template <class E, E GpuTuning::*F, const char* const* kNames, size_t kCount>
json enum_value(const GpuTuning& t) {
  return json(std::string(kNames[size_t(t.*F)]));
}
#define PN_ENUM_KEY(E, field, names) \
  parse_enum<E, &GpuTuning::field, names, std::size(names)>, enum_value<E, &GpuTuning::field, names, std::size(names)>

const std::vector<GpuTuningKey> kKeys = {
    {"cuda_occ", "0, 10 or 12",
     "resident blocks of 128 threads an SM the cuda traversal's trace kernels are compiled for (10: 48 registers; "
     "0: as many as they take, 64, 8 blocks; 12: 40 registers)",
     [](GpuTuning& t, const std::string& s) -> std::string {
       const int i = choice(s, {"0", "10", "12"});
       if (i < 0) return "must be 0, 10 or 12";
       t.cuda_occ = i == 0 ? 0 : i == 1 ? 10 : 12;
       return "";
     },
     [](const GpuTuning& t) { return json(t.cuda_occ); }},
    {"cuda_block", "32..256, a multiple of 32",
     "threads a block of the cuda traversal's trace kernels; other than 128 only with cuda_occ=0 (the kernels for "
     "10 or 12 blocks are compiled for 128)",
     [](GpuTuning& t, const std::string& s) -> std::string {
       long long v = 0;
       if (!whole_number(s, 32, 256, &v) || v % 32 != 0) return "must be a multiple of 32 in 32..256";
       t.cuda_block = int(v);
       return "";
     },
     [](const GpuTuning& t) { return json(t.cuda_block); }},
    {"cuda_leaf", "1..16", "most triangle references a leaf of the cuda traversal's BVH (the SAH decides below it)",
     [](GpuTuning& t, const std::string& s) -> std::string {
       long long v = 0;
       if (!whole_number(s, 1, 16, &v)) return "must be a whole number in 1..16";
       t.bvh.leaf_size = uint32_t(v);
       return "";
     },
     [](const GpuTuning& t) { return json(t.bvh.leaf_size); }},
    {"cuda_splits", kBool, "spatial splits in the cuda traversal's BVHs of meshes",
     [](GpuTuning& t, const std::string& s) -> std::string {
       return boolean(s, &t.bvh.spatial_splits) ? "" : kMustBool;
     },
     [](const GpuTuning& t) { return json(t.bvh.spatial_splits); }},
    {"cuda_sah_tri", "a number in (0, 100]", "the BVH build's SAH cost of a triangle test, a node visit's being 1",
     [](GpuTuning& t, const std::string& s) -> std::string {
       char* end = nullptr;
       const float v = s.empty() || std::isspace(static_cast<unsigned char>(s[0])) ? 0.f : std::strtof(s.c_str(), &end);
       if (!end || *end != '\0' || !(v > 0.f && v <= 100.f)) return "must be a number in (0, 100]";
       t.bvh.triangle_cost = v;
       return "";
     },
     [](const GpuTuning& t) { return json(double(t.bvh.triangle_cost)); }},
    {"cuda_reinsert", kBool,
     "the cuda traversal's BVHs optimized by reinsertion after the build (Bittner et al. 2013): fewer node visits, "
     "a longer build",
     [](GpuTuning& t, const std::string& s) -> std::string {
       return boolean(s, &t.bvh.reinsertion) ? "" : kMustBool;
     },
     [](const GpuTuning& t) { return json(t.bvh.reinsertion); }},
    {"cuda_loop", "auto, while or ifif",
     "the cuda traversal's loop: auto is if-if where the scene's rays visit at least 24 nodes, else while-while",
     PN_ENUM_KEY(CudaLoop, cuda_loop, kLoopNames)},
    {"cuda_box", "auto, slab or fma",
     "the cuda traversal's box test: auto is the one-FMA test for shadow rays in flat scenes; fma for every ray; "
     "slab (subtract-multiply) for every ray",
     PN_ENUM_KEY(CudaBox, cuda_box, kBoxNames)},
    {"cuda_flat", kBool, "the cuda traversal's flat form where the scene is flat (false: the general form always)",
     parse_bool<&GpuTuning::cuda_flat>, bool_value<&GpuTuning::cuda_flat>},
    {"optix_maxreg", "0..255", "the OptiX module's register limit (0: OptiX's default)",
     parse_int<&GpuTuning::optix_maxreg, 0, 255>, int_value<&GpuTuning::optix_maxreg>},
    {"optix_pixels_per_thread", "1..1024",
     "pixels a thread of the megakernel's launch (above 1: a 1D launch, each thread looping over its pixels)",
     parse_int<&GpuTuning::optix_pixels_per_thread, 1, 1024>, int_value<&GpuTuning::optix_pixels_per_thread>},
    {"optix_launch", "2d or 1d", "the megakernel's launch shape: W x H, or W*H x 1",
     PN_ENUM_KEY(OptixLaunch, optix_launch, kLaunchNames)},
    {"optix_spheres", "custom or builtin",
     "how OptiX intersects spheres: custom (core/geometry.h in an intersection program) or builtin (OptiX's "
     "sphere primitives)",
     PN_ENUM_KEY(OptixSpheres, optix_spheres, kSphereNames)},
    {"wavefront_paths", "1024..67108864",
     "the wavefront's pool of paths: a launch runs as waves of at most this many (2^21: 1080p at one "
     "sample a pixel in one wave)",
     [](GpuTuning& t, const std::string& s) -> std::string {
       long long v = 0;
       if (!whole_number(s, 1024, 1ll << 26, &v)) return "must be a number of paths in 1024..67108864";
       t.wavefront_paths = uint32_t(v);
       return "";
     },
     [](const GpuTuning& t) { return json(t.wavefront_paths); }},
    {"shadow_order", "auto, direction or queue",
     "the wavefront's shadow rays traced in direction order: auto where the scene's rays visit at least 24 "
     "nodes (with the fused shadow stage only)",
     PN_ENUM_KEY(OrderMode, shadow_order, kShadowOrderNames)},
    {"shadow_reverse", kBool,
     "ordered shadow rays traced from the light back (faster on Sponza, and biased there: DEVELOPERS.md)",
     parse_bool<&GpuTuning::shadow_reverse>, bool_value<&GpuTuning::shadow_reverse>},
    {"ray_order", "auto, cells or queue",
     "the wavefront's bounce rays traced in direction and origin cell order: auto where the scene's rays visit "
     "at least 24 nodes (the cuda trace stage only)",
     PN_ENUM_KEY(OrderMode, ray_order, kRayOrderNames)},
    {"wavefront_fuse", kBool,
     "the cuda stage's shadow rays traced and applied by one kernel (false: two kernels, as the optix stage's)",
     parse_bool<&GpuTuning::wavefront_fuse>, bool_value<&GpuTuning::wavefront_fuse>},
    {"wavefront_film", kBool,
     "a wave that holds a whole launch adds into the film itself (false: through the launch sums and "
     "launch_accumulate)",
     parse_bool<&GpuTuning::wavefront_film>, bool_value<&GpuTuning::wavefront_film>},
    {"wavefront_graph", kBool,
     "each wave's kernels recorded once in a CUDA graph and replayed (false: launched one by one)",
     parse_bool<&GpuTuning::wavefront_graph>, bool_value<&GpuTuning::wavefront_graph>},
};

std::string key_list() {
  std::string s;
  for (const GpuTuningKey& k : kKeys) s += std::string(s.empty() ? "" : ", ") + k.key;
  return s;
}

#undef PN_ENUM_KEY

}  // namespace

const std::vector<GpuTuningKey>& gpu_tuning_keys() { return kKeys; }

void apply_gpu_tuning(GpuTuning& t, const std::string& assignment) {
  const size_t eq = assignment.find('=');
  if (eq == std::string::npos)
    throw std::invalid_argument("'" + assignment + "' is not KEY=VALUE (keys: " + key_list() + ")");
  const std::string key = assignment.substr(0, eq), value = assignment.substr(eq + 1);
  for (const GpuTuningKey& k : kKeys)
    if (key == k.key) {
      const std::string why = k.parse(t, value);
      if (!why.empty()) throw std::invalid_argument(key + " " + why + ", not '" + value + "'");
      return;
    }
  throw std::invalid_argument("unknown key '" + key + "' (keys: " + key_list() + ")");
}

GpuTuning parse_gpu_tuning(const std::vector<std::string>& assignments) {
  GpuTuning t;
  for (const std::string& a : assignments) apply_gpu_tuning(t, a);
  if (t.cuda_block != 128 && t.cuda_occ != 0)
    throw std::invalid_argument("cuda_block=" + std::to_string(t.cuda_block) + " needs cuda_occ=0 (the kernels for " +
                                std::to_string(t.cuda_occ) + " resident blocks an SM are compiled for 128 threads)");
  return t;
}

std::string gpu_tuning_text(const GpuTuningKey& k, const GpuTuning& t) {
  const json v = k.value(t);
  if (v.is_string()) return v.get<std::string>();
  if (v.is_number_float()) {
    char buf[32];
    std::snprintf(buf, sizeof buf, "%g", v.get<double>());
    return buf;
  }
  return v.dump();
}

json gpu_tuning_json(const GpuTuning& t) {
  json j = json::object();
  for (const GpuTuningKey& k : kKeys) j[k.key] = k.value(t);
  return j;
}

std::string gpu_tuning_help() {
  const GpuTuning defaults;
  std::string s;
  for (const GpuTuningKey& k : kKeys)
    s += std::string("\n  ") + k.key + " = " + k.values + " (default " + gpu_tuning_text(k, defaults) + "): " + k.help;
  return s;
}

std::string gpu_tuning_markdown() {
  const GpuTuning defaults;
  std::string s = "| key | values | default | what it does |\n| --- | --- | --- | --- |\n";
  for (const GpuTuningKey& k : kKeys)
    s += std::string("| `") + k.key + "` | " + k.values + " | `" + gpu_tuning_text(k, defaults) + "` | " + k.help +
         " |\n";
  return s;
}

}  // namespace pn
