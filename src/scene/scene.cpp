// What a Scene answers about itself once built (scene.h).
#include "scene/scene.h"

#include <algorithm>
#include <cmath>

namespace pn {

namespace {
// Whether a material the instance's triangles use satisfies `pred`: the mesh's
// per-face materials, or else the instance's own.
template <class Pred>
bool any_instance_material(const Scene& s, const Instance& inst, Pred pred) {
  const TriangleMesh& m = s.meshes[inst.mesh];
  if (m.face_materials.empty()) return pred(s.materials[inst.material]);
  for (uint32_t fm : m.face_materials)
    if (pred(s.materials[fm])) return true;
  return false;
}
}  // namespace

bool Scene::instance_alpha_masked(const Instance& inst) const {
  return any_instance_material(*this, inst, [](const Material& m) { return m.alpha_mode == AlphaMode::Mask; });
}
bool Scene::instance_emits(const Instance& inst) const {
  return any_instance_material(*this, inst, [](const Material& m) { return !is_black(m.emission); });
}

uint32_t Scene::features() const {
  uint32_t f = 0;
  for (const Instance& inst : instances) {
    const TriangleMesh& m = meshes[inst.mesh];
    if (!m.normals.empty() || !m.uvs.empty()) f |= kFeatureShading;
  }
  for (const Material& m : materials) {
    if (m.base_color_tex >= 0 || m.metallic_roughness_tex >= 0 || m.normal_tex >= 0 || m.emission_tex >= 0)
      f |= kFeatureTextures;
    if (m.metallic > 0.f || m.specular > 0.f) f |= kFeatureSpecular;
  }
  if (environment.texture >= 0) f |= kFeatureEnvironment;
  return f;
}

float Scene::bounding_radius() const {
  Vec3 lo(kInf), hi(-kInf);
  std::vector<std::pair<Vec3, Vec3>> boxes(meshes.size(), {Vec3(kInf), Vec3(-kInf)});
  for (size_t i = 0; i < meshes.size(); ++i)
    for (const Vec3& p : meshes[i].positions) {
      boxes[i].first = vmin(boxes[i].first, p);
      boxes[i].second = vmax(boxes[i].second, p);
    }
  for (const Instance& inst : instances) {  // the world box of each instance's object box
    const auto& [blo, bhi] = boxes[inst.mesh];
    if (!(blo.x <= bhi.x)) continue;
    for (int c = 0; c < 8; ++c) {
      Vec3 w = inst.to_world.point(Vec3(c & 1 ? bhi.x : blo.x, c & 2 ? bhi.y : blo.y, c & 4 ? bhi.z : blo.z));
      lo = vmin(lo, w);
      hi = vmax(hi, w);
    }
  }
  for (const Sphere& sp : spheres) {
    lo = vmin(lo, sp.center - Vec3(sp.radius));
    hi = vmax(hi, sp.center + Vec3(sp.radius));
  }
  if (!(lo.x <= hi.x)) return 1.f;
  return 0.5f * length(hi - lo);
}

Camera Scene::make_camera() const {
  return Camera::look_at(camera.eye, camera.target, camera.up, camera.fov, render.width, render.height);
}

IntegratorSettings Scene::integrator() const { return render.integrator; }

size_t Scene::triangle_count() const {
  size_t n = 0;
  for (const auto& inst : instances) n += meshes[inst.mesh].indices.size();
  return n;
}

}  // namespace pn
