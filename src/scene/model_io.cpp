// Model files: OBJ + MTL and glTF 2.0 into meshes, materials and textures.
#include "scene/model_io.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <map>
#include <set>
#include <sstream>
#include <unordered_map>

#include <tiny_gltf.h>

#include "io/image_load.h"
#include "scene/mesh_io.h"

namespace pn {
namespace fs = std::filesystem;

namespace {

// Most warnings one model file adds (the rest are counted in one last line).
constexpr size_t kMaxWarningsPerModel = 12;
// Largest element count of any one glTF accessor (and vertex count of an OBJ).
constexpr size_t kMaxElements = size_t(1) << 28;
// Deepest glTF node hierarchy walked (the walk recurses).
constexpr int kMaxNodeDepth = 256;

std::string one_line(std::string s) {
  while (!s.empty() && (s.back() == '\n' || s.back() == '\r' || s.back() == ' ')) s.pop_back();
  for (char& c : s)
    if (c == '\n' || c == '\r') c = ' ';
  return s;
}

std::string first_line(const std::string& s) {
  auto p = s.find('\n');
  return one_line(p == std::string::npos ? s : s.substr(0, p));
}

// Texture paths written on Windows ("textures\\a.jpg", ".\\a.jpg") work here too.
std::string normalize_rel(std::string p) {
  std::replace(p.begin(), p.end(), '\\', '/');
  while (p.rfind("./", 0) == 0) p = p.substr(2);
  return p;
}

std::string url_decode(const std::string& s) {
  std::string out;
  for (size_t i = 0; i < s.size(); ++i) {
    if (s[i] == '%' && i + 2 < s.size() && std::isxdigit((unsigned char)s[i + 1]) && std::isxdigit((unsigned char)s[i + 2])) {
      out += char(std::stoi(s.substr(i + 1, 2), nullptr, 16));
      i += 2;
    } else {
      out += s[i];
    }
  }
  return out;
}

float luminance_of(const float c[3]) { return 0.2126f * c[0] + 0.7152f * c[1] + 0.0722f * c[2]; }

// Common state of one model file being loaded.
struct ModelContext {
  Scene& s;
  std::string path, dir, where, label;  // label: file name, prefix of material names
  size_t warnings = 0;

