// The GPU backends' tuning knobs (issue 36): for measurements, typed, passed down from the applications in
// BackendOptions::tuning (`--tune KEY=VALUE` on every command that makes a backend, Python's gpu_tuning=).
// One table (gpu_tuning_keys) defines every key once: parsing KEY=VALUE, --help's text, the docs' table
// (docs/guide.md, checked by a test) and bench's JSON come from it. The defaults are today's measured choices:
// a GpuTuning{} renders as penumbra always has. The CPU backend ignores every key.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

namespace pn {

// How the cuda traversal builds its BVH (backends/cuda/bvh_build.h): leaves of up to 8 references (the SAH
// decides), spatial splits and a triangle test costing a node visit.
struct BvhBuildOptions {
  bool spatial_splits = true;  // in the meshes' trees (cuda_splits)
  uint32_t leaf_size = 8;      // most triangle references a leaf, 1..kMaxLeafSize (cuda_leaf)
  float triangle_cost = 1.f;   // the SAH's cost of a triangle test, a node visit's being 1 (cuda_sah_tri)
  bool reinsertion = false;    // each tree optimized by reinsertion after the build (cuda_reinsert)
};

// A queue traced in the order of a key where the scene's rays are long (Auto), always (Ordered) or never (Queue).
enum class OrderMode { Auto, Ordered, Queue };
enum class CudaLoop { Auto, While, IfIf };       // the traversal loop (backends/cuda/trace_forms.h)
enum class CudaBox { Auto, Slab, Fma };          // the box test
enum class OptixLaunch { Grid2d, Linear1d };     // the megakernel's launch shape: W x H, or W*H x 1
enum class OptixSpheres { Custom, Builtin };     // spheres: core/geometry.h's intersection program, or OptiX's

struct GpuTuning {
  // The cuda traversal (backends/cuda): its kernels' occupancy and block size, its BVH, its traversal's forms.
  int cuda_occ = 10;      // resident blocks of 128 threads an SM the trace kernels are compiled for: 0, 10 or 12
  int cuda_block = 128;   // threads a block of the trace kernels (other than 128 only with cuda_occ 0)
  BvhBuildOptions bvh;    // cuda_leaf, cuda_splits, cuda_sah_tri
  CudaLoop cuda_loop = CudaLoop::Auto;
  CudaBox cuda_box = CudaBox::Auto;
  bool cuda_flat = true;  // the flat form where the scene is flat (false: the general form always)
  // The OptiX backend (backends/optix, NOTES.md).
  int optix_maxreg = 0;   // the module's register limit; 0: OptiX's default
  int optix_pixels_per_thread = 1;
  OptixLaunch optix_launch = OptixLaunch::Grid2d;
  OptixSpheres optix_spheres = OptixSpheres::Custom;
  // The wavefront (backends/wavefront, backends/optix/WAVEFRONT.md).
  uint32_t wavefront_paths = 1u << 21;  // the path pool: one slot per pixel of a 1920 x 2048 frame
  OrderMode shadow_order = OrderMode::Auto;
  bool shadow_reverse = false;  // ordered shadow rays traced from the light back (biased: off by default)
  OrderMode ray_order = OrderMode::Auto;
  bool wavefront_fuse = true;   // the trace stage's fused shadow + apply kernel where it offers one
  bool wavefront_film = true;   // a wave holding a whole launch adds into the film directly
  bool wavefront_graph = true;  // each wave's kernels recorded in a CUDA graph (false: launched one by one)
};

// One key of the table.
struct GpuTuningKey {
  const char* key;     // "cuda_loop"
  const char* values;  // the accepted values as the help and the docs show them: "auto, while or ifif"
  const char* help;    // what it does, in a sentence
  // Sets the field from `text`; "" when it is a value, else why not ("must be auto, while or ifif").
  std::string (*parse)(GpuTuning& t, const std::string& text);
  nlohmann::json (*value)(const GpuTuning& t);  // the field as JSON (bench --json)
};

// The table: every key once.
const std::vector<GpuTuningKey>& gpu_tuning_keys();

// Applies one "KEY=VALUE". Throws std::invalid_argument with one line that names the key and the accepted values
// (an unknown key: the keys there are).
void apply_gpu_tuning(GpuTuning& t, const std::string& assignment);
// Applies each assignment in order (a key given twice: the last wins), then checks the keys that go together
// (cuda_block needs cuda_occ 0). Throws std::invalid_argument with one line.
GpuTuning parse_gpu_tuning(const std::vector<std::string>& assignments);

// A key's value in `t` as text ("auto", "10", "true"), as KEY=VALUE accepts it.
std::string gpu_tuning_text(const GpuTuningKey& k, const GpuTuning& t);
// Every key and its value in `t`: {"cuda_occ": 10, "cuda_loop": "auto", ...} (bench --json: the tuning in effect).
nlohmann::json gpu_tuning_json(const GpuTuning& t);
// --tune's help: a line a key ("  cuda_loop = auto, while or ifif (default auto): ...").
std::string gpu_tuning_help();
// The docs' table (docs/guide.md), Markdown: key, values, default, what it does.
std::string gpu_tuning_markdown();

}  // namespace pn
