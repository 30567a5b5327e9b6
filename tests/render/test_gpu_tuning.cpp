// The GPU's tuning knobs (render/gpu_tuning.h): one table of keys, each parsed from KEY=VALUE with its errors
// naming the key; the defaults are the values the GPU code had before they became options; the docs' table is
// the code's.
#include <gtest/gtest.h>

#include <fstream>
#include <map>
#include <set>
#include <sstream>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include "render/gpu_tuning.h"

namespace pn {
namespace {

// The message of the std::invalid_argument that parsing `assignments` throws ("" when it throws none).
std::string error_of(const std::vector<std::string>& assignments) {
  try {
    parse_gpu_tuning(assignments);
  } catch (const std::invalid_argument& e) {
    return e.what();
  }
  return "";
}

// The defaults are the values each knob had when unset (the environment's defaults, before the options).
TEST(GpuTuning, DefaultsAreTheMeasuredChoices) {
  const GpuTuning t;
  EXPECT_EQ(t.cuda_occ, 10);
  EXPECT_EQ(t.cuda_block, 128);
  EXPECT_EQ(t.bvh.leaf_size, 8u);
  EXPECT_TRUE(t.bvh.spatial_splits);
  EXPECT_FLOAT_EQ(t.bvh.triangle_cost, 1.f);
  EXPECT_EQ(t.cuda_loop, CudaLoop::Auto);
  EXPECT_EQ(t.cuda_box, CudaBox::Auto);
  EXPECT_TRUE(t.cuda_flat);
  EXPECT_EQ(t.optix_maxreg, 0);
  EXPECT_EQ(t.optix_pixels_per_thread, 1);
  EXPECT_EQ(t.optix_launch, OptixLaunch::Grid2d);
  EXPECT_EQ(t.optix_spheres, OptixSpheres::Custom);
  EXPECT_EQ(t.wavefront_paths, 1u << 21);
  EXPECT_EQ(t.shadow_order, OrderMode::Auto);
  EXPECT_FALSE(t.shadow_reverse);
  EXPECT_EQ(t.ray_order, OrderMode::Auto);
  EXPECT_TRUE(t.wavefront_fuse);
  EXPECT_TRUE(t.wavefront_film);
  EXPECT_TRUE(t.wavefront_graph);
  EXPECT_EQ(gpu_tuning_json(parse_gpu_tuning({})), gpu_tuning_json(t));
  // Each key's default, as the JSON and the help give it, parses back to the default.
  for (const GpuTuningKey& k : gpu_tuning_keys()) {
    GpuTuning u;
    apply_gpu_tuning(u, std::string(k.key) + "=" + gpu_tuning_text(k, t));
    EXPECT_EQ(gpu_tuning_json(u), gpu_tuning_json(t)) << k.key;
  }
}

// Every key with a good value (that changes it) and a bad one; a key added to the table must be added here.
TEST(GpuTuning, EveryKeyParsesAGoodValueAndNamesItselfForABadOne) {
  const std::map<std::string, std::pair<std::string, std::string>> cases = {
      {"cuda_occ", {"12", "11"}},
      {"cuda_block", {"64", "48"}},
      {"cuda_leaf", {"4", "17"}},
      {"cuda_splits", {"false", "no"}},
      {"cuda_sah_tri", {"2.5", "nan"}},
      {"cuda_reinsert", {"true", "maybe"}},
      {"cuda_loop", {"ifif", "sometimes"}},
      {"cuda_box", {"fma", "FMA"}},
      {"cuda_flat", {"0", "auto"}},
      {"optix_maxreg", {"64", "-1"}},
      {"optix_pixels_per_thread", {"4", "0"}},
      {"optix_launch", {"1d", "3d"}},
      {"optix_spheres", {"builtin", ""}},
      {"wavefront_paths", {"5000", "1023"}},
      {"shadow_order", {"direction", "cells"}},
      {"shadow_reverse", {"1", "yes"}},
      {"ray_order", {"queue", "direction"}},
      {"wavefront_fuse", {"0", "2"}},
      {"wavefront_film", {"false", "off"}},
      {"wavefront_graph", {"0", "0x"}},
  };
  std::set<std::string> keys;
  const GpuTuning defaults;
  for (const GpuTuningKey& k : gpu_tuning_keys()) {
    keys.insert(k.key);
    auto it = cases.find(k.key);
    ASSERT_NE(it, cases.end()) << "no test case for key " << k.key;
    const auto& [good, bad] = it->second;
    // Good: the key's value changes to it, and nothing else does.
    std::vector<std::string> args = {std::string(k.key) + "=" + good};
    if (std::string(k.key) == "cuda_block") args.insert(args.begin(), "cuda_occ=0");
    const GpuTuning t = parse_gpu_tuning(args);
    nlohmann::json changed = gpu_tuning_json(t), before = gpu_tuning_json(defaults);
    EXPECT_NE(changed[k.key], before[k.key]) << k.key << "=" << good;
    if (std::string(k.key) == "cuda_block") changed["cuda_occ"] = before["cuda_occ"];
    changed[k.key] = before[k.key];
    EXPECT_EQ(changed, before) << k.key << "=" << good << " changed another key";
    // Bad: one line that names the key, the value and the accepted values.
    const std::string why = error_of({std::string(k.key) + "=" + bad});
    EXPECT_EQ(why.rfind(std::string(k.key) + " must be ", 0), 0u) << why;
    EXPECT_NE(why.find("'" + bad + "'"), std::string::npos) << why;
    EXPECT_EQ(why.find('\n'), std::string::npos) << why;
  }
  EXPECT_EQ(keys.size(), gpu_tuning_keys().size()) << "a key is in the table twice";
  EXPECT_EQ(keys.size(), cases.size()) << "a test case names no key of the table";
}

TEST(GpuTuning, UnknownKeysAndMalformedAssignmentsFail) {
  std::string why = error_of({"cuda_occupancy=10"});
  EXPECT_NE(why.find("unknown key 'cuda_occupancy'"), std::string::npos) << why;
  EXPECT_NE(why.find("cuda_occ"), std::string::npos) << why;  // the keys there are
  why = error_of({"cuda_occ"});
  EXPECT_NE(why.find("'cuda_occ' is not KEY=VALUE"), std::string::npos) << why;
  why = error_of({"=10"});
  EXPECT_NE(why.find("unknown key ''"), std::string::npos) << why;
  // The values a key accepts are its own: " 12" and "12 " are not 12.
  EXPECT_NE(error_of({"cuda_leaf= 4"}), "");
  EXPECT_NE(error_of({"cuda_sah_tri=2.5x"}), "");
  EXPECT_NE(error_of({"cuda_sah_tri=0"}), "");
  EXPECT_NE(error_of({"wavefront_paths=67108865"}), "");
  EXPECT_EQ(error_of({"wavefront_paths=67108864"}), "");
}

// Keys that go together: another block size needs the kernels compiled for any number of registers; the last of
// a key given twice wins.
TEST(GpuTuning, CombinationsAndRepeats) {
  std::string why = error_of({"cuda_block=64"});
  EXPECT_NE(why.find("cuda_block=64 needs cuda_occ=0"), std::string::npos) << why;
  EXPECT_EQ(error_of({"cuda_block=64", "cuda_occ=0"}), "");
  EXPECT_EQ(error_of({"cuda_block=128", "cuda_occ=12"}), "");
  const GpuTuning t = parse_gpu_tuning({"shadow_order=queue", "shadow_order=direction", "cuda_occ=0"});
  EXPECT_EQ(t.shadow_order, OrderMode::Ordered);
  EXPECT_EQ(t.cuda_occ, 0);
}

// bench --json writes every key with its value; --help lists every key with its values and default.
TEST(GpuTuning, JsonAndHelpHaveEveryKey) {
  const nlohmann::json j = gpu_tuning_json(parse_gpu_tuning({"cuda_loop=while", "wavefront_paths=4096"}));
  EXPECT_EQ(j.size(), gpu_tuning_keys().size());
  EXPECT_EQ(j["cuda_loop"], "while");
  EXPECT_EQ(j["wavefront_paths"], 4096);
  EXPECT_EQ(j["cuda_flat"], true);
  EXPECT_EQ(j["cuda_occ"], 10);
  const std::string help = gpu_tuning_help();
  for (const GpuTuningKey& k : gpu_tuning_keys())
    EXPECT_NE(help.find(std::string("\n  ") + k.key + " = " + k.values + " (default "), std::string::npos) << k.key;
}

// docs/guide.md's table of the keys is the code's (gpu_tuning_markdown), between its two markers.
TEST(GpuTuning, DocsTableIsTheCodesTable) {
  const std::string path = std::string(PENUMBRA_SOURCE_DATA) + "/../docs/guide.md";
  std::ifstream f(path);
  ASSERT_TRUE(f.good()) << path;
  std::stringstream ss;
  ss << f.rdbuf();
  const std::string doc = ss.str();
  const std::string begin = "<!-- gpu-tuning-table: generated, tests/render/test_gpu_tuning.cpp checks it -->\n";
  const std::string end = "<!-- /gpu-tuning-table -->";
  const size_t a = doc.find(begin), b = doc.find(end);
  ASSERT_NE(a, std::string::npos) << path << " has no " << begin;
  ASSERT_NE(b, std::string::npos) << path << " has no " << end;
  ASSERT_LT(a, b);
  EXPECT_EQ(doc.substr(a + begin.size(), b - a - begin.size()), gpu_tuning_markdown())
      << "docs/guide.md's table differs from the code's; the code's is:\n"
      << gpu_tuning_markdown();
}

}  // namespace
}  // namespace pn