  ModelContext(Scene& scene, const std::string& p, const std::string& w) : s(scene), path(p), where(w) {
    fs::path fp(p);
    dir = fp.has_parent_path() ? fp.parent_path().string() : std::string(".");
    label = fp.filename().string();
  }
  [[noreturn]] void fail(const std::string& msg) const { throw SceneError(where + ": " + one_line(msg)); }
  void warn(const std::string& msg) {
    ++warnings;
    if (warnings < kMaxWarningsPerModel) s.warnings.push_back(path + ": " + one_line(msg));
    else if (warnings == kMaxWarningsPerModel) s.warnings.push_back(path + ": further warnings not shown");
  }
  // A texture file relative to the model; missing or bad: a warning, -1.
  int32_t texture(const std::string& rel, TexelFormat fmt, const std::string& what) {
    if (rel.empty()) return -1;
    fs::path p(normalize_rel(rel));
    if (p.is_relative()) p = fs::path(dir) / p;
    std::string err;
    int32_t t = scene_texture_file(s, p.lexically_normal().string(), fmt, false, &err);
    if (t < 0) warn("texture '" + rel + "' (" + what + "): " + err + "; using the factor alone");
    return t;
  }
  uint32_t add_material(const std::string& name, const Material& m) {
    s.materials.push_back(m);
    s.material_names.push_back(label + "/" + name);
    return uint32_t(s.materials.size() - 1);
  }
};

Affine affine_from_columns(const double* c) {  // column-major 4x4
  Affine a;
  for (int r = 0; r < 3; ++r)
    for (int k = 0; k < 4; ++k) a.m[4 * r + k] = float(c[4 * k + r]);
  return a;
}

bool affine_finite(const Affine& a) {
  for (float v : a.m)
    if (!std::isfinite(v)) return false;
  return true;
}

// --- OBJ + MTL ---------------------------------------------------------------------

// MTL -> metallic-roughness (docs/scene-format.md):
//   base colour = Kd (x map_Kd); specular = clamp(luminance(Ks) / 0.08, 0, 1);
//   roughness = sqrt(alpha) with the Phong exponent's alpha = sqrt(2 / (Ns + 2));
//   metallic = 0; emission = Ke (x map_Ke; Ke = 1 when only map_Ke is given);
//   d < 1 or map_d: alpha mask with cutoff 0.5 (map_d's luminance becomes the
//   base-colour texture's alpha); norm: a tangent-space normal map.
Material mtl_material(ModelContext& ctx, const tinyobj::material_t& mt) {
  Material m;
  auto fin = [](float v, float lo, float hi, float dflt) { return std::isfinite(v) ? clamp(v, lo, hi) : dflt; };
  m.base_color = Vec3(fin(mt.diffuse[0], 0.f, 1.f, 0.8f), fin(mt.diffuse[1], 0.f, 1.f, 0.8f), fin(mt.diffuse[2], 0.f, 1.f, 0.8f));
  float ks[3] = {fin(mt.specular[0], 0.f, 1.f, 0.f), fin(mt.specular[1], 0.f, 1.f, 0.f), fin(mt.specular[2], 0.f, 1.f, 0.f)};
  m.specular = clamp(luminance_of(ks) / 0.08f, 0.f, 1.f);
  float ns = fin(mt.shininess, 0.f, 1e6f, 0.f);
  m.roughness = std::sqrt(std::sqrt(2.f / (ns + 2.f)));
  m.metallic = 0.f;
  m.emission = Vec3(fin(mt.emission[0], 0.f, 1e9f, 0.f), fin(mt.emission[1], 0.f, 1e9f, 0.f), fin(mt.emission[2], 0.f, 1e9f, 0.f));
  const std::string mname = "material '" + mt.name + "'";
  if (!mt.emissive_texname.empty()) {
    m.emission_tex = ctx.texture(mt.emissive_texname, TexelFormat::Rgba8Srgb, "map_Ke of " + mname);
    if (m.emission_tex >= 0 && is_black(m.emission)) m.emission = Vec3(1.f);
  }
  if (!mt.normal_texname.empty()) {
    m.normal_tex = ctx.texture(mt.normal_texname, TexelFormat::Rgba8Linear, "norm of " + mname);
    if (std::isfinite(mt.normal_texopt.bump_multiplier) && mt.normal_texopt.bump_multiplier > 0.f)
      m.normal_scale = std::min(mt.normal_texopt.bump_multiplier, 10.f);
  }
  const float d = fin(mt.dissolve, 0.f, 1.f, 1.f);
  const bool has_map_d = !mt.alpha_texname.empty();
  if (d < 1.f || has_map_d) {
    m.alpha = d;
    m.alpha_mode = AlphaMode::Mask;
    m.alpha_cutoff = 0.5f;
  }
  if (!has_map_d) {
    m.base_color_tex = ctx.texture(mt.diffuse_texname, TexelFormat::Rgba8Srgb, "map_Kd of " + mname);
    return m;
  }
  // map_d: its luminance becomes the alpha of the base-colour texture (a combined
  // RGBA texture, white RGB when there is no map_Kd), shared like any texture.
  auto resolve = [&](const std::string& rel) {
    fs::path p(normalize_rel(rel));
    if (p.is_relative()) p = fs::path(ctx.dir) / p;
    return p.lexically_normal().string();
  };
  const std::string kd_path = mt.diffuse_texname.empty() ? "" : resolve(mt.diffuse_texname);
  const std::string d_path = resolve(mt.alpha_texname);
  DecodedImage alpha_img;
  std::string err;
  if (!decode_image_file(d_path, false, &alpha_img, &err)) {
    ctx.warn("texture '" + mt.alpha_texname + "' (map_d of " + mname + "): " + err + "; using d alone");
    if (d >= 1.f) m.alpha_mode = AlphaMode::Opaque;
    m.base_color_tex = ctx.texture(mt.diffuse_texname, TexelFormat::Rgba8Srgb, "map_Kd of " + mname);
    return m;
  }
  std::string kd_err;
  const std::string key = kd_path + "|alpha=" + d_path;
  m.base_color_tex = scene_texture(
      ctx.s, key, TexelFormat::Rgba8Srgb, false,
      [&](DecodedImage* out, std::string* e) {
        if (kd_path.empty() || !decode_image_file(kd_path, false, out, e)) {
          if (!kd_path.empty()) ctx.warn("texture '" + mt.diffuse_texname + "' (map_Kd of " + mname + "): " + *e + "; using the factor alone");
          *out = DecodedImage();
          out->width = alpha_img.width;
          out->height = alpha_img.height;
          out->texels.assign(size_t(out->width) * out->height * 4, 255);
        }
        // Alpha = the luminance (times alpha) of map_d, sampled at the nearest texel.
        for (int y = 0; y < out->height; ++y)
          for (int x = 0; x < out->width; ++x) {
            int ax = int((int64_t(x) * alpha_img.width) / out->width), ay = int((int64_t(y) * alpha_img.height) / out->height);
            const uint8_t* a = &alpha_img.texels[(size_t(ay) * alpha_img.width + ax) * 4];
            float lum = (0.2126f * a[0] + 0.7152f * a[1] + 0.0722f * a[2]) * (a[3] / 255.f);
            out->texels[(size_t(y) * out->width + x) * 4 + 3] = uint8_t(std::lround(clamp(lum, 0.f, 255.f)));
          }
        return true;
      },
      &kd_err);
  return m;
}

struct ObjKey {
  int v, t, n;
  bool operator==(const ObjKey& o) const { return v == o.v && t == o.t && n == o.n; }
};
struct ObjKeyHash {
  size_t operator()(const ObjKey& k) const {
    uint64_t h = uint64_t(uint32_t(k.v)) * 0x9E3779B97F4A7C15ull;
    h ^= uint64_t(uint32_t(k.t)) * 0xC2B2AE3D27D4EB4Full + (h << 6) + (h >> 2);
    h ^= uint64_t(uint32_t(k.n)) * 0x165667B19E3779F9ull + (h << 6) + (h >> 2);
    return size_t(h);
  }
};

LoadedModel load_obj(ModelContext& ctx) {
  ObjFile obj;
  std::string error;
  if (!read_obj_file(ctx.path, &obj, &error)) ctx.fail(error);
  {
    std::stringstream ws(obj.warning);
    for (std::string line; std::getline(ws, line);)
      if (!one_line(line).empty()) ctx.warn(line);
  }
  const auto& attrib = obj.attrib;
  const auto& materials = obj.materials;
  const size_t nv = attrib.vertices.size() / 3, nt = attrib.texcoords.size() / 2, nn = attrib.normals.size() / 3;
  if (nv > kMaxElements) ctx.fail("'" + ctx.path + "': too many vertices (" + std::to_string(nv) + ")");

  // Materials: the MTL's, created on first use; faces without one get a default grey.
  std::vector<int64_t> mat_index(materials.size(), -1);
  int64_t default_mat = -1;
  auto material_of = [&](int id) -> uint32_t {
    if (id >= 0 && size_t(id) < materials.size()) {
      if (mat_index[id] < 0) mat_index[id] = ctx.add_material(materials[id].name, mtl_material(ctx, materials[id]));
      return uint32_t(mat_index[id]);
    }
    if (default_mat < 0) {
      Material grey;  // Lambertian grey
      grey.base_color = Vec3(0.7f);
      default_mat = ctx.add_material("(default)", grey);
    }
    return uint32_t(default_mat);
  };
  bool mtllib_missing = materials.empty() && obj.warning.find("Material file") != std::string::npos;
  if (mtllib_missing) ctx.warn("its material library (.mtl) could not be read: faces get a default grey material");

  TriangleMesh mesh;
  mesh.name = ctx.path;
  const bool split = nt > 0 || nn > 0;
  std::unordered_map<ObjKey, uint32_t, ObjKeyHash> remap;
  auto vertex = [&](const tinyobj::index_t& ix, size_t face, const std::string& shape) -> uint32_t {
    int vi = ix.vertex_index;
    if (vi < 0 || size_t(vi) >= nv)
      ctx.fail("'" + ctx.path + "': face " + std::to_string(face + 1) + " of shape '" + shape + "' uses vertex index " +
               std::to_string(vi + 1) + " out of range (1.." + std::to_string(nv) + ")");
    if (!split) return uint32_t(vi);
    int ti = (ix.texcoord_index >= 0 && size_t(ix.texcoord_index) < nt) ? ix.texcoord_index : -1;
    int ni = (ix.normal_index >= 0 && size_t(ix.normal_index) < nn) ? ix.normal_index : -1;
    ObjKey key{vi, ti, ni};
    auto it = remap.find(key);
    if (it != remap.end()) return it->second;
    uint32_t id = uint32_t(mesh.positions.size());
    mesh.positions.push_back(Vec3(attrib.vertices[3 * vi], attrib.vertices[3 * vi + 1], attrib.vertices[3 * vi + 2]));
    if (nt > 0) {
      Vec2 uv;
      if (ti >= 0) uv = Vec2(attrib.texcoords[2 * ti], 1.f - attrib.texcoords[2 * ti + 1]);  // OBJ v up -> image v down
      if (!(std::isfinite(uv.x) && std::isfinite(uv.y))) uv = Vec2();
      mesh.uvs.push_back(uv);
    }
    if (nn > 0) {
      Vec3 n;
      if (ni >= 0) n = Vec3(attrib.normals[3 * ni], attrib.normals[3 * ni + 1], attrib.normals[3 * ni + 2]);
      if (!is_finite(n)) n = Vec3();
      mesh.normals.push_back(n);
    }
    remap.emplace(key, id);
    return id;
  };
  if (!split) {
    mesh.positions.reserve(nv);
    for (size_t i = 0; i < nv; ++i)
      mesh.positions.push_back(Vec3(attrib.vertices[3 * i], attrib.vertices[3 * i + 1], attrib.vertices[3 * i + 2]));
  }
  size_t degenerate = 0;
  for (const auto& shape : obj.shapes) {
    const auto& idx = shape.mesh.indices;
    if (idx.size() % 3 != 0) ctx.fail("'" + ctx.path + "': shape '" + shape.name + "' is not triangulated");
    for (size_t f = 0; f < idx.size() / 3; ++f) {
      std::array<uint32_t, 3> tri;
      for (int k = 0; k < 3; ++k) tri[k] = vertex(idx[3 * f + k], f, shape.name);
      const Vec3 &a = mesh.positions[tri[0]], &b = mesh.positions[tri[1]], &c = mesh.positions[tri[2]];
      if (!(length_sq(cross(b - a, c - a)) > 0.f)) {  // zero area (or repeated vertices): nothing to hit
        ++degenerate;
        continue;
      }
      mesh.indices.push_back(tri);
      int mid = f < shape.mesh.material_ids.size() ? shape.mesh.material_ids[f] : -1;
      mesh.face_materials.push_back(material_of(mid));
    }
  }
  for (const Vec3& p : mesh.positions)
    if (!is_finite(p)) ctx.fail("'" + ctx.path + "': a vertex has a non-finite coordinate");
  if (mesh.indices.empty()) ctx.fail("'" + ctx.path + "' contains no (non-degenerate) faces");
  if (degenerate > 0) ctx.warn(std::to_string(degenerate) + " degenerate triangle(s) dropped");
  LoadedModel out;
  out.path = ctx.path;
  ctx.s.meshes.push_back(std::move(mesh));
  out.meshes.push_back(uint32_t(ctx.s.meshes.size() - 1));
  out.placements.push_back(ModelPlacement{out.meshes[0], Affine()});
  return out;
}

// --- glTF 2.0 ------------------------------------------------------------------------

// tinygltf reads whatever path a buffer or image URI names once it can open it:
// a folder gives a size of 2^63 - 1 and an allocation of that much (found by
// fuzz_gltf). Only regular files are read; anything else is a one-line error.
bool read_regular_file(std::vector<unsigned char>* out, std::string* err, const std::string& path, void* user) {
  std::error_code ec;
  if (!fs::is_regular_file(path, ec)) {
    if (err) *err += "not a regular file: " + path + "\n";
    return false;
  }
  return tinygltf::ReadWholeFile(out, err, path, user);
}

// tinygltf hands embedded images (data URIs, .glb buffer views) to this loader;
// it keeps the encoded bytes, decoded later only if a material uses them.
// External image files are not read by tinygltf (TINYGLTF_NO_EXTERNAL_IMAGE).
bool keep_encoded_image(tinygltf::Image* image, const int, std::string*, std::string*, int, int,
                        const unsigned char* bytes, int size, void*) {
  if (bytes && size > 0) image->image.assign(bytes, bytes + size);
  image->width = image->height = image->component = image->bits = 0;
  return true;
}

// Validated view of an accessor's elements.
struct Accessor {
  const uint8_t* base = nullptr;
  size_t stride = 0, count = 0;
  int comp_type = 0, ncomp = 0;
  bool normalized = false;

