// Built-in scenes, written as scene documents so that they go through the same
// parser as files: `penumbra scenes --dump NAME` prints one to start editing.
//
// The thesis's three share the Cornell box (Goral et al. 1984, dimensions of the
// Cornell "box data" in metres/100): floor y=0, ceiling y=5.488, back wall
// z=5.592, red wall at x=5.56 (left in the image), green wall at x=0; the front
// is open. `sponza`, `bunnies` and `glossy` use model files and an HDR sky found
// through scene_data_roots() and the source tree's data/ folder.
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <mutex>
#include <utility>

#include "scene/scene.h"

namespace pn {
using json = nlohmann::json;

namespace {

constexpr float kW = 5.56f, kH = 5.488f, kD = 5.592f;

// The thesis's reference power, per RGB channel: the original Cornell ceiling
// light (L = 18.4, 15.6, 8.0 over 1.30 x 1.05) emits Phi = pi A L. Giving lights
// by power keeps the image's brightness fixed as their radius changes.
const json kCornellPower = {78.9, 66.9, 34.3};

json quad(json corner, json e1, json e2, const char* material) {
  return {{"type", "quad"}, {"corner", corner}, {"edge1", e1}, {"edge2", e2}, {"material", material}};
}

json cornell_box(float light_radius, json light_center) {
  json shapes = json::array({
      quad({0, 0, 0}, {0, 0, kD}, {kW, 0, 0}, "white"),    // floor
      quad({0, kH, 0}, {kW, 0, 0}, {0, 0, kD}, "white"),   // ceiling
      quad({0, 0, kD}, {0, kH, 0}, {kW, 0, 0}, "white"),   // back wall
      quad({kW, 0, 0}, {0, 0, kD}, {0, kH, 0}, "red"),     // left (as seen)
      quad({0, 0, 0}, {0, kH, 0}, {0, 0, kD}, "green"),    // right (as seen)
      {{"type", "box"}, {"center", {1.855, 0.825, 1.69}}, {"size", {1.65, 1.65, 1.65}}, {"rotate_y", -17}, {"material", "white"}},
      {{"type", "box"}, {"center", {3.685, 1.65, 3.515}}, {"size", {1.65, 3.3, 1.65}}, {"rotate_y", 17}, {"material", "white"}},
  });
  return {
      {"camera", {{"eye", {2.78, 2.73, -8.0}}, {"target", {2.78, 2.73, 0.0}}, {"up", {0, 1, 0}}, {"fov", 39.3}}},
      // The thesis's estimator (light sampling alone, no MIS), so that the chapter-4 study is unchanged.
      {"render", {{"width", 1920}, {"height", 1080}, {"spp", 64}, {"max_depth", 8}, {"rr_depth", 5},
                  {"strategy", "solid-angle"}, {"mis", "none"}, {"seed", 0}}},
      {"background", {0, 0, 0}},
      {"materials", {{"white", {{"albedo", {0.73, 0.73, 0.73}}}},
                     {"red", {{"albedo", {0.65, 0.05, 0.05}}}},
                     {"green", {{"albedo", {0.12, 0.45, 0.15}}}},
                     {"slat", {{"albedo", {0.6, 0.6, 0.6}}}}}},
      {"shapes", shapes},
      {"lights", json::array({{{"type", "sphere"}, {"center", light_center}, {"radius", light_radius},
                               {"power", kCornellPower}}})},
  };
}

// Cornell box with a sphere light in place of the ceiling light. Its radius
// (light.radius) and position (light.center) are free; power stays fixed.
json make_cornell_sphere() { return cornell_box(0.25f, {2.78, 4.4, 2.8}); }

// A small light with its centre two radii from the back wall: the irradiance on
// the wall varies quickly with position, the thesis's near-light case (sec. 4.2.1).
json make_cornell_near() {
  const float r = 0.15f;
  return cornell_box(r, {1.6, 3.2, kD - 2.f * r});
}

// The light sits above two crossed layers of slats (blinds) that block about 90%
// of the directions towards it: most shadow rays are occluded (sec. 4.5).
json make_occlusion() {
  json doc = cornell_box(0.3f, {2.78, 4.95, 2.8});
  const float pitch = 0.25f, width = 0.17f, thick = 0.04f;
  // Two slat meshes, each placed many times by instances (one GAS each on the GPU).
  doc["meshes"] = {{"slat-x", {{"type", "box"}, {"center", {0, 0, 0}}, {"size", {width, thick, kD}}}},
                   {"slat-z", {{"type", "box"}, {"center", {0, 0, 0}}, {"size", {kW, thick, width}}}}};
  for (int i = 0; pitch * (i + 0.5f) < kW; ++i)
    doc["shapes"].push_back({{"type", "instance"}, {"mesh", "slat-x"}, {"material", "slat"},
                             {"transform", {{"translate", {pitch * (i + 0.5f), 4.42, kD / 2}}}}});
  for (int i = 0; pitch * (i + 0.5f) < kD; ++i)
    doc["shapes"].push_back({{"type", "instance"}, {"mesh", "slat-z"}, {"material", "slat"},
                             {"transform", {{"translate", {kW / 2, 4.37, pitch * (i + 0.5f)}}}}});
  return doc;
}

// The classic Cornell box: its original ceiling light, a 1.30 x 1.05 quad just
// below the ceiling emitting downwards (the scene of Mitsuba's cornell_box() and
// pbrt's tests), with the thesis's power. MIS on, as for any new render.
json make_cornell_quad() {
  json doc = cornell_box(0.25f, {0, 0, 0});
  doc["render"]["mis"] = "power";
  doc["lights"] = json::array({{{"type", "quad"}, {"corner", {2.13, kH - 0.001, 2.27}}, {"edge1", {1.30, 0, 0}},
                                {"edge2", {0, 0, 1.05}}, {"power", kCornellPower}}});
  return doc;
}

// A folded light panel: six emissive triangles (a pleated strip 3.56 wide)
// hinged at the back wall 3.3 above the floor and rising to 3.6-4.2 at 1.3 from
// the wall, emitting from its underside towards the room, the wall below it and
// a glossy floor. Points of the wall just below the hinge see the panel under a
// large solid angle and its pleats nearly edge-on: where area sampling of
// polygons is at its worst (its 1 / d^2 and 1 / cos terms at their largest).
json make_polygon_near() {
  json doc = cornell_box(0.25f, {0, 0, 0});
  doc["render"]["mis"] = "power";
  doc["lights"] = json::array();
  doc["materials"]["floor"] = {
      {"base_color", {0.45, 0.45, 0.47}}, {"metallic", 0}, {"roughness", "$roughness"}, {"specular", 0.5}};
  doc["materials"]["panel"] = {{"albedo", {0, 0, 0}}, {"emission", {6.0, 5.3, 4.0}}};
  doc["shapes"][0]["material"] = "floor";
  doc["shapes"].erase(6);  // the tall box: it would hide the lit wall
  const float xs[4] = {1.0f, 2.19f, 3.37f, 4.56f};
  json positions = json::array(), indices = json::array();
  for (int i = 0; i < 4; ++i) {
    positions.push_back({xs[i], 3.3, kD - 0.05});                       // 2i: the hinge
    positions.push_back({xs[i], i % 2 ? 4.2 : 3.6, kD - 1.3});          // 2i + 1: the pleated front edge
  }
  // Wound so that the emitting (front) side is the underside.
  const Vec3 towards(0.f, -0.9f, -0.43f);
  auto vtx = [&](int k) {
    const json& p = positions[size_t(k)];
    return Vec3(p[0].get<float>(), p[1].get<float>(), p[2].get<float>());
  };
  auto add = [&](int a, int b, int c) {
    if (dot(cross(vtx(b) - vtx(a), vtx(c) - vtx(a)), towards) < 0.f) std::swap(b, c);
    indices.push_back({a, b, c});
  };
  for (int i = 0; i < 3; ++i) {
    add(2 * i, 2 * i + 1, 2 * i + 2);
    add(2 * i + 2, 2 * i + 1, 2 * i + 3);
  }
  // defaults.panel_z moves the panel along z (negative: away from the back wall); defaults.roughness is the
  // glossy floor's.
  doc["defaults"] = {{"panel_z", 0}, {"roughness", 0.2}};
  doc["shapes"].push_back({{"type", "mesh"}, {"positions", positions}, {"indices", indices}, {"material", "panel"},
                           {"transform", {{"translate", {0, 0, "$panel_z"}}}}});
  return doc;
}

// --- Scenes with model files ------------------------------------------------------

#ifndef PENUMBRA_SOURCE_DIR
#define PENUMBRA_SOURCE_DIR "."
#endif

// A file of the scene data (relative to a root of scene_data_roots()): the first
// root holding it, else its path under the first root (load_scene then names
// every root in its error).
std::string scene_data_file(const std::string& rel) {
  std::vector<std::string> roots = scene_data_roots();
  for (const auto& r : roots) {
    std::error_code ec;
    std::filesystem::path p = std::filesystem::path(r) / rel;
    if (std::filesystem::is_regular_file(p, ec)) return p.lexically_normal().string();
  }
  return (std::filesystem::path(roots.front()) / rel).lexically_normal().string();
}

// A file of this source tree's data/ folder (the glossy scene's sky), or of
// SceneSearch::data where that is set ($PENUMBRA_DATA; the Python package's own copy).
std::string source_data_file(const std::string& rel) {
  std::error_code ec;
  if (const std::string data = scene_search().data; !data.empty()) {
    std::filesystem::path p = std::filesystem::path(data) / rel;
    if (std::filesystem::is_regular_file(p, ec)) return p.lexically_normal().string();
  }
  std::filesystem::path p = std::filesystem::path(PENUMBRA_SOURCE_DIR) / "data" / rel;
  if (!std::filesystem::is_regular_file(p, ec)) {
    std::filesystem::path local = std::filesystem::path("data") / rel;
    if (std::filesystem::is_regular_file(local, ec)) return std::filesystem::absolute(local).lexically_normal().string();
  }
  return p.lexically_normal().string();
}

json render_block() {
  return {{"width", 1920}, {"height", 1080}, {"spp", 64}, {"max_depth", 8}, {"rr_depth", 5},
          {"strategy", "solid-angle"}, {"seed", 0}};
}

// The Sponza atrium (Dabrovic), with the camera and light of its source scene
// (lajolla_public's sponza.xml): the light, a sphere of radius 0.1 and radiance
// 5000, hangs at (0, 17, 0), above the open roof (the model ends at y = 15.65).
// The source's horizontal field of view of 90.47 degrees is kept at 16:9:
// vertical fov = 2 atan(tan(90.47/2) * 9/16) = 59.12 degrees.
json make_sponza() {
  const double hfov = 90.47 * kPi / 180.0;
  const double vfov = 2.0 * std::atan(std::tan(hfov / 2.0) * 9.0 / 16.0) * 180.0 / kPi;
  return {
      {"camera", {{"eye", {14.4499, 6.89415, -1.18547}}, {"target", {13.4563, 6.78438, -1.15861}},
                  {"up", {-0.109708, 0.993957, 0.00374357}}, {"fov", std::round(vfov * 100.0) / 100.0}}},
      {"render", render_block()},
      {"background", {0, 0, 0}},
      {"models", json::array({{{"file", scene_data_file("sponza/sponza.obj")}}})},
      {"lights", json::array({{{"type", "sphere"}, {"center", {0, 17, 0}}, {"radius", 0.1}, {"radiance", 5000}}})},
  };
}

// Stanford bunnies on a ground plane, 24 x 24 instances of one mesh (40 million
// triangles placed, 69,451 stored): the IAS keeps memory flat. The bunny is
// 0.154 units tall in its file, scaled by 10 and stood on y = 0.
json make_bunnies() {
  const int n = 24;
  const double pitch = 2.0, scale = 10.0, lift = -0.032987 * scale;
  const char* names[4] = {"clay", "jade", "gold", "plastic"};
  json models = json::array();
  std::vector<json> transforms(4, json::array());
  for (int i = 0; i < n; ++i)
    for (int k = 0; k < n; ++k) {
      double x = (i - (n - 1) / 2.0) * pitch, z = (k - (n - 1) / 2.0) * pitch;
      double angle = double((i * 37 + k * 91) % 360);
      transforms[size_t((i + 2 * k) % 4)].push_back(
          {{"scale", scale}, {"rotate", {0, 1, 0, angle}}, {"translate", {x + 0.2, lift, z}}});
    }
  const std::string bunny = scene_data_file("models/stanford-bunny.obj");
  for (int m = 0; m < 4; ++m) models.push_back({{"file", bunny}, {"material", names[m]}, {"transforms", transforms[m]}});
  return {
      {"camera", {{"eye", {-20, 14, -30}}, {"target", {2, 0, 2}}, {"up", {0, 1, 0}}, {"fov", 35}}},
      {"render", render_block()},
      {"background", {0.06, 0.07, 0.09}},
      {"materials", {{"ground", {{"albedo", {0.5, 0.5, 0.5}}}},
                     {"clay", {{"albedo", {0.75, 0.45, 0.3}}}},
                     {"jade", {{"base_color", {0.25, 0.6, 0.4}}, {"metallic", 0}, {"roughness", 0.3}, {"specular", 0.5}}},
                     {"gold", {{"base_color", {1.0, 0.766, 0.336}}, {"metallic", 1}, {"roughness", 0.35}}},
                     {"plastic", {{"base_color", {0.1, 0.2, 0.7}}, {"metallic", 0}, {"roughness", 0.15}, {"specular", 0.5}}}}},
      {"shapes", json::array({{{"type", "quad"}, {"corner", {-40, 0, -40}}, {"edge1", {0, 0, 80}}, {"edge2", {80, 0, 0}},
                               {"material", "ground"}}})},
      {"models", models},
      {"lights", json::array({{{"type", "sphere"}, {"center", {-8, 24, -12}}, {"radius", 2.5}, {"power", 60000}}})},
  };
}

// Rough metals and plastics under a sphere light and an HDR sky with a sun
// (data/sky.hdr, made by scripts/make_sky.py): glossy reflections of small, bright
// sources, where sampling the light alone is not enough.
// Metals and plastics under a sphere light and an HDR sky with a sun
// (data/sky.hdr, made by scripts/make_sky.py): glossy reflections of small, bright
// sources, where sampling the light alone is not enough. One parameter, the
// roughness of every material (defaults.roughness, 0 = mirror-like, 1 = rough),
// so that a sweep can run from one end to the other.
json make_glossy() {
  struct Ball { const char* mat; double x, z; };
  const Ball balls[] = {{"gold", -3.3, -0.8}, {"gold", -2.2, -0.8}, {"copper", -1.1, -0.8},
                        {"copper", 0, -0.8}, {"aluminium", 1.1, -0.8}, {"aluminium", 2.2, -0.8}, {"aluminium", 3.3, -0.8},
                        {"plastic-red", -3.0, 1.2}, {"plastic-blue", -1.6, 1.2}, {"plastic-white", 1.6, 1.2},
                        {"plastic-green", 3.0, 1.2}};
  json shapes = json::array();
  shapes.push_back({{"type", "quad"}, {"corner", {-20, 0, -20}}, {"edge1", {0, 0, 40}}, {"edge2", {40, 0, 0}},
                    {"material", "floor"}});
  for (const Ball& b : balls)
    shapes.push_back({{"type", "sphere"}, {"center", {b.x, 0.5, b.z}}, {"radius", 0.5}, {"material", b.mat}});
  shapes.push_back({{"type", "box"}, {"center", {-2.3, 0.45, 2.9}}, {"size", {0.9, 0.9, 0.9}}, {"rotate_y", 30},
                    {"material", "plastic-white"}});
  shapes.push_back({{"type", "box"}, {"center", {2.3, 0.45, 2.9}}, {"size", {0.9, 0.9, 0.9}}, {"rotate_y", -20},
                    {"material", "copper"}});
  auto metal = [](json c) { return json{{"base_color", c}, {"metallic", 1}, {"roughness", "$roughness"}}; };
  auto plastic = [](json c) {
    return json{{"base_color", c}, {"metallic", 0}, {"roughness", "$roughness"}, {"specular", 0.5}};
  };
  return {
      {"defaults", {{"roughness", 0.2}}},
      {"camera", {{"eye", {0, 3.0, -7.8}}, {"target", {0, 0.6, 0.8}}, {"up", {0, 1, 0}}, {"fov", 38}}},
      {"render", render_block()},
      {"materials", {{"floor", plastic({0.35, 0.35, 0.38})},
                     {"gold", metal({1.0, 0.766, 0.336})}, {"copper", metal({0.955, 0.638, 0.538})},
                     {"aluminium", metal({0.913, 0.922, 0.924})},
                     {"plastic-red", plastic({0.7, 0.05, 0.05})}, {"plastic-blue", plastic({0.05, 0.15, 0.7})},
                     {"plastic-white", plastic({0.8, 0.8, 0.8})}, {"plastic-green", plastic({0.1, 0.5, 0.15})}}},
      {"shapes", shapes},
      {"models", json::array({{{"file", scene_data_file("models/stanford-bunny.obj")}, {"material", "gold"},
                               {"transform", {{"scale", 12}, {"rotate", {0, 1, 0, 200}}, {"translate", {0, -0.396, 1.4}}}}}})},
      {"lights", json::array({{{"type", "sphere"}, {"center", {2.5, 4.0, -1.5}}, {"radius", 0.3}, {"power", 300}}})},
      {"environment", {{"file", source_data_file("sky.hdr")}, {"rotation", 0}, {"intensity", 1}}},
  };
}

// --- Many lights ------------------------------------------------------------------

// Warm, cool and white lamps, a few red and green ones.
const json kLampColors = {{1.0, 0.75, 0.45}, {1.0, 0.85, 0.65}, {0.6, 0.75, 1.0}, {1.0, 1.0, 1.0}, {1.0, 0.45, 0.35},
                          {0.55, 1.0, 0.6}};

// Thousands of small sphere lights of varied power (a factor of 100 between
// the dimmest and the brightest) and colour, scattered in a slab above a floor
// whose left half is diffuse and right half glossy, among pillars and a wall
// that shadow one another's lamps. `defaults.lights` (4000) sets their number;
// the total power stays fixed, so the image's brightness does not change with
// it (a "scatter" light: docs/scene-format.md).
json make_many_spheres() {
  json shapes = json::array();
  shapes.push_back(quad({-12, 0, -12}, {0, 0, 24}, {12, 0, 0}, "matte"));   // x in [-12, 0]: diffuse
  shapes.push_back(quad({0, 0, -12}, {0, 0, 24}, {12, 0, 0}, "glossy"));    // x in [0, 12]: glossy
  for (int i = 0; i < 3; ++i)
    for (int k = 0; k < 3; ++k)
      shapes.push_back({{"type", "box"}, {"center", {-6 + 6 * i, 1.25, -5 + 5 * k}}, {"size", {0.8, 2.5, 0.8}},
                        {"rotate_y", 15 * (i + k)}, {"material", "stone"}});
  shapes.push_back({{"type", "box"}, {"center", {1.5, 0.6, 1.2}}, {"size", {7, 1.2, 0.3}}, {"rotate_y", -25},
                    {"material", "stone"}});
  shapes.push_back({{"type", "sphere"}, {"center", {-3, 0.9, 2.5}}, {"radius", 0.9}, {"material", "glossy"}});
  return {
      {"defaults", {{"lights", 4000}}},
      {"camera", {{"eye", {0, 8.5, -15}}, {"target", {0, 0.4, 0.5}}, {"up", {0, 1, 0}}, {"fov", 42}}},
      {"render", {{"width", 1920}, {"height", 1080}, {"spp", 64}, {"max_depth", 8}, {"rr_depth", 5},
                  {"strategy", "solid-angle"}, {"mis", "power"}, {"seed", 0}}},
      {"background", {0, 0, 0}},
      {"materials", {{"matte", {{"albedo", {0.6, 0.6, 0.6}}}},
                     {"glossy", {{"base_color", {0.5, 0.5, 0.52}}, {"metallic", 0}, {"roughness", 0.15}, {"specular", 0.5}}},
                     {"stone", {{"albedo", {0.55, 0.5, 0.45}}}}}},
      {"shapes", shapes},
      {"lights", json::array({{{"type", "scatter"}, {"count", "$lights"}, {"seed", 14}, {"min", {-10, 0.2, -9}},
                               {"max", {10, 2.4, 9}}, {"radius", {0.015, 0.05}}, {"power", 1500}, {"power_spread", 100},
                               {"colors", kLampColors}}})},
  };
}

// Sponza at night: rows of small lanterns (sphere lights) along both arcades
// of the ground floor and of the gallery above, a little inside the columns
// and along the middle of each walkway: 8 rows of `defaults.lanterns` (40)
// lights each, warm and of varied power; the roof light of `sponza` is off.
json make_sponza_lanterns() {
  json doc = make_sponza();
  json lights = json::array();
  struct Row { double y, z; };
  const Row rows[] = {{3.0, -3.9}, {3.0, -5.6}, {3.0, 3.9}, {3.0, 5.6}, {7.1, -3.9}, {7.1, -5.6}, {7.1, 3.9}, {7.1, 5.6}};
  uint32_t seed = 1;
  for (const Row& r : rows)
    lights.push_back({{"type", "scatter"}, {"layout", "line"}, {"count", "$lanterns"}, {"seed", seed++},
                      {"min", {-12.5, r.y, r.z}}, {"max", {12.5, r.y, r.z}}, {"radius", {0.04, 0.07}}, {"power", 100},
                      {"power_spread", 8}, {"colors", {{1.0, 0.7, 0.4}, {1.0, 0.8, 0.55}, {1.0, 0.6, 0.3}}}});
  doc["defaults"] = {{"lanterns", 40}};
  doc["lights"] = lights;
  doc["render"]["mis"] = "power";
  return doc;
}

}  // namespace

namespace {
std::mutex g_search_mutex;
SceneSearch g_search;  // set_scene_search's
}  // namespace

void set_scene_search(const SceneSearch& search) {
  std::lock_guard<std::mutex> lock(g_search_mutex);
  g_search = search;
}

SceneSearch scene_search() {
  std::lock_guard<std::mutex> lock(g_search_mutex);
  return g_search;
}

std::vector<std::string> scene_data_roots() {
  std::vector<std::string> roots;
  if (const std::string scenes = scene_search().scenes; !scenes.empty()) roots.push_back(scenes);
  roots.push_back((std::filesystem::path(PENUMBRA_SOURCE_DIR) / ".." / "shared" / "scenes").lexically_normal().string());
  roots.push_back((std::filesystem::path("..") / "shared" / "scenes").string());
  return roots;
}

const std::vector<BuiltinScene>& builtin_scenes() {
  static const std::vector<BuiltinScene> scenes = {
      {"cornell-sphere", "Cornell box lit by a sphere light (radius 0.25, fixed power; set light.radius)",
       make_cornell_sphere},
      {"cornell-near", "Cornell box with a small sphere light two radii from the back wall", make_cornell_near},
      {"occlusion", "sphere light behind two crossed layers of slats: most shadow rays are blocked", make_occlusion},
      {"cornell-quad", "the classic Cornell box with its original ceiling quad light", make_cornell_quad},
      {"polygon-near", "a pleated panel of emissive triangles hinged at the back wall, above a glossy floor "
                       "(set defaults.roughness, default 0.2, and defaults.panel_z)",
       make_polygon_near},
      {"sponza", "Dabrovic's Sponza atrium (OBJ + MTL + textures) lit by a small sphere light above its open roof",
       make_sponza},
      {"bunnies", "24 x 24 instanced Stanford bunnies (40M triangles placed, one mesh stored) under a sphere light",
       make_bunnies},
      {"glossy", "metal and plastic spheres, boxes and a bunny under a sphere light and an HDR sky with a sun "
                 "(set defaults.roughness, default 0.2)",
       make_glossy},
      {"many-spheres", "thousands of small sphere lights of varied power and colour over a diffuse and a glossy floor "
                       "among pillars (set defaults.lights, default 4000)",
       make_many_spheres},
      {"sponza-lanterns", "Sponza at night: 8 rows of small lanterns along its arcades and gallery (set "
                          "defaults.lanterns, lights per row, default 40)",
       make_sponza_lanterns},
  };
  return scenes;
}

const BuiltinScene* find_builtin(const std::string& name) {
  for (const auto& s : builtin_scenes())
    if (name == s.name) return &s;
  return nullptr;
}

}  // namespace pn
