// The path tracer: one piece of code for every backend, written as a path
// state and step functions (start_path, on_hit / on_miss, on_shadow_result:
// below) that any schedule of ray queries can drive; trace_path drives them
// depth-first, for the CPU backend and the OptiX raygen program alike.
//
// That driver takes a Tracer with two queries and nothing else:
//     bool intersect(const Ray&, float tmax, HitRecord*) const;  // closest hit
//     bool occluded(const Ray&, float tmax) const;               // any hit
// The CPU backend answers them with Embree, the OptiX backend with optixTrace;
// both skip alpha-masked holes (alpha_discards) in both queries. The hit is
// turned into a shading point here, by core/scene_view.h, for both.
//
// Estimator. A path x0 (camera) -> x1 -> x2 ... carries throughput
//     beta_k = prod_{j<k} f(x_j) |cos theta_j| / p_bsdf(w_j)
// and at every vertex x_k (k <= max_depth) next-event estimation adds, for one
// light chosen with probability P(light | x_k) and one direction w drawn from it
// by the strategy with solid-angle density p_light(w),
//     beta_k * f(x_k, w) * L_e * cos theta / (P(light) p_light(w)) * w_light
// if the shadow ray is clear. Emission that a BSDF-sampled ray finds (a light's
// surface, an emissive triangle, the environment) adds beta_k * L_e * w_bsdf.
// The weights (core/strategy.h, mis_weight):
//   --mis none:   w_light = 1; w_bsdf = 1 where no light sampling happened
//                 (camera rays, the bsdf strategy), else 0: each light path is
//                 counted once, by light sampling (the thesis's estimator);
//   --mis balance|power: w_light = h(P p_light, p_bsdf), w_bsdf = h(p_bsdf,
//                 P p_light), both densities of the same direction at the same
//                 vertex, so that the weights sum to 1 wherever both techniques
//                 can produce it (Veach & Guibas 1995).
// Russian roulette from vertex rr_depth on keeps the estimator unbiased
// (beta /= survival probability).
//
// Light selection `restir` (core/restir.h) replaces the light sample of the
// first vertex x1 by the one kept of M candidates resampled by their
// unshadowed contribution p_hat (RIS): f L cos * w_light * W, with W the kept
// sample's unbiased contribution weight. Its MIS weight pairs M times the
// density of restir's source, M P(light) p_light, with p_bsdf, as the BSDF side
// does (restir_mis_density): any two weights that sum to 1 keep the estimator
// unbiased. With spatial reuse the backends run x1's light as frame-level
// passes (render_sample with a RestirPrimaryOut leaves it out and records x1
// and its reservoir).
#pragma once

#include "camera.h"
#include "common.h"
#include "geometry.h"
#include "light_sampler.h"
#include "material.h"
#include "reservoir.h"
#include "rng.h"
#include "scene_view.h"
#include "strategy.h"
#include "vec.h"