  float get(size_t i, int c) const {
    const uint8_t* p = base + i * stride;
    switch (comp_type) {
      case TINYGLTF_COMPONENT_TYPE_FLOAT: { float v; std::memcpy(&v, p + 4 * c, 4); return v; }
      case TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE: { float v = p[c]; return normalized ? v / 255.f : v; }
      case TINYGLTF_COMPONENT_TYPE_BYTE: { float v = float(int8_t(p[c])); return normalized ? std::max(v / 127.f, -1.f) : v; }
      case TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT: { uint16_t v; std::memcpy(&v, p + 2 * c, 2); return normalized ? v / 65535.f : float(v); }
      case TINYGLTF_COMPONENT_TYPE_SHORT: { int16_t v; std::memcpy(&v, p + 2 * c, 2); return normalized ? std::max(v / 32767.f, -1.f) : float(v); }
      case TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT: { uint32_t v; std::memcpy(&v, p + 4 * c, 4); return float(v); }
      default: return 0.f;
    }
  }
  uint32_t index(size_t i) const {
    const uint8_t* p = base + i * stride;
    switch (comp_type) {
      case TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE: return p[0];
      case TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT: { uint16_t v; std::memcpy(&v, p, 2); return v; }
      case TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT: { uint32_t v; std::memcpy(&v, p, 4); return v; }
      default: return 0xFFFFFFFFu;
    }
  }
};

struct GltfLoader {
  explicit GltfLoader(ModelContext& c) : ctx(c) {}
  ModelContext& ctx;
  tinygltf::Model model;
  std::map<int, uint32_t> materials;    // glTF material -> scene material
  std::map<int, int64_t> meshes;        // glTF mesh -> scene mesh (-1: no triangles)
  std::map<std::pair<int, int>, int32_t> textures;  // (glTF texture, format) -> scene texture
  bool warned_blend = false;
  size_t degenerate = 0;  // zero-area triangles dropped, over all meshes
  uint64_t placed_triangles = 0;  // over all placements so far

