// How the cuda traversal's kernels trace a scene: which of bvh_traverse.h's forms they are compiled in, for
// closest-hit and for shadow rays, chosen once for a BVH on the host (CudaTraversal). Host code, header-only (the
// CPU tests check the choice; the CUDA trace library and the CPU library both use it).
#pragma once

#include <string>

#include "backends/cuda/bvh_traverse.h"
#include "backends/trace_stage.h"
#include "render/gpu_tuning.h"

namespace pn {

// The forms (bvh_traverse.h's kBvhFlat | kBvhIfIf | kBvhFmaBox bits) for closest-hit and for shadow rays, and
// why in a few words. By default kBvhFlat where the scene is flat (BvhView::flat); the if-if loop for both where
// rays are long (BvhStats::sah_visits_per_ray at least kIfIfMinVisits), else while-while; the one-FMA box test
// for shadow rays in flat scenes. For measurements, GpuTuning (--tune): cuda_loop = auto | while | ifif,
// cuda_box = auto | slab | fma (fma: both kinds of rays), cuda_flat = false (the general form).
struct CudaTraceForms {
  int closest = 0;
  int shadow = 0;
  std::string reason;  // "if-if loop (auto: rays visit 46.4 nodes, at least 24), flat scene, FMA box test for ..."
};
// Measured on the H200 (commit 62b61c2; its docs/results are in git history): random rays in Sponza (46 visits)
// with the flat form, while-while -> if-if, ms for 4.2M closest / shadow 1.62 / 1.52 -> 1.42 / 1.26; in cornell-sphere
// (9.4 visits) 0.62 / 0.36 -> 0.66 / 0.40. The FMA box test for shadow rays: Sponza 1.63 -> 1.52 (while-while),
// cornell-sphere 0.385 -> 0.363; in the general form it spills, and occlusion and bunnies lost 2% at 1080p.
constexpr double kIfIfMinVisits = 24.0;

// The choice for a BVH whose view is `flat` (BvhView::flat) and whose rays visit `sah_visits_per_ray` nodes, as
// `tuning`'s cuda_loop, cuda_box and cuda_flat say.
inline CudaTraceForms choose_trace_forms(bool flat, double sah_visits_per_ray, const GpuTuning& tuning) {
  CudaTraceForms f;
  std::string why = tuning.cuda_loop == CudaLoop::IfIf ? "cuda_loop=ifif" : "cuda_loop=while";
  const bool if_if = tuning.cuda_loop == CudaLoop::Auto ? rays_are_long(sah_visits_per_ray, kIfIfMinVisits, &why)
                                                         : tuning.cuda_loop == CudaLoop::IfIf;
  f.reason = std::string(if_if ? "if-if" : "while-while") + " loop (" + why + ")";
  if (if_if) f.closest = f.shadow = kBvhIfIf;
  if (flat && tuning.cuda_flat) {
    f.closest |= kBvhFlat;
    f.shadow |= kBvhFlat;
    f.reason += ", flat scene";
  } else {
    f.reason += flat ? ", general form (cuda_flat=false)" : ", general form";
  }
  // The FMA box test keeps o / d's products live beside o: where the flat form frees registers, shadow rays gain
  // by it; closest hits (more state) and the general form spill for it and lose.
  const CudaBox box = tuning.cuda_box;
  const bool fma_shadow = box == CudaBox::Auto ? (f.shadow & kBvhFlat) != 0 : box == CudaBox::Fma;
  if (fma_shadow) f.shadow |= kBvhFmaBox;
  if (box == CudaBox::Fma) f.closest |= kBvhFmaBox;
  f.reason += box == CudaBox::Slab  ? ", subtract-multiply box test (cuda_box=slab)"
              : box == CudaBox::Fma ? ", FMA box test (cuda_box=fma)"
              : fma_shadow          ? ", FMA box test for shadow rays"
                                    : ", subtract-multiply box test";
  return f;
}

}  // namespace pn
