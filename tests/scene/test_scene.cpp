// Scene files: the format, overrides, and what bad input must produce: a
// SceneError whose one-line message names the file and the field.
#include <gtest/gtest.h>

#include <fstream>
#include <random>

#include "backends/make_backend.h"
#include "render/backend.h"
#include "scene/scene.h"

namespace pn {
namespace {

using json = nlohmann::json;
const std::string kData = PENUMBRA_TEST_DATA;

json minimal() {
  return json::parse(R"({
    "camera": {"eye": [0, 0, -3], "target": [0, 0, 0], "fov": 40},
    "render": {"width": 8, "height": 8, "spp": 2},
    "materials": {"white": {"albedo": [0.5, 0.5, 0.5]}},
    "shapes": [{"type": "sphere", "center": [0, 0, 0], "radius": 1, "material": "white"}],
    "lights": [{"type": "sphere", "center": [0, 3, 0], "radius": 0.5, "radiance": 4}]
  })");
}

// Expects parse_scene to reject `doc` with a message naming `field`.
void expect_error(const json& doc, const std::string& field, const std::string& what = "") {
  try {
    parse_scene(doc, "test.json", ".");
    ADD_FAILURE() << "accepted a scene with a bad " << field << ": " << doc.dump();
  } catch (const SceneError& e) {
    std::string msg = e.what();
    EXPECT_EQ(msg.rfind("test.json: ", 0), 0u) << msg;
    EXPECT_NE(msg.find(field), std::string::npos) << "message does not name '" << field << "': " << msg;
    if (!what.empty()) {
      EXPECT_NE(msg.find(what), std::string::npos) << msg;
    }
    EXPECT_EQ(msg.find('\n'), std::string::npos) << "not one line: " << msg;
  }
}

// The thesis's scenes (the Cornell box family; test_models.cpp checks the
// built-in scenes made of model files).
const std::vector<std::string> kThesisScenes = {"cornell-sphere", "cornell-near", "occlusion"};

TEST(Scene, BuiltinsParseAndHaveOneSphereLight) {
  ASSERT_EQ(builtin_scenes().size(), 10u);
  for (const std::string& name : kThesisScenes) {
    const BuiltinScene* b = find_builtin(name);
    ASSERT_NE(b, nullptr) << name;
    Scene s = load_scene(b->name);
    EXPECT_EQ(s.lights.size(), 1u) << name;
    EXPECT_EQ(s.lights[0].type, LightType::Sphere) << name;
    EXPECT_EQ(s.render.integrator.mis, Mis::None) << name << ": the thesis's estimator, so that chapter 4 is unchanged";
    EXPECT_EQ(s.render.width, 1920);
    EXPECT_EQ(s.render.height, 1080);
    EXPECT_GT(s.triangle_count(), 20u);
  }
  // The occlusion scene places its slats as instances of two meshes.
  Scene occ = load_scene("occlusion");
  EXPECT_GT(occ.instances.size(), occ.meshes.size() + 30);
}

TEST(Scene, PowerKeepsBrightnessAsRadiusChanges) {
  Scene a = load_scene("cornell-sphere", {"light.radius=0.1"});
  Scene b = load_scene("cornell-sphere", {"light.radius=0.4"});
  // Phi = pi * A * L: the same power from both.
  for (int c = 0; c < 3; ++c)
    EXPECT_NEAR(kPi * a.lights[0].area * a.lights[0].radiance[c], kPi * b.lights[0].area * b.lights[0].radiance[c],
                1e-3 * kPi * a.lights[0].area * a.lights[0].radiance[c]);
  EXPECT_NEAR(a.lights[0].radiance.x / b.lights[0].radiance.x, 16.f, 1e-3f);
  EXPECT_FLOAT_EQ(a.lights[0].radius, 0.1f);
  EXPECT_FLOAT_EQ(a.spheres.back().radius, 0.1f);  // the geometry follows the light
}

TEST(Scene, OverridesReachAnyValue) {
  Scene s = load_scene("cornell-near", {"render.spp=3", "render.strategy=area", "camera.fov=20",
                                        "lights.0.center=[1,2,3]", "materials.red.albedo=0.25"});
  EXPECT_EQ(s.render.spp, 3);
  EXPECT_EQ(s.render.integrator.strategy, Strategy::Area);
  EXPECT_FLOAT_EQ(s.camera.fov, 20.f);
  EXPECT_FLOAT_EQ(s.lights[0].p.z, 3.f);
  // Setting radiance replaces power (they are alternatives).
  Scene r = load_scene("cornell-sphere", {"light.radiance=7"});
  EXPECT_FLOAT_EQ(r.lights[0].radiance.y, 7.f);
}

TEST(Scene, OverrideErrorsNameTheAssignment) {
  for (std::string bad : {"render.spp", "=3", "nosuch.field=1", "lights.9.radius=1", "render.spp.x=1", "light..radius=1"}) {
    try {
      load_scene("cornell-sphere", {bad});
      ADD_FAILURE() << "accepted --set " << bad;
    } catch (const SceneError& e) {
      EXPECT_NE(std::string(e.what()).find("builtin:cornell-sphere"), std::string::npos) << e.what();
    }
  }
  // A value that parses but is wrong is caught by validation, naming the field.
  try {
    load_scene("cornell-sphere", {"light.radius=-1"});
    ADD_FAILURE();
  } catch (const SceneError& e) {
    EXPECT_NE(std::string(e.what()).find("lights[0].radius"), std::string::npos) << e.what();
  }
}

TEST(Scene, MeshFilesAndInstances) {
  Scene s = load_scene(kData + "/mesh_scene.json");
  ASSERT_EQ(s.lights.size(), 2u);
  EXPECT_EQ(s.triangle_count(), 4u + 4u + 2u + 2u);
  // The instance is scaled by 0.5 and moved by -1.5 in x.
  const Instance& inst = s.instances[1];
  Vec3 p = inst.to_world.point(Vec3(0.f));
  EXPECT_NEAR(p.x, -1.5f, 1e-6f);
  Vec3 back = inst.to_object.point(inst.to_world.point(Vec3(0.3f, 0.2f, 0.1f)));
  EXPECT_NEAR(back.x, 0.3f, 1e-5f);
  EXPECT_NEAR(back.y, 0.2f, 1e-5f);
  EXPECT_NEAR(back.z, 0.1f, 1e-5f);
  // power 100 on a sphere of radius 0.3: L = Phi / (4 pi^2 r^2).
  EXPECT_NEAR(s.lights[0].radiance.x, 100.0 / (4 * M_PI * M_PI * 0.09), 1e-3);
}

TEST(Scene, NonFiniteNumbersAreRejected) {
  // JSON has no NaN or infinity literals; an overflowing literal is the way in.
  std::string path = ::testing::TempDir() + "/overflow.json";
  std::ofstream(path) << R"({"camera": {"eye": [0, 0, 1e999], "target": [0,0,0]}, "shapes": []})";
  try {
    load_scene(path);
    ADD_FAILURE() << "accepted 1e999";
  } catch (const SceneError& e) {
    EXPECT_NE(std::string(e.what()).find("overflow.json: invalid JSON"), std::string::npos) << e.what();
  }
  // Through --set, nan/inf are not numbers at all.
  for (std::string v : {"nan", "inf", "-inf", "1e999"}) {
    try {
      load_scene("cornell-sphere", {"light.radius=" + v});
      ADD_FAILURE() << "accepted radius " << v;
    } catch (const SceneError& e) {
      EXPECT_NE(std::string(e.what()).find("lights[0].radius"), std::string::npos) << e.what();
    }
  }
}

TEST(Scene, BadFilesGiveOneLineErrorsNamingFileAndField) {
  struct Bad {
    std::string file, expect;
  } cases[] = {
      {"missing_mesh.json", "missing.obj"},
      {"bad_index_scene.json", "out of range"},
      {"truncated.json", "invalid JSON"},
      {"no_such_scene.json", "cannot open"},
  };
  for (const auto& c : cases) {
    std::string path = kData + "/" + c.file;
    try {
      load_scene(path);
      ADD_FAILURE() << "accepted " << c.file;
    } catch (const SceneError& e) {
      std::string msg = e.what();
      EXPECT_NE(msg.find(c.file), std::string::npos) << msg;
      EXPECT_NE(msg.find(c.expect), std::string::npos) << msg;
      EXPECT_EQ(msg.find('\n'), std::string::npos) << msg;
    }
  }
}

TEST(Scene, InvalidValuesAreRejected) {
  auto with = [](const std::string& ptr, const json& v) {
    json d = minimal();
    d[json::json_pointer(ptr)] = v;
    return d;
  };
  expect_error(with("/lights/0/radius", -1), "lights[0].radius", "> 0");
  expect_error(with("/lights/0/radius", 0), "lights[0].radius");
  expect_error(with("/shapes/0/radius", "big"), "shapes[0].radius", "number");
  expect_error(with("/render/width", 0), "render.width");
  expect_error(with("/render/width", 100000), "render.width");
  expect_error(with("/render/height", -5), "render.height");
  expect_error(with("/render/spp", 0), "render.spp");
  expect_error(with("/render/spp", 1.5), "render.spp", "integer");
  expect_error(with("/render/spp", 1e12), "render.spp");
  expect_error(with("/render/max_depth", -1), "render.max_depth");
  expect_error(with("/render/strategy", "cone"), "render.strategy", "solid-angle");
  expect_error(with("/render/bogus", 1), "render.bogus", "unknown key");
  expect_error(with("/camera/eye", json::array({0, 0})), "camera.eye", "3 numbers");
  expect_error(with("/camera/target", json::array({0, 0, -3})), "camera.target");
  expect_error(with("/camera/up", json::array({0, 0, 1})), "camera.up", "parallel");
  expect_error(with("/camera/fov", 180), "camera.fov");
  expect_error(with("/materials/white/albedo", 1.5), "materials.white.albedo");
  expect_error(with("/shapes/0/material", "gold"), "shapes[0].material", "unknown material");
  expect_error(with("/shapes/0/type", "torus"), "shapes[0].type");
  expect_error(with("/lights/0/power", 10), "lights[0]", "exactly one");
  expect_error(with("/lights/0/radiance", -1), "lights[0].radiance");
  expect_error(with("/lights/0/type", "point"), "lights[0].type");
  expect_error(with("/lights/0/center", json::array({0, 1e30, 0})), "lights[0].center[1]");
  expect_error(with("/shapes/0/transform", 1), "shapes[0].transform");
  expect_error(with("/background", json::array({1, 2})), "background");
  json no_cam = minimal();
  no_cam.erase("camera");
  expect_error(no_cam, "(top level)", "camera");
  json degenerate = minimal();
  degenerate["shapes"].push_back({{"type", "quad"}, {"corner", {0, 0, 0}}, {"edge1", {1, 0, 0}}, {"edge2", {2, 0, 0}},
                                  {"material", "white"}});
  expect_error(degenerate, "shapes[1]", "non-zero area");
  json bad_index = minimal();
  bad_index["shapes"].push_back({{"type", "mesh"}, {"positions", {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}}},
                                 {"indices", {{0, 1, 3}}}, {"material", "white"}});
  expect_error(bad_index, "shapes[1].indices[0][2]");
  json singular = minimal();
  singular["meshes"] = {{"m", {{"type", "box"}, {"center", {0, 0, 0}}, {"size", {1, 1, 1}}}}};
  singular["shapes"].push_back({{"type", "instance"}, {"mesh", "m"}, {"material", "white"},
                                {"transform", {{"scale", {1, 0, 1}}}}});
  expect_error(singular, "shapes[1].transform.scale");
}