  // Accessor `ai`, checked against its buffer; `what` names it in messages.
  Accessor accessor(int ai, std::initializer_list<int> types, std::initializer_list<int> comps, const std::string& what) {
    if (ai < 0 || size_t(ai) >= model.accessors.size()) ctx.fail(what + ": accessor " + std::to_string(ai) + " does not exist");
    const tinygltf::Accessor& a = model.accessors[size_t(ai)];
    const std::string name = what + " (accessor " + std::to_string(ai) + ")";
    if (std::find(types.begin(), types.end(), a.type) == types.end()) ctx.fail(name + ": unexpected element type");
    if (std::find(comps.begin(), comps.end(), a.componentType) == comps.end())
      ctx.fail(name + ": unexpected component type " + std::to_string(a.componentType));
    if (a.sparse.isSparse) ctx.fail(name + ": sparse accessors are not supported");
    Accessor r;
    r.comp_type = a.componentType;
    r.ncomp = tinygltf::GetNumComponentsInType(uint32_t(a.type));
    r.normalized = a.normalized;
    r.count = size_t(a.count);
    if (r.count > kMaxElements) ctx.fail(name + ": claims " + std::to_string(a.count) + " elements (more than penumbra accepts)");
    if (r.count == 0) return r;
    if (a.bufferView < 0 || size_t(a.bufferView) >= model.bufferViews.size())
      ctx.fail(name + ": has no valid bufferView");
    const tinygltf::BufferView& bv = model.bufferViews[size_t(a.bufferView)];
    if (bv.buffer < 0 || size_t(bv.buffer) >= model.buffers.size()) ctx.fail(name + ": its bufferView has no valid buffer");
    const tinygltf::Buffer& buf = model.buffers[size_t(bv.buffer)];
    const int csize = tinygltf::GetComponentSizeInBytes(uint32_t(a.componentType));
    if (r.ncomp <= 0 || csize <= 0) ctx.fail(name + ": invalid type");
    const uint64_t elem = uint64_t(csize) * uint64_t(r.ncomp);
    r.stride = bv.byteStride ? size_t(bv.byteStride) : size_t(elem);
    if (r.stride < elem) ctx.fail(name + ": byteStride smaller than an element");
    const uint64_t need = uint64_t(a.byteOffset) + uint64_t(r.stride) * (r.count - 1) + elem;
    if (uint64_t(bv.byteOffset) + uint64_t(bv.byteLength) > uint64_t(buf.data.size()) ||
        uint64_t(bv.byteOffset) > uint64_t(buf.data.size()) || uint64_t(bv.byteLength) > uint64_t(buf.data.size()))
      ctx.fail(name + ": bufferView " + std::to_string(a.bufferView) + " extends beyond its buffer (" +
               std::to_string(buf.data.size()) + " bytes)");
    if (need > uint64_t(bv.byteLength))
      ctx.fail(name + ": " + std::to_string(a.count) + " elements need " + std::to_string(need) +
               " bytes, more than its bufferView's " + std::to_string(bv.byteLength));
    r.base = buf.data.data() + bv.byteOffset + a.byteOffset;
    return r;
  }

