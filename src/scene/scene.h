// Host-side scene: what a scene file describes, validated, ready for a backend.
//
// A scene comes from a JSON file (docs/scene-format.md) or from a built-in
// generator (builtin_scenes.cpp), always through the same parser, so built-in
// scenes obey the same rules and can be dumped, edited and reloaded.
#pragma once

#include <array>
#include <cstdint>
#include <stdexcept>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "core/camera.h"
#include "core/integrator.h"
#include "core/lights.h"
#include "core/material.h"
#include "core/strategy.h"
#include "core/transform.h"

namespace pn {

// Any problem with a scene or its overrides. what() is one line:
// "<file>: <field>: <problem>".
class SceneError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// Triangle geometry in its own (object) space. Placed in the world by one or
// more Instances: the GPU builds one GAS per mesh and an IAS over instances,
// the CPU one Embree scene per mesh and Embree instances over them.
struct TriangleMesh {
  std::string name;
  std::vector<Vec3> positions;
  std::vector<std::array<uint32_t, 3>> indices;
};

struct Instance {
  uint32_t mesh = 0;
  Affine to_world;    // object -> world
  Affine to_object;   // its inverse (normals use its transpose)
  uint32_t material = 0;
  int32_t light = -1;  // >= 0 for the triangles of a quad light
};

struct Sphere {
  Vec3 center;
  float radius = 1.f;
  uint32_t material = 0;
  int32_t light = -1;  // >= 0 for the surface of a sphere light
};

struct CameraDesc {
  Vec3 eye{0.f, 0.f, 0.f};
  Vec3 target{0.f, 0.f, -1.f};
  Vec3 up{0.f, 1.f, 0.f};
  float fov = 40.f;  // vertical, degrees
};

struct RenderSettings {
  int width = 640;
  int height = 360;
  int spp = 16;
  int max_depth = 8;
  int rr_depth = 5;
  Strategy strategy = Strategy::SolidAngle;
  uint32_t seed = 0;
};

struct Scene {
  std::string source;  // the file, or "builtin:<name>"; used in messages
  CameraDesc camera;
  RenderSettings render;
  Vec3 background{0.f, 0.f, 0.f};
  std::vector<Material> materials;
  std::vector<std::string> material_names;
  std::vector<Sphere> spheres;       // includes the surfaces of sphere lights
  std::vector<TriangleMesh> meshes;   // quads, boxes, quad lights, meshes, named meshes
  std::vector<Instance> instances;    // every placement of a mesh in the world
  std::vector<Light> lights;

  SceneView view() const;
  Camera make_camera() const;
  IntegratorSettings integrator() const;
  size_t triangle_count() const;
};

// Loads a built-in scene by name or a scene file by path, applies "key=value"
// overrides (see apply_override) and validates everything. Throws SceneError.
Scene load_scene(const std::string& name_or_path, const std::vector<std::string>& overrides = {});

// The JSON text of a scene (built-in or file) after overrides, before parsing.
nlohmann::json load_scene_json(const std::string& name_or_path,
                               const std::vector<std::string>& overrides, std::string* source);

// Parses a scene from JSON. `source` names it in error messages and `base_dir`
// resolves relative mesh file paths.
Scene parse_scene(const nlohmann::json& j, const std::string& source, const std::string& base_dir);

// Applies one "a.b.c=value" override to a scene document. The value is parsed
// as JSON when it can be (numbers, arrays, true/false), else taken as a string.
// "light." is shorthand for "lights.0."; array elements are addressed by index.
void apply_override(nlohmann::json& doc, const std::string& assignment, const std::string& source);

struct BuiltinScene {
  const char* name;
  const char* description;
  nlohmann::json (*make)();
};
const std::vector<BuiltinScene>& builtin_scenes();
const BuiltinScene* find_builtin(const std::string& name);

// Parses a strategy name; throws SceneError listing the valid names.
Strategy parse_strategy(const std::string& name, const std::string& where);
std::string strategy_names();  // "area, solid-angle, bsdf"

}  // namespace pn