// Fuzz-style: thousands of mutated scene files, textual and structural. Each
// must either load (and then render a tiny image with finite values) or fail
// with a SceneError whose message names the file. No other outcome is allowed.
TEST(Scene, FuzzedFilesNeverCrash) {
  std::mt19937 gen(12345);
  const std::string file = "fuzz.json";
  std::vector<std::string> seeds;
  for (const std::string& name : kThesisScenes) seeds.push_back(find_builtin(name)->make().dump(1));
  seeds.push_back(minimal().dump(1));
  const std::vector<std::string> tokens = {"-1", "0", "1e39", "-1e39", "1e-45", "NaN", "null", "true", "\"\"",
                                           "[]", "{}", "[0,0]", "4294967296", "-0", "\"area\"", "2147483647"};
  int loaded = 0, rejected = 0;
  for (int iter = 0; iter < 1500; ++iter) {
    std::string text = seeds[gen() % seeds.size()];
    int edits = 1 + gen() % 3;
    for (int e = 0; e < edits; ++e) {
      size_t pos = gen() % text.size();
      switch (gen() % 5) {
        case 0: text.erase(pos, 1 + gen() % 8); break;                        // delete
        case 1: text[pos] = char(32 + gen() % 95); break;                     // flip a character
        case 2: text.insert(pos, tokens[gen() % tokens.size()]); break;       // insert a token
        case 3: text = text.substr(0, pos); break;                            // truncate
        default: {                                                            // replace a number
          size_t d = text.find_first_of("0123456789", pos);
          if (d != std::string::npos) text.replace(d, 1, tokens[gen() % tokens.size()]);
        }
      }
      if (text.empty()) text = "{";
    }
    json doc = json::parse(text, nullptr, false);
    try {
      if (doc.is_discarded()) throw SceneError(file + ": invalid JSON");
      Scene s = parse_scene(doc, file, kData);
      // Rendering a mutated scene must not crash or produce NaN either.
      s.render.width = std::min(s.render.width, 6);
      s.render.height = std::min(s.render.height, 4);
      s.render.integrator.max_depth = std::min(s.render.integrator.max_depth, 4);
      std::string note;
      auto backend = make_backend("cpu", s, BackendOptions{1}, &note);
      FrameSpec f = frame_spec(s);
      Film film(s.render.width, s.render.height);
      backend->render(f, film, 0, 1);
      for (float v : film.mean()) ASSERT_TRUE(std::isfinite(v)) << text;
      ++loaded;
    } catch (const SceneError& e) {
      ASSERT_EQ(std::string(e.what()).rfind(file, 0), 0u) << e.what();
      ASSERT_EQ(std::string(e.what()).find('\n'), std::string::npos) << e.what();
      ++rejected;
    }
  }
  EXPECT_GT(loaded, 10);
  EXPECT_GT(rejected, 100);
}

}  // namespace
}  // namespace pn

