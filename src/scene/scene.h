// Host-side scene: what a scene file describes, validated, ready for a backend.
//
// A scene comes from a JSON file (docs/scene-format.md) or from a built-in
// generator (builtin_scenes.cpp), always through the same parser, so built-in
// scenes obey the same rules and can be dumped, edited and reloaded.
#pragma once

#include <array>
#include <cstdint>
#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "core/camera.h"
#include "core/integrator.h"
#include "core/lights.h"
#include "core/material.h"
#include "core/scene_view.h"
#include "core/strategy.h"
#include "core/texture.h"
#include "core/transform.h"
#include "scene/light_bvh_build.h"

namespace pn {

// Limits of one scene (docs/scene-format.md). Instancing lets a small file
// describe a huge scene; beyond these, loading stops with one line naming the
// file (and, for model files, the node) instead of exhausting memory or time.
constexpr size_t kMaxInstances = size_t(1) << 20;              // placements of meshes: 1,048,576
constexpr uint64_t kMaxPlacedTriangles = uint64_t(1) << 32;    // triangles over all placements: 4,294,967,296
constexpr size_t kMaxTriangleLights = size_t(1) << 22;         // placed emissive triangles: 4,194,304

// Any problem with a scene or its overrides. what() is one line:
// "<file>: <field>: <problem>". Errors raised with the three parts keep them
// (file(), field()) for callers that report them apart (the Python module).
class SceneError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;  // one message: file() and field() are empty
  SceneError(const std::string& file, const std::string& field, const std::string& problem)
      : std::runtime_error(file + ": " + (field.empty() ? "" : field + ": ") + problem), file_(file), field_(field) {}
  const std::string& file() const { return file_; }
  const std::string& field() const { return field_; }

 private:
  std::string file_, field_;
};

// Triangle geometry in its own (object) space. Placed in the world by one or
// more Instances: the GPU builds one GAS per mesh and an IAS over instances,
// the CPU one Embree scene per mesh and Embree instances over them.
struct TriangleMesh {
  std::string name;
  std::vector<Vec3> positions;
  std::vector<std::array<uint32_t, 3>> indices;
  std::vector<Vec3> normals;             // per vertex, or empty (flat shading)
  std::vector<Vec2> uvs;                 // per vertex (image convention: v down), or empty
  std::vector<uint32_t> face_materials;  // per triangle (scene material indices), or empty
  // Filled by finalize_scene(): per triangle, its rank among the mesh's emissive
  // triangles (-1: not emissive); empty when no triangle emits.
  std::vector<int32_t> face_lights;
};

struct Instance {
  uint32_t mesh = 0;
  Affine to_world;    // object -> world
  Affine to_object;   // its inverse (normals use its transpose)
  uint32_t material = 0;  // when the mesh has no face_materials
  int32_t light = -1;  // >= 0 for the triangles of a quad light
  int32_t light_base = -1;  // finalize_scene(): first light of this instance's emissive triangles
};

// An image a material or the environment refers to, decoded: width*height RGBA
// texels, row 0 at the top; 4 bytes per texel for the 8-bit formats, 16 (float)
// for Rgba32f.
struct TextureImage {
  std::string path;  // where it came from (messages)
  int width = 0, height = 0;
  TexelFormat format = TexelFormat::Rgba8Srgb;
  bool nearest = false;
  std::vector<uint8_t> texels;
  TextureView view() const;  // host view (CPU backend)
};

// A piecewise-constant density over the environment image (core/environment.h): a marginal over rows, a
// conditional per row; integral: the marginal's (0: empty).
struct EnvironmentDistribution {
  std::vector<float> marginal_func, marginal_cdf;        // height, height + 1
  std::vector<float> conditional_func, conditional_cdf;  // height x width, height x (width + 1)
  float integral = 0.f;
};

// The environment map and its sampling distributions (finalize_scene()).
struct Environment {
  int32_t texture = -1;  // index into Scene::textures (Rgba32f, nearest); -1: none
  float rotation = 0.f;  // degrees about +y
  Vec3 scale{1.f};       // intensity
  EnvironmentDistribution distribution;  // luminance x sin(theta)
  EnvironmentDistribution compensated;   // max(0, luminance - its mean over the sphere) x sin(theta): MIS compensation
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
  // The estimator: strategy, MIS (power by default: what pbrt-v4 and Mitsuba 3
  // users expect; the thesis's scenes say "none"), light selection, restir's
  // settings, max_depth and rr_depth, as the core's integrator takes them.
  IntegratorSettings integrator;
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
  std::vector<Light> lights;          // spheres, quads, emissive triangles (world space), environment
  std::vector<float> light_cdf;       // power-proportional selection (LightSelection::Power), lights.size() + 1 entries
  LightBvh light_bvh;                 // LightSelection::Bvh: every light with a surface and power
  float infinite_light_probability = 0.f;  // LightSelection::Bvh: of the environment (core/light_selection.h)
  std::vector<TextureImage> textures;
  Environment environment;
  std::vector<std::string> warnings;  // non-fatal problems found while loading (missing textures, ...)

  Camera make_camera() const;
  float bounding_radius() const;
  uint32_t features() const;  // SceneFeature bits (core/scene_view.h) the scene uses
  // Whether some triangle of the instance has an alpha-masked material (then
  // backends test its hits: Embree filters, OptiX any-hit), or an emissive one.
  bool instance_alpha_masked(const Instance& inst) const;
  bool instance_emits(const Instance& inst) const;  // of everything that is not a light at infinity
  IntegratorSettings integrator() const;
  size_t triangle_count() const;
};

