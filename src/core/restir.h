// ReSTIR DI's frame-level passes (Bitterli et al. 2020, "Spatiotemporal
// reservoir resampling for real-time ray tracing with dynamic direct lighting"),
// run by the backends over a whole frame, one camera sample per pixel at a time:
//
//   1. primary: every pixel's camera path (core/integrator.h, the step
//      functions with a RestirPrimaryOut): its first vertex's M candidates
//      resampled into a reservoir (reservoir_before_visibility, W set by its
//      shadow query), the rest of the path's radiance kept aside;
//   2. temporal (with `temporal`): every pixel combines its reservoir with the
//      final one of the same pixel at the previous sample, its confidence M
//      capped at temporal_cap times the new one's (restir_temporal_reuse). The
//      camera is static between samples (a progressive render, the viewer
//      until the view changes), so the history is the same pixel's, no motion
//      vectors; a render call starts without history (the viewer keeps it
//      across frames until it resets the image);
//   3. spatial (spatial_passes times): every pixel combines its reservoir with
//      those of k random neighbours within the radius (restir_spatial_reuse);
//   4. shade: every pixel's direct light from its final reservoir, weighted by
//      MIS against the BSDF sample that the path took (restir_shade), which
//      becomes the next sample's history.
// The CPU backend runs them with threads over tiles (or, in its Wavefront
// schedule, as the GPU does), the GPU's wavefront as its stages (the primary
// pass as waves, the others recorded, traced and replayed: backends/wavefront/
// wavefront.h); all call these functions. The GPU's megakernel (--megakernel)
// has no frame passes: it renders restir without reuse only (an OptiX raygen
// running these passes hung with the generalized balance heuristic; the
// wavefront runs them faster anyway, 17.8 against 26.5 ms a sample).
//
// Combination: reservoirs r_i with samples y_i, weights W_i and counts M_i are
// resampled at pixel q.
//   unbiased (default): generalized RIS (Lin et al. 2022) with the generalized
//     balance heuristic as MIS weights, w_i = m_i(y_i) p_hat_q(y_i) W_i,
//     m_i(y) = M_i p_hat_i(y) / sum_j M_j p_hat_j(y), W = (sum of w_i) /
//     p_hat_q(y), where every target is (by default, visibility_reuse) the
//     SHADOWED contribution p_hat V at its own pixel: the primary reservoir is
//     zeroed when its sample is occluded (visibility reuse), and the final
//     sample is known to be visible (no shadow ray when shading). Exactly
//     unbiased for any number of passes, with bounded weights; n^2 - n shadow
//     rays per pixel and pass (n = 1 + the neighbours found). With `pairwise`:
//     pairwise MIS (restir_combine_pairwise), also exactly unbiased and
//     bounded, 2 (n - 1) shadow rays per pixel and pass. The paper's own
//     unbiased combination (1/Z, Algorithm 6) was tried first: also unbiased, but a sample whose target is small at
//     its own pixel and large at q (a point near a sphere light's silhouette,
//     drawn by the cone) gave fireflies that did not average out (measured on
//     many-spheres at 1080p: RMSE rising from 16 to 64 spp).
//   Without visibility reuse (visibility_reuse = 0) both combinations take
//     the UNSHADOWED targets p_hat: the primary reservoir keeps an occluded
//     sample, the reuse traces no shadow ray, and the final shading traces
//     one. Still exactly unbiased (the weights sum to 1 wherever any target
//     is positive, and p_hat_q > 0 wherever the shadowed integrand is: GRIS
//     asks no more); noisier where lights are occluded, as occluded samples
//     are reused, and cheaper by every pass's shadow rays.
//   biased: resampling with the unshadowed p_hat_q, W = (sum of w_i) / (M
//     p_hat_q(y)) with w_i = p_hat_q(y_i) W_i M_i (the paper's biased
//     combination), a shadow ray when shading. Cheaper; darker where a
//     neighbour's sample is occluded or out of reach at q.
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

// Whether a frame needs the passes: restir with spatial or temporal reuse
// (without them, render_sample resamples each path's first vertex on its own).
PN_FN bool restir_frame_passes(const IntegratorSettings& s) {
  return s.light_selection == LightSelection::Restir && (s.restir.spatial_passes > 0 || s.restir.temporal != 0) &&
         strategy_uses_nee(s.strategy);
}

// The pass number of temporal reuse in Rng::for_pass (after every spatial one).
constexpr uint32_t kRestirTemporalPass = kMaxRestirPasses;

// Neighbour similarity (Bitterli et al. 2020): normals within 25 degrees and
// depths within 10%.
PN_FN bool restir_similar(const RestirPixel& q, const RestirPixel& n) {
  return dot(q.bsdf.n, n.bsdf.n) >= 0.906307787f && std::fabs(n.t - q.t) <= 0.1f * q.t;
}

