// ReSTIR DI's frame-level passes (Bitterli et al. 2020, "Spatiotemporal
// reservoir resampling for real-time ray tracing with dynamic direct lighting"),
// run by the backends over a whole frame, one camera sample per pixel at a time:
//
//   1. primary: every pixel's camera path (core/integrator.h, the step
//      functions with a RestirPrimaryOut): its first vertex's M candidates
//      resampled into a reservoir (reservoir_before_visibility, W set by its
//      shadow query), the rest of the path's radiance kept aside;
//   2. spatial (spatial_passes times): every pixel combines its reservoir with
//      those of k random neighbours within the radius (restir_spatial_reuse);
//   3. shade: every pixel's direct light from its final reservoir, weighted by
//      MIS against the BSDF sample that the path took (restir_shade).
// The CPU backend runs them with threads over tiles, the OptiX backend as
// launches of their own raygen programs; both call these functions.
//
// Combination (the paper's Algorithm 6, unbiased with 1/Z): reservoirs r_i with
// samples y_i, weights W_i and counts M_i are resampled at pixel q with
//     w_i = p_hat_q(y_i) W_i M_i,      W = (sum of w_i) / (Z p_hat_q(y)),
// Z = the sum of M_i over the reservoirs i whose own target is not 0 at the
// kept y. That is unbiased when each target is the very function whose
// support the reservoir's samples cover. Here:
//   unbiased (default): the target is the SHADOWED contribution p_hat V
//     everywhere: the primary reservoir is zeroed when its sample is occluded
//     (visibility reuse), resampling weights at q test V_q(y_i) (a shadow ray
//     per neighbour), Z tests V_i(y) from each neighbour (another), and the
//     final sample is known to be visible (no shadow ray). Exactly unbiased for
//     any number of passes: 2k shadow rays per pixel and pass.
//   biased: resampling with the unshadowed p_hat_q, Z = the sum of all M_i
//     (the paper's biased combination), a shadow ray when shading. Cheaper;
//     darker where a neighbour's sample is occluded or out of reach at q.
// Neighbours whose normal differs by more than 25 degrees or whose depth by
// more than 10% are not taken (the paper's heuristic; it only chooses which
// reservoirs are combined, so it cannot bias).
//
// The final shading's MIS weight against the BSDF sample uses, for the light
// technique, M times the density of restir's SOURCE (M P(light) p_light) at q,
// the same function the BSDF side's weight uses (bsdf_emission_weight,
// restir_mis_density). Resampling's density is intractable, but any pair of
// weights that sums to 1 for every direction keeps the estimate unbiased
// (E[g(y) W] = integral of g for any g), so this choice only costs optimality.
#pragma once

#include "common.h"
#include "integrator.h"
#include "reservoir.h"
#include "rng.h"
#include "scene_view.h"

