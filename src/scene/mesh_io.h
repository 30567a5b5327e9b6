// Wavefront OBJ files: read once by tinyobjloader (read_obj_file) for both of
// the scene's users of them, a "mesh" geometry's triangles (load_obj_triangles)
// and an OBJ model with its MTL materials (model_io.h).
#pragma once

#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include <tiny_obj_loader.h>

#include "core/vec.h"

namespace pn {

// One OBJ file as the loader reads it, polygons fan-triangulated.
struct ObjFile {
  tinyobj::attrib_t attrib;
  std::vector<tinyobj::shape_t> shapes;
  std::vector<tinyobj::material_t> materials;  // its MTL library's, looked up beside the file
  std::string warning;                         // the loader's warnings (a missing .mtl, ...), one a line
};

// Returns false with a one-line reason in *error where `path` is not a regular
// file or the loader cannot read it.
bool read_obj_file(const std::string& path, ObjFile* out, std::string* error);

// Reads the triangles of a Wavefront OBJ file (polygons are fan-triangulated by
// the loader). Returns false with a one-line reason in *error for a missing,
// unreadable or malformed file, out-of-range indices or non-finite coordinates.
bool load_obj_triangles(const std::string& path, std::vector<Vec3>* positions,
                        std::vector<std::array<uint32_t, 3>>* indices, std::string* error);

}  // namespace pn