  int32_t texture(int ti, TexelFormat fmt, const std::string& what) {
    if (ti < 0) return -1;
    auto key = std::make_pair(ti, int(fmt));
    auto it = textures.find(key);
    if (it != textures.end()) return it->second;
    int32_t result = -1;
    if (size_t(ti) >= model.textures.size()) {
      ctx.warn(what + ": texture " + std::to_string(ti) + " does not exist; using the factor alone");
    } else {
      const int src = model.textures[size_t(ti)].source;
      if (src < 0 || size_t(src) >= model.images.size()) {
        ctx.warn(what + ": texture " + std::to_string(ti) + " has no supported image source; using the factor alone");
      } else {
        const tinygltf::Image& img = model.images[size_t(src)];
        if (!img.image.empty()) {  // embedded (data URI or .glb buffer view)
          std::string err;
          const std::vector<unsigned char>& bytes = img.image;
          result = scene_texture(ctx.s, ctx.path + "#image" + std::to_string(src), fmt, false,
                                 [&](DecodedImage* out, std::string* e) {
                                   return decode_image_memory(bytes.data(), bytes.size(), false, out, e);
                                 },
                                 &err);
          if (result < 0) ctx.warn(what + ": embedded image " + std::to_string(src) + ": " + err + "; using the factor alone");
        } else if (!img.uri.empty()) {
          result = ctx.texture(url_decode(img.uri), fmt, what);
        } else {
          ctx.warn(what + ": image " + std::to_string(src) + " has no data; using the factor alone");
        }
      }
    }
    textures[key] = result;
    return result;
  }

  uint32_t material(int mi) {
    auto it = materials.find(mi);
    if (it != materials.end()) return it->second;
    Material m;  // glTF's default material: white, metallic 1, roughness 1
    m.base_color = Vec3(1.f);
    m.metallic = 1.f;
    m.roughness = 1.f;
    m.specular = 0.5f;
    std::string name = "(default)";
    if (mi >= 0 && size_t(mi) < model.materials.size()) {
      const tinygltf::Material& g = model.materials[size_t(mi)];
      name = g.name.empty() ? "material" + std::to_string(mi) : g.name;
      const std::string what = "material '" + name + "'";
      auto f = [](double v, float lo, float hi, float dflt) { return std::isfinite(v) ? clamp(float(v), lo, hi) : dflt; };
      const auto& pbr = g.pbrMetallicRoughness;
      if (pbr.baseColorFactor.size() == 4) {
        m.base_color = Vec3(f(pbr.baseColorFactor[0], 0, 1, 1), f(pbr.baseColorFactor[1], 0, 1, 1), f(pbr.baseColorFactor[2], 0, 1, 1));
        m.alpha = f(pbr.baseColorFactor[3], 0, 1, 1);
      }
      m.metallic = f(pbr.metallicFactor, 0, 1, 1);
      m.roughness = f(pbr.roughnessFactor, 0, 1, 1);
      m.base_color_tex = texture(pbr.baseColorTexture.index, TexelFormat::Rgba8Srgb, what + " baseColorTexture");
      m.metallic_roughness_tex = texture(pbr.metallicRoughnessTexture.index, TexelFormat::Rgba8Linear, what + " metallicRoughnessTexture");
      m.normal_tex = texture(g.normalTexture.index, TexelFormat::Rgba8Linear, what + " normalTexture");
      m.normal_scale = f(g.normalTexture.scale, -10, 10, 1);
      if (g.emissiveFactor.size() == 3)
        m.emission = Vec3(f(g.emissiveFactor[0], 0, 1, 0), f(g.emissiveFactor[1], 0, 1, 0), f(g.emissiveFactor[2], 0, 1, 0));
      auto ext = g.extensions.find("KHR_materials_emissive_strength");
      if (ext != g.extensions.end() && ext->second.IsObject() && ext->second.Has("emissiveStrength")) {
        const tinygltf::Value& v = ext->second.Get("emissiveStrength");
        if (v.IsNumber()) m.emission = m.emission * f(v.GetNumberAsDouble(), 0, 1e6f, 1);
      }
      m.emission_tex = texture(g.emissiveTexture.index, TexelFormat::Rgba8Srgb, what + " emissiveTexture");
      for (const auto* info : {&pbr.baseColorTexture, &pbr.metallicRoughnessTexture, &g.emissiveTexture})
        if (info->index >= 0 && info->texCoord != 0) ctx.warn(what + ": uses TEXCOORD_" + std::to_string(info->texCoord) + "; penumbra reads TEXCOORD_0");
      if (g.alphaMode == "MASK") {
        m.alpha_mode = AlphaMode::Mask;
        m.alpha_cutoff = f(g.alphaCutoff, 0, 1, 0.5f);
      } else if (g.alphaMode == "BLEND") {
        m.alpha_mode = AlphaMode::Mask;
        m.alpha_cutoff = 0.5f;
        if (!warned_blend) ctx.warn(what + ": alphaMode BLEND is rendered as MASK with cutoff 0.5");
        warned_blend = true;
      }
    }
    uint32_t idx = ctx.add_material(name, m);
    materials[mi] = idx;
    return idx;
  }

