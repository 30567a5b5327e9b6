// Model files (OBJ + MTL, glTF 2.0) and the scene keys that place them: real
// files made by others (Debian's assimp-testmodels; skipped when absent), small
// files made for these tests (tests/data), and bad input, which must end in a
// one-line SceneError naming the file or load with a warning, never crash.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <random>
#include <sstream>

#include "apps/environment.h"
#include "render/backend.h"
#include "apps/converge.h"
#include "backends/make_backend.h"
#include "scene/scene.h"

namespace pn {
namespace {

namespace fs = std::filesystem;
using json = nlohmann::json;
const std::string kData = PENUMBRA_TEST_DATA;

// The test binary reads $PENUMBRA_SCENES and $PENUMBRA_DATA as the applications do (apps/environment.h), once,
// before any test: where the scenes' data is elsewhere, the built-in scenes' tests find it as `penumbra` would.
class SceneSearchFromEnvironment : public ::testing::Environment {
 public:
  void SetUp() override { set_scene_search(scene_search_from_environment()); }
};
::testing::Environment* const kSceneSearch = ::testing::AddGlobalTestEnvironment(new SceneSearchFromEnvironment);
const std::string kAssimp = "/usr/share/assimp/models";

// A scene placing one model file, with a camera (unless `camera` is false) and a light.
json model_scene(const std::string& file, bool camera = true, json model_extra = json::object()) {
  json m = {{"file", file}};
  for (auto it = model_extra.begin(); it != model_extra.end(); ++it) m[it.key()] = it.value();
  json doc = {{"render", {{"width", 8}, {"height", 6}, {"spp", 2}, {"max_depth", 3}}},
              {"models", json::array({m})},
              {"lights", json::array({{{"type", "sphere"}, {"center", {0, 50, 30}}, {"radius", 1}, {"power", 1000}}})}};
  if (camera) doc["camera"] = {{"eye", {0, 1, 6}}, {"target", {0, 0, 0}}};
  return doc;
}

// A file of assimp-testmodels, or "" (and the test is skipped).
std::string assimp(const std::string& rel) {
  std::string p = kAssimp + "/" + rel;
  std::error_code ec;
  return fs::is_regular_file(p, ec) ? p : std::string();
}
#define REQUIRE_ASSIMP(var, rel)                                                                        \
  const std::string var = assimp(rel);                                                                  \
  if (var.empty()) GTEST_SKIP() << "assimp-testmodels is not installed (no " << kAssimp << "/" << rel \
                                << "): apt-get install assimp-testmodels"

void render_tiny(const Scene& s) {
  std::string note;
  auto backend = make_backend("cpu", s, BackendOptions{1}, &note);
  Film film(s.render.width, s.render.height);
  backend->render(frame_spec(s), film, 0, 1);
  for (float v : film.mean()) ASSERT_TRUE(std::isfinite(v));
}

// World-space bounds of every instance.
std::pair<Vec3, Vec3> world_bounds(const Scene& s) {
  Vec3 lo(kInf), hi(-kInf);
  for (const Instance& inst : s.instances)
    for (const auto& tri : s.meshes[inst.mesh].indices)
      for (uint32_t i : tri) {
        Vec3 p = inst.to_world.point(s.meshes[inst.mesh].positions[i]);
        lo = vmin(lo, p);
        hi = vmax(hi, p);
      }
  return {lo, hi};
}

void expect_near3(Vec3 a, Vec3 b, float tol, const std::string& what) {
  EXPECT_NEAR(a.x, b.x, tol) << what;
  EXPECT_NEAR(a.y, b.y, tol) << what;
  EXPECT_NEAR(a.z, b.z, tol) << what;
}

// A material of the model by the name penumbra gives it ("<file>/<name>").
const Material* find_material(const Scene& s, const std::string& name) {
  for (size_t i = 0; i < s.material_names.size(); ++i)
    if (s.material_names[i] == name) return &s.materials[i];
  return nullptr;
}

void expect_scene_error(const json& doc, const std::string& names, const std::string& what = "") {
  try {
    Scene s = parse_scene(doc, "m.json", kData);
    ADD_FAILURE() << "accepted: " << doc.dump();
  } catch (const SceneError& e) {
    std::string msg = e.what();
    EXPECT_EQ(msg.rfind("m.json: ", 0), 0u) << msg;
    EXPECT_NE(msg.find(names), std::string::npos) << msg;
    if (!what.empty()) {
      EXPECT_NE(msg.find(what), std::string::npos) << msg;
    }
    EXPECT_EQ(msg.find('\n'), std::string::npos) << msg;
  }
}

// --- Real files (assimp-testmodels) ----------------------------------------------------

TEST(Models, GltfWithExternalTexture) {
  REQUIRE_ASSIMP(path, "glTF2/BoxTextured-glTF/BoxTextured.gltf");
  Scene s = parse_scene(model_scene(path), "m.json", kData);
  EXPECT_TRUE(s.warnings.empty()) << s.warnings[0];
  ASSERT_EQ(s.instances.size(), 1u);
  EXPECT_EQ(s.triangle_count(), 12u);  // 36 indices
  const TriangleMesh& m = s.meshes[s.instances[0].mesh];
  EXPECT_EQ(m.face_materials.size(), 12u);
  EXPECT_EQ(m.uvs.size(), m.positions.size());
  EXPECT_EQ(m.normals.size(), m.positions.size());
  const Material* mat = find_material(s, "BoxTextured.gltf/Texture");
  ASSERT_NE(mat, nullptr);
  EXPECT_EQ(mat->metallic, 0.f);     // metallicFactor 0
  EXPECT_EQ(mat->roughness, 1.f);    // default
  EXPECT_EQ(mat->specular, 0.5f);    // F0 0.04
  ASSERT_GE(mat->base_color_tex, 0);
  const TextureImage& t = s.textures[size_t(mat->base_color_tex)];
  EXPECT_EQ(t.format, TexelFormat::Rgba8Srgb);
  EXPECT_GT(t.width, 0);
  EXPECT_EQ(t.texels.size(), size_t(t.width) * t.height * 4);
  // The root node's matrix turns the unit cube's y into z: still the unit cube.
  auto [lo, hi] = world_bounds(s);
  expect_near3(lo, Vec3(-0.5f), 1e-5f, "lo");
  expect_near3(hi, Vec3(0.5f), 1e-5f, "hi");
  render_tiny(s);
}

TEST(Models, GlbWithEmbeddedTextureMatchesGltf) {
  REQUIRE_ASSIMP(glb, "glTF2/BoxTextured-glTF-Binary/BoxTextured.glb");
  REQUIRE_ASSIMP(gltf, "glTF2/BoxTextured-glTF/BoxTextured.gltf");
  Scene a = parse_scene(model_scene(glb), "m.json", kData);
  Scene b = parse_scene(model_scene(gltf), "m.json", kData);
  ASSERT_EQ(a.textures.size(), 1u);
  EXPECT_NE(a.textures[0].path.find("#image"), std::string::npos) << a.textures[0].path;
  ASSERT_EQ(b.textures.size(), 1u);
  EXPECT_EQ(a.textures[0].width, b.textures[0].width);
  EXPECT_EQ(a.textures[0].texels, b.textures[0].texels);  // the same PNG, embedded or beside
  EXPECT_EQ(a.triangle_count(), b.triangle_count());
}

TEST(Models, GltfNodeHierarchyIsInstancedNotFlattened) {
  REQUIRE_ASSIMP(path, "glTF2/2CylinderEngine-glTF-Binary/2CylinderEngine.glb");
  // Mesh nodes, counted from the file's own JSON chunk.
  std::ifstream in(path, std::ios::binary);
  std::vector<char> bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  uint32_t json_len = 0;
  std::memcpy(&json_len, bytes.data() + 12, 4);
  json doc = json::parse(std::string(bytes.data() + 20, json_len));
  size_t mesh_nodes = 0;
  for (const auto& n : doc["nodes"]) mesh_nodes += n.contains("mesh");
  ASSERT_GT(mesh_nodes, 20u);

  Scene s = parse_scene(model_scene(path), "m.json", kData);
  EXPECT_EQ(s.instances.size(), mesh_nodes);
  EXPECT_LE(s.meshes.size(), doc["meshes"].size());  // meshes shared by nodes are stored once
  EXPECT_LT(s.meshes.size(), s.instances.size());
  // The model transform composes with the hierarchy: scale 2 and a shift double and move the bounds.
  auto [lo, hi] = world_bounds(s);
  Scene t = parse_scene(model_scene(path, true, {{"transform", {{"scale", 2}, {"translate", {10, 0, 0}}}}}), "m.json", kData);
  auto [lo2, hi2] = world_bounds(t);
  const float tol = 1e-4f * length(hi - lo);
  expect_near3(lo2, lo * 2.f + Vec3(10.f, 0.f, 0.f), tol, "lo");
  expect_near3(hi2, hi * 2.f + Vec3(10.f, 0.f, 0.f), tol, "hi");
  // Several placements share the meshes: the file is loaded once.
  Scene u = parse_scene(model_scene(path, true, {{"transforms", json::array({{{"translate", {0, 0, 0}}}, {{"translate", {0, 500, 0}}}})}}),
                        "m.json", kData);
  EXPECT_EQ(u.meshes.size(), s.meshes.size());
  EXPECT_EQ(u.instances.size(), 2 * mesh_nodes);
}

TEST(Models, GltfCameraUsedWhenTheSceneHasNone) {
  REQUIRE_ASSIMP(path, "glTF2/cameras/Cameras.gltf");
  Scene s = parse_scene(model_scene(path, /*camera=*/false), "m.json", kData);
  expect_near3(s.camera.eye, Vec3(0.5f, 0.5f, 3.f), 1e-5f, "eye");
  expect_near3(s.camera.target - s.camera.eye, Vec3(0.f, 0.f, -1.f), 1e-5f, "view direction");
  EXPECT_NEAR(s.camera.fov, 0.7 * 180.0 / kPi, 1e-3);
  // A scene's own camera wins.
  Scene t = parse_scene(model_scene(path, true), "m.json", kData);
  expect_near3(t.camera.eye, Vec3(0.f, 1.f, 6.f), 0.f, "scene camera");
}

TEST(Models, ObjMtlWithTexturesNormalsAndUvs) {
  REQUIRE_ASSIMP(path, "OBJ/spider.obj");
  Scene s = parse_scene(model_scene(path), "m.json", kData);
  ASSERT_EQ(s.instances.size(), 1u);
  const TriangleMesh& m = s.meshes[s.instances[0].mesh];
  EXPECT_GT(m.indices.size(), 1000u);
  EXPECT_EQ(m.face_materials.size(), m.indices.size());
  EXPECT_EQ(m.uvs.size(), m.positions.size());
  EXPECT_EQ(m.normals.size(), m.positions.size());
  // The four materials its faces use each have a JPEG named with Windows separators (".\\x.jpg"), all found.
  EXPECT_EQ(s.textures.size(), 4u);
  const Material* skin = find_material(s, "spider.obj/Skin");
  ASSERT_NE(skin, nullptr);
  EXPECT_NEAR(skin->base_color.x, 0.827451f, 1e-5f);
  EXPECT_GE(skin->base_color_tex, 0);
  EXPECT_EQ(skin->specular, 0.f);     // Ks 0
  EXPECT_EQ(skin->metallic, 0.f);
  EXPECT_NEAR(skin->roughness, 1.f, 1e-6f);  // Ns 0: alpha 1
  for (const std::string& w : s.warnings) EXPECT_EQ(w.find("texture"), std::string::npos) << w;
  render_tiny(s);
}

// --- Small files made for the tests ------------------------------------------------------

TEST(Models, TinyGltfAndGlbHierarchyCameraMaterial) {
  for (const char* f : {"tiny.gltf", "tiny.glb"}) {
    Scene s = parse_scene(model_scene(f, /*camera=*/false), "m.json", kData);
    EXPECT_TRUE(s.warnings.empty()) << f << ": " << s.warnings[0];
    ASSERT_EQ(s.instances.size(), 2u) << f;
    EXPECT_EQ(s.meshes.size(), 1u) << f;
    EXPECT_EQ(s.triangle_count(), 4u) << f;
    auto [lo, hi] = world_bounds(s);  // (1,0,0) + 2 x unit quad, and (0,3,0) + unit quad
    expect_near3(lo, Vec3(0.f, 0.f, 0.f), 1e-6f, f);
    expect_near3(hi, Vec3(3.f, 4.f, 0.f), 1e-6f, f);
    expect_near3(s.camera.eye, Vec3(0.f, 0.f, 5.f), 1e-6f, f);
    EXPECT_NEAR(s.camera.fov, 0.8 * 180.0 / kPi, 1e-3);
    const Material* m = find_material(s, std::string(f) + "/red");
    ASSERT_NE(m, nullptr) << f;
    expect_near3(m->base_color, Vec3(0.8f, 0.1f, 0.1f), 1e-6f, f);
    EXPECT_FLOAT_EQ(m->metallic, 0.25f);
    EXPECT_FLOAT_EQ(m->roughness, 0.5f);
    EXPECT_EQ(m->alpha_mode, AlphaMode::Mask);
    EXPECT_FLOAT_EQ(m->alpha_cutoff, 0.3f);
    render_tiny(s);
  }
}

TEST(Models, ObjMissingTextureWarnsAndFallsBack) {
  Scene s = parse_scene(model_scene("tiny_textured.obj"), "m.json", kData);
  ASSERT_EQ(s.instances.size(), 1u);
  EXPECT_EQ(s.triangle_count(), 3u);  // the degenerate face is dropped
  const TriangleMesh& m = s.meshes[s.instances[0].mesh];
  // Vertices split where (v, vt, vn) differ; OBJ's v up becomes image v down.
  ASSERT_EQ(m.uvs.size(), m.positions.size());
  EXPECT_FLOAT_EQ(m.uvs[0].y, 1.f);  // vt 0 0 -> image (0, 1)
  const Material* present = find_material(s, "tiny_textured.obj/present");
  const Material* missing = find_material(s, "tiny_textured.obj/missing");
  ASSERT_TRUE(present && missing);
  ASSERT_GE(present->base_color_tex, 0);
  EXPECT_NEAR(present->specular, 0.04f / 0.08f, 1e-6f);
  EXPECT_NEAR(present->roughness, std::sqrt(std::sqrt(2.f / 102.f)), 1e-6f);
  const TextureImage& t = s.textures[size_t(present->base_color_tex)];
  ASSERT_EQ(t.width, 4);
  EXPECT_EQ(t.texels[0], 255);  // row 0 is the top: the red texel
  EXPECT_EQ(t.texels[1], 0);
  EXPECT_EQ(missing->base_color_tex, -1);
  expect_near3(missing->base_color, Vec3(0.2f, 0.4f, 0.6f), 1e-6f, "fallback colour");
  EXPECT_EQ(missing->alpha_mode, AlphaMode::Mask);  // d 0.25
  bool named = false;
  for (const std::string& w : s.warnings) named = named || w.find("no_such_texture.png") != std::string::npos;
  EXPECT_TRUE(named) << (s.warnings.empty() ? "no warnings" : s.warnings[0]);
  render_tiny(s);
}

TEST(Models, MissingMtlWarnsAndUsesGrey) {
  fs::path dir = fs::temp_directory_path() / "penumbra_models_mtl";
  fs::create_directories(dir);
  std::ofstream(dir / "a.obj") << "mtllib gone.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nusemtl x\nf 1 2 3\n";
  Scene s = parse_scene(model_scene((dir / "a.obj").string()), "m.json", kData);
  EXPECT_EQ(s.triangle_count(), 1u);
  ASSERT_FALSE(s.warnings.empty());
  EXPECT_NE(find_material(s, "a.obj/(default)"), nullptr);
  render_tiny(s);
}

TEST(Models, MaterialOverrideAndMaterialTextures) {
  json doc = model_scene("tiny.gltf", true, {{"material", "m"}});
  doc["materials"] = {{"m", {{"base_color", 0.5}, {"metallic", 0}, {"base_color_texture", "checker.bmp"},
                             {"normal_texture", "nothing_here.png"}}}};
  Scene s = parse_scene(doc, "m.json", kData);
  for (const Instance& inst : s.instances) {
    EXPECT_TRUE(s.meshes[inst.mesh].face_materials.empty());
    EXPECT_EQ(s.material_names[inst.material], "m");
  }
  const Material& m = s.materials[s.instances[0].material];
  EXPECT_GE(m.base_color_tex, 0);
  EXPECT_EQ(m.normal_tex, -1);
  ASSERT_EQ(s.warnings.size(), 1u);
  EXPECT_NE(s.warnings[0].find("materials.m.normal_texture"), std::string::npos) << s.warnings[0];
  EXPECT_NE(s.warnings[0].find("nothing_here.png"), std::string::npos) << s.warnings[0];
  render_tiny(s);
}

TEST(Models, EnvironmentFromHdr) {
  json doc = model_scene("tiny.gltf");
  doc["environment"] = {{"file", std::string(PENUMBRA_SOURCE_DATA) + "/sky.hdr"}, {"rotation", 90}, {"intensity", {1, 2, 3}}};
  Scene s = parse_scene(doc, "m.json", kData);
  ASSERT_GE(s.environment.texture, 0);
  const TextureImage& t = s.textures[size_t(s.environment.texture)];
  EXPECT_EQ(t.format, TexelFormat::Rgba32f);
  EXPECT_TRUE(t.nearest);
  EXPECT_EQ(t.width, 2 * t.height);
  EXPECT_EQ(s.environment.rotation, 90.f);
  expect_near3(s.environment.scale, Vec3(1.f, 2.f, 3.f), 0.f, "intensity");
  EXPECT_GT(s.environment.distribution.integral, 0.f);
  EXPECT_EQ(s.lights.back().type, LightType::Environment);
  render_tiny(s);
  json bad = model_scene("tiny.gltf");
  bad["environment"] = {{"file", "checker.hdr"}};
  expect_scene_error(bad, "environment.file", "checker.hdr");
}

// --- Bad input ----------------------------------------------------------------------------

// Writes `text` as `name` in a fresh temp folder and returns its path.
std::string temp_file(const std::string& name, const std::string& text) {
  fs::path dir = fs::temp_directory_path() / "penumbra_models_bad";
  fs::create_directories(dir);
  std::ofstream(dir / name, std::ios::binary) << text;
  return (dir / name).string();
}

std::string read_text(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

TEST(Models, BadFilesGiveOneLineErrorsNamingTheFile) {
  // Out-of-range and malformed OBJ.
  expect_scene_error(model_scene("bad_index.obj"), "bad_index.obj", "out of range");
  expect_scene_error(model_scene(temp_file("empty.obj", "# nothing\n")), "empty.obj", "no");
  expect_scene_error(model_scene("does_not_exist.gltf"), "does_not_exist.gltf", "does not exist");
  expect_scene_error(model_scene("checker.bmp"), "checker.bmp", "unknown format");
  // Truncated and malformed glTF.
  std::string gltf = read_text(kData + "/tiny.gltf");
  expect_scene_error(model_scene(temp_file("trunc.gltf", gltf.substr(0, gltf.size() / 2))), "trunc.gltf");
  std::string glb = read_text(kData + "/tiny.glb");
  expect_scene_error(model_scene(temp_file("trunc.glb", glb.substr(0, glb.size() - 40))), "trunc.glb");
  // An accessor claiming 2^31 elements, and one reaching past its buffer view.
  json g = json::parse(gltf);
  g["accessors"][3]["count"] = 2147483648ull;
  expect_scene_error(model_scene(temp_file("huge.gltf", g.dump())), "huge.gltf", "elements");
  g = json::parse(gltf);
  g["accessors"][0]["count"] = 400;
  expect_scene_error(model_scene(temp_file("long.gltf", g.dump())), "long.gltf", "bufferView");
  // Out-of-range indices.
  g = json::parse(gltf);
  g["accessors"][0]["count"] = 2;
  g["meshes"][0]["primitives"][0]["attributes"] = {{"POSITION", 0}};
  expect_scene_error(model_scene(temp_file("index.gltf", g.dump())), "index.gltf", "out of range");
  // A cycle in the node hierarchy.
  g = json::parse(gltf);
  g["nodes"][1]["children"] = {0};
  expect_scene_error(model_scene(temp_file("cycle.gltf", g.dump())), "cycle.gltf", "cycle");
  // Only non-triangle primitives: skipped with a warning, and then nothing is left.
  g = json::parse(gltf);
  g["meshes"][0]["primitives"][0]["mode"] = 1;
  expect_scene_error(model_scene(temp_file("lines.gltf", g.dump())), "lines.gltf", "triangle");
  // A missing texture in glTF: a warning, then the factor alone.
  g = json::parse(gltf);
  g["images"] = {{{"uri", "missing.png"}}};
  g["textures"] = {{{"source", 0}}};
  g["materials"][0]["pbrMetallicRoughness"]["baseColorTexture"] = {{"index", 0}};
  Scene s = parse_scene(model_scene(temp_file("notex.gltf", g.dump())), "m.json", kData);
  ASSERT_FALSE(s.warnings.empty());
  EXPECT_NE(s.warnings[0].find("missing.png"), std::string::npos) << s.warnings[0];
  render_tiny(s);
  // Degenerate triangles are dropped, with a warning.
  g = json::parse(gltf);
  g["accessors"][3]["count"] = 6;
  Scene d = parse_scene(model_scene(temp_file("degenerate.gltf", g.dump())), "m.json", kData);
  EXPECT_EQ(d.triangle_count(), 4u);
  REQUIRE_ASSIMP(oor, "glTF2/IndexOutOfRange/IndexOutOfRange.gltf");
  expect_scene_error(model_scene(oor), "IndexOutOfRange.gltf", "out of range");
  REQUIRE_ASSIMP(rec, "glTF2/RecursiveNodes/RecursiveNodes.gltf");
  expect_scene_error(model_scene(rec), "RecursiveNodes.gltf", "cycle");
  REQUIRE_ASSIMP(inf, "glTF2/BoxWithInfinites-glTF-Binary/BoxWithInfinites.glb");
  expect_scene_error(model_scene(inf), "BoxWithInfinites.glb", "non-finite");
  REQUIRE_ASSIMP(mal, "invalid/malformed.obj");
  try {
    Scene m = parse_scene(model_scene(mal), "m.json", kData);
  } catch (const SceneError& e) {
    EXPECT_NE(std::string(e.what()).find("malformed.obj"), std::string::npos) << e.what();
  }
}

// Fuzz-style: byte flips, insertions and truncations of small OBJ, glTF and GLB
// files. Each must load (and render a tiny image with finite values) or fail
// with a one-line SceneError naming the scene; a crash or a sanitizer report
// fails the test.
TEST(Models, FuzzedModelFilesNeverCrash) {
  std::mt19937 gen(4242);
  fs::path dir = fs::temp_directory_path() / "penumbra_models_fuzz";
  fs::create_directories(dir);
  fs::copy_file(kData + "/checker.bmp", dir / "checker.bmp", fs::copy_options::overwrite_existing);
  fs::copy_file(kData + "/tiny_textured.mtl", dir / "tiny_textured.mtl", fs::copy_options::overwrite_existing);
  const std::vector<std::pair<std::string, std::string>> seeds = {
      {"f.obj", read_text(kData + "/tiny_textured.obj")},
      {"f.gltf", read_text(kData + "/tiny.gltf")},
      {"f.glb", read_text(kData + "/tiny.glb")},
  };
  const std::vector<std::string> tokens = {"-1", "0", "1e39", "nan", "4294967295", "2147483648", "65535", "\"\"",
                                           "[]", "{}", "/", "//", " 0/0/0", "-2147483648", "null", "999999999999"};
  int loaded = 0, rejected = 0;
  for (int iter = 0; iter < 1200; ++iter) {
    const auto& [name, seed] = seeds[size_t(iter) % seeds.size()];
    std::string text = seed;
    int edits = 1 + gen() % 3;
    for (int e = 0; e < edits && !text.empty(); ++e) {
      size_t pos = gen() % text.size();
      switch (gen() % 5) {
        case 0: text.erase(pos, 1 + gen() % 8); break;
        case 1: text[pos] = char(gen() % 256); break;
        case 2: text.insert(pos, tokens[gen() % tokens.size()]); break;
        case 3: text = text.substr(0, pos); break;
        default: {
          size_t d = text.find_first_of("0123456789", pos);
          if (d != std::string::npos) text.replace(d, 1, tokens[gen() % tokens.size()]);
        }
      }
    }
    const std::string path = (dir / name).string();
    std::ofstream(path, std::ios::binary | std::ios::trunc) << text;
    try {
      Scene s = parse_scene(model_scene(path), "fuzz.json", dir.string());
      render_tiny(s);
      ++loaded;
    } catch (const SceneError& e) {
      ASSERT_EQ(std::string(e.what()).rfind("fuzz.json: ", 0), 0u) << e.what();
      ASSERT_EQ(std::string(e.what()).find('\n'), std::string::npos) << e.what();
      ++rejected;
    }
  }
  EXPECT_GT(loaded, 50);
  EXPECT_GT(rejected, 50);
}

// --- Built-in scenes with models ----------------------------------------------------------

// The applications' folder of scene data is searched first, before the defaults, which stay; converge's default
// cache follows the XDG convention from the values the applications pass.
TEST(Models, SceneSearchComesFirstAndTheCacheFollowsXdg) {
  const SceneSearch saved = scene_search();
  set_scene_search({"/nonexistent/scenes", "/nonexistent/data"});
  const std::vector<std::string> roots = scene_data_roots();
  ASSERT_GE(roots.size(), 3u);
  EXPECT_EQ(roots.front(), "/nonexistent/scenes");
  set_scene_search(SceneSearch());
  EXPECT_EQ(scene_data_roots().size(), roots.size() - 1);
  EXPECT_EQ(scene_data_roots().front(), roots[1]);
  set_scene_search(saved);
  EXPECT_EQ(default_cache_dir("/xdg", "/home/u"), "/xdg/penumbra");
  EXPECT_EQ(default_cache_dir("", "/home/u"), "/home/u/.cache/penumbra");
  EXPECT_EQ(default_cache_dir("", ""), ".penumbra-cache");
}

TEST(Models, BuiltinScenesWithModels) {
  for (const char* name : {"sponza", "bunnies", "glossy"}) {
    Scene s;
    try {
      s = load_scene(name);
    } catch (const SceneError& e) {
      std::string msg = e.what();
      // Absent data: one line naming the file, the folders tried and the script that downloads it.
      EXPECT_NE(msg.find(" not found in "), std::string::npos) << msg;
      EXPECT_NE(msg.find("$PENUMBRA_SCENES"), std::string::npos) << msg;  // absent data: says how to point at it
      EXPECT_NE(msg.find(": run scripts/fetch-scenes.sh"), std::string::npos) << msg;
      EXPECT_EQ(msg.find('\n'), std::string::npos) << msg;
      std::printf("[ SKIPPED  ] %s: %s\n", name, msg.c_str());
      continue;
    }
    EXPECT_EQ(s.render.width, 1920) << name;
    EXPECT_EQ(s.render.height, 1080) << name;
    EXPECT_EQ(s.render.spp, 64) << name;
    EXPECT_TRUE(s.warnings.empty()) << name << ": " << s.warnings[0];
    EXPECT_EQ(s.lights[0].type, LightType::Sphere) << name;
    if (std::string(name) == "sponza") {
      EXPECT_EQ(s.triangle_count(), 66445u);
      EXPECT_EQ(s.textures.size(), 10u);
    }
    if (std::string(name) == "bunnies") {
      EXPECT_GT(s.triangle_count(), 20000000u);     // placed
      EXPECT_LT(s.meshes.size(), 4u);               // stored: the bunny (plain copy) and the ground
    }
    if (std::string(name) == "glossy") {
      EXPECT_GE(s.environment.texture, 0);
      EXPECT_EQ(s.lights.back().type, LightType::Environment);
    }
  }
}

}  // namespace
}  // namespace pn