namespace pn {

struct IntegratorSettings {
  Strategy strategy = Strategy::SolidAngle;
  Mis mis = Mis::Power;
  LightSelection light_selection = LightSelection::Power;
  RestirSettings restir;  // light_selection == Restir only
  int max_depth = 8;  // maximum number of scattering vertices on a path
  int rr_depth = 5;   // Russian roulette from this vertex on
  // MIS compensation of the environment (environment.h; Karlik et al. 2019): see environment_compensated.
  bool mis_compensation = false;
  uint32_t slc_cut = 8;  // light_selection == Slc: the most nodes of a cut (1..kMaxLightCut), a shadow ray each
};
inline bool operator==(const IntegratorSettings& a, const IntegratorSettings& b) {
  return a.strategy == b.strategy && a.mis == b.mis && a.light_selection == b.light_selection &&
         a.restir == b.restir && a.max_depth == b.max_depth && a.rr_depth == b.rr_depth &&
         a.mis_compensation == b.mis_compensation && a.slc_cut == b.slc_cut;
}

// Whether light samples of the environment come from its MIS-compensated distribution: with mis_compensation,
// where MIS weighs each light sample against a BSDF sample (balance or power) that covers what the compensated
// distribution leaves out. Not with restir, whose resampled candidates are weighed in its own passes: there (and
// without MIS) the setting changes nothing.
PN_FN bool environment_compensated(const IntegratorSettings& s) {
  return s.mis_compensation && s.mis != Mis::None && s.light_selection != LightSelection::Restir;
}
inline bool operator!=(const IntegratorSettings& a, const IntegratorSettings& b) { return !(a == b); }

// The selection method light samples are drawn with: restir's source for
// restir (it resamples what its source draws), else the method itself. Every
// selection pmf, MIS weights' included, is this method's.
PN_FN LightSelection candidate_selection(const IntegratorSettings& s) {
  return s.light_selection == LightSelection::Restir ? s.restir.source : s.light_selection;
}

// Whether light sampling weighs by the BSDF's lobes: the `ltc` strategy and `sg-bvh` selection, in code compiled
// with their bits (kFeatureLtc, kFeatureSgBvh: core/features.h).
template <uint32_t kFeatures = kAllFeatures>
PN_FN bool light_sampling_sees_lobes(const IntegratorSettings& s) {
  return ((kFeatures & kFeatureLtc) && s.strategy == Strategy::Ltc) ||
         ((kFeatures & kFeatureSgBvh) && candidate_selection(s) == LightSelection::SgBvh);
}

// What the light samplers see at a shading point: the point and its shading normal, and where they weigh by the
// BSDF's lobes (light_sampling_sees_lobes), the lobes at wo (core/lights.h).
template <uint32_t kFeatures = kAllFeatures>
PN_FN LightSampleContext light_sample_context(const IntegratorSettings& s, Vec3 p, const Bsdf& bsdf, Vec3 wo) {
  constexpr bool kSpecular = (kFeatures & kFeatureSpecular) != 0;
  LightSampleContext c{p, bsdf.frame.n};
  if (!light_sampling_sees_lobes<kFeatures>(s)) return c;
  const float cos_o = dot(wo, bsdf.frame.n);
  c.wo = wo;
  c.alpha = bsdf.alpha;
  c.specular = kSpecular && bsdf.has_specular ? luminance(bsdf_fresnel(bsdf, cos_o)) : 0.f;
  c.diffuse = luminance(bsdf.diffuse) * bsdf_coat_transmission<kSpecular>(bsdf, cos_o);
  return c;
}

// The feature bits of the light sampling a configuration runs that only code compiled with them holds
// (core/features.h): ltc, sg-bvh (also as restir's source) and slc.
PN_FN uint32_t extra_light_sampling(const IntegratorSettings& s) {
  return (s.strategy == Strategy::Ltc ? uint32_t(kFeatureLtc) : 0u) |
         (candidate_selection(s) == LightSelection::SgBvh ? uint32_t(kFeatureSgBvh) : 0u) |
         (s.light_selection == LightSelection::Slc ? uint32_t(kFeatureSlc) : 0u);
}

// Light samples a vertex makes at most: one, or with slc one per node of its cut and one of the environment
// where the scene has one (light_cut_queries).
PN_FN uint32_t light_samples_per_vertex(const IntegratorSettings& s, bool environment) {
  if (s.light_selection != LightSelection::Slc) return 1u;
  return pn_min(pn_max(s.slc_cut, 1u), kMaxLightCut) + (environment ? 1u : 0u);
}

// Whether the previous vertex a step reads (path_reads_prev) must hold the BSDF's lobes too: for `ltc`'s pdf and
// `sg-bvh`'s pmf.
template <uint32_t kFeatures = kAllFeatures>
PN_FN bool path_reads_prev_lobes(const IntegratorSettings& s) {
  return light_sampling_sees_lobes<kFeatures>(s);
}

// The light technique's density in MIS weights: P(light) p_light per sample,
// times the number of candidates where restir resampled M of them (as if the
// light technique took M samples: the weights then give the BSDF sample less
// of what resampling finds well; any pair of weights that sums to 1 for every
// direction keeps the estimate unbiased, this one is closer to the resampled
// density than one candidate's).
PN_FN float restir_mis_density(float p_light, float candidates) { return p_light * candidates; }

// One light sample for next-event estimation at a shading point, before its
// shadow ray: the chosen light, the strategy's sample of it, the BSDF there.
// With resampling (ris: restir's first vertex), it is the one kept of M
// candidates, each drawn with density p = P(light) p_light(w) and weighted by
// w = p_hat / p, p_hat = luminance(f L cos); its unbiased contribution weight
// (in solid angle) is W = w_sum / (M p_hat(y)).
struct DirectSample {
  SelectedLight sel;  // pmf 0: none
  LightSample ls;
  Vec3 f;
  bool ris = false;
  uint32_t M = 1;
  float w_sum = 0.f;
  float p_hat = 0.f;  // of the kept candidate (solid angle)
};

template <uint32_t kFeatures = kAllFeatures>
PN_FN DirectSample choose_direct_sample(const SceneView& scene, const IntegratorSettings& s, const Bsdf& bsdf, Vec3 p,
                                        Vec3 wo, bool ris, float u_select, Vec2 u, Rng* rng) {
  constexpr bool kSpecular = (kFeatures & kFeatureSpecular) != 0;
  const LightSampleContext ctx = light_sample_context<kFeatures>(s, p, bsdf, wo);
  const LightSelection method = candidate_selection(s);
  DirectSample d;
  d.ris = ris && rng;
  d.M = d.ris ? pn_max(1u, s.restir.candidates) : 1u;
  for (uint32_t k = 0; k < d.M; ++k) {
    if (k > 0) {
      u_select = rng->uniform();
      u = rng->uniform2();
    }
    const SelectedLight sel = select_light<kFeatures>(scene.selection, scene.num_lights, method, ctx, u_select);
    if (!(sel.pmf > 0.f)) continue;
    const LightSample ls = sample_light<kFeatures>(scene, s.strategy, load_light(scene.lights, sel.index), ctx, u,
                                                   environment_compensated(s));
    if (!(ls.pdf > 0.f)) continue;
    const Vec3 f = bsdf_eval<kSpecular>(bsdf, wo, ls.wi);
    if (is_black(f)) continue;
    if (!d.ris) {
      d.sel = sel;
      d.ls = ls;
      d.f = f;
      break;
    }
    const float p_hat = luminance(f * ls.L) * dot(bsdf.frame.n, ls.wi);
    const float w = p_hat / (sel.pmf * ls.pdf);
    if (!(p_hat > 0.f) || !std::isfinite(w)) continue;
    d.w_sum += w;
    if (rng->uniform() * d.w_sum < w) {
      d.sel = sel;
      d.ls = ls;
      d.f = f;
      d.p_hat = p_hat;
    }
  }
  return d;
}

// A shadow ray and what its result decides: the step functions below return
// one per vertex with a light sample, and a driver traces it whenever it likes
// before the path's next hit is consumed (on_shadow_result). Everything the
// result needs is in the query (the contribution is computed with the
// throughput of the vertex that made it), so the path's state never waits for
// it: a wavefront traces every path's query in a kernel of its own.
enum class ShadowKind : uint32_t {
  None,       // no shadow ray: no light sample was kept (or restir's kept one has no target here)
  Radiance,   // next-event estimation: `contribution` joins the path's radiance if the ray is clear
  Reservoir,  // restir's primary pass: the reservoir's W becomes `reservoir_W` if clear (visibility reuse)
};

struct ShadowQuery {
  Ray ray;
  float tmax = 0.f;
  Vec3 contribution;         // Radiance: beta * f * L * cos / (P(light) p_light) * w_light (* p W)
  float reservoir_W = 0.f;   // Reservoir: the kept candidate's contribution weight, area measure
  ShadowKind kind = ShadowKind::None;
};

// The shadow query of a chosen light sample, its contribution before the
// path's throughput: f * L * cos / (P(light) p_light) times its MIS weight
// (times p W for a resampled one), counted if the shadow ray is clear.
template <uint32_t kFeatures = kAllFeatures>
PN_FN ShadowQuery direct_shadow_query(const IntegratorSettings& s, const Bsdf& bsdf, Vec3 p, PointBound p_bound,
                                      Vec3 wo, const DirectSample& d) {
  constexpr bool kSpecular = (kFeatures & kFeatureSpecular) != 0;
  ShadowQuery q;
  if (!(d.sel.pmf > 0.f)) return q;
  const LightSample& ls = d.ls;
  // The shadow ray leaves on the side of the geometric surface wi points to
  // (bsdf_eval is 0 otherwise) and runs to the sampled point itself, so that
  // the offset can never carry it past the light's surface.
  const ShadowRay r = light_shadow_ray(p, p_bound, bsdf.ng, ls.wi, ls.y, ls.infinite);
  q.ray = r.ray;
  q.tmax = r.tmax;
  q.kind = ShadowKind::Radiance;
  const float p_light = ls.pdf * d.sel.pmf;
  const float w = s.mis == Mis::None ? 1.f
                                     : mis_weight(s.mis, restir_mis_density(p_light, float(d.M)),
                                                  bsdf_pdf<kSpecular>(bsdf, wo, ls.wi));
  const float ris = d.ris ? d.w_sum * p_light / (float(d.M) * d.p_hat) : 1.f;  // p W
  q.contribution = d.f * ls.L * (dot(bsdf.frame.n, ls.wi) * w / p_light * ris);
  return q;
}

// slc's light samples at a vertex (stochastic lightcuts, core/light_bvh.h): one in each node of the cut at p, then
// one of the environment, each a shadow query with the path's throughput beta passed to emit(query). Their sum
// estimates the direct light: a light's probability is its node's sample's (selection_pmf), and the MIS weight of
// each is the one-sample weight with that probability. Code with kFeatureSlc only.
template <uint32_t kFeatures, class Emit>
PN_FN void light_cut_queries(const SceneView& scene, const IntegratorSettings& s, const Bsdf& bsdf,
                             const SurfaceHit& hit, Vec3 wo, Vec3 beta, Rng& rng, Emit&& emit) {
  if constexpr ((kFeatures & kFeatureSlc) != 0) {
    constexpr bool kSpecular = (kFeatures & kFeatureSpecular) != 0;
    const LightSampleContext ctx = light_sample_context<kFeatures>(s, hit.p, bsdf, wo);
    const LightBvhQuery q = light_bvh_query<false>(ctx);
    const LightCut cut = light_bvh_cut(scene.selection.bvh, q, s.slc_cut);
    const uint32_t n = cut.count + (scene.selection.infinite_light >= 0 ? 1u : 0u);
    for (uint32_t k = 0; k < n; ++k) {
      const float u_select = rng.uniform();
      const Vec2 u = rng.uniform2();
      DirectSample d;
      if (k < cut.count) {
        const LightBvhPick pick = light_bvh_select_below<false>(scene.selection.bvh, q, cut.node[k], u_select);
        d.sel.index = pick.light;
        d.sel.pmf = pick.pmf;
      } else {
        d.sel.index = uint32_t(scene.selection.infinite_light);
        d.sel.pmf = 1.f;
      }
      if (!(d.sel.pmf > 0.f)) continue;
      d.ls = sample_light<kFeatures>(scene, s.strategy, load_light(scene.lights, d.sel.index), ctx, u,
                                     environment_compensated(s));
      if (!(d.ls.pdf > 0.f)) continue;
      d.f = bsdf_eval<kSpecular>(bsdf, wo, d.ls.wi);
      if (is_black(d.f)) continue;
      ShadowQuery sq = direct_shadow_query<kFeatures>(s, bsdf, hit.p, hit.p_bound, wo, d);
      sq.contribution = beta * sq.contribution;
      emit(sq);
    }
  }
}

// The radiance of a chosen light sample (direct_shadow_query), its shadow ray traced now.
template <uint32_t kFeatures = kAllFeatures, class Tracer>
PN_HD Vec3 shade_direct_sample(const Tracer& tracer, const IntegratorSettings& s, const Bsdf& bsdf, Vec3 p,
                               PointBound p_bound, Vec3 wo, const DirectSample& d) {
  const ShadowQuery q = direct_shadow_query<kFeatures>(s, bsdf, p, p_bound, wo, d);
  if (q.kind == ShadowKind::None || tracer.occluded(q.ray, q.tmax)) return Vec3(0.f);
  return q.contribution;
}

// Next-event estimation at a shading point: radiance from one light sample,
// f * L * cos / (P(light) p_light) times its MIS weight. Shared by the path
// loop and the direct-lighting tests.
template <uint32_t kFeatures = kAllFeatures, class Tracer>
PN_HD Vec3 estimate_direct(const Tracer& tracer, const SceneView& scene, const IntegratorSettings& s,
                           const Bsdf& bsdf, Vec3 p, PointBound p_bound, Vec3 wo, float u_select, Vec2 u) {
  const DirectSample d = choose_direct_sample<kFeatures>(scene, s, bsdf, p, wo, false, u_select, u, nullptr);
  return shade_direct_sample<kFeatures>(tracer, s, bsdf, p, p_bound, wo, d);
}

// Convenience for tests: a strategy with the default MIS and selection off, at an exact point p.
template <uint32_t kFeatures = kAllFeatures, class Tracer>
PN_HD Vec3 estimate_direct(const Tracer& tracer, const SceneView& scene, Strategy strategy, const Bsdf& bsdf, Vec3 p,
                           Vec3 wo, float u_select, Vec2 u) {
  IntegratorSettings s;
  s.strategy = strategy;
  s.mis = Mis::None;
  return estimate_direct<kFeatures>(tracer, scene, s, bsdf, p, 0.f, wo, u_select, u);
}

// The reservoir of restir's first vertex, for the frame-level passes
// (core/restir.h): the kept candidate with its contribution weight in the area
// measure (W / G). With visibility reuse, W is 0 until the kept candidate is
// known to be visible (the reservoir's target becomes p_hat V) and *q receives
// the shadow query that sets it (ShadowKind::Reservoir); without, W is set now
// (the target stays unshadowed) and *q is none.
template <uint32_t kFeatures = kAllFeatures>
PN_FN Reservoir reservoir_before_visibility(const SceneView& scene, const Bsdf& bsdf, Vec3 p, PointBound p_bound,
                                            Vec3 wo, const DirectSample& d, ShadowQuery* q,
                                            bool visibility_reuse = true) {
  Reservoir r;
  *q = ShadowQuery();
  r.M = float(d.M);
  if (!(d.sel.pmf > 0.f)) return r;
  r.s = light_point(scene.lights[d.sel.index], d.sel.index, d.ls);
  r.w_sum = d.w_sum;
  const TargetEval t = restir_target<kFeatures>(scene, bsdf, p, wo, r.s);
  r.p_hat = t.p_hat;
  if (!(t.p_hat > 0.f)) return r;
  if (!visibility_reuse) {
    r.W = d.w_sum / (r.M * t.p_hat);
    return r;
  }
  const ShadowRay sr = light_shadow_ray(p, p_bound, bsdf.ng, t.wi, r.s.y, r.s.infinite != 0);
  q->ray = sr.ray;
  q->tmax = sr.tmax;
  q->reservoir_W = d.w_sum / (r.M * t.p_hat);
  q->kind = ShadowKind::Reservoir;
  return r;
}

// The same with its shadow ray traced now.
template <uint32_t kFeatures = kAllFeatures, class Tracer>
PN_HD Reservoir make_reservoir(const Tracer& tracer, const SceneView& scene, const Bsdf& bsdf, Vec3 p,
                               PointBound p_bound, Vec3 wo, const DirectSample& d, bool visibility_reuse = true) {
  ShadowQuery q;
  Reservoir r = reservoir_before_visibility<kFeatures>(scene, bsdf, p, p_bound, wo, d, &q, visibility_reuse);
  if (q.kind == ShadowKind::Reservoir && !tracer.occluded(q.ray, q.tmax)) r.W = q.reservoir_W;
  return r;
}

// The vertex a BSDF-sampled ray left from: what the MIS weight of emission it
// finds needs to know (the density NEE would have had for that direction).
// BSDFs have no delta lobes, so there is no specular flag: every BSDF sample
// has a finite pdf and is weighed by MIS.
// Its light-sample context is kept field by field, the point and normal first: a
// wavefront moves the first 32 bytes as two 16-byte words, and the lobes' 32 only
// where light sampling weighs by them (path_reads_prev_lobes: ltc, sg-bvh).
struct alignas(16) PrevVertex {
  Vec3 p, n;                     // the LightSampleContext's point and shading normal
  float bsdf_pdf = 0.f;
  float light_candidates = 1.f;  // M at restir's first vertex (restir_mis_density), else 1
  Vec3 wo;                       // the rest of its LightSampleContext: the BSDF's lobes
  float alpha = 1.f, specular = 0.f, diffuse = 0.f;

