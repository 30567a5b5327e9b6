#include "scene/mesh_io.h"

#include <cmath>
#include <filesystem>
#include <sstream>

namespace pn {

bool read_obj_file(const std::string& path, ObjFile* out, std::string* error) {
  std::error_code ec;
  if (!std::filesystem::is_regular_file(path, ec)) {
    *error = "OBJ file '" + path + "' does not exist or is not a file";
    return false;
  }
  tinyobj::ObjReaderConfig config;
  config.triangulate = true;
  config.vertex_color = false;
  config.mtl_search_path = std::filesystem::path(path).parent_path().string();
  tinyobj::ObjReader reader;
  if (!reader.ParseFromFile(path, config)) {
    std::string msg = reader.Error();
    msg = msg.substr(0, msg.find_first_of("\r\n"));  // its first line
    *error = "cannot read OBJ file '" + path + "': " + (msg.empty() ? "parse error" : msg);
    return false;
  }
  out->attrib = reader.GetAttrib();
  out->shapes = reader.GetShapes();
  out->materials = reader.GetMaterials();
  out->warning = reader.Warning();
  return true;
}

bool load_obj_triangles(const std::string& path, std::vector<Vec3>* positions,
                        std::vector<std::array<uint32_t, 3>>* indices, std::string* error) {
  ObjFile obj;
  if (!read_obj_file(path, &obj, error)) return false;
  const auto& attrib = obj.attrib;
  size_t nv = attrib.vertices.size() / 3;
  positions->clear();
  indices->clear();
  positions->reserve(nv);
  for (size_t i = 0; i < nv; ++i) {
    Vec3 p(attrib.vertices[3 * i], attrib.vertices[3 * i + 1], attrib.vertices[3 * i + 2]);
    if (!is_finite(p)) {
      *error = "mesh file '" + path + "': vertex " + std::to_string(i + 1) + " has a non-finite coordinate";
      return false;
    }
    positions->push_back(p);
  }
  for (const auto& shape : obj.shapes) {
    const auto& idx = shape.mesh.indices;
    if (idx.size() % 3 != 0) {
      *error = "mesh file '" + path + "': shape '" + shape.name + "' is not triangulated";
      return false;
    }
    for (size_t f = 0; f < idx.size(); f += 3) {
      std::array<uint32_t, 3> tri;
      for (int k = 0; k < 3; ++k) {
        int vi = idx[f + k].vertex_index;
        if (vi < 0 || size_t(vi) >= nv) {
          *error = "mesh file '" + path + "': face " + std::to_string(f / 3 + 1) + " of shape '" + shape.name +
                   "' uses vertex index " + std::to_string(vi + 1) + " out of range (1.." + std::to_string(nv) + ")";
          return false;
        }
        tri[k] = uint32_t(vi);
      }
      indices->push_back(tri);
    }
  }
  if (indices->empty()) {
    *error = "mesh file '" + path + "' contains no faces";
    return false;
  }
  return true;
}

}  // namespace pn