// The target at pixel `at` of reservoir sample y as the unbiased reuse weighs it: with `shadowed` (visibility
// reuse), 0 where y is occluded from `at` (a shadow ray); else the unshadowed p_hat.
template <uint32_t kFeatures = kAllFeatures, class Tracer>
PN_HD float restir_reuse_target(const Tracer& tracer, const SceneView& scene, const RestirPixel& at,
                                const LightPoint& y, bool shadowed) {
  const TargetEval t = restir_target<kFeatures>(scene, unpack_bsdf(at.bsdf), at.p, at.wo, y);
  if (shadowed && t.p_hat > 0.f && !light_visible(tracer, at.p, at.p_bound, at.bsdf.ng, t.wi, y.y, y.infinite != 0)) return 0.f;
  return t.p_hat;
}

// Pairwise MIS (Bitterli's dissertation, 2022, ch. 9), here with the
// reservoirs' confidences M in each pair's balance heuristic: q's own reservoir
// is the canonical technique c, and each of the k = n - 1 neighbours is weighed
// against c alone, as a pair that holds 1/k of the total weight:
//   m_i(y) = (1/k) M_i p_i(y) / (M_i p_i(y) + (M_c/k) p_c(y)),
//   m_c(y) = (1/k) sum_i (M_c/k) p_c(y) / (M_i p_i(y) + (M_c/k) p_c(y)),
// p_j the target at pixel j (shadowed with visibility reuse). The weights sum to 1 wherever p_c(y) > 0
// (each pair's two terms sum to 1/k), so the combination is unbiased, and with
// equal confidences and targets every reservoir gets 1/n, as the generalized
// balance heuristic. Bounded as that one: m_i p_c W_i <= (M_i / M_c) p_i W_i.
// Shadow rays (visibility reuse): 2k per pixel and pass (each neighbour's
// sample seen from q, q's sample seen from each neighbour), not k^2 + k.
template <uint32_t kFeatures = kAllFeatures, class Tracer>
PN_HD Reservoir restir_combine_pairwise(const Tracer& tracer, const SceneView& scene, const RestirPixel* const* at,
                                        const Reservoir* const* in, uint32_t n, Rng& rng, bool shadowed) {
  Reservoir r;
  for (uint32_t i = 0; i < n; ++i) r.M += in[i]->M;
  const Reservoir& c = *in[0];
  const float k = float(pn_max(n, 2u) - 1);  // no neighbour (n = 1): the loops do not run, and m_c = 1
  const float mc = c.M / k;  // the canonical's confidence in each pair
  if (c.W > 0.f) {  // q's own sample: its weight against every neighbour
    float m_c = 0.f;
    for (uint32_t i = 1; i < n; ++i) {
      const float p_i = restir_reuse_target<kFeatures>(tracer, scene, *at[i], c.s, shadowed);
      const float den = in[i]->M * p_i + mc * c.p_hat;
      m_c += den > 0.f ? mc * c.p_hat / den : 0.f;
    }
    m_c = n == 1 ? 1.f : m_c / k;
    if (r.update(c.s, m_c * c.p_hat * c.W, rng.uniform())) r.p_hat = c.p_hat;
  }
  for (uint32_t i = 1; i < n; ++i) {  // each neighbour's sample, against q's alone
    const Reservoir& ri = *in[i];
    if (!(ri.W > 0.f)) continue;
    const float p_c = restir_reuse_target<kFeatures>(tracer, scene, *at[0], ri.s, shadowed);
    if (!(p_c > 0.f)) continue;
    const float num = ri.M * ri.p_hat;  // its own target (with visibility reuse, visible as W > 0)
    const float m_i = num / (num + mc * p_c) / k;
    if (r.update(ri.s, m_i * p_c * ri.W, rng.uniform())) r.p_hat = p_c;
  }
  if (r.w_sum > 0.f) r.W = r.w_sum / r.p_hat;
  return r;
}

