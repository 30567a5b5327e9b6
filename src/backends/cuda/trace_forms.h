// How the cuda traversal's kernels trace a scene: which of bvh_traverse.h's forms they are compiled in, for
// closest-hit and for shadow rays, chosen once for a BVH on the host (CudaTraversal). Host code: the CPU tests
// check the choice.
#pragma once

#include <string>

namespace pn {

// The forms (bvh_traverse.h's kBvhFlat | kBvhIfIf | kBvhFmaBox bits) for closest-hit and for shadow rays, and
// why in a few words. By default kBvhFlat where the scene is flat (BvhView::flat); the if-if loop for both where
// rays are long (BvhStats::sah_visits_per_ray at least kIfIfMinVisits), else while-while; the one-FMA box test
// for shadow rays in flat scenes. For measurements:
// PENUMBRA_CUDA_LOOP = auto | while | ifif, PENUMBRA_CUDA_BOX = auto | slab | fma (fma: both kinds of rays),
// PENUMBRA_CUDA_FLAT = 0 (the general form). Another value is an error naming the variable.
struct CudaTraceForms {
  int closest = 0;
  int shadow = 0;
  std::string reason;  // "if-if loop (auto: rays visit 46.4 nodes, at least 24), flat scene, FMA box test for ..."
};
CudaTraceForms choose_trace_forms(bool flat, double sah_visits_per_ray);
// Measured on the H200 (session 30, docs/results/h200-session30): random rays in Sponza (46 visits) with the
// flat form, while-while -> if-if, ms for 4.2M closest / shadow 1.62 / 1.52 -> 1.42 / 1.26; in cornell-sphere
// (9.4 visits) 0.62 / 0.36 -> 0.66 / 0.40. The FMA box test for shadow rays: Sponza 1.63 -> 1.52 (while-while),
// cornell-sphere 0.385 -> 0.363; in the general form it spills, and occlusion and bunnies lost 2% at 1080p.
constexpr double kIfIfMinVisits = 24.0;

}  // namespace pn