namespace pn {
namespace {

// The feature mask picks the GPU's raygen level: it must cover what a scene
// uses, and stay empty for the thesis's Lambertian Cornell boxes.
TEST(SceneFeatures, CoverWhatTheSceneUses) {
  for (const char* name : {"cornell-sphere", "cornell-near", "occlusion"})
    EXPECT_EQ(load_scene(name).features(), 0u) << name;
  std::string source;
  nlohmann::json j = load_scene_json("cornell-sphere", {}, &source);
  j["materials"]["white"] = {{"base_color", {0.5, 0.5, 0.5}}, {"metallic", 0.0}, {"roughness", 0.5}};
  EXPECT_EQ(parse_scene(j, "test", ".").features(), uint32_t(kFeatureSpecular));
  j["environment"] = {{"file", std::string(PENUMBRA_SOURCE_DATA) + "/sky.hdr"}};
  EXPECT_EQ(parse_scene(j, "test", ".").features(), uint32_t(kFeatureSpecular | kFeatureEnvironment));
  // An OBJ with normals, uvs and a texture.
  j.erase("environment");
  j["models"] = {{{"file", std::string(PENUMBRA_TEST_DATA) + "/tiny_textured.obj"}}};
  const uint32_t obj = parse_scene(j, "test", ".").features();
  EXPECT_EQ(obj & (kFeatureShading | kFeatureTextures), uint32_t(kFeatureShading | kFeatureTextures));
}

// The light-sampling lab's scenes: a quad light, an emissive polygon; new
// scenes take MIS by default.
TEST(Scene, CornellQuadAndPolygonNear) {
  Scene q = load_scene("cornell-quad");
  ASSERT_EQ(q.lights.size(), 1u);
  EXPECT_EQ(q.lights[0].type, LightType::Quad);
  EXPECT_NEAR(q.lights[0].area, 1.30f * 1.05f, 1e-5f);
  EXPECT_LT(q.lights[0].n.y, -0.999f) << "the ceiling light emits downwards";
  EXPECT_EQ(q.render.integrator.mis, Mis::Power);
  Scene p = load_scene("polygon-near");
  ASSERT_EQ(p.lights.size(), 6u);
  for (const Light& l : p.lights) {
    EXPECT_EQ(l.type, LightType::Triangle);
    EXPECT_LT(l.n.y, -0.5f) << "emits from the underside";
    for (Vec3 v : {l.p, l.p + l.e1, l.p + l.e2}) {
      EXPECT_LT(v.z, 5.592f);
      EXPECT_GT(v.z, 5.592f - 1.5f) << "within a fraction of its size from the back wall";
    }
  }
  EXPECT_EQ(p.render.integrator.mis, Mis::Power);
}

// "defaults" and "$name": a scene's parameters, set with --set defaults.name=value.
TEST(Scene, DefaultsParameterizeAScene) {
  json doc = {{"defaults", {{"r", 0.3}}},
              {"camera", {{"eye", {0, 0, 5}}, {"target", {0, 0, 0}}}},
              {"materials", {{"m", {{"base_color", 0.5}, {"roughness", "$r"}}}}},
              {"shapes", {{{"type", "sphere"}, {"center", {0, 0, 0}}, {"radius", "$r"}, {"material", "m"}}}}};
  Scene s = parse_scene(doc, "params.json", ".");
  EXPECT_FLOAT_EQ(s.spheres[0].radius, 0.3f);
  EXPECT_FLOAT_EQ(s.materials[1].roughness, 0.3f);
  std::vector<std::string> over = {"defaults.r=0.7"};
  nlohmann::json d2 = doc;
  apply_override(d2, over[0], "params.json");
  EXPECT_FLOAT_EQ(parse_scene(d2, "params.json", ".").spheres[0].radius, 0.7f);
  json bad = doc;
  bad["shapes"][0]["radius"] = "$radius";
  expect_error(bad, "shapes[0].radius", "unknown parameter '$radius'");
  bad = doc;
  bad["defaults"]["r"] = "$r";
  expect_error(bad, "defaults.r", "cannot refer to another");
  // The glossy scene's roughness.
  const BuiltinScene* g = find_builtin("glossy");
  ASSERT_NE(g, nullptr);
  json gd = g->make();
  ASSERT_TRUE(gd.contains("defaults"));
  EXPECT_EQ(gd["materials"]["gold"]["roughness"], "$roughness");
}

}  // namespace
}  // namespace pn