  // glTF mesh -> one scene mesh (its triangle primitives merged), or -1.
  int64_t mesh(int gi) {
    auto it = meshes.find(gi);
    if (it != meshes.end()) return it->second;
    const tinygltf::Mesh& gm = model.meshes[size_t(gi)];
    const std::string mname = "mesh " + std::to_string(gi) + (gm.name.empty() ? "" : " '" + gm.name + "'");
    TriangleMesh m;
    m.name = ctx.path + "#" + (gm.name.empty() ? std::to_string(gi) : gm.name);
    bool any_normals = false, any_uvs = false;
    for (const auto& p : gm.primitives) {
      any_normals = any_normals || p.attributes.count("NORMAL");
      any_uvs = any_uvs || p.attributes.count("TEXCOORD_0");
    }
    for (size_t pi = 0; pi < gm.primitives.size(); ++pi) {
      const tinygltf::Primitive& p = gm.primitives[pi];
      const std::string what = "'" + ctx.path + "': " + mname + " primitive " + std::to_string(pi);
      if (p.mode != TINYGLTF_MODE_TRIANGLES && p.mode != -1) {
        ctx.warn(mname + " primitive " + std::to_string(pi) + ": mode " + std::to_string(p.mode) + " is not triangles; skipped");
        continue;
      }
      auto pos_it = p.attributes.find("POSITION");
      if (pos_it == p.attributes.end()) {
        ctx.warn(mname + " primitive " + std::to_string(pi) + ": no POSITION; skipped");
        continue;
      }
      Accessor pos = accessor(pos_it->second, {TINYGLTF_TYPE_VEC3}, {TINYGLTF_COMPONENT_TYPE_FLOAT}, what + " POSITION");
      const size_t nv = pos.count, base = m.positions.size();
      if (base + nv > kMaxElements) ctx.fail(what + ": too many vertices");
      for (size_t i = 0; i < nv; ++i) {
        Vec3 v(pos.get(i, 0), pos.get(i, 1), pos.get(i, 2));
        if (!is_finite(v) || std::fabs(v.x) > 1e7f || std::fabs(v.y) > 1e7f || std::fabs(v.z) > 1e7f)
          ctx.fail(what + ": vertex " + std::to_string(i) + " has a non-finite or huge coordinate");
        m.positions.push_back(v);
      }
      if (any_normals) {
        auto n_it = p.attributes.find("NORMAL");
        if (n_it != p.attributes.end()) {
          Accessor n = accessor(n_it->second, {TINYGLTF_TYPE_VEC3}, {TINYGLTF_COMPONENT_TYPE_FLOAT}, what + " NORMAL");
          if (n.count != nv) ctx.fail(what + ": NORMAL has " + std::to_string(n.count) + " elements, POSITION " + std::to_string(nv));
          for (size_t i = 0; i < nv; ++i) {
            Vec3 v(n.get(i, 0), n.get(i, 1), n.get(i, 2));
            m.normals.push_back(is_finite(v) ? v : Vec3());
          }
        } else {
          m.normals.resize(m.positions.size(), Vec3());
        }
      }
      if (any_uvs) {
        auto t_it = p.attributes.find("TEXCOORD_0");
        if (t_it != p.attributes.end()) {
          Accessor t = accessor(t_it->second, {TINYGLTF_TYPE_VEC2},
                                {TINYGLTF_COMPONENT_TYPE_FLOAT, TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE, TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT},
                                what + " TEXCOORD_0");
          if (t.count != nv) ctx.fail(what + ": TEXCOORD_0 has " + std::to_string(t.count) + " elements, POSITION " + std::to_string(nv));
          for (size_t i = 0; i < nv; ++i) {
            Vec2 uv(t.get(i, 0), t.get(i, 1));  // glTF is already in image convention
            m.uvs.push_back(std::isfinite(uv.x) && std::isfinite(uv.y) ? uv : Vec2());
          }
        } else {
          m.uvs.resize(m.positions.size(), Vec2());
        }
      }
      const uint32_t mat = material(p.material);
      std::vector<uint32_t> idx;
      if (p.indices >= 0) {
        Accessor ia = accessor(p.indices, {TINYGLTF_TYPE_SCALAR},
                               {TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE, TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT, TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT},
                               what + " indices");
        idx.resize(ia.count);
        for (size_t i = 0; i < ia.count; ++i) {
          idx[i] = ia.index(i);
          if (idx[i] >= nv)
            ctx.fail(what + ": index " + std::to_string(idx[i]) + " out of range (" + std::to_string(nv) + " vertices)");
        }
      } else {
        idx.resize(nv);
        for (size_t i = 0; i < nv; ++i) idx[i] = uint32_t(i);
      }
      if (idx.size() % 3 != 0) ctx.warn(mname + " primitive " + std::to_string(pi) + ": index count not a multiple of 3; the rest ignored");
      for (size_t f = 0; f + 2 < idx.size(); f += 3) {
        std::array<uint32_t, 3> tri = {uint32_t(base + idx[f]), uint32_t(base + idx[f + 1]), uint32_t(base + idx[f + 2])};
        const Vec3 &a = m.positions[tri[0]], &b = m.positions[tri[1]], &c = m.positions[tri[2]];
        if (!(length_sq(cross(b - a, c - a)) > 0.f)) {
          ++degenerate;
          continue;
        }
        m.indices.push_back(tri);
        m.face_materials.push_back(mat);
      }
    }
    int64_t result = -1;
    if (!m.indices.empty()) {
      ctx.s.meshes.push_back(std::move(m));
      result = int64_t(ctx.s.meshes.size() - 1);
    }
    meshes[gi] = result;
    return result;
  }

