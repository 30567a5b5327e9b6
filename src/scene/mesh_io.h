// Triangle meshes from files.
#pragma once

#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include "core/vec.h"

namespace pn {

// Reads the triangles of a Wavefront OBJ file (polygons are fan-triangulated by
// the loader). Returns false with a one-line reason in *error for a missing,
// unreadable or malformed file, out-of-range indices or non-finite coordinates.
bool load_obj_triangles(const std::string& path, std::vector<Vec3>* positions,
                        std::vector<std::array<uint32_t, 3>>* indices, std::string* error);

}  // namespace pn
