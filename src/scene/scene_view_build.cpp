// A parsed scene as the flat arrays the light-transport core reads
// (core/scene_view.h): build_scene_view places them (host memory for the CPU,
// device memory for the GPU), make_host_view keeps them on the host.
#include <cmath>
#include <cstring>
#include <memory>
#include <stdexcept>
#include <vector>

#include "scene/scene.h"

namespace pn {

TextureView TextureImage::view() const {
  TextureView v;
  v.texels = texels.data();
  v.width = width;
  v.height = height;
  v.format = format;
  v.nearest = nearest;
  return v;
}

namespace {

// Places a vector's elements: nullptr when empty.
template <class T>
const T* place_array(SceneArrays& arrays, const std::vector<T>& v, const char* what, bool scene_owned) {
  if (v.empty()) return nullptr;
  return static_cast<const T*>(arrays.place(v.data(), v.size() * sizeof(T), alignof(T), what, scene_owned));
}

}  // namespace

std::vector<SphereView> sphere_views(const Scene& scene) {
  std::vector<SphereView> out;
  out.reserve(scene.spheres.size());
  for (const Sphere& sp : scene.spheres) out.push_back(SphereView{sp.center, sp.radius, sp.material, sp.light});
  return out;
}

PlacedSceneView build_scene_view(const Scene& scene, SceneArrays& arrays) {
  PlacedSceneView placed;
  // Each placed mesh's arrays once, whatever its number of instances.
  std::vector<bool> used(scene.meshes.size(), false);
  for (const Instance& inst : scene.instances) used.at(inst.mesh) = true;
  placed.meshes.resize(scene.meshes.size());
  for (size_t m = 0; m < scene.meshes.size(); ++m) {
    if (!used[m]) continue;
    const TriangleMesh& mesh = scene.meshes[m];
    MeshView& v = placed.meshes[m];
    v.positions = place_array(arrays, mesh.positions, "mesh vertices", true);
    static_assert(sizeof(mesh.indices[0]) == 3 * sizeof(uint32_t), "indices: 3 packed uint32 a triangle");
    v.indices = reinterpret_cast<const uint32_t*>(place_array(arrays, mesh.indices, "mesh indices", true));
    v.normals = place_array(arrays, mesh.normals, "mesh normals", true);
    v.uvs = place_array(arrays, mesh.uvs, "mesh texture coordinates", true);
    v.face_materials = place_array(arrays, mesh.face_materials, "mesh face materials", true);
    v.face_lights = place_array(arrays, mesh.face_lights, "mesh face lights", true);
    v.num_triangles = uint32_t(mesh.indices.size());
  }
  std::vector<InstanceView> instances;
  instances.reserve(scene.instances.size());
  for (const Instance& inst : scene.instances) {
    InstanceView v;
    v.to_world = inst.to_world;
    v.to_object = inst.to_object;
    v.mesh = placed.meshes[inst.mesh];
    v.material = inst.material;
    v.light = inst.light;
    v.light_base = inst.light_base;
    instances.push_back(v);
  }
  const std::vector<SphereView> spheres = sphere_views(scene);
  std::vector<TextureView> textures;
  textures.reserve(scene.textures.size());
  for (size_t i = 0; i < scene.textures.size(); ++i) textures.push_back(arrays.texture(scene.textures[i], i));

  SceneView& v = placed.view;
  v.lights = place_array(arrays, scene.lights, "lights", true);
  v.num_lights = uint32_t(scene.lights.size());
  v.selection = make_light_selection_view(scene, place_array(arrays, scene.light_cdf, "the light selection CDF", true),
                                          place_array(arrays, scene.light_bvh.nodes, "the light BVH", true),
                                          place_array(arrays, scene.light_bvh.trails, "the light BVH", true));
  v.materials = place_array(arrays, scene.materials, "materials", true);
  v.num_materials = uint32_t(scene.materials.size());
  v.textures = place_array(arrays, textures, "texture records", false);
  v.num_textures = uint32_t(textures.size());
  v.instances = place_array(arrays, instances, "instance records", false);
  v.num_instances = uint32_t(instances.size());
  v.spheres = place_array(arrays, spheres, "sphere records", false);
  v.num_spheres = uint32_t(spheres.size());
  v.background = scene.background;
  const Environment& env = scene.environment;
  if (env.texture >= 0 && size_t(env.texture) < textures.size()) {
    EnvironmentView& e = v.environment;
    e.image = textures[size_t(env.texture)];
    e.width = uint32_t(e.image.width);
    e.height = uint32_t(e.image.height);
    auto place_distribution = [&](const EnvironmentDistribution& from, EnvironmentDistributionView& to) {
      to.marginal.func = place_array(arrays, from.marginal_func, "the environment's distribution", true);
      to.marginal.cdf = place_array(arrays, from.marginal_cdf, "the environment's distribution", true);
      to.marginal.n = e.height;
      to.marginal.integral = from.integral;
      to.conditional_func = place_array(arrays, from.conditional_func, "the environment's distribution", true);
      to.conditional_cdf = place_array(arrays, from.conditional_cdf, "the environment's distribution", true);
    };
    place_distribution(env.distribution, e.distribution);
    place_distribution(env.compensated, e.compensated);
    const float rad = env.rotation * kPi / 180.f;
    e.cos_rot = std::cos(rad);
    e.sin_rot = std::sin(rad);
    e.scale = env.scale;
    for (size_t i = 0; i < scene.lights.size(); ++i)
      if (scene.lights[i].type == LightType::Environment) v.environment_light = int32_t(i);
  }
  return placed;
}

std::unique_ptr<HostSceneView> make_host_view(const Scene& scene) {
  // Host memory: the scene's own arrays as they are, copies of the rest.
  class HostArrays final : public SceneArrays {
   public:
    explicit HostArrays(HostSceneView& h) : h_(h) {}
    const void* place(const void* data, size_t bytes, size_t align, const char*, bool scene_owned) override {
      if (scene_owned || bytes == 0) return bytes ? data : nullptr;
      if (align > __STDCPP_DEFAULT_NEW_ALIGNMENT__) throw std::logic_error("make_host_view: over-aligned array");
      h_.copies.emplace_back(new unsigned char[bytes]);
      std::memcpy(h_.copies.back().get(), data, bytes);
      return h_.copies.back().get();
    }
    TextureView texture(const TextureImage& image, size_t) override { return image.view(); }

   private:
    HostSceneView& h_;
  };
  auto h = std::make_unique<HostSceneView>();
  HostArrays arrays(*h);
  h->view = build_scene_view(scene, arrays).view;
  return h;
}

LightSelectionView make_light_selection_view(const Scene& scene, const float* power_cdf, const LightBvhNode* bvh_nodes,
                                             const uint64_t* bvh_trails) {
  LightSelectionView v;
  v.power_cdf = power_cdf;
  if (bvh_nodes && bvh_trails) v.bvh = LightBvhView{bvh_nodes, bvh_trails};
  for (size_t i = 0; i < scene.lights.size(); ++i)
    if (scene.lights[i].type == LightType::Environment) v.infinite_light = int32_t(i);
  v.infinite_probability = v.infinite_light >= 0 ? scene.infinite_light_probability : 0.f;
  return v;
}

}  // namespace pn