  static Affine node_local(const tinygltf::Node& n) {
    if (n.matrix.size() == 16) return affine_from_columns(n.matrix.data());
    Affine t;
    if (n.scale.size() == 3) t = scaling(Vec3(float(n.scale[0]), float(n.scale[1]), float(n.scale[2])));
    if (n.rotation.size() == 4) {
      double x = n.rotation[0], y = n.rotation[1], z = n.rotation[2], w = n.rotation[3];
      double len = std::sqrt(x * x + y * y + z * z + w * w);
      if (len > 0 && std::isfinite(len)) {
        x /= len, y /= len, z /= len, w /= len;
        Affine r;
        r.m[0] = float(1 - 2 * (y * y + z * z)), r.m[1] = float(2 * (x * y - z * w)), r.m[2] = float(2 * (x * z + y * w));
        r.m[4] = float(2 * (x * y + z * w)), r.m[5] = float(1 - 2 * (x * x + z * z)), r.m[6] = float(2 * (y * z - x * w));
        r.m[8] = float(2 * (x * z - y * w)), r.m[9] = float(2 * (y * z + x * w)), r.m[10] = float(1 - 2 * (x * x + y * y));
        t = compose(r, t);
      }
    }
    if (n.translation.size() == 3)
      t = compose(translation(Vec3(float(n.translation[0]), float(n.translation[1]), float(n.translation[2]))), t);
    return t;
  }

  // The node hierarchy must be a forest (glTF 2.0: every node has at most one
  // parent, no cycles, and a scene lists only roots). Checked before the walk,
  // so that the walk visits each node at most once: a small file whose nodes
  // list the same children over and over cannot expand into billions of
  // placements. Returns the parent of each node (-1: none).
  std::vector<int> check_forest() {
    const size_t n = model.nodes.size();
    std::vector<int> parent(n, -1);
    auto node = [](size_t i) { return "node " + std::to_string(i); };
    for (size_t p = 0; p < n; ++p)
      for (int c : model.nodes[p].children) {
        if (c < 0 || size_t(c) >= n)
          ctx.fail("'" + ctx.path + "': " + node(p) + " lists child " + std::to_string(c) + ", which does not exist");
        if (parent[size_t(c)] == int(p))
          ctx.fail("'" + ctx.path + "': " + node(p) + " lists child " + std::to_string(c) + " twice");
        if (parent[size_t(c)] >= 0)
          ctx.fail("'" + ctx.path + "': " + node(size_t(c)) + " has two parents (nodes " +
                   std::to_string(parent[size_t(c)]) + " and " + std::to_string(p) +
                   "): the node hierarchy must be a tree (penumbra does not instance a node twice)");
        parent[size_t(c)] = int(p);
      }
    // With one parent each, a cycle is a closed chain of parents.
    std::vector<uint8_t> state(n, 0);  // 0: not seen, 1: on the current chain, 2: done
    std::vector<size_t> chain;
    for (size_t i = 0; i < n; ++i) {
      chain.clear();
      int k = int(i);
      while (k >= 0 && state[size_t(k)] == 0) {
        state[size_t(k)] = 1;
        chain.push_back(size_t(k));
        k = parent[size_t(k)];
      }
      if (k >= 0 && state[size_t(k)] == 1)
        ctx.fail("'" + ctx.path + "': the node hierarchy has a cycle through " + node(size_t(k)));
      for (size_t c : chain) state[c] = 2;
    }
    return parent;
  }

  void visit(int ni, const Affine& parent, int depth, LoadedModel& out) {
    if (ni < 0 || size_t(ni) >= model.nodes.size()) ctx.fail("'" + ctx.path + "': node " + std::to_string(ni) + " does not exist");
    if (depth > kMaxNodeDepth)
      ctx.fail("'" + ctx.path + "': node " + std::to_string(ni) + " is deeper than " + std::to_string(kMaxNodeDepth) +
               " levels in the node hierarchy");
    const tinygltf::Node& n = model.nodes[size_t(ni)];
    const Affine world = compose(parent, node_local(n));
    if (n.mesh >= 0) {
      if (size_t(n.mesh) >= model.meshes.size()) ctx.fail("'" + ctx.path + "': node " + std::to_string(ni) + " uses mesh " + std::to_string(n.mesh) + " which does not exist");
      int64_t mi = mesh(n.mesh);
      bool ok = false;
      inverse(world, &ok);
      if (mi >= 0 && (!ok || !affine_finite(world))) {
        ctx.warn("node " + std::to_string(ni) + ": its transform is not invertible or not finite; skipped");
      } else if (mi >= 0) {
        out.placements.push_back(ModelPlacement{uint32_t(mi), world});
        placed_triangles += ctx.s.meshes[size_t(mi)].indices.size();
        if (out.placements.size() > kMaxInstances)
          ctx.fail("'" + ctx.path + "': node " + std::to_string(ni) + ": more than " + std::to_string(kMaxInstances) +
                   " mesh placements, penumbra's limit");
        if (placed_triangles > kMaxPlacedTriangles)
          ctx.fail("'" + ctx.path + "': node " + std::to_string(ni) + ": more than " +
                   std::to_string(kMaxPlacedTriangles) + " triangles placed, penumbra's limit");
      }
    }
    if (n.camera >= 0 && !out.has_camera && size_t(n.camera) < model.cameras.size() &&
        model.cameras[size_t(n.camera)].type == "perspective") {
      const auto& c = model.cameras[size_t(n.camera)].perspective;
      Vec3 eye = world.point(Vec3(0.f)), fwd = world.vector(Vec3(0.f, 0.f, -1.f)), up = world.vector(Vec3(0.f, 1.f, 0.f));
      float fov = float(c.yfov * 180.0 / kPi);
      if (is_finite(eye) && length(fwd) > 0.f && length(cross(normalize(fwd), up)) > 1e-4f && fov > 0.1f && fov < 179.f) {
        out.has_camera = true;
        out.camera.eye = eye;
        out.camera.target = eye + normalize(fwd);
        out.camera.up = normalize(up);
        out.camera.fov = fov;
      }
    }
    for (int child : n.children) visit(child, world, depth + 1, out);
  }

