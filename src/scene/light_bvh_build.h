// The light BVH's build on the host (the tree itself, its importance and its
// traversal are core/light_bvh.h).
#pragma once

#include <cstddef>
#include <cstdint>
#include <vector>

#include "core/light_bvh.h"
#include "core/lights.h"

namespace pn {

struct LightBvh {
  std::vector<LightBvhNode> nodes;  // flat, depth first: node i's first child is i + 1
  std::vector<uint64_t> trails;     // per light of the scene (core/light_bvh.h); 0: not in the tree
  uint32_t lights = 0;              // lights in the tree
  uint32_t depth = 0;               // edges on the longest root-to-leaf path
  double build_ms = 0;              // wall time of build_light_bvh
  size_t bytes() const { return nodes.size() * sizeof(LightBvhNode) + trails.size() * sizeof(uint64_t); }
};

// Builds the tree over every light with a surface (sphere, quad, triangle) and
// power[i] > 0 (power: luminance of the emitted flux, as power selection uses).
// Splits minimise pbrt-v4's surface-area-orientation heuristic (details and
// shortcuts in light_bvh_build.cpp); ranges whose centroids cannot be told
// apart, and ranges deep enough that the 64-bit trails could overflow, are
// split at the median. The tree does not depend on the number of threads.
LightBvh build_light_bvh(const std::vector<Light>& lights, const std::vector<float>& power);

// The bounds of one light as a leaf: its box, phi, and cone of normals.
LightBvhNode light_leaf_bounds(const Light& l, float phi);

// The union of two nodes' bounds: boxes, powers, and the smallest cone holding
// both cones of normals (widened by 1e-4 rad against rounding).
LightBvhNode union_light_bounds(const LightBvhNode& a, const LightBvhNode& b);

}  // namespace pn