// Where a backend keeps the arrays a SceneView points at: host memory (the
// CPU), device memory (the GPU). build_scene_view fills the view once for all
// backends; the backend only says where each array goes.
class SceneArrays {
 public:
  virtual ~SceneArrays() = default;
  // The address, in the backend's memory, of a copy of `bytes` bytes at `data`
  // (nullptr when bytes is 0). `scene_owned`: `data` is an array of the Scene,
  // which outlives the view, so host memory may point at it without a copy.
  virtual const void* place(const void* data, size_t bytes, size_t align, const char* what, bool scene_owned) = 0;
  // Scene::textures[index] as the device programs read it.
  virtual TextureView texture(const TextureImage& image, size_t index) = 0;
};

// A scene's view in one backend's memory: the SceneView, and each placed
// mesh's arrays (by Scene::meshes index; all null for a mesh no instance
// places), which a GPU backend's acceleration structures are built from.
struct PlacedSceneView {
  SceneView view;
  std::vector<MeshView> meshes;
};
PlacedSceneView build_scene_view(const Scene& scene, SceneArrays& arrays);

// The sphere records a SceneView points at, one per Scene::spheres (build_scene_view places them; a GPU backend's
// light edit writes them over their device copy).
std::vector<SphereView> sphere_views(const Scene& scene);

// The arrays a SceneView points at, in host memory, for a backend that traces
// on the CPU. Lives as long as the scene it was made from, which must not move.
struct HostSceneView {
  SceneView view;
  std::vector<std::unique_ptr<unsigned char[]>> copies;  // the view's arrays that are not the scene's own
};
std::unique_ptr<HostSceneView> make_host_view(const Scene& scene);

// The scene's LightSelectionView with its arrays at the given addresses (host
// memory for the CPU, device memory for the GPU): the one place that fills it.
LightSelectionView make_light_selection_view(const Scene& scene, const float* power_cdf, const LightBvhNode* bvh_nodes,
                                             const uint64_t* bvh_trails);

// Completes a parsed scene: a triangle light for every emissive triangle of
// every instance, the environment's light and distribution, the lights'
// power-proportional selection CDF and their light BVH. parse_scene() calls it; code that builds a
// Scene by hand calls it once when done.
void finalize_scene(Scene& scene);

// The radiance of a sphere light of radius `radius` emitting `power` (watts per RGB channel): Phi = pi A L with
// A = 4 pi r^2, computed as the scene format's `power` is.
Vec3 sphere_light_radiance(Vec3 power, float radius);

// Moves, resizes or re-powers sphere light `light` of a finished scene in place: the light, the sphere that is its
// surface, and what selects lights (the power CDF, the light BVH) become what they would be had the scene been
// built that way. The same limits as the scene format's (a centre within +-1e7, a radius in (0, 1e7], a power in
// [0, 1e9] and a finite radiance); a value outside them throws SceneError naming the scene and leaves it
// unchanged. A backend made from the scene sees the change after Backend::update_lights() (render/backend.h).
void set_sphere_light(Scene& scene, size_t light, Vec3 center, float radius, Vec3 power);

// Loads a built-in scene by name or a scene file by path, applies "key=value"
// overrides (see apply_override) and validates everything. Throws SceneError.
Scene load_scene(const std::string& name_or_path, const std::vector<std::string>& overrides = {});

// The JSON text of a scene (built-in or file) after overrides, before parsing.
nlohmann::json load_scene_json(const std::string& name_or_path,
                               const std::vector<std::string>& overrides, std::string* source);

// The settings of one frame in a scene document: its "render" block, and its
// "camera" block where it has one (else `camera` keeps its value: a model
// file's camera), validated as parse_scene() validates them. What changes
// between frames without a new scene (the Python module's Renderer).
void parse_frame_settings(const nlohmann::json& doc, const std::string& source, CameraDesc* camera,
                          RenderSettings* render);

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

// Where the built-in scenes' files are looked for first. The applications set it
// before any scene is loaded (src/apps/environment.h: $PENUMBRA_SCENES and
// $PENUMBRA_DATA; the Python module likewise); nothing below src/apps reads the
// environment. Empty fields: the defaults alone.
struct SceneSearch {
  std::string scenes;  // a folder of model data (sponza/, models/), searched before the defaults
  std::string data;    // a folder of the data/ files (the glossy scene's sky), searched before this source tree's
};
void set_scene_search(const SceneSearch& search);
SceneSearch scene_search();

// Folders searched, in order, for the model data of the built-in scenes that use
// it (sponza/, models/): SceneSearch::scenes ($PENUMBRA_SCENES), <source
// dir>/../shared/scenes, ../shared/scenes (relative to the current directory).
std::vector<std::string> scene_data_roots();

// A strategy, MIS mode or light-selection method by name (core/strategy.h,
// core/light_selection.h: find_* and *_names beside their tables), or a
// SceneError naming `where` and listing the valid names.
Strategy parse_strategy(const std::string& name, const std::string& where);
Mis parse_mis(const std::string& name, const std::string& where);
LightSelection parse_light_selection(const std::string& name, const std::string& where);
// The method for reports: its name, with restir's settings, e.g. "restir (32
// candidates from power, 2 spatial passes of 3 neighbours within 30 px,
// unbiased)"; the biased variant says BIASED.
std::string light_selection_label(LightSelection method, const RestirSettings& restir);

}  // namespace pn