  PN_FN static PrevVertex at(const LightSampleContext& c, float bsdf_pdf, float light_candidates = 1.f) {
    PrevVertex v;
    v.set_ctx(c);
    v.bsdf_pdf = bsdf_pdf;
    v.light_candidates = light_candidates;
    return v;
  }
  PN_FN LightSampleContext ctx() const {
    LightSampleContext c{p, n};
    c.wo = wo;
    c.alpha = alpha;
    c.specular = specular;
    c.diffuse = diffuse;
    return c;
  }
  PN_FN void set_ctx(const LightSampleContext& c) {
    p = c.p;
    n = c.n;
    wo = c.wo;
    alpha = c.alpha;
    specular = c.specular;
    diffuse = c.diffuse;
  }
};

// The weight of emission from light `index` found along direction w by a
// BSDF-sampled ray (depth > 0, NEE on, MIS on).
template <uint32_t kFeatures = kAllFeatures>
PN_FN float bsdf_emission_weight(const SceneView& scene, const IntegratorSettings& s, const PrevVertex& prev,
                                 uint32_t index, Vec3 w) {
  const LightSampleContext ctx = prev.ctx();
  const float p_light = selection_pmf<kFeatures>(scene.selection, scene.num_lights, candidate_selection(s), ctx, index,
                                                 s.slc_cut) *
                        light_pdf<kFeatures>(scene, s.strategy, load_light(scene.lights, index), ctx, w,
                                             environment_compensated(s));
  return mis_weight(s.mis, prev.bsdf_pdf, restir_mis_density(p_light, prev.light_candidates));
}

// Whether a step reads PathState::prev: only for the MIS weight of emission that a
// BSDF-sampled ray finds (bsdf_emission_weight). Without it a schedule that keeps
// paths in memory (the wavefront) need not keep the previous vertex.
PN_FN bool path_reads_prev(const IntegratorSettings& s) {
  return strategy_uses_nee(s.strategy) && s.mis != Mis::None;
}

// Whether the vertex a path ends at (depth == max_depth) can add radiance: it adds only the emission its ray
// finds, an emitter's or the escaped radiance, and next-event estimation without MIS leaves that to the light
// samples (all of it where the environment is a light or the background is black). Where it cannot, the ray to
// it is not traced: the same estimate, one ray a path fewer.
template <uint32_t kFeatures = kAllFeatures>
PN_FN bool last_vertex_adds(const SceneView& scene, const IntegratorSettings& s) {
  if (!strategy_uses_nee(s.strategy) || s.mis != Mis::None) return true;
  const bool environment = (kFeatures & kFeatureEnvironment) && scene.environment.present();
  return scene.environment_light < 0 && (environment || !is_black(scene.background));
}

// --- The path, as a state and step functions ------------------------------------
//
// A path is a PathState advanced by three steps, each a function of the state
// and of one answer from a backend:
//     start_path                   camera ray of one pixel sample
//     on_hit(closest hit) / on_miss  emission found, the light sample's
//                                  ShadowQuery, the BSDF sample (the next ray)
//                                  and Russian roulette; or the path ends
//     on_shadow_result(query, blocked)  the light sample counted if clear
// The state holds everything that lives from one trace to the next, so paths
// can be advanced in any interleaving: depth-first, one path at a time
// (trace_path below: the CPU backend and the OptiX raygen), or breadth-first,
// a pool of paths a step at a time (the CPU backend's breadth-first schedule;
// a wavefront GPU's kernels). The one rule: a path's shadow result is consumed
// before its next hit (tracing either ray may come first: on_hit has already
// written the next ray and the query holds its own contribution). Random
// numbers are drawn only by start_path and on_hit, from the state's stream in
// the order of the vertices, so every schedule computes the same image, bit for
// bit.

// Everything a path carries from one trace to the next (a wavefront keeps it
// in a pool, one array per field).
struct PathState {
  Ray ray;            // the next ray to trace (while active)
  Vec3 beta;          // throughput: prod f |cos| / p_bsdf over the vertices so far (/ Russian roulette)
  Vec3 L;             // radiance gathered so far
  Rng rng;            // the camera sample's stream
  PrevVertex prev;    // where `ray` left from (depth > 0)
  uint32_t pixel = 0;         // y * width + x
  uint32_t sample_index = 0;
  int32_t depth = 0;          // vertices behind `ray`: 0 for the camera ray
  uint32_t active = 0;        // 1: `ray` waits for its closest hit; 0: the path has ended, L is final
};

// The camera ray of sample `sample_index` of pixel (px, py): its own RNG stream,
// a uniformly jittered position in the pixel (box filter). With `primary`
// (restir's frame-level passes) that pixel's record starts invalid (and its
// reservoir without a sample), until the path's first vertex writes both.
PN_FN PathState start_path(const Camera& camera, int px, int py, uint32_t sample_index, uint32_t seed,
                           RestirPrimaryOut* primary = nullptr) {
  PathState st;
  st.pixel = uint32_t(py) * uint32_t(camera.width) + uint32_t(px);
  st.sample_index = sample_index;
  st.rng = Rng(st.pixel, sample_index, seed);
  const Vec2 j = st.rng.uniform2();
  st.ray = camera.generate_ray(float(px) + j.x, float(py) + j.y);
  st.beta = Vec3(1.f);
  st.L = Vec3(0.f);
  st.depth = 0;
  st.active = 1;
  if (primary) {  // no record yet: every pass reads a pixel's reservoir only where its record is valid
    primary->pixel->valid = 0;
    primary->reservoir->W = 0.f;
  }
  return st;
}

// The path's ray escaped: the environment's (or background's) radiance, weighted
// as emission found by a BSDF sample. The path ends.
template <uint32_t kFeatures = kAllFeatures>
PN_FN void on_miss(PathState& st, const SceneView& scene, const IntegratorSettings& s) {
  const bool nee = strategy_uses_nee(s.strategy);
  const bool mis = nee && s.mis != Mis::None;
  const Vec3 Le = escaped_radiance<kFeatures>(scene, st.ray.d);
  if (st.depth == 0 || !nee || scene.environment_light < 0) {
    st.L += st.beta * Le;
  } else if (mis) {
    const uint32_t env = uint32_t(scene.environment_light);
    st.L += st.beta * Le * bsdf_emission_weight<kFeatures>(scene, s, st.prev, env, st.ray.d);
  }
  st.active = 0;
}

// The answer to a path's shadow query: its contribution counted (or the
// reservoir's W set) if the shadow ray was clear.
PN_FN void on_shadow_result(PathState& st, const ShadowQuery& q, bool blocked, RestirPrimaryOut* primary = nullptr) {
  if (blocked) return;
  if (q.kind == ShadowKind::Radiance) st.L += q.contribution;
  else if (q.kind == ShadowKind::Reservoir && primary) primary->reservoir->W = q.reservoir_W;
}

// The path's ray hit `rec` (a closest hit): emission there; unless the path
// ends at this vertex, next-event estimation (returned as a shadow query, or
// none) and the BSDF sample that continues the path (st.ray), then Russian
// roulette. st.active is 0 when the path ends here; the query, if any, must
// still be consumed. kFeatures must cover the scene's features (SceneFeature);
// fewer compile to less code.
//
// restir resamples the light samples of the first vertex (x1); with `primary`
// (its frame-level passes, core/restir.h) that vertex's direct light is left
// out of the path's radiance and its shading point and reservoir are written
// there instead (the query then sets the reservoir's W).
//
// With `now` (a tracer: the depth-first driver), the query is traced and
// consumed here, before the BSDF sample, and none is returned: the same
// estimate, but on the GPU's megakernel the light sample's state is dead before
// the BSDF is sampled (measured on the H200: tracing it after the BSDF sample
// cost 13% on cornell-sphere solid-angle and 37% with MIS).
//
// slc makes a query per node of its cut (light_cut_queries): with `now` each is traced and consumed here; else
// every one goes to `more` (a driver's sink: more->push(query)), to be traced and consumed as a returned query
// is, and none is returned. A driver that runs slc passes one or the other.
struct NoShadowTracer {
  PN_FN bool occluded(const Ray&, float) const { return false; }
};
struct NoQuerySink {
  PN_FN void push(const ShadowQuery&) {}
};

template <uint32_t kFeatures = kAllFeatures, class ShadowTracer = NoShadowTracer, class QuerySink = NoQuerySink>
PN_FN ShadowQuery on_hit(PathState& st, const SceneView& scene, const IntegratorSettings& s, const HitRecord& rec,
                         RestirPrimaryOut* primary = nullptr, const ShadowTracer* now = nullptr,
                         QuerySink* more = nullptr) {
  const bool nee = strategy_uses_nee(s.strategy);
  const bool mis = nee && s.mis != Mis::None;
  const bool restir = s.light_selection == LightSelection::Restir;
  const int depth = st.depth;
  Rng& rng = st.rng;
  ShadowQuery q;
  const SurfaceHit hit = resolve_hit<kFeatures>(scene, st.ray, rec);
  // Emission, from the front of an emitting surface.
  if (hit.light >= 0 && dot(hit.n, st.ray.d) < 0.f) {
    const Vec3 Le = light_emission<kFeatures>(scene, load_light(scene.lights, hit.light), hit.uv);
    if (depth == 0 || !nee) st.L += st.beta * Le;
    else if (mis)
      st.L += st.beta * Le * bsdf_emission_weight<kFeatures>(scene, s, st.prev, uint32_t(hit.light), st.ray.d);
  }
  st.active = 0;
  if (depth == s.max_depth) return q;

  const Vec3 wo = -st.ray.d;
  const Bsdf bsdf = surface_bsdf<kFeatures>(scene, hit, wo);
  if (is_black(bsdf.diffuse) && !bsdf.has_specular) return q;

  // Next-event estimation: a light sample, its shadow ray left to the driver; slc's, one per node of its cut.
  if ((kFeatures & kFeatureSlc) && s.light_selection == LightSelection::Slc) {
    if (nee)
      light_cut_queries<kFeatures>(scene, s, bsdf, hit, wo, st.beta, rng, [&](const ShadowQuery& sq) {
        if (now) on_shadow_result(st, sq, now->occluded(sq.ray, sq.tmax));
        else more->push(sq);
      });
  } else if (nee) {
    float u_select = rng.uniform();
    Vec2 u_light = rng.uniform2();
    const DirectSample d =
        choose_direct_sample<kFeatures>(scene, s, bsdf, hit.p, wo, restir && depth == 0, u_select, u_light, &rng);
    if (depth == 0 && primary) {
      RestirPixel& px = *primary->pixel;
      px.bsdf = pack_bsdf(bsdf);
      px.p = hit.p;
      px.p_bound = hit.p_bound;
      px.wo = wo;
      px.t = hit.t;
      px.valid = 1;
      *primary->reservoir =
          reservoir_before_visibility<kFeatures>(scene, bsdf, hit.p, hit.p_bound, wo, d, &q,
                                                 s.restir.visibility_reuse != 0);
    } else {
      q = direct_shadow_query<kFeatures>(s, bsdf, hit.p, hit.p_bound, wo, d);
      q.contribution = st.beta * q.contribution;
    }
    if (now && q.kind != ShadowKind::None) {
      on_shadow_result(st, q, now->occluded(q.ray, q.tmax), primary);
      q = ShadowQuery();
    }
  }

  // Continue the path by sampling the BSDF.
  float u_lobe = rng.uniform();
  BsdfSample bs = bsdf_sample<(kFeatures & kFeatureSpecular) != 0>(bsdf, wo, u_lobe, rng.uniform2());
  if (!(bs.pdf > 0.f)) return q;
  if (depth + 1 == s.max_depth && !last_vertex_adds<kFeatures>(scene, s)) return q;  // the vertex it finds adds nothing
  st.beta *= bs.weight;
  st.prev.set_ctx(light_sample_context<kFeatures>(s, hit.p, bsdf, wo));
  st.prev.bsdf_pdf = bs.pdf;
  st.prev.light_candidates = restir && depth == 0 ? float(pn_max(1u, s.restir.candidates)) : 1.f;

  // Russian roulette.
  if (depth + 1 >= s.rr_depth) {
    float p_end = pn_max(0.05f, 1.f - max_component(st.beta));
    if (rng.uniform() < p_end) return q;
    st.beta *= 1.f / (1.f - p_end);
  }
  st.ray = Ray(offset_ray_origin(hit.p, bsdf.ng, hit.p_bound, bs.wi), bs.wi);
  st.depth = depth + 1;
  st.active = 1;
  return q;
}

// The depth-first driver: the path to its end, each shadow query traced where on_hit makes it.
// Returns its radiance estimate.
template <uint32_t kFeatures = kAllFeatures, class Tracer>
PN_HD Vec3 trace_path(const Tracer& tracer, const SceneView& scene, const IntegratorSettings& s, PathState& st,
                      RestirPrimaryOut* primary = nullptr) {
  while (st.active) {
    HitRecord rec;
    if (!tracer.intersect(st.ray, kInf, &rec)) {
      on_miss<kFeatures>(st, scene, s);
      break;
    }
    on_hit<kFeatures>(st, scene, s, rec, primary, &tracer);  // its shadow query traced inside
  }
  return st.L;
}

// One camera sample of pixel (px, py), depth-first: what every backend's
// ordinary render calls.
template <uint32_t kFeatures = kAllFeatures, class Tracer>
PN_HD Vec3 render_sample(const Tracer& tracer, const SceneView& scene, const Camera& camera,
                         const IntegratorSettings& s, int px, int py, uint32_t sample_index, uint32_t seed,
                         RestirPrimaryOut* primary = nullptr) {
  PathState st = start_path(camera, px, py, sample_index, seed, primary);
  return trace_path<kFeatures>(tracer, scene, s, st, primary);
}

}  // namespace pn
