// Light selection: which light one light sample goes to, a choice of its own
// beside how the chosen light is sampled (core/light_strategies.h). The
// probability of choosing light i, P(i | x), multiplies every light pdf,
// MIS weights included. The shading point is an argument because methods that
// adapt to it (the light BVH, core/light_bvh.h) need it.
//
// `restir` is not a distribution of its own: it resamples M candidates drawn
// by its source method (RestirSettings::source, core/restir.h), so
// select_light() and selection_pmf() are called with that source; the
// integrator asks candidate_selection() which method to pass.
#pragma once

#include "common.h"
#include "enum_names.h"
#include "features.h"
#include "light_bvh.h"
#include "lights.h"
#include "sampling.h"

namespace pn {

#define PN_LIGHT_SELECTIONS(X)                                                                  \
  X(Uniform, "uniform", "every light with the same probability")                                \
  X(Power, "power", "in proportion to emitted power (luminance of pi A L; the environment's by " \
                    "its image over the scene's bounding disk)")                                \
  X(Bvh, "bvh", "a light BVH traversed by importance at the shading point (distance, orientation, power; "  \
                "Conty Estevez & Kulla 2018); the environment outside it with a fixed probability")        \
  X(Restir, "restir", "ReSTIR DI (Bitterli et al. 2020): M candidates from --restir-source resampled by their " \
                      "unshadowed contribution, spatial reuse between pixels (--restir-spatial)")                 \
  X(SgBvh, "sg-bvh", "the light BVH with each node weighed by the BSDF's lobes, spherical Gaussians of the "      \
                     "node's light and of the diffuse and GGX lobes (after Tokuyoshi et al. 2024)")              \
  X(Slc, "slc", "stochastic lightcuts (Yuksel 2019): a cut of at most --slc-cut nodes of the light BVH at the "  \
                "shading point, a light sample and shadow ray in each; the environment sampled besides")

enum class LightSelection : uint32_t {
#define PN_X(e, name, desc) e,
  PN_LIGHT_SELECTIONS(PN_X)
#undef PN_X
      Count
};
constexpr int kNumLightSelections = int(LightSelection::Count);

inline const char* light_selection_name(LightSelection s) {
  static const char* names[] = {
#define PN_X(e, name, desc) name,
      PN_LIGHT_SELECTIONS(PN_X)
#undef PN_X
  };
  return int(s) < kNumLightSelections ? names[int(s)] : "?";
}
// The method named `name` (false: none is), and every name: "uniform, power, bvh, restir, sg-bvh".
inline bool find_light_selection(const std::string& name, LightSelection* out) {
  return find_enum(name, kNumLightSelections, light_selection_name, out);
}
inline std::string light_selection_names() { return enum_names(kNumLightSelections, light_selection_name); }
inline const char* light_selection_description(LightSelection s) {
  static const char* descs[] = {
#define PN_X(e, name, desc) desc,
      PN_LIGHT_SELECTIONS(PN_X)
#undef PN_X
  };
  return int(s) < kNumLightSelections ? descs[int(s)] : "?";
}

// What selection needs of the scene beside the number of lights, built by the
// host's finalize_scene: the power CDF (count + 1 entries), the light BVH, and
// the light at infinity (the environment), which the BVH leaves out and picks
// with a fixed probability: its share of the power, clamped to
// [kMinInfiniteProbability, 1 - kMinInfiniteProbability] so that neither a
// bright sky nor a dim one starves the other lights or itself (1 when the tree
// is empty).
struct LightSelectionView {
  const float* power_cdf = nullptr;  // null: power selection falls back to uniform
  LightBvhView bvh;                  // null nodes: bvh selection falls back to power
  int32_t infinite_light = -1;       // index of the environment light, or -1
  float infinite_probability = 0.f;  // bvh: the probability of choosing it
};
constexpr float kMinInfiniteProbability = 0.1f;

// restir's parameters (core/reservoir.h, core/restir.h): at the first vertex
// of every camera path, `candidates` light samples drawn by `source` and the
// strategy are resampled by their unshadowed contribution (RIS, Talbot 2005);
// then `spatial_passes` passes each combine every pixel's reservoir with those
// of `neighbors` random pixels within `radius` pixels; with `temporal`, first
// with the same pixel's final reservoir of the previous sample (its M capped at
// `temporal_cap` times the new one's). Unbiased by default;
// `unbiased = 0` is the paper's biased combination (cheaper, darker where
// neighbours see different lights), labelled as such wherever it is reported.
// `visibility_reuse` (default) traces the primary reservoir's sample and makes
// every target of the reuse the shadowed one (shadow rays in every pass, none
// when shading); without it the targets are unshadowed (no shadow ray until
// the final shading, unbiased all the same: core/restir.h).
struct RestirSettings {
  uint32_t candidates = 32;
  uint32_t spatial_passes = 2;
  uint32_t neighbors = 3;
  float radius = 30.f;
  uint32_t unbiased = 1;
  LightSelection source = LightSelection::Power;
  uint32_t temporal = 0;      // 1: temporal reuse between successive samples of a static camera
  float temporal_cap = 20.f;  // the history's M at most this times the new reservoir's
  uint32_t pairwise = 0;      // 1 (unbiased only): pairwise MIS in the reuse, 2k shadow rays a pass, not k^2 + k
  uint32_t visibility_reuse = 1;  // 0: unshadowed targets in the reuse, one shadow ray when shading
};
inline bool operator==(const RestirSettings& a, const RestirSettings& b) {
  return a.candidates == b.candidates && a.spatial_passes == b.spatial_passes && a.neighbors == b.neighbors &&
         a.radius == b.radius && a.unbiased == b.unbiased && a.source == b.source && a.temporal == b.temporal &&
         a.temporal_cap == b.temporal_cap && a.pairwise == b.pairwise && a.visibility_reuse == b.visibility_reuse;
}
inline bool operator!=(const RestirSettings& a, const RestirSettings& b) { return !(a == b); }
constexpr uint32_t kMaxRestirCandidates = 4096;
constexpr uint32_t kMaxRestirPasses = 16;
constexpr uint32_t kMaxRestirNeighbors = 16;

struct SelectedLight {
  uint32_t index = 0;
  float pmf = 0.f;  // 0: nothing selected (no lights)
};

// sg-bvh's lobes only where kFeatures has kFeatureSgBvh (else it selects as bvh: core/features.h).
template <uint32_t kFeatures = kAllFeatures>
PN_FN SelectedLight select_light(const LightSelectionView& v, uint32_t n, LightSelection method,
                                 const LightSampleContext& ctx, float u) {
  constexpr bool kSg = (kFeatures & kFeatureSgBvh) != 0;
  SelectedLight s;
  if (n == 0) return s;
  switch (method) {
    case LightSelection::Slc:  // one light of a cut of one node: the light BVH's (the integrator samples whole cuts)
    case LightSelection::Bvh:
    case LightSelection::SgBvh:
      if (v.bvh.nodes || v.infinite_light >= 0) {
        const float p_inf = v.infinite_light >= 0 ? v.infinite_probability : 0.f;
        if (u < p_inf) {
          s.index = uint32_t(v.infinite_light);
          s.pmf = p_inf;
          return s;
        }
        const float ub = pn_min((u - p_inf) / (1.f - p_inf), kOneMinusEpsilon);
        const LightBvhPick pick = kSg && method == LightSelection::SgBvh ? light_bvh_select<kSg>(v.bvh, ctx, ub)
                                                                            : light_bvh_select<false>(v.bvh, ctx, ub);
        s.index = pick.light;
        s.pmf = pick.pmf * (1.f - p_inf);
        return s;
      }
      [[fallthrough]];
    case LightSelection::Power:
    case LightSelection::Restir:  // callers pass restir's source; power if they do not
      if (v.power_cdf) {
        s.index = find_cdf_piece(v.power_cdf, n, u);
        s.pmf = v.power_cdf[s.index + 1] - v.power_cdf[s.index];
        return s;
      }
      break;
    case LightSelection::Uniform:
    case LightSelection::Count:
      break;
  }
  s.index = pn_min(uint32_t(u * float(n)), n - 1);
  s.pmf = 1.f / float(n);
  return s;
}

// P(light i | x), as select_light() chooses.
// slc: the probability of i's sample in a cut of at most `cut_nodes` nodes (the environment's: 1), a light's in
// the one sample of its part of the lights (code with kFeatureSlc; else as bvh).
template <uint32_t kFeatures = kAllFeatures>
PN_FN float selection_pmf(const LightSelectionView& v, uint32_t n, LightSelection method, const LightSampleContext& ctx,
                          uint32_t i, uint32_t cut_nodes = 1) {
  constexpr bool kSg = (kFeatures & kFeatureSgBvh) != 0;
  if (i >= n) return 0.f;
  switch (method) {
    case LightSelection::Slc:
      if constexpr ((kFeatures & kFeatureSlc) != 0) {
        if (int32_t(i) == v.infinite_light) return 1.f;
        const LightBvhQuery q = light_bvh_query<false>(ctx);
        return light_cut_pmf(v.bvh, q, light_bvh_cut(v.bvh, q, cut_nodes), i);
      }
      [[fallthrough]];
    case LightSelection::Bvh:
    case LightSelection::SgBvh:
      if (v.bvh.nodes || v.infinite_light >= 0) {
        const float p_inf = v.infinite_light >= 0 ? v.infinite_probability : 0.f;
        if (int32_t(i) == v.infinite_light) return p_inf;
        const float pmf = kSg && method == LightSelection::SgBvh ? light_bvh_pmf<kSg>(v.bvh, ctx, i)
                                                                    : light_bvh_pmf<false>(v.bvh, ctx, i);
        return pmf * (1.f - p_inf);
      }
      [[fallthrough]];
    case LightSelection::Power:
    case LightSelection::Restir:
      if (v.power_cdf) return v.power_cdf[i + 1] - v.power_cdf[i];
      break;
    case LightSelection::Uniform:
    case LightSelection::Count:
      break;
  }
  return 1.f / float(n);
}

}  // namespace pn
