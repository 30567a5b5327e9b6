// Model files placed by a scene's "models": Wavefront OBJ + MTL (tinyobjloader)
// and glTF 2.0, .gltf and .glb (tinygltf), turned into the scene's meshes,
// materials and textures. docs/scene-format.md states the material mappings.
#pragma once

#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include "scene/scene.h"

namespace pn {

struct DecodedImage;

// One placement of one of the model's meshes, in the model's own space.
struct ModelPlacement {
  uint32_t mesh = 0;  // index into Scene::meshes
  Affine to_model;    // mesh -> model space (glTF: the node hierarchy composed)
};

struct LoadedModel {
  std::string path;
  std::vector<uint32_t> meshes;            // the Scene::meshes this model added
  std::vector<ModelPlacement> placements;  // OBJ: one, identity; glTF: one per node with a mesh
  bool has_camera = false;                 // glTF: the first perspective camera
  CameraDesc camera;                       // in model space
};

// Loads a model file into `s` (meshes with face_materials, materials named
// "<file name>/<material>", textures shared with the rest of the scene).
// Problems that leave the scene renderable (a missing texture or .mtl, a
// skipped primitive) become Scene::warnings; others throw SceneError
// "<where>: <problem>" on one line.
LoadedModel load_model(Scene& s, const std::string& path, const std::string& where);

// A texture of the scene by file, loaded once per (file, format). Returns its
// index, or -1 with the reason in *error (file missing or undecodable).
int32_t scene_texture_file(Scene& s, const std::string& path, TexelFormat format, bool nearest, std::string* error);

// The same for a texture identified by `key` whose pixels `decode` produces.
int32_t scene_texture(Scene& s, const std::string& key, TexelFormat format, bool nearest,
                      const std::function<bool(DecodedImage*, std::string*)>& decode, std::string* error);

}  // namespace pn