namespace pn {

// Whether a frame needs the passes: restir with spatial reuse (without it,
// render_sample resamples each path's first vertex on its own).
PN_FN bool restir_frame_passes(const IntegratorSettings& s) {
  return s.light_selection == LightSelection::Restir && s.restir.spatial_passes > 0 && strategy_uses_nee(s.strategy);
}

// Neighbour similarity (Bitterli et al. 2020): normals within 25 degrees and
// depths within 10%.
PN_FN bool restir_similar(const RestirPixel& q, const RestirPixel& n) {
  return dot(q.bsdf.frame.n, n.bsdf.frame.n) >= 0.906307787f && std::fabs(n.t - q.t) <= 0.1f * q.t;
}

// Pass `pass` of spatial reuse at pixel (px, py) of a width x height frame:
// q's new reservoir from `in` (every pixel's previous one).
template <uint32_t kFeatures = kAllFeatures, class Tracer>
PN_HD Reservoir restir_spatial_reuse(const Tracer& tracer, const SceneView& scene, const RestirSettings& rs,
                                     const RestirPixel* pixels, const Reservoir* in, int width, int height, int px,
                                     int py, uint32_t sample_index, uint32_t seed, uint32_t pass) {
  const uint32_t qi = uint32_t(py) * uint32_t(width) + uint32_t(px);
  const RestirPixel& q = pixels[qi];
  if (!q.valid) return in[qi];
  const bool unbiased = rs.unbiased != 0;
  Rng rng = Rng::for_pass(qi, sample_index, seed, pass);
  // The reservoirs combined: q's own first, then the neighbours found.
  uint32_t idx[kMaxRestirNeighbors + 1];
  uint32_t n = 0;
  idx[n++] = qi;
  const uint32_t k = pn_min(rs.neighbors, kMaxRestirNeighbors);
  for (uint32_t i = 0; i < k; ++i) {
    const Vec2 d = sample_uniform_disk_concentric(rng.uniform2());
    const int x = px + int(std::floor(d.x * rs.radius + 0.5f)), y = py + int(std::floor(d.y * rs.radius + 0.5f));
    if (x < 0 || y < 0 || x >= width || y >= height || (x == px && y == py)) continue;
    const uint32_t j = uint32_t(y) * uint32_t(width) + uint32_t(x);
    if (pixels[j].valid && restir_similar(q, pixels[j])) idx[n++] = j;
  }
  Reservoir r;
  uint32_t kept = 0;
  float M = 0.f;
  for (uint32_t i = 0; i < n; ++i) {
    const Reservoir& ri = in[idx[i]];
    M += ri.M;
    if (!(ri.W > 0.f)) continue;
    float p_hat = ri.p_hat;  // q's own sample: its target is known, and it is visible (W > 0)
    if (i > 0) {
      const TargetEval t = restir_target<kFeatures>(scene, q.bsdf, q.p, q.wo, ri.s);
      p_hat = t.p_hat;
      if (unbiased && p_hat > 0.f && !light_visible(tracer, q.p, q.bsdf.ng, t.wi, ri.s.y, ri.s.infinite != 0))
        p_hat = 0.f;
    }
    if (r.update(ri.s, p_hat * ri.W * ri.M, rng.uniform())) {
      kept = i;
      r.p_hat = p_hat;
    }
  }
  r.M = M;
  if (!(r.w_sum > 0.f)) return r;
  // Z: the confidence of every reservoir that could have produced the kept
  // sample. The one it came from could; q's own could (its weight at q is > 0).
  float Z = M;
  if (unbiased) {
    Z = in[idx[kept]].M + (kept != 0 ? in[qi].M : 0.f);
    for (uint32_t i = 1; i < n; ++i) {
      if (i == kept) continue;
      const RestirPixel& nb = pixels[idx[i]];
      const TargetEval t = restir_target<kFeatures>(scene, nb.bsdf, nb.p, nb.wo, r.s);
      if (t.p_hat > 0.f && light_visible(tracer, nb.p, nb.bsdf.ng, t.wi, r.s.y, r.s.infinite != 0)) Z += in[idx[i]].M;
    }
  }
  r.W = r.w_sum / (Z * r.p_hat);
  return r;
}

// Pass 3: the direct light of q's first vertex from its reservoir, weighted by
// MIS against the BSDF sample of q's path (core/integrator.h,
// bsdf_emission_weight), unshadowed where the reservoir's target already holds
// visibility (unbiased), else after a shadow ray.
template <uint32_t kFeatures = kAllFeatures, class Tracer>
PN_HD Vec3 restir_shade(const Tracer& tracer, const SceneView& scene, const IntegratorSettings& s,
                        const RestirPixel& q, const Reservoir& r) {
  if (!q.valid || !(r.W > 0.f)) return Vec3(0.f);
  const TargetEval t = restir_target<kFeatures>(scene, q.bsdf, q.p, q.wo, r.s);
  if (!(t.p_hat > 0.f)) return Vec3(0.f);
  if (!s.restir.unbiased && !light_visible(tracer, q.p, q.bsdf.ng, t.wi, r.s.y, r.s.infinite != 0)) return Vec3(0.f);
  float w = 1.f;
  if (s.mis != Mis::None) {
    const LightSampleContext ctx{q.p, q.bsdf.frame.n};
    const float p_light = selection_pmf(scene.selection, scene.num_lights, candidate_selection(s), ctx, r.s.light) *
                          light_pdf<kFeatures>(scene, s.strategy, scene.lights[r.s.light], ctx, t.wi);
    w = mis_weight(s.mis, restir_mis_density(p_light, float(pn_max(1u, s.restir.candidates))),
                   bsdf_pdf<(kFeatures & kFeatureSpecular) != 0>(q.bsdf, q.wo, t.wi));
  }
  return t.contribution * (t.G * r.W * w);
}

}  // namespace pn