// Combines n reservoirs: in[i] holds a sample found at pixel at[i]; at[0] and
// in[0] are q's own, where the result is used (see the top of this file).
template <uint32_t kFeatures = kAllFeatures, class Tracer>
PN_HD Reservoir restir_combine(const Tracer& tracer, const SceneView& scene, const RestirSettings& rs,
                               const RestirPixel* const* at, const Reservoir* const* in, uint32_t n, Rng& rng) {
  const RestirPixel& q = *at[0];
  const bool shadowed = rs.visibility_reuse != 0;
  if (rs.unbiased && rs.pairwise) return restir_combine_pairwise<kFeatures>(tracer, scene, at, in, n, rng, shadowed);
  Reservoir r;
  float M = 0.f;
  for (uint32_t i = 0; i < n; ++i) M += in[i]->M;
  r.M = M;
  if (rs.unbiased) {
    // The generalized balance heuristic (Talbot; Lin et al. 2022, GRIS): reservoir i's sample y_i enters with
    // m_i(y_i) p_hat_q(y_i) W_i, where m_i(y) = M_i p_hat_i(y) / sum_j M_j p_hat_j(y) and every target is of one
    // kind (shadowed with visibility reuse) at its own pixel; then W = (sum of weights) / p_hat_q(y). Unlike 1/Z,
    // the weight is bounded (m_i p_hat_q W_i <= M_i p_hat_i W_i p_hat_q / (M_q p_hat_q) = w_sum_i / M_q): a
    // sample whose own target was small (a point near a sphere light's silhouette, drawn by its cone) cannot
    // become a firefly where another pixel's target is large. n^2 - n targets (and, with visibility reuse, shadow
    // rays) per pixel and pass.
    for (uint32_t i = 0; i < n; ++i) {
      const Reservoir& ri = *in[i];
      if (!(ri.W > 0.f)) continue;
      float p_q = 0.f, num = 0.f, den = 0.f;
      for (uint32_t j = 0; j < n; ++j) {
        float p_j;
        if (j == i) {
          p_j = ri.p_hat;  // its own target (with visibility reuse, visible as W > 0)
        } else {
          p_j = restir_reuse_target<kFeatures>(tracer, scene, *at[j], ri.s, shadowed);
        }
        if (j == 0) p_q = p_j;
        if (j == i) num = in[j]->M * p_j;
        den += in[j]->M * p_j;
      }
      if (!(num > 0.f) || !(p_q > 0.f)) continue;
      if (r.update(ri.s, num / den * p_q * ri.W, rng.uniform())) r.p_hat = p_q;
    }
    if (r.w_sum > 0.f) r.W = r.w_sum / r.p_hat;
    return r;
  }
  // Biased: the paper's combination with unshadowed targets at q and Z = the sum of all M_i.
  const Bsdf q_bsdf = unpack_bsdf(q.bsdf);
  for (uint32_t i = 0; i < n; ++i) {
    const Reservoir& ri = *in[i];
    if (!(ri.W > 0.f)) continue;
    const float p_hat = i == 0 ? ri.p_hat : restir_target<kFeatures>(scene, q_bsdf, q.p, q.wo, ri.s).p_hat;
    if (r.update(ri.s, p_hat * ri.W * ri.M, rng.uniform())) r.p_hat = p_hat;
  }
  if (r.w_sum > 0.f) r.W = r.w_sum / (M * r.p_hat);
  return r;
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
  const RestirPixel* at[kMaxRestirNeighbors + 1];
  const Reservoir* res[kMaxRestirNeighbors + 1];
  for (uint32_t i = 0; i < n; ++i) at[i] = &pixels[idx[i]], res[i] = &in[idx[i]];
  return restir_combine<kFeatures>(tracer, scene, rs, at, res, n, rng);
}

// Temporal reuse at pixel `pixel_index`: q's reservoir `current` (from the
// primary pass) combined with `history`, the final reservoir of the same pixel
// at the previous sample, found at `history_pixel`. The history's M is capped
// at temporal_cap x current.M (Bitterli et al. 2020 use 20), so that an old
// sample cannot dominate for ever; the generalized balance heuristic stays an
// exact MIS weight for any M, so the cap costs no bias. No history (the first
// sample) or a dissimilar one (another surface under the pixel's jitter):
// `current` as it is.
template <uint32_t kFeatures = kAllFeatures, class Tracer>
PN_HD Reservoir restir_temporal_reuse(const Tracer& tracer, const SceneView& scene, const RestirSettings& rs,
                                      const RestirPixel& q, const Reservoir& current, const RestirPixel& history_pixel,
                                      const Reservoir& history, uint32_t pixel_index, uint32_t sample_index,
                                      uint32_t seed) {
  if (!q.valid || !history_pixel.valid || !(history.M > 0.f) || !restir_similar(q, history_pixel)) return current;
  Reservoir h = history;
  h.M = pn_min(h.M, rs.temporal_cap * pn_max(current.M, 1.f));
  Rng rng = Rng::for_pass(pixel_index, sample_index, seed, kRestirTemporalPass);
  const RestirPixel* at[2] = {&q, &history_pixel};
  const Reservoir* res[2] = {&current, &h};
  return restir_combine<kFeatures>(tracer, scene, rs, at, res, 2, rng);
}

// The reuse steps of a frame, in order: temporal reuse first (with `temporal`), then the spatial passes.
PN_FN uint32_t restir_reuse_steps(const RestirSettings& rs) { return (rs.temporal ? 1u : 0u) + rs.spatial_passes; }