  LoadedModel load() {
    tinygltf::TinyGLTF loader;
    loader.SetImageLoader(keep_encoded_image, nullptr);
    loader.SetFsCallbacks({&tinygltf::FileExists, &tinygltf::ExpandFilePath, &read_regular_file,
                           &tinygltf::WriteWholeFile, nullptr});
    std::string err, warn;
    std::string ext = fs::path(ctx.path).extension().string();
    std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return char(std::tolower(c)); });
    bool ok = ext == ".glb" ? loader.LoadBinaryFromFile(&model, &err, &warn, ctx.path)
                            : loader.LoadASCIIFromFile(&model, &err, &warn, ctx.path);
    if (!ok || !err.empty()) {
      std::string msg = first_line(err.empty() ? warn : err);
      ctx.fail("cannot read glTF file '" + ctx.path + "': " + (msg.empty() ? "parse error" : msg));
    }
    {
      std::stringstream ws(warn);
      for (std::string line; std::getline(ws, line);)
        if (!one_line(line).empty()) ctx.warn(line);
    }
    static const std::set<std::string> kSupported = {"KHR_materials_emissive_strength", "KHR_texture_transform",
                                                     "KHR_materials_specular", "KHR_materials_ior"};
    for (const std::string& e : model.extensionsRequired)
      if (!kSupported.count(e)) ctx.fail("'" + ctx.path + "' requires the glTF extension " + e + ", which penumbra does not support");
    LoadedModel out;
    out.path = ctx.path;
    const std::vector<int> parent = check_forest();
    std::vector<int> roots;
    if (!model.scenes.empty()) {
      int si = model.defaultScene >= 0 && size_t(model.defaultScene) < model.scenes.size() ? model.defaultScene : 0;
      roots = model.scenes[size_t(si)].nodes;
      std::vector<bool> listed(model.nodes.size(), false);
      for (int r : roots) {
        if (r < 0 || size_t(r) >= model.nodes.size())
          ctx.fail("'" + ctx.path + "': scene " + std::to_string(si) + " lists node " + std::to_string(r) +
                   ", which does not exist");
        if (parent[size_t(r)] >= 0)
          ctx.fail("'" + ctx.path + "': scene " + std::to_string(si) + " lists node " + std::to_string(r) +
                   " as a root, but it is a child of node " + std::to_string(parent[size_t(r)]));
        if (listed[size_t(r)])
          ctx.fail("'" + ctx.path + "': scene " + std::to_string(si) + " lists node " + std::to_string(r) + " twice");
        listed[size_t(r)] = true;
      }
    } else {  // no scene: every node that is nobody's child
      for (size_t i = 0; i < model.nodes.size(); ++i)
        if (parent[i] < 0) roots.push_back(int(i));
    }
    for (int r : roots) visit(r, Affine(), 0, out);
    if (degenerate > 0) ctx.warn(std::to_string(degenerate) + " degenerate (zero-area) triangle(s) dropped");
    for (const auto& kv : meshes)
      if (kv.second >= 0) out.meshes.push_back(uint32_t(kv.second));
    if (out.placements.empty()) ctx.fail("'" + ctx.path + "' has no node with a triangle mesh");
    return out;
  }
};

}  // namespace

int32_t scene_texture(Scene& s, const std::string& key, TexelFormat format, bool nearest,
                      const std::function<bool(DecodedImage*, std::string*)>& decode, std::string* error) {
  for (size_t i = 0; i < s.textures.size(); ++i)
    if (s.textures[i].path == key && s.textures[i].format == format && s.textures[i].nearest == nearest)
      return int32_t(i);
  DecodedImage img;
  if (!decode(&img, error)) return -1;
  const bool want_float = format == TexelFormat::Rgba32f;
  if (img.is_float != want_float || img.width <= 0 || img.height <= 0) {
    *error = "unexpected pixel format";
    return -1;
  }
  if (img.repaired_texels > 0)
    s.warnings.push_back(key + ": " + std::to_string(img.repaired_texels) + " of " +
                         std::to_string(size_t(img.width) * size_t(img.height)) +
                         " texels are NaN, infinite or negative; those channels are treated as 0");
  TextureImage t;
  t.path = key;
  t.width = img.width;
  t.height = img.height;
  t.format = format;
  t.nearest = nearest;
  t.texels = std::move(img.texels);
  s.textures.push_back(std::move(t));
  return int32_t(s.textures.size() - 1);
}

int32_t scene_texture_file(Scene& s, const std::string& path, TexelFormat format, bool nearest, std::string* error) {
  return scene_texture(s, path, format, nearest,
                       [&](DecodedImage* out, std::string* e) {
                         std::error_code ec;
                         if (!fs::is_regular_file(path, ec)) {
                           *e = "file '" + path + "' not found";
                           return false;
                         }
                         if (!decode_image_file(path, format == TexelFormat::Rgba32f, out, e)) {
                           *e = "'" + path + "': " + *e;
                           return false;
                         }
                         return true;
                       },
                       error);
}

LoadedModel load_model(Scene& s, const std::string& path, const std::string& where) {
  ModelContext ctx(s, path, where);
  std::error_code ec;
  if (!fs::is_regular_file(path, ec)) ctx.fail("model file '" + path + "' does not exist or is not a file");
  std::string ext = fs::path(path).extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return char(std::tolower(c)); });
  if (ext == ".obj") return load_obj(ctx);
  if (ext == ".gltf" || ext == ".glb") {
    GltfLoader g(ctx);
    return g.load();
  }
  ctx.fail("model file '" + path + "': unknown format '" + ext + "' (expected .obj, .gltf or .glb)");
}

}  // namespace pn
