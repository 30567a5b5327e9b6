// Scene files (JSON) and built-in scenes parsed and validated into a Scene: the
// format, "key=value" overrides and parameters. Every rejection names the file
// and the field.
#include "scene/scene.h"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <limits>
#include <map>
#include <new>
#include <set>
#include <sstream>
#include <stdexcept>

#include "scene/json_node.h"
#include "scene/mesh_io.h"
#include "scene/model_io.h"
#include "scene/procedural.h"

namespace pn {
namespace fs = std::filesystem;
using json = nlohmann::json;

namespace {

// Limits that reject absurd requests before they turn into crashes or hangs.
constexpr int kMaxResolution = 16384;
constexpr int kMaxSpp = 1 << 24;
constexpr int kMaxDepth = 1024;
using scene_detail::kMaxCoordinate;
using scene_detail::kMaxEmission;

using scene_detail::Node;
using scene_detail::add_instance;
using scene_detail::add_mesh;
using scene_detail::box_mesh;
using scene_detail::parse_scatter;
using scene_detail::quad_mesh;

std::string parent_dir(const std::string& path) {
  fs::path p(path);
  return p.has_parent_path() ? p.parent_path().string() : std::string(".");
}

uint32_t material_ref(const Node& n, const std::map<std::string, uint32_t>& materials) {
  std::string name = n.string();
  auto it = materials.find(name);
  if (it == materials.end()) {
    std::string list;
    for (const auto& kv : materials) list += (list.empty() ? "" : ", ") + kv.first;
    n.fail("unknown material '" + name + "' (defined: " + (list.empty() ? "none" : list) + ")");
  }
  return it->second;
}

void parse_camera(const Node& n, Scene& s) {
  n.expect_object({"eye", "target", "up", "fov"});
  n.require("eye");
  n.require("target");
  s.camera.eye = n.at("eye").vec3();
  s.camera.target = n.at("target").vec3();
  if (n.has("up")) s.camera.up = n.at("up").vec3();
  if (n.has("fov")) s.camera.fov = n.at("fov").real(0.1, 179.0);
  Vec3 f = s.camera.target - s.camera.eye;
  if (!(length(f) > 0.f)) n.at("target").fail("must differ from camera.eye");
  if (!(length(cross(normalize(f), s.camera.up)) > 1e-4f)) {
    if (n.has("up")) n.at("up").fail("must not be parallel to the viewing direction (and not zero)");
    n.at("target").fail("the viewing direction is parallel to the default up [0, 1, 0]: give camera.up");
  }
}

// "restir": {"candidates", "spatial_passes", "neighbors", "radius", "unbiased", "pairwise", "visibility_reuse",
// "source", "temporal", "temporal_cap"} (core/light_selection.h, RestirSettings).
void parse_restir(const Node& n, RestirSettings* r) {
  n.expect_object({"candidates", "spatial_passes", "neighbors", "radius", "unbiased", "pairwise", "visibility_reuse",
                   "source", "temporal", "temporal_cap"});
  if (n.has("candidates")) r->candidates = uint32_t(n.at("candidates").integer(1, long(kMaxRestirCandidates)));
  if (n.has("spatial_passes")) r->spatial_passes = uint32_t(n.at("spatial_passes").integer(0, long(kMaxRestirPasses)));
  if (n.has("neighbors")) r->neighbors = uint32_t(n.at("neighbors").integer(1, long(kMaxRestirNeighbors)));
  if (n.has("radius")) r->radius = n.at("radius").real(1.0, 4096.0);
  auto flag = [&](const char* key, uint32_t* out) {
    if (n.has(key)) *out = n.at(key).boolean() ? 1u : 0u;
  };
  flag("unbiased", &r->unbiased);
  flag("pairwise", &r->pairwise);
  if (r->pairwise && !r->unbiased)
    n.at("pairwise").fail("pairwise MIS is for the unbiased combination (unbiased: true)");
  flag("visibility_reuse", &r->visibility_reuse);
  flag("temporal", &r->temporal);
  if (n.has("temporal_cap")) r->temporal_cap = n.at("temporal_cap").real(1.0, 1000.0);
  if (n.has("source")) {
    Node src = n.at("source");
    LightSelection m;
    if (!find_light_selection(src.string(), &m) || m == LightSelection::Restir || m == LightSelection::Slc)
      src.fail("unknown source '" + src.string() + "' (expected one of: uniform, power, bvh, sg-bvh)");
    r->source = m;
  }
}

void parse_render(const Node& n, Scene& s) {
  n.expect_object({"width", "height", "spp", "max_depth", "rr_depth", "strategy", "mis", "mis_compensation",
                   "light_selection", "slc_cut", "restir", "seed"});
  RenderSettings& r = s.render;
  if (n.has("width")) r.width = n.at("width").integer(1, kMaxResolution);
  if (n.has("height")) r.height = n.at("height").integer(1, kMaxResolution);
  if (n.has("spp")) r.spp = n.at("spp").integer(1, kMaxSpp);
  if (n.has("max_depth")) r.integrator.max_depth = n.at("max_depth").integer(0, kMaxDepth);
  if (n.has("rr_depth")) r.integrator.rr_depth = n.at("rr_depth").integer(1, kMaxDepth);
  // Names of the integrator's choices: an unknown one fails naming its field.
  auto choice = [&](const char* key, auto* out, auto find, const std::string& names) {
    if (!n.has(key)) return;
    Node v = n.at(key);
    if (!find(v.string(), out)) v.fail("unknown " + std::string(key) + " '" + v.string() + "' (expected one of: " + names + ")");
  };
  choice("strategy", &r.integrator.strategy, find_strategy, strategy_names());
  choice("mis", &r.integrator.mis, find_mis, mis_names());
  if (n.has("mis_compensation")) r.integrator.mis_compensation = n.at("mis_compensation").boolean();
  choice("light_selection", &r.integrator.light_selection, find_light_selection, light_selection_names());
  if (n.has("slc_cut")) r.integrator.slc_cut = uint32_t(n.at("slc_cut").integer(1, long(kMaxLightCut)));
  if (n.has("restir")) parse_restir(n.at("restir"), &r.integrator.restir);
  if (n.has("seed")) r.seed = uint32_t(n.at("seed").integer(0, long(std::numeric_limits<uint32_t>::max())));
}

// {"translate": [x,y,z], "rotate": [ax, ay, az, degrees], "scale": s or [sx,sy,sz]},
// applied in the order scale, rotate, translate.
Affine parse_transform(const Node& n) {
  n.expect_object({"translate", "rotate", "scale"});
  Affine t;
  if (n.has("scale")) {
    Node sc = n.at("scale");
    Vec3 v = sc.j.is_number() ? Vec3(sc.positive(kMaxCoordinate)) : sc.vec3();
    if (!(v.x != 0.f && v.y != 0.f && v.z != 0.f)) sc.fail("scale factors must be non-zero");
    t = scaling(v);
  }
  if (n.has("rotate")) {
    Node r = n.at("rotate");
    if (!r.j.is_array() || r.j.size() != 4) r.fail("expected [axis_x, axis_y, axis_z, degrees]");
    Vec3 axis(r.at(size_t(0)).real(-1e6, 1e6), r.at(size_t(1)).real(-1e6, 1e6), r.at(size_t(2)).real(-1e6, 1e6));
    if (!(length(axis) > 0.f)) r.fail("the rotation axis must not be zero");
    t = compose(rotation(normalize(axis), r.at(size_t(3)).real(-3600.0, 3600.0)), t);
  }
  if (n.has("translate")) t = compose(translation(n.at("translate").vec3()), t);
  bool ok = false;
  inverse(t, &ok);
  if (!ok) n.fail("the transform is not invertible");
  return t;
}

// The geometry of a quad, box or mesh (shared by "shapes" and "meshes").
TriangleMesh parse_geometry(const Node& n, const std::string& type, const std::string& base_dir) {
  if (type == "quad") {
    for (auto k : {"corner", "edge1", "edge2"}) n.require(k);
    Vec3 e1 = n.at("edge1").vec3(), e2 = n.at("edge2").vec3();
    if (!(length(cross(e1, e2)) > 0.f)) n.fail("edge1 and edge2 must span a non-zero area");
    return quad_mesh(n.path, n.at("corner").vec3(), e1, e2);
  }
  if (type == "box") {
    n.require("center");
    n.require("size");
    Vec3 size = n.at("size").vec3();
    if (!(size.x > 0.f && size.y > 0.f && size.z > 0.f)) n.at("size").fail("every extent must be > 0");
    float rot = n.has("rotate_y") ? n.at("rotate_y").real(-3600.0, 3600.0) : 0.f;
    return box_mesh(n.path, n.at("center").vec3(), size, rot);
  }
  // type == "mesh"
  TriangleMesh m;
  m.name = n.path;
  if (n.has("file")) {
    if (n.has("positions") || n.has("indices")) n.fail("give either 'file' or 'positions'/'indices', not both");
    std::string file = n.at("file").string();
    fs::path p(file);
    if (p.is_relative()) p = fs::path(base_dir) / p;
    std::string err;
    if (!load_obj_triangles(p.string(), &m.positions, &m.indices, &err)) n.at("file").fail(err);
    return m;
  }
  n.require("positions");
  n.require("indices");
  Node pos = n.at("positions"), idx = n.at("indices");
  if (!pos.j.is_array() || pos.j.empty()) pos.fail("expected a non-empty array of [x, y, z]");
  if (!idx.j.is_array() || idx.j.empty()) idx.fail("expected a non-empty array of [i, j, k]");
  for (size_t i = 0; i < pos.j.size(); ++i) m.positions.push_back(pos.at(i).vec3());
  for (size_t i = 0; i < idx.j.size(); ++i) {
    Node t = idx.at(i);
    if (!t.j.is_array() || t.j.size() != 3) t.fail("expected an array of 3 vertex indices");
    std::array<uint32_t, 3> tri;
    for (int k = 0; k < 3; ++k) tri[k] = uint32_t(t.at(size_t(k)).integer(0, long(m.positions.size()) - 1));
    m.indices.push_back(tri);
  }
  return m;
}

const std::set<std::string> kGeometryKeys[] = {
    {"corner", "edge1", "edge2"},                 // quad
    {"center", "size", "rotate_y"},               // box
    {"positions", "indices", "file"},             // mesh
};

std::set<std::string> geometry_keys(const Node& n, const std::string& type, std::set<std::string> extra) {
  int k = type == "quad" ? 0 : type == "box" ? 1 : type == "mesh" ? 2 : -1;
  if (k < 0) n.at("type").fail("unknown type '" + type + "'");
  extra.insert(kGeometryKeys[k].begin(), kGeometryKeys[k].end());
  return extra;
}

// "meshes": {"name": {"type": "quad" | "box" | "mesh", geometry...}}: shared
// geometry placed by shapes of type "instance".
void parse_named_meshes(const Node& n, Scene& s, std::map<std::string, uint32_t>* named,
                        const std::string& base_dir) {
  if (!n.j.is_object()) n.fail("expected an object mapping names to meshes");
  for (auto it = n.j.begin(); it != n.j.end(); ++it) {
    Node m = n.at(it.key());
    if (!m.j.is_object()) m.fail("expected an object");
    m.require("type");
    std::string type = m.at("type").string();
    if (type != "quad" && type != "box" && type != "mesh")
      m.at("type").fail("unknown mesh type '" + type + "' (expected quad, box or mesh)");
    m.expect_object(geometry_keys(m, type, {"type"}));
    TriangleMesh mesh = parse_geometry(m, type, base_dir);
    mesh.name = it.key();
    (*named)[it.key()] = add_mesh(s, std::move(mesh));
  }
}

void parse_shape(const Node& n, Scene& s, const std::map<std::string, uint32_t>& mats,
                 const std::map<std::string, uint32_t>& named, const std::string& base_dir) {
  if (!n.j.is_object()) n.fail("expected an object");
  n.require("type");
  std::string type = n.at("type").string();
  auto mat = [&]() { n.require("material"); return material_ref(n.at("material"), mats); };
  auto xform = [&]() { return n.has("transform") ? parse_transform(n.at("transform")) : Affine(); };
  if (type == "sphere") {
    n.expect_object({"type", "center", "radius", "material"});
    n.require("center");
    n.require("radius");
    Sphere sp;
    sp.center = n.at("center").vec3();
    sp.radius = n.at("radius").positive(kMaxCoordinate);
    sp.material = mat();
    s.spheres.push_back(sp);
  } else if (type == "quad" || type == "box" || type == "mesh") {
    n.expect_object(geometry_keys(n, type, {"type", "material", "transform"}));
    Affine t = xform();
    uint32_t m = mat();
    add_instance(s, add_mesh(s, parse_geometry(n, type, base_dir)), t, m, -1);
  } else if (type == "instance") {
    n.expect_object({"type", "mesh", "material", "transform"});
    n.require("mesh");
    Node mn = n.at("mesh");
    std::string name = mn.string();
    auto it = named.find(name);
    if (it == named.end()) mn.fail("unknown mesh '" + name + "' (define it under \"meshes\")");
    Affine t = xform();
    add_instance(s, it->second, t, mat(), -1);
  } else {
    n.at("type").fail("unknown shape type '" + type + "' (expected sphere, quad, box, mesh or instance)");
  }
}

// A texture a scene file names (relative to the scene file). A missing or bad
// file is a warning: the material keeps its factor alone.
int32_t material_texture(const Node& n, Scene& s, const std::string& base_dir, TexelFormat format) {
  fs::path p(n.string());
  if (p.is_relative()) p = fs::path(base_dir) / p;
  std::string err;
  int32_t t = scene_texture_file(s, p.lexically_normal().string(), format, false, &err);
  if (t < 0) s.warnings.push_back(s.source + ": " + n.path + ": " + err + "; using the factor alone");
  return t;
}

// A material: {"albedo": c} is Lambert's (the thesis's scenes); otherwise the
// metallic-roughness model of core/material.h, with glTF's defaults. Textures
// multiply their factors.
Material parse_material(const Node& m, Scene& s, const std::string& base_dir) {
  m.expect_object({"albedo", "base_color", "metallic", "roughness", "specular", "emission", "alpha",
                   "alpha_cutoff", "base_color_texture", "metallic_roughness_texture", "normal_texture",
                   "normal_scale", "emission_texture"});
  Material mat;
  if (m.has("albedo")) {
    for (auto k : {"base_color", "metallic", "roughness", "specular", "metallic_roughness_texture"})
      if (m.has(k)) m.at(k).fail("'albedo' (Lambert) and the metallic-roughness keys exclude each other");
    mat.base_color = m.at("albedo").color(1.f);
    mat.metallic = 0.f;
    mat.roughness = 1.f;
    mat.specular = 0.f;
  } else {
    mat.base_color = m.has("base_color") ? m.at("base_color").color(1.f) : Vec3(1.f);
    mat.metallic = m.has("metallic") ? m.at("metallic").real(0.0, 1.0) : 1.f;
    mat.roughness = m.has("roughness") ? m.at("roughness").real(0.0, 1.0) : 1.f;
    mat.specular = m.has("specular") ? m.at("specular").real(0.0, 1.0) : 0.5f;
  }
  if (m.has("emission")) mat.emission = m.at("emission").color(1e9f);
  if (m.has("alpha")) mat.alpha = m.at("alpha").real(0.0, 1.0);
  if (m.has("alpha_cutoff")) {
    mat.alpha_cutoff = m.at("alpha_cutoff").real(0.0, 1.0);
    mat.alpha_mode = AlphaMode::Mask;
  }
  if (m.has("normal_scale")) mat.normal_scale = m.at("normal_scale").real(-10.0, 10.0);
  if (m.has("base_color_texture"))
    mat.base_color_tex = material_texture(m.at("base_color_texture"), s, base_dir, TexelFormat::Rgba8Srgb);
  if (m.has("metallic_roughness_texture"))
    mat.metallic_roughness_tex = material_texture(m.at("metallic_roughness_texture"), s, base_dir, TexelFormat::Rgba8Linear);
  if (m.has("normal_texture"))
    mat.normal_tex = material_texture(m.at("normal_texture"), s, base_dir, TexelFormat::Rgba8Linear);
  if (m.has("emission_texture")) {
    mat.emission_tex = material_texture(m.at("emission_texture"), s, base_dir, TexelFormat::Rgba8Srgb);
    if (mat.emission_tex >= 0 && !m.has("emission")) mat.emission = Vec3(1.f);
  }
  return mat;
}

// "models": [{"file": F, "transform": T | "transforms": [T...], "material": name}].
// Each file is loaded once per scene; every placement of every mesh node is an
// instance (the model's meshes are shared, never flattened). With "material",
// that material replaces the model's own (on copies of its meshes without
// per-face materials). The first model camera found is returned in *camera.
void parse_models(const Node& n, Scene& s, const std::map<std::string, uint32_t>& mats, const std::string& base_dir,
                  bool* has_camera, CameraDesc* camera) {
  if (!n.j.is_array()) n.fail("expected an array of models");
  std::map<std::string, LoadedModel> loaded;
  std::map<uint32_t, uint32_t> plain_copy;  // mesh -> its copy without face materials
  auto file_key = [&](const Node& fn) {
    fs::path p(fn.string());
    if (p.is_relative()) p = fs::path(base_dir) / p;
    std::error_code ec;
    fs::path canon = fs::weakly_canonical(p, ec);
    return std::make_pair(ec ? p.lexically_normal().string() : canon.string(), p.lexically_normal().string());
  };
  // Files placed only with a "material" override need no per-face materials at all.
  std::map<std::string, bool> own_materials_used;
  for (size_t i = 0; i < n.j.size(); ++i) {
    Node m = n.at(i);
    if (!m.j.is_object() || !m.has("file") || !m.j["file"].is_string()) continue;
    bool& used = own_materials_used[file_key(m.at("file")).first];
    used = used || !m.has("material");
  }
  for (size_t i = 0; i < n.j.size(); ++i) {
    Node m = n.at(i);
    m.expect_object({"file", "transform", "transforms", "material"});
    m.require("file");
    if (m.has("transform") && m.has("transforms")) m.fail("give either 'transform' or 'transforms', not both");
    std::vector<Affine> placements;
    if (m.has("transforms")) {
      Node ts = m.at("transforms");
      if (!ts.j.is_array() || ts.j.empty()) ts.fail("expected a non-empty array of transforms");
      if (ts.j.size() > (size_t(1) << 24)) ts.fail("too many transforms");
      for (size_t k = 0; k < ts.j.size(); ++k) placements.push_back(parse_transform(ts.at(k)));
    } else {
      placements.push_back(m.has("transform") ? parse_transform(m.at("transform")) : Affine());
    }
    int64_t override_mat = m.has("material") ? int64_t(material_ref(m.at("material"), mats)) : -1;
    Node fn = m.at("file");
    const auto [key, path] = file_key(fn);
    auto it = loaded.find(key);
    if (it == loaded.end()) {
      it = loaded.emplace(key, load_model(s, path, s.source + ": " + fn.path)).first;
      if (!own_materials_used[key])
        for (uint32_t mesh : it->second.meshes) s.meshes[mesh].face_materials.clear();
    }
    const LoadedModel& model = it->second;
    const uint64_t adding = uint64_t(placements.size()) * model.placements.size();
    if (s.instances.size() + adding > kMaxInstances)
      m.fail("places " + std::to_string(adding) + " meshes (" + std::to_string(placements.size()) + " transforms x " +
             std::to_string(model.placements.size()) + " mesh nodes), which brings the scene beyond " +
             std::to_string(kMaxInstances) + " instances, penumbra's limit");
    for (const Affine& t : placements) {
      for (const ModelPlacement& pl : model.placements) {
        uint32_t mesh = pl.mesh;
        if (override_mat >= 0 && !s.meshes[mesh].face_materials.empty()) {
          auto c = plain_copy.find(mesh);
          if (c == plain_copy.end()) {
            TriangleMesh copy = s.meshes[mesh];
            copy.face_materials.clear();
            c = plain_copy.emplace(mesh, add_mesh(s, std::move(copy))).first;
          }
          mesh = c->second;
        }
        add_instance(s, mesh, compose(t, pl.to_model), override_mat >= 0 ? uint32_t(override_mat) : 0u, -1);
      }
    }
    if (model.has_camera && !*has_camera) {
      *has_camera = true;
      const Affine& t = placements[0];
      camera->eye = t.point(model.camera.eye);
      camera->target = t.point(model.camera.target);
      camera->up = t.vector(model.camera.up);
      camera->fov = model.camera.fov;
    }
  }
}

// "environment": {"file": an equirectangular .hdr or .exr, "rotation": degrees
// about +y, "intensity": number or [r, g, b]}.
void parse_environment(const Node& n, Scene& s, const std::string& base_dir) {
  n.expect_object({"file", "rotation", "intensity"});
  n.require("file");
  Node fn = n.at("file");
  fs::path p(fn.string());
  if (p.is_relative()) p = fs::path(base_dir) / p;
  std::string err;
  int32_t t = scene_texture_file(s, p.lexically_normal().string(), TexelFormat::Rgba32f, true, &err);
  if (t < 0) fn.fail(err);
  s.environment.texture = t;
  s.environment.rotation = n.has("rotation") ? n.at("rotation").real(-3600.0, 3600.0) : 0.f;
  s.environment.scale = n.has("intensity") ? n.at("intensity").color(1e6f) : Vec3(1.f);
}

// Lights are given by `radiance` L or by total emitted `power` Phi (watts per
// RGB channel). For a surface emitting L on one side into the hemisphere,
// Phi = pi * A * L, so a sphere of radius r has L = Phi / (4 pi^2 r^2): with power
// fixed, changing the radius leaves the scene's brightness unchanged.
void parse_light(const Node& n, Scene& s, const std::map<std::string, uint32_t>& mats) {
  if (!n.j.is_object()) n.fail("expected an object");
  n.require("type");
  std::string type = n.at("type").string();
  bool has_l = n.has("radiance"), has_p = n.has("power");
  if (has_l == has_p && type != "scatter") n.fail("give exactly one of 'radiance' or 'power'");
  uint32_t black = 0;  // material 0 is the implicit black "light" material
  int32_t index = int32_t(s.lights.size());
  uint32_t material = n.has("material") ? material_ref(n.at("material"), mats) : black;
  if (type == "sphere") {
    n.expect_object({"type", "center", "radius", "radiance", "power", "material"});
    n.require("center");
    n.require("radius");
    Vec3 c = n.at("center").vec3();
    float r = n.at("radius").positive(kMaxCoordinate);
    Vec3 L = has_l ? n.at("radiance").color(kMaxEmission)
                   : sphere_light_radiance(n.at("power").color(kMaxEmission), r);
    if (!is_finite(L)) n.at("radius").fail("too small for the given power (radiance overflows)");
    s.lights.push_back(Light::sphere(c, r, L));
    s.spheres.push_back(Sphere{c, r, material, index});
  } else if (type == "quad") {
    n.expect_object({"type", "corner", "edge1", "edge2", "radiance", "power", "material"});
    for (auto k : {"corner", "edge1", "edge2"}) n.require(k);
    Vec3 corner = n.at("corner").vec3(), e1 = n.at("edge1").vec3(), e2 = n.at("edge2").vec3();
    float area = length(cross(e1, e2));
    if (!(area > 0.f)) n.fail("edge1 and edge2 must span a non-zero area");
    Vec3 L = has_l ? n.at("radiance").color(kMaxEmission) : n.at("power").color(kMaxEmission) / (kPi * area);
    if (!is_finite(L)) n.fail("too small for the given power (radiance overflows)");
    s.lights.push_back(Light::quad(corner, e1, e2, L));
    add_instance(s, add_mesh(s, quad_mesh(n.path, corner, e1, e2)), Affine(), material, index);
  } else if (type == "scatter") {
    parse_scatter(n, s, material);
  } else {
    n.at("type").fail("unknown light type '" + type + "' (expected sphere, quad or scatter)");
  }
}

}  // namespace

namespace {
template <class E>
E parse_enum(const std::string& text, const std::string& where, const char* what, int count, const char* (*name)(E)) {
  E e;
  if (find_enum(text, count, name, &e)) return e;
  throw SceneError(where + ": unknown " + what + " '" + text + "' (expected one of: " + enum_names(count, name) + ")");
}
}  // namespace

Strategy parse_strategy(const std::string& name, const std::string& where) {
  return parse_enum(name, where, "strategy", kNumStrategies, strategy_name);
}
Mis parse_mis(const std::string& name, const std::string& where) {
  return parse_enum(name, where, "MIS mode", kNumMisModes, mis_name);
}
std::string light_selection_label(LightSelection method, const RestirSettings& r) {
  std::string s = light_selection_name(method);
  if (method != LightSelection::Restir) return s;
  s += " (" + std::to_string(r.candidates) + " candidates from " + light_selection_name(r.source);
  if (r.spatial_passes > 0) {
    char radius[32];
    std::snprintf(radius, sizeof radius, "%g", double(r.radius));
    s += ", " + std::to_string(r.spatial_passes) + " spatial pass" + (r.spatial_passes > 1 ? "es" : "") + " of " +
         std::to_string(r.neighbors) + " neighbour" + (r.neighbors > 1 ? "s" : "") + " within " + radius + " px";
  }
  if (r.temporal) {
    char cap[32];
    std::snprintf(cap, sizeof cap, "%g", double(r.temporal_cap));
    s += std::string(", temporal reuse (history M <= ") + cap + " x)";
  }
  if (!r.visibility_reuse) s += ", unshadowed reuse";
  return s + (r.unbiased ? (r.pairwise ? ", unbiased, pairwise MIS)" : ", unbiased)") : ", BIASED)");
}

LightSelection parse_light_selection(const std::string& name, const std::string& where) {
  return parse_enum(name, where, "light selection", kNumLightSelections, light_selection_name);
}

namespace {
// Replaces every string "$name" of the document by defaults[name] (the scene's
// parameters: Mitsuba's <default> and $name). Unknown names are errors that
// name the field.
void substitute_parameters(json& j, const json& defaults, const std::string& path, const std::string& source) {
  if (j.is_string()) {
    const std::string& v = j.get_ref<const std::string&>();
    if (v.size() < 2 || v[0] != '$') return;
    for (size_t i = 1; i < v.size(); ++i)
      if (!(std::isalnum((unsigned char)v[i]) || v[i] == '_')) return;
    const std::string name = v.substr(1);
    if (!defaults.is_object() || !defaults.contains(name)) {
      std::string list;
      if (defaults.is_object())
        for (auto it = defaults.begin(); it != defaults.end(); ++it) list += (list.empty() ? "" : ", ") + it.key();
      throw SceneError(source + ": " + path + ": unknown parameter '" + v + "' (\"defaults\" defines: " +
                       (list.empty() ? "none" : list) + ")");
    }
    j = defaults[name];
  } else if (j.is_object()) {
    for (auto it = j.begin(); it != j.end(); ++it)
      substitute_parameters(it.value(), defaults, path.empty() ? it.key() : path + "." + it.key(), source);
  } else if (j.is_array()) {
    for (size_t i = 0; i < j.size(); ++i) substitute_parameters(j[i], defaults, path + "[" + std::to_string(i) + "]", source);
  }
}

// The limits of scene.h over the whole scene, before finalize_scene() makes a
// light of every placed emissive triangle.
void check_scene_limits(const Scene& s) {
  auto fail = [&](const std::string& msg) -> void { throw SceneError(s.source + ": " + msg); };
  if (s.instances.size() > kMaxInstances)
    fail(std::to_string(s.instances.size()) + " mesh instances, more than penumbra's limit of " +
         std::to_string(kMaxInstances));
  uint64_t placed = 0;
  for (const Instance& inst : s.instances) placed += s.meshes[inst.mesh].indices.size();
  if (placed > kMaxPlacedTriangles)
    fail(std::to_string(placed) + " triangles placed, more than penumbra's limit of " +
         std::to_string(kMaxPlacedTriangles));
  // Emissive faces of each mesh with per-face materials, counted once a mesh.
  std::vector<int64_t> mesh_emissive(s.meshes.size(), -1);
  uint64_t emissive = 0;
  for (const Instance& inst : s.instances) {
    const TriangleMesh& m = s.meshes[inst.mesh];
    if (inst.light >= 0) continue;  // a quad light is one light already
    if (m.face_materials.empty()) {
      emissive += is_black(s.materials[inst.material].emission) ? 0 : m.indices.size();
      continue;
    }
    int64_t& n = mesh_emissive[inst.mesh];
    if (n < 0) {
      n = 0;
      for (uint32_t fm : m.face_materials) n += is_black(s.materials[fm].emission) ? 0 : 1;
    }
    emissive += uint64_t(n);
  }
  if (emissive > kMaxTriangleLights)
    fail(std::to_string(emissive) + " emissive triangles placed (each one a light), more than penumbra's limit of " +
         std::to_string(kMaxTriangleLights));
}

}  // namespace

Scene parse_scene(const json& original, const std::string& source, const std::string& base_dir) {
  Scene s;
  s.source = source;
  json doc = original;
  if (doc.is_object()) {
    json defaults = doc.contains("defaults") ? doc["defaults"] : json::object();
    if (!defaults.is_object()) Node{defaults, "defaults", s.source}.fail("expected an object mapping names to values");
    for (auto it = defaults.begin(); it != defaults.end(); ++it)
      if (it.value().is_string() && !it.value().get_ref<const std::string&>().empty() &&
          it.value().get_ref<const std::string&>()[0] == '$')
        Node{it.value(), "defaults." + it.key(), s.source}.fail("a parameter's value cannot refer to another one");
    for (auto it = doc.begin(); it != doc.end(); ++it)
      if (it.key() != "defaults") substitute_parameters(it.value(), defaults, it.key(), s.source);
  }
  Node root{doc, "", s.source};
  root.expect_object({"camera", "render", "background", "materials", "meshes", "shapes", "lights", "models",
                      "environment", "defaults"});
  if (root.has("render")) parse_render(root.at("render"), s);
  if (root.has("background")) s.background = root.at("background").color(1e9f);

  // Material 0 is black: the default surface of lights.
  Material black;
  black.base_color = Vec3(0.f);
  s.materials.push_back(black);
  s.material_names.push_back("(light)");
  std::map<std::string, uint32_t> mats;
  if (root.has("materials")) {
    Node ms = root.at("materials");
    if (!ms.j.is_object()) ms.fail("expected an object mapping names to materials");
    for (auto it = ms.j.begin(); it != ms.j.end(); ++it) {
      mats[it.key()] = uint32_t(s.materials.size());
      s.materials.push_back(parse_material(ms.at(it.key()), s, base_dir));
      s.material_names.push_back(it.key());
    }
  }
  std::map<std::string, uint32_t> named;
  if (root.has("meshes")) parse_named_meshes(root.at("meshes"), s, &named, base_dir);
  if (root.has("shapes")) {
    Node shapes = root.at("shapes");
    if (!shapes.j.is_array()) shapes.fail("expected an array");
    for (size_t i = 0; i < shapes.j.size(); ++i) parse_shape(shapes.at(i), s, mats, named, base_dir);
  }
  bool model_camera = false;
  CameraDesc camera;
  if (root.has("models")) parse_models(root.at("models"), s, mats, base_dir, &model_camera, &camera);
  if (root.has("lights")) {
    Node lights = root.at("lights");
    if (!lights.j.is_array()) lights.fail("expected an array");
    for (size_t i = 0; i < lights.j.size(); ++i) parse_light(lights.at(i), s, mats);
  }
  if (root.has("environment")) parse_environment(root.at("environment"), s, base_dir);
  // The scene's camera, else the first camera of its models.
  if (root.has("camera")) parse_camera(root.at("camera"), s);
  else if (model_camera) s.camera = camera;
  else root.fail("missing required key 'camera' (and no model file has a perspective camera)");
  if (s.spheres.empty() && s.instances.empty()) root.fail("the scene has no shapes and no lights");
  check_scene_limits(s);
  finalize_scene(s);
  if (s.lights.empty() && is_black(s.background))
    s.warnings.push_back(s.source + ": the scene has no light (no light, no emissive material, no environment, and a "
                                    "black background): the image will be black");
  return s;
}

void parse_frame_settings(const json& doc, const std::string& source, CameraDesc* camera, RenderSettings* render) {
  Scene s;
  s.source = source;
  s.camera = *camera;
  Node root{doc, "", s.source};
  if (!doc.is_object()) root.fail("expected an object, got " + std::string(doc.type_name()));
  if (root.has("render")) parse_render(root.at("render"), s);
  if (root.has("camera")) parse_camera(root.at("camera"), s);
  *camera = s.camera;
  *render = s.render;
}

namespace {
// Whether parts[0..i] names a block of the scene format whose every key is
// optional (render, render.restir): an override may create it.
bool is_optional_block(const std::vector<std::string>& parts, size_t i) {
  if (i == 0) return parts[0] == "render";
  return i == 1 && parts[0] == "render" && parts[1] == "restir";
}
}  // namespace

void apply_override(json& doc, const std::string& assignment, const std::string& source) {
  auto eq = assignment.find('=');
  auto fail = [&](const std::string& msg) -> void {
    throw SceneError(source, "--set " + assignment, msg);
  };
  if (eq == std::string::npos || eq == 0) fail("expected key=value, e.g. light.radius=0.05");
  std::string key = assignment.substr(0, eq), text = assignment.substr(eq + 1);
  if (key == "light" || key.rfind("light.", 0) == 0) key = "lights.0" + key.substr(5);
  std::vector<std::string> parts;
  std::stringstream ss(key);
  for (std::string p; std::getline(ss, p, '.');) {
    if (p.empty()) fail("empty component in key '" + key + "'");
    parts.push_back(p);
  }
  json value = json::parse(text, nullptr, /*allow_exceptions=*/false);
  if (value.is_discarded()) value = text;  // a bare word: a string
  json* cur = &doc;
  for (size_t i = 0; i < parts.size(); ++i) {
    const std::string& p = parts[i];
    bool last = i + 1 == parts.size();
    if (cur->is_array()) {
      char* end = nullptr;
      unsigned long idx = std::strtoul(p.c_str(), &end, 10);
      if (*end != '\0') fail("'" + p + "' is not an index into an array");
      if (idx >= cur->size()) fail("index " + p + " is out of range (size " + std::to_string(cur->size()) + ")");
      cur = &(*cur)[idx];
    } else if (cur->is_object()) {
      // "render" is optional and so is each of its keys, "render.restir" too:
      // an override creates them, so that render options work on scene files
      // without them (render.restir.candidates on a scene without that block).
      if (!last && !cur->contains(p)) {
        if (!is_optional_block(parts, i)) fail("no field '" + p + "' to descend into");
        (*cur)[p] = json::object();
      }
      if (last && cur->contains("radiance") && p == "power") cur->erase("radiance");
      if (last && cur->contains("power") && p == "radiance") cur->erase("power");
      cur = &(*cur)[p];
    } else {
      fail("'" + p + "' cannot be set inside a " + std::string(cur->type_name()));
    }
  }
  *cur = value;
}

json load_scene_json(const std::string& name_or_path, const std::vector<std::string>& overrides,
                     std::string* source) {
  json doc;
  if (const BuiltinScene* b = find_builtin(name_or_path)) {
    *source = "builtin:" + name_or_path;
    doc = b->make();
  } else {
    *source = name_or_path;
    std::ifstream in(name_or_path, std::ios::binary);
    if (!in) {
      std::string names;
      for (const auto& bs : builtin_scenes()) names += (names.empty() ? "" : ", ") + std::string(bs.name);
      throw SceneError(name_or_path, "", "cannot open scene file (and it is not a built-in scene: " + names + ")");
    }
    std::stringstream buf;
    buf << in.rdbuf();
    try {
      doc = json::parse(buf.str());
    } catch (const json::exception& e) {  // syntax errors, number overflow
      std::string what = e.what();
      auto pos = what.find("] ");
      if (pos != std::string::npos) pos += 2;
      throw SceneError(name_or_path, "", "invalid JSON: " + (pos == std::string::npos ? what : what.substr(pos)));
    }
  }
  for (const auto& o : overrides) apply_override(doc, o, *source);
  return doc;
}

Scene load_scene(const std::string& name_or_path, const std::vector<std::string>& overrides) {
  std::string source;
  json doc = load_scene_json(name_or_path, overrides, &source);
  std::string base = find_builtin(name_or_path) ? std::string(".") : parent_dir(name_or_path);
  // A built-in scene whose model data is absent: say where it was looked for.
  if (find_builtin(name_or_path) && doc.is_object() && doc.contains("models") && doc["models"].is_array()) {
    for (size_t i = 0; i < doc["models"].size(); ++i) {
      const json& m = doc["models"][i];
      if (!m.is_object() || !m.contains("file") || !m["file"].is_string()) continue;
      std::error_code ec;
      const std::string f = m["file"].get<std::string>();
      if (fs::is_regular_file(f, ec)) continue;
      const std::string field = "models[" + std::to_string(i) + "].file";
      // The scene's own file is under the first root (scene_data_file); one set with --set is not.
      const std::vector<std::string> data_roots = scene_data_roots();
      const fs::path rel = fs::path(f).lexically_normal().lexically_relative(fs::path(data_roots.front()).lexically_normal());
      if (rel.empty() || *rel.begin() == "..") throw SceneError(source, field, "'" + f + "' not found");
      std::string roots;
      for (const std::string& r : data_roots) roots += (roots.empty() ? "" : ", ") + r;
      throw SceneError(source, field, rel.generic_string() + " not found in " + roots +
                       ": run scripts/fetch-scenes.sh (downloads Sponza and the Stanford bunny), or set "
                       "$PENUMBRA_SCENES to the folder that holds them");
    }
  }
  try {
    return parse_scene(doc, source, base);
  } catch (const json::exception& e) {  // should not happen: Node checks types first
    throw SceneError(source + ": " + e.what());
  }
}

}  // namespace pn
