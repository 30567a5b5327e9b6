// Built-in scenes, written as scene documents so that they go through the same
// parser as files: `penumbra scenes --dump NAME` prints one to start editing.
//
// All three share the Cornell box (Goral et al. 1984, dimensions of the Cornell
// "box data" in metres/100): floor y=0, ceiling y=5.488, back wall z=5.592, red
// wall at x=5.56 (left in the image), green wall at x=0; the front is open.
#include <cstdio>

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
      {"render", {{"width", 1920}, {"height", 1080}, {"spp", 64}, {"max_depth", 8}, {"rr_depth", 5},
                  {"strategy", "solid-angle"}, {"seed", 0}}},
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

}  // namespace

const std::vector<BuiltinScene>& builtin_scenes() {
  static const std::vector<BuiltinScene> scenes = {
      {"cornell-sphere", "Cornell box lit by a sphere light (radius 0.25, fixed power; set light.radius)",
       make_cornell_sphere},
      {"cornell-near", "Cornell box with a small sphere light two radii from the back wall", make_cornell_near},
      {"occlusion", "sphere light behind two crossed layers of slats: most shadow rays are blocked", make_occlusion},
  };
  return scenes;
}

const BuiltinScene* find_builtin(const std::string& name) {
  for (const auto& s : builtin_scenes())
    if (name == s.name) return &s;
  return nullptr;
}

}  // namespace pn
