// Geometry and lights made by the scene format rather than read from files:
// quads and boxes (geometry "quad", "box"), the "scatter" light (many
// spheres placed by a seeded generator), and the two steps every placed mesh
// takes (add_mesh, add_instance). Internal to scene/ (scene.cpp).
#pragma once

#include <cstdint>
#include <string>

#include "core/transform.h"
#include "scene/json_node.h"
#include "scene/scene.h"

namespace pn::scene_detail {

// A quad of two triangles, corner + s e1 + t e2 for s, t in [0, 1].
TriangleMesh quad_mesh(const std::string& name, Vec3 corner, Vec3 e1, Vec3 e2);
// Axis-aligned box of `size` centred at `center`, rotated about +y by `rot_y`
// degrees, with outward-facing triangles.
TriangleMesh box_mesh(const std::string& name, Vec3 center, Vec3 size, float rot_y);

// Adds a mesh to the scene and returns its index.
uint32_t add_mesh(Scene& s, TriangleMesh m);
// Places mesh `mesh` with `to_world` (its inverse computed here), `material`
// where its faces have none, and `light` >= 0 for a quad light's own instance.
void add_instance(Scene& s, uint32_t mesh, const Affine& to_world, uint32_t material, int32_t light);

// A light of type "scatter": `n` is its object (the format: docs/scene-format.md).
void parse_scatter(const Node& n, Scene& s, uint32_t material);

}  // namespace pn::scene_detail