// The pass of reuse step `step` (< restir_reuse_steps): kRestirTemporalPass or a spatial pass's number.
PN_FN uint32_t restir_reuse_pass(const RestirSettings& rs, uint32_t step) {
  return rs.temporal ? (step == 0 ? kRestirTemporalPass : step - 1u) : step;
}

// One reuse pass of a frame at one pixel: `pass` is kRestirTemporalPass (temporal reuse, with the history) or a
// spatial pass's number. Every backend's reuse runs this.
struct RestirReuse {
  const RestirPixel* pixels = nullptr;  // the frame's records
  const Reservoir* in = nullptr;        // every pixel's reservoir before the pass
  const RestirPixel* history_pixels = nullptr;  // temporal reuse: the previous sample's
  const Reservoir* history = nullptr;
  int width = 0, height = 0;
  uint32_t sample = 0, seed = 0, pass = 0;
};

template <uint32_t kFeatures = kAllFeatures, class Tracer>
PN_HD Reservoir restir_reuse(const Tracer& tracer, const SceneView& scene, const RestirSettings& rs,
                             const RestirReuse& r, uint32_t pixel) {
  if (r.pass == kRestirTemporalPass)
    return restir_temporal_reuse<kFeatures>(tracer, scene, rs, r.pixels[pixel], r.in[pixel], r.history_pixels[pixel],
                                            r.history[pixel], pixel, r.sample, r.seed);
  return restir_spatial_reuse<kFeatures>(tracer, scene, rs, r.pixels, r.in, r.width, r.height,
                                         int(pixel % uint32_t(r.width)), int(pixel / uint32_t(r.width)), r.sample,
                                         r.seed, r.pass);
}

// Whether the reuse weighs by shadowed targets (a shadow ray per target it evaluates): the unbiased combination
// with visibility reuse.
PN_FN bool restir_reuse_traces(const RestirSettings& rs) { return rs.unbiased && rs.visibility_reuse; }

// The most shadow rays restir_reuse can trace at one pixel (the combination traces only where a target is
// positive; these are the loops' lengths): none for unshadowed targets (the biased combination, or no visibility
// reuse), 2 (n - 1) with pairwise MIS and n (n - 1) with the generalized balance heuristic, n the reservoirs
// combined (q's and the neighbours', or q's and its history).
PN_FN uint32_t restir_reuse_max_rays(const RestirSettings& rs, uint32_t pass) {
  if (!restir_reuse_traces(rs)) return 0;
  const uint32_t n = pass == kRestirTemporalPass ? 2u : pn_min(rs.neighbors, kMaxRestirNeighbors) + 1u;
  return rs.pairwise ? 2u * (n - 1u) : n * (n - 1u);
}

// The same for restir_shade: a shadow ray only where the reservoirs' targets were unshadowed.
PN_FN uint32_t restir_shade_max_rays(const RestirSettings& rs) { return restir_reuse_traces(rs) ? 0u : 1u; }

// Pass 4: the direct light of q's first vertex from its reservoir, weighted by
// MIS against the BSDF sample of q's path (core/integrator.h,
// bsdf_emission_weight), unshadowed where the reservoir's target already holds
// visibility (unbiased with visibility reuse), else after a shadow ray.
template <uint32_t kFeatures = kAllFeatures, class Tracer>
PN_HD Vec3 restir_shade(const Tracer& tracer, const SceneView& scene, const IntegratorSettings& s,
                        const RestirPixel& q, const Reservoir& r) {
  if (!q.valid || !(r.W > 0.f)) return Vec3(0.f);
  const Bsdf bsdf = unpack_bsdf(q.bsdf);
  const TargetEval t = restir_target<kFeatures>(scene, bsdf, q.p, q.wo, r.s);
  if (!(t.p_hat > 0.f)) return Vec3(0.f);
  if (!restir_reuse_traces(s.restir) && !light_visible(tracer, q.p, q.p_bound, q.bsdf.ng, t.wi, r.s.y, r.s.infinite != 0))
    return Vec3(0.f);
  if constexpr (tracer_records_only<Tracer>::value) return Vec3(0.f);  // its one query is made: the rest is discarded
  float w = 1.f;
  if (s.mis != Mis::None) {
    const LightSampleContext ctx = light_sample_context<kFeatures>(s, q.p, bsdf, q.wo);
    const float p_light = selection_pmf<kFeatures>(scene.selection, scene.num_lights, candidate_selection(s), ctx, r.s.light) *
                          light_pdf<kFeatures>(scene, s.strategy, scene.lights[r.s.light], ctx, t.wi);
    w = mis_weight(s.mis, restir_mis_density(p_light, float(pn_max(1u, s.restir.candidates))),
                   bsdf_pdf<(kFeatures & kFeatureSpecular) != 0>(bsdf, q.wo, t.wi));
  }
  return t.contribution * (t.G * r.W * w);
}

}  // namespace pn
