// A sphere light edited in place (set_sphere_light, Backend::update_lights), as the viewer's light panel edits it:
// the scene becomes the scene file with those values, and the backend renders what a backend made from it renders.
#include <gtest/gtest.h>

#include <cstddef>
#include <cstring>
#include <limits>
#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

#include "backends/cuda/bvh_build.h"
#include "backends/make_backend.h"
#include "gpu_paths.h"
#include "render/backend.h"
#include "scene/scene.h"

namespace pn {
namespace {

struct Edit {
  Vec3 center;
  float radius;
  Vec3 power;
};

// Values a float holds exactly and the scene format reads back exactly, so the override and the edit agree bit for
// bit.
std::vector<std::string> as_overrides(const Edit& e) {
  auto v = [](Vec3 x) {
    return "[" + std::to_string(x.x) + "," + std::to_string(x.y) + "," + std::to_string(x.z) + "]";
  };
  return {"light.center=" + v(e.center), "light.radius=" + std::to_string(e.radius), "light.power=" + v(e.power)};
}

std::vector<std::string> small(const std::string& selection) {
  return {"render.width=40", "render.height=24", "render.seed=7", "render.light_selection=" + selection};
}

std::vector<float> render(Backend& b, const Scene& s, uint32_t spp) {
  Film film(s.render.width, s.render.height);
  b.render(frame_spec(s), film, 0, spp);
  return film.mean();
}

bool same_bytes(const void* a, const void* b, size_t n) { return std::memcmp(a, b, n) == 0; }

// A light's bytes up to its last member: the 12 bytes of padding after it (alignas(16)) hold whatever the stack
// held (under AddressSanitizer they differed between the two scenes).
constexpr size_t kLightBytes = offsetof(Light, emission_tex) + sizeof(Light::emission_tex);

void expect_same_lights(const Scene& a, const Scene& b) {
  ASSERT_EQ(a.lights.size(), b.lights.size());
  for (size_t i = 0; i < a.lights.size(); ++i)
    EXPECT_TRUE(same_bytes(&a.lights[i], &b.lights[i], kLightBytes)) << "light " << i;
  ASSERT_EQ(a.spheres.size(), b.spheres.size());
  for (size_t i = 0; i < a.spheres.size(); ++i) {
    EXPECT_TRUE(same_bytes(&a.spheres[i].center, &b.spheres[i].center, sizeof(Vec3))) << "sphere " << i;
    EXPECT_EQ(a.spheres[i].radius, b.spheres[i].radius) << "sphere " << i;
  }
  EXPECT_EQ(a.light_cdf, b.light_cdf);
  ASSERT_EQ(a.light_bvh.nodes.size(), b.light_bvh.nodes.size());
  EXPECT_TRUE(same_bytes(a.light_bvh.nodes.data(), b.light_bvh.nodes.data(),
                         a.light_bvh.nodes.size() * sizeof(LightBvhNode)));
  EXPECT_EQ(a.light_bvh.trails, b.light_bvh.trails);
}

// Built-in scenes whose first light is a sphere, each with a way of selecting lights; the edit moves the light,
// grows it and changes its colour. `file`: the scene file's first light is that sphere (many-spheres' first entry
// scatters its 10,000), so that --set light.* can make the same scene.
struct Case {
  const char* scene;
  const char* selection;
  Edit edit;
  bool file;
};
const Case kCases[] = {
    {"cornell-sphere", "power", {{2.5f, 4.5f, 2.75f}, 0.5f, {40.f, 30.f, 20.f}}, true},
    {"cornell-near", "uniform", {{2.75f, 3.f, 4.75f}, 0.25f, {10.f, 10.f, 12.f}}, true},
    {"many-spheres", "bvh", {{0.5f, 0.25f, -2.5f}, 0.125f, {2.f, 1.f, 0.5f}}, false},
};

TEST(LightEdit, TheSceneBecomesTheFileWithTheEditedValues) {
  for (const Case& c : kCases) {
    if (!c.file) continue;
    SCOPED_TRACE(c.scene);
    Scene edited = load_scene(c.scene, small(c.selection));
    set_sphere_light(edited, 0, c.edit.center, c.edit.radius, c.edit.power);
    std::vector<std::string> o = small(c.selection);
    for (const std::string& s : as_overrides(c.edit)) o.push_back(s);
    const Scene file = load_scene(c.scene, o);
    expect_same_lights(edited, file);
  }
}

TEST(LightEdit, TheCpuBackendUpdatedInPlaceRendersAsANewOne) {
  for (const Case& c : kCases) {
    SCOPED_TRACE(c.scene);
    Scene scene = load_scene(c.scene, small(c.selection));
    std::string note;
    auto backend = make_backend("cpu", scene, BackendOptions{2}, &note);
    const std::vector<float> before = render(*backend, scene, 4);
    set_sphere_light(scene, 0, c.edit.center, c.edit.radius, c.edit.power);
    ASSERT_TRUE(backend->update_lights());
    const std::vector<float> in_place = render(*backend, scene, 4);

    auto fresh_backend = make_backend("cpu", scene, BackendOptions{2}, &note);
    const std::vector<float> fresh = render(*fresh_backend, scene, 4);
    EXPECT_EQ(in_place, fresh);   // bit for bit: the same scene, seed and samples
    EXPECT_NE(in_place, before);  // and the edit did change the image
  }
}

// The GPU backend updated in place (update_lights: the light arrays written over, the spheres' GAS and the IAS
// built again, the cuda traversal's top level rebuilt) renders bit for bit what a backend made from the edited scene
// renders, on each path: the wavefront with either trace stage and the megakernel. Skipped without a GPU (CTest's
// gpu label runs it on one: tests/gpu).
TEST(LightEdit, TheGpuBackendUpdatedInPlaceRendersAsANewOne) {
  for (const GpuPath& path : kGpuPaths) {
    for (const Case& c : kCases) {
      SCOPED_TRACE(std::string(c.scene) + ", " + path.name);
      Scene scene = load_scene(c.scene, small(c.selection));
      std::string why;
      std::unique_ptr<Backend> backend = path.backend(scene, &why);
      if (!backend) GTEST_SKIP() << "no GPU backend here: " << why;
      const std::vector<float> before = render(*backend, scene, 4);
      set_sphere_light(scene, 0, c.edit.center, c.edit.radius, c.edit.power);
      ASSERT_TRUE(backend->update_lights());
      const std::vector<float> in_place = render(*backend, scene, 4);
      const std::unique_ptr<Backend> fresh_backend = path.backend(scene, &why);
      ASSERT_TRUE(fresh_backend) << why;
      EXPECT_EQ(in_place, render(*fresh_backend, scene, 4));
      EXPECT_NE(in_place, before);
    }
  }
}

// The cuda traversal's BVH with its top level built again after an edit (rebuild_bvh_top, what the GPU's
// update_lights does) is the BVH build_bvh makes of the edited scene, array for array: the meshes' trees kept, the
// spheres and the top level new.
TEST(LightEdit, TheCudaTraversalsTopLevelRebuiltIsTheEditedScenesBvh) {
  for (const Case& c : kCases) {
    SCOPED_TRACE(c.scene);
    Scene scene = load_scene(c.scene, small(c.selection));
    BvhHost bvh = build_bvh(scene);
    const size_t bottom = bvh.bottom_nodes;
    const std::vector<float> spheres_before = bvh.spheres;
    set_sphere_light(scene, 0, c.edit.center, c.edit.radius, c.edit.power);
    rebuild_bvh_top(scene, bvh);
    const BvhHost fresh = build_bvh(scene);
    EXPECT_EQ(bvh.bottom_nodes, bottom);
    ASSERT_EQ(bvh.nodes.size(), fresh.nodes.size());
    EXPECT_TRUE(same_bytes(bvh.nodes.data(), fresh.nodes.data(), bvh.nodes.size() * sizeof(BvhNode)));
    ASSERT_EQ(bvh.triangles.size(), fresh.triangles.size());
    EXPECT_TRUE(same_bytes(bvh.triangles.data(), fresh.triangles.data(), bvh.triangles.size() * sizeof(BvhTriangle)));
    ASSERT_EQ(bvh.instances.size(), fresh.instances.size());
    EXPECT_TRUE(same_bytes(bvh.instances.data(), fresh.instances.data(), bvh.instances.size() * sizeof(BvhInstance)));
    EXPECT_EQ(bvh.items, fresh.items);
    EXPECT_EQ(bvh.spheres, fresh.spheres);
    EXPECT_EQ(bvh.root, fresh.root);
    EXPECT_EQ(bvh.stats.sah_visits_per_ray, fresh.stats.sah_visits_per_ray);
    EXPECT_NE(bvh.spheres, spheres_before);  // the edit reached the spheres
  }
  const Scene scene = load_scene("cornell-sphere");
  BvhHost other = build_bvh(scene);
  other.mesh_root.push_back(0);  // as a BVH of a scene with one mesh more
  EXPECT_THROW(rebuild_bvh_top(scene, other), std::logic_error);
}

TEST(LightEdit, ValuesOutsideTheFormatsLimitsThrowAndLeaveTheSceneAsItWas) {
  const Scene original = load_scene("cornell-sphere", small("power"));
  const Light& l = original.lights[0];
  const Vec3 power = l.radiance * (kPi * l.area);
  const float nan = std::numeric_limits<float>::quiet_NaN();
  const Edit bad[] = {
      {l.p, 0.f, power},                     // a radius must be positive
      {l.p, -1.f, power},
      {l.p, nan, power},
      {l.p, 2e7f, power},                    // beyond the format's coordinates
      {{0.f, 2e7f, 0.f}, l.radius, power},
      {{nan, 0.f, 0.f}, l.radius, power},
      {l.p, l.radius, {-1.f, 1.f, 1.f}},     // a power in [0, 1e9]
      {l.p, l.radius, {2e9f, 1.f, 1.f}},
      {l.p, l.radius, {nan, 1.f, 1.f}},
      {l.p, 1e-30f, {1e9f, 1e9f, 1e9f}},     // a radiance that overflows
  };
  for (const Edit& e : bad) {
    Scene s = original;
    EXPECT_THROW(set_sphere_light(s, 0, e.center, e.radius, e.power), SceneError)
        << "radius " << e.radius << " centre " << e.center.x << "," << e.center.y << " power " << e.power.x;
    expect_same_lights(s, original);
  }
  Scene s = original;
  EXPECT_THROW(set_sphere_light(s, s.lights.size(), l.p, l.radius, power), SceneError);  // no such light
  Scene quad = load_scene("cornell-quad");
  EXPECT_THROW(set_sphere_light(quad, 0, l.p, l.radius, power), SceneError);  // not a sphere
}

}  // namespace
}  // namespace pn
