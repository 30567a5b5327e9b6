// A light BVH: light selection that adapts to the shading point (Conty Estevez
// & Kulla 2018, "Importance Sampling of Many Lights with Adaptive Tree
// Splitting"; the form of pbrt-v4's BVHLightSampler, written anew here).
//
// Every node bounds the lights below it: their box, their total power phi, and
// the directions their emitting sides face (a cone of normals: axis w, half
// angle theta_o; a sphere's normals cover every direction, theta_o = pi).
// Every light penumbra has emits diffusely from one side, so each normal's
// emission spans a hemisphere: theta_e = pi / 2 for all of them (pbrt keeps
// theta_e per node for spotlights; we have none).
//
// The importance of a node at a shading point p with normal n bounds what its
// lights can contribute there:
//     I = phi * cos(theta') / d^2 * cos(theta'_i)
// where d^2 is the mean of the squared distances from p to the box's centre
// and to its nearest point (never taken below an eighth of the box's bounding
// radius r), theta' the smallest angle any emitting normal of the
// node can make with the direction to p (theta_w - theta_o - theta_b, clamped
// at 0; theta_w: between w and the direction from the box to p, theta_b: the
// half angle the box's bounding sphere subtends at p), and theta'_i the
// smallest angle between n and a direction into that bounding sphere. I is 0
// only where no light of the node can contribute: theta' >= pi / 2 (every
// emitting side faces away from p) or theta'_i >= pi / 2 (the whole node below
// p's surface, where the BSDF, which only reflects, is 0).
//
// Traversal: from the root, go to child c with probability I_c / (I_0 + I_1),
// remapping the one uniform u into [0, 1) at every level, until a leaf (one
// light each). The probability of a given light (its pmf, which MIS needs for
// directions BSDF sampling found) is the product of the same ratios along its
// path, which a per-light bit trail encodes: bit k is the child taken at depth
// k (1: the second), above the highest set bit nothing, so that trail 1 is the
// root and 0 marks a light outside the tree (the environment, lights of zero
// power).
//
// The clamp of d: at r (the first choice), every point within r of two large
// siblings' centres, which on many-spheres' slab of lamps is every floor point
// for the upper levels, saw them as equally important wherever it was; at r / 4
// the nearer one wins. The MSE of a direct-lighting sample there (10,000 lamps,
// 192x108, against power's) fell from 0.49 to 0.18 (r / 2: 0.19, r / 10: 0.18,
// pbrt-v4's d^2 >= |diagonal| / 2, which is not scale-invariant: 0.20), and
// neither sponza-lanterns (0.081 to 0.079) nor polygon-near (0.43 to 0.42) lost.
// Then the distance itself: the centre's alone ranks a large box far from p as
// a small one at its centre; the mean of the centre's and the nearest point's
// squared distances, clamped at r / 8, took that MSE from 0.185 to 0.171
// (r / 4: 0.175; weights 1/4 and 3/4: 0.175, 3/4 and 1/4: 0.180), with
// polygon-near 0.440 to 0.443 and sponza-lanterns 0.118 to 0.119 (8 seeds of 4
// spp at 192x108: within their noise).
//
// The tree is built on the host (scene/light_bvh_build.cpp) and stored flat:
// node i's first child is node i + 1, its second `index`; a leaf holds its
// light's index with kLightBvhLeaf set. The same arrays live in device memory
// for the GPU.
#pragma once

#include "common.h"
#include "lights.h"
#include "vec.h"

namespace pn {

constexpr uint32_t kLightBvhLeaf = 0x80000000u;

// 48 bytes, aligned to 16 so that a GPU thread reads a node in three 16-byte loads.
struct alignas(16) LightBvhNode {
  Vec3 lo;                   // box of the emitting surfaces
  float phi = 0.f;           // power (luminance of Phi), summed over the node's lights
  Vec3 hi;
  float cos_theta_o = 1.f;   // every emitting normal lies within theta_o of w (-1: any direction)
  Vec3 w;                    // axis of the normals' cone (unit)
  uint32_t index = 0;        // interior: second child; leaf: light index | kLightBvhLeaf
};

// cos(max(0, a - b)) and sin(max(0, a - b)) of angles given by cosines and
// sines (both in [0, pi]).
PN_FN float cos_sub_clamped(float sin_a, float cos_a, float sin_b, float cos_b) {
  return cos_a > cos_b ? 1.f : cos_a * cos_b + sin_a * sin_b;
}
PN_FN float sin_sub_clamped(float sin_a, float cos_a, float sin_b, float cos_b) {
  return cos_a > cos_b ? 0.f : sin_a * cos_b - cos_a * sin_b;
}

// A node as the traversal reads it: on the GPU, three 16-byte loads through the
// read-only cache (its members read one by one compiled to a scalar load each,
// up to 12 a child). The scene's arrays are placed at alignof(LightBvhNode).
PN_FN LightBvhNode load_light_bvh_node(const LightBvhNode* nodes, uint32_t i) {
#ifdef __CUDA_ARCH__
  const float4* q = reinterpret_cast<const float4*>(nodes + i);
  const float4 a = __ldg(q), b = __ldg(q + 1), c = __ldg(q + 2);
  LightBvhNode n;
  n.lo = Vec3(a.x, a.y, a.z);
  n.phi = a.w;
  n.hi = Vec3(b.x, b.y, b.z);
  n.cos_theta_o = b.w;
  n.w = Vec3(c.x, c.y, c.z);
  n.index = __float_as_uint(c.w);
  return n;
#else
  return nodes[i];
#endif
}

// A node's box as the shading point p sees it: what the bound and the SG estimate share.
struct LightBvhNodeView {
  Vec3 extent;  // hi - lo
  Vec3 to_p;    // p from the box's centre
  float dist2;  // |to_p|^2
  float r2;     // the box's bounding sphere, squared radius
};
PN_FN LightBvhNodeView light_bvh_node_view(const LightBvhNode& b, Vec3 p) {
  LightBvhNodeView g;
  g.extent = b.hi - b.lo;
  g.to_p = p - (b.lo + b.hi) * 0.5f;
  g.dist2 = length_sq(g.to_p);
  g.r2 = length_sq(g.extent) * 0.25f;
  return g;
}

// The importance I of the node at a shading point with unit normal n, the node seen from there as g.
PN_FN float light_bvh_importance(const LightBvhNode& b, const LightBvhNodeView& g, Vec3 n) {
  const Vec3 extent = g.extent, to_p = g.to_p;
  const float dist2 = g.dist2, r2 = g.r2;
  // p's distance to the box's nearest point, per axis: |to_p| - extent / 2 where that is positive.
  const float near2 = length_sq(vmax(vabs(to_p) - extent * 0.5f, Vec3(0.f)));
  const float d2 = pn_max(0.5f * (dist2 + near2), r2 * (1.f / 64.f));  // d >= r / 8
  if (!(d2 > 0.f)) return 0.f;
  // Inside the bounding sphere theta_b covers every direction: theta' and theta'_i are 0 (cos_p = cos_pi = 1,
  // as the general formulas below compute it there).
  if (!(dist2 > r2)) return b.phi / d2;
  // Angles: theta_b (the bounding sphere seen from p).
  const float inv_dist = pn_rsqrt(dist2);
  const float sin2_b = r2 * inv_dist * inv_dist;
  const float sin_b = std::sqrt(sin2_b), cos_b = safe_sqrt(1.f - sin2_b);
  // theta' = max(0, theta_w - theta_o - theta_b), against theta_e = pi / 2. Normals in every direction
  // (theta_o = pi: spheres, or lights facing every way) make theta' 0 and cos_p exactly 1, as the general
  // formula computes it; the short cut spares the traversal of many sphere lights most of its arithmetic.
  float cos_p = 1.f;
  if (b.cos_theta_o > -1.f) {
    const Vec3 wi = to_p * inv_dist;
    const float cos_w = clamp(dot(b.w, wi), -1.f, 1.f), sin_w = safe_sqrt(1.f - cos_w * cos_w);
    const float sin_o = safe_sqrt(1.f - b.cos_theta_o * b.cos_theta_o);
    const float cos_x = cos_sub_clamped(sin_w, cos_w, sin_o, b.cos_theta_o);
    const float sin_x = sin_sub_clamped(sin_w, cos_w, sin_o, b.cos_theta_o);
    cos_p = cos_sub_clamped(sin_x, cos_x, sin_b, cos_b);
    if (!(cos_p > 0.f)) return 0.f;
  }
  // theta'_i: the direction towards the box is -to_p.
  const float cos_i = clamp(-dot(n, to_p) * inv_dist, -1.f, 1.f), sin_i = safe_sqrt(1.f - cos_i * cos_i);
  const float cos_pi = cos_sub_clamped(sin_i, cos_i, sin_b, cos_b);
  if (!(cos_pi > 0.f)) return 0.f;
  return b.phi * cos_p * cos_pi / d2;
}

// The importance I of the node at shading point p with unit normal n.
PN_FN float light_bvh_importance(const LightBvhNode& b, Vec3 p, Vec3 n) {
  return light_bvh_importance(b, light_bvh_node_view(b, p), n);
}

// --- Importance with the BSDF's lobes: spherical Gaussians (sg-bvh) ---------------------
//
// The importance above bounds the cosine at the receiver and knows nothing of its
// BSDF: on a glossy surface it spends samples on lights the lobe never reflects.
// sg-bvh (after Tokuyoshi, Ikeda, Kulkarni & Harada, "Hierarchical Light
// Sampling with Accurate Spherical Gaussian Lighting", SIGGRAPH Asia 2024)
// estimates what a node reflects towards wo: the node's light, seen from p, as a
// normalised spherical Gaussian (SG) around the direction to its box's centre,
// its sharpness from the solid angle of the box's bounding sphere (an SG of
// sharpness lambda covers about 2 pi / lambda sr; the cone pi sin^2(theta_b)), and
// the BSDF times the cosine as two SGs: the diffuse lobe, kd / pi times the
// cosine's SG fit 1.17 exp(2.133 (w . n - 1)), and the GGX lobe, its NDF's SG
// exp((2 / alpha^2)(h . n - 1)) warped to the reflected direction (sharpness
// divided by 4 cos_o; Wang et al. 2009), normalised and weighted by the lobe's
// Fresnel luminance. The estimate is the bound's importance I above (its distance,
// power and orientation terms) times the SG product integral:
//     I_sg = I * integral(G_light (f cos)_SG)
// in closed form. The simplifications of the paper here: the
// node's spread comes from its box, not from the lights' positional variance, and
// the SG integrals are over the sphere, not clipped to the hemisphere.
// I_sg never goes below 5% of the bound's importance times the lobes' weight / pi,
// and is 0 exactly where the bound is: every light that can contribute keeps a
// pmf > 0 (an SG's value underflows to 0 for sharp lobes far apart).

// The receiver's lobes as SGs, once per shading point.
struct SgLobes {
  Vec3 n;                        // the cosine lobe's axis
  float diffuse = 0.f;           // its weight: kd's luminance (LightSampleContext::diffuse)
  Vec3 r;                        // the GGX lobe's axis: wo reflected about n
  float specular = 0.f;          // its weight: the Fresnel luminance at wo (LightSampleContext::specular)
  float lambda_s = 0.f;          // its sharpness
  float norm_s = 0.f;            // 1 / its integral
};

// 1 - exp(-2 l) for l >= 0: 1 in float beyond l = 9 (exp(-18) < 2^-24), where the exponential is skipped.
PN_FN float sg_one_minus_exp2(float l) { return l > 9.f ? 1.f : -std::expm1(-2.f * l); }

// The integral over the sphere of exp(l1 (w . a1 - 1)) exp(l2 (w . a2 - 1)), a1, a2 unit:
// 2 pi exp(lm - l1 - l2) (1 - exp(-2 lm)) / lm with lm = |l1 a1 + l2 a2|.
PN_FN float sg_product_integral(Vec3 a1, float l1, Vec3 a2, float l2) {
  const float lm = length(a1 * l1 + a2 * l2);
  if (!(lm > 1e-4f)) return 4.f * kPi * std::exp(-l1 - l2);  // the product is constant: exp(-l1 - l2)
  return kTwoPi * std::exp(lm - l1 - l2) * sg_one_minus_exp2(lm) / lm;
}
// The integral of exp(l (w . a - 1)) over the sphere.
PN_FN float sg_integral(float l) { return l > 1e-4f ? kTwoPi * sg_one_minus_exp2(l) / l : 4.f * kPi; }

constexpr float kSgCosineSharpness = 2.133f, kSgCosineAmplitude = 1.17f;

PN_FN SgLobes make_sg_lobes(const LightSampleContext& ctx) {
  SgLobes s;
  s.n = ctx.n;
  s.diffuse = ctx.diffuse;
  const float cos_o = dot(ctx.wo, ctx.n);
  if (ctx.specular > 0.f && cos_o > 0.f) {
    s.specular = ctx.specular;
    s.r = ctx.n * (2.f * cos_o) - ctx.wo;
    const float a2 = pn_max(ctx.alpha * ctx.alpha, 1e-6f);
    s.lambda_s = pn_min((2.f / a2) / (4.f * pn_max(cos_o, 1e-3f)), 1e6f);
    s.norm_s = 1.f / sg_integral(s.lambda_s);
  }
  return s;
}

// The node's importance for the lobes: I_sg, between the floor above and 0 where the bound is 0.
PN_FN_CALLED float light_bvh_importance_sg(const LightBvhNode& b, Vec3 p, const SgLobes& lobes) {
  const LightBvhNodeView g = light_bvh_node_view(b, p);
  const float bound = light_bvh_importance(b, g, lobes.n);
  const float weight = lobes.diffuse + lobes.specular;
  if (!(bound > 0.f) || !(weight > 0.f)) return bound;
  const Vec3 to_c = -g.to_p;  // the box's centre from p (exactly centre - p)
  const float dist2 = g.dist2, r2 = g.r2;
  // The light's SG: around the centre's direction, sharpness 2 / sin^2(theta_b) (about 0 from inside the sphere).
  const float sin2_b = dist2 > r2 ? r2 / dist2 : 1.f;
  const float lambda_l = 2.f / pn_max(sin2_b, 1e-12f);
  const Vec3 a_l = dist2 > 0.f ? to_c * pn_rsqrt(dist2) : lobes.n;
  const float norm_l = 1.f / sg_integral(lambda_l);
  float f = 0.f;
  if (lobes.diffuse > 0.f)
    f = lobes.diffuse * (kInvPi * kSgCosineAmplitude) * sg_product_integral(a_l, lambda_l, lobes.n, kSgCosineSharpness);
  if (lobes.specular > 0.f) f += lobes.specular * lobes.norm_s * sg_product_integral(a_l, lambda_l, lobes.r, lobes.lambda_s);
  f *= norm_l;
  // The bound keeps its best-case cosine at the receiver (1 for a node that reaches over the normal): the SG
  // cosine lobe refines it, never makes a node that cannot contribute count.
  return pn_max(bound * f, 0.05f * bound * weight * kInvPi);
}

// --- Selection by traversal, and the pmf of a given light ---------------------------

struct LightBvhView {
  const LightBvhNode* nodes = nullptr;  // null: no tree (no lights with a surface and power)
  const uint64_t* trails = nullptr;     // per light (SceneView::lights): its bit trail, 0 outside the tree
};

struct LightBvhPick {
  uint32_t light = 0;
  float pmf = 0.f;  // 0: nothing (no node has importance at p)
};

// What a traversal weighs nodes by: the bound (bvh) or, with lobes, the SG estimate (sg-bvh). The traversals are
// templates on which (kSg): bvh's code is the bound's alone, as before sg-bvh existed.
struct LightBvhQuery {
  Vec3 p, n;
  SgLobes lobes;  // kSg only
};
template <bool kSg>
PN_FN LightBvhQuery light_bvh_query(const LightSampleContext& ctx) {
  LightBvhQuery q;
  q.p = ctx.p;
  q.n = ctx.n;
  if constexpr (kSg) q.lobes = make_sg_lobes(ctx);
  return q;
}
template <bool kSg>
PN_FN float light_bvh_node_importance(const LightBvhNode& b, const LightBvhQuery& q) {
  if constexpr (kSg) return light_bvh_importance_sg(b, q.p, q.lobes);
  return light_bvh_importance(b, q.p, q.n);
}

// The probability of the first of two sibling nodes, from their importance; -1
// when neither has any (traversal stops there).
template <bool kSg>
PN_FN float light_bvh_first_probability(const LightBvhNode& c0, const LightBvhNode& c1, const LightBvhQuery& q) {
  const float i0 = light_bvh_node_importance<kSg>(c0, q);
  const float i1 = light_bvh_node_importance<kSg>(c1, q);
  if (!(i0 > 0.f || i1 > 0.f)) return -1.f;
  return i0 / (i0 + i1);
}

// The same at interior node `node`.
template <bool kSg>
PN_FN float light_bvh_first_child_probability(const LightBvhView& v, uint32_t node, const LightBvhQuery& q) {
  return light_bvh_first_probability<kSg>(load_light_bvh_node(v.nodes, node + 1),
                                          load_light_bvh_node(v.nodes, load_light_bvh_node(v.nodes, node).index), q);
}

// Whether a tree whose root is a leaf (one light) has importance at ctx: no parent checked it.
PN_FN bool light_bvh_root_leaf_visible(const LightBvhView& v, const LightBvhQuery& q) {
  return light_bvh_importance(load_light_bvh_node(v.nodes, 0), q.p, q.n) > 0.f;
}

// One light, by one traversal with the uniform u. Each level reads the two
// children (the node itself was read as a child of its parent).
// kSg: weigh nodes by the BSDF's lobes at ctx (sg-bvh).
template <bool kSg = false>
PN_FN LightBvhPick light_bvh_select_below(const LightBvhView& v, const LightBvhQuery& q, uint32_t node, float u);

template <bool kSg = false>
PN_FN LightBvhPick light_bvh_select(const LightBvhView& v, const LightSampleContext& ctx, float u) {
  if (!v.nodes) return LightBvhPick();
  return light_bvh_select_below<kSg>(v, light_bvh_query<kSg>(ctx), 0, u);
}

// The same from node `node` down (0: the root): a light of its subtree, with its probability given the node.
template <bool kSg>
PN_FN LightBvhPick light_bvh_select_below(const LightBvhView& v, const LightBvhQuery& q, uint32_t node, float u) {
  LightBvhPick pick;
  uint32_t index = load_light_bvh_node(v.nodes, node).index;
  float pmf = 1.f;
  while (!(index & kLightBvhLeaf)) {
    const LightBvhNode c0 = load_light_bvh_node(v.nodes, node + 1), c1 = load_light_bvh_node(v.nodes, index);
    const float p0 = light_bvh_first_probability<kSg>(c0, c1, q);
    if (p0 < 0.f) return pick;
    if (u < p0) {
      u = pn_min(u / p0, kOneMinusEpsilon);
      pmf *= p0;
      node = node + 1;
      index = c0.index;
    } else {
      u = pn_min((u - p0) / (1.f - p0), kOneMinusEpsilon);
      pmf *= 1.f - p0;
      node = index;
      index = c1.index;
    }
  }
  if (node == 0 && !light_bvh_root_leaf_visible(v, q)) return pick;
  pick.light = index & ~kLightBvhLeaf;
  pick.pmf = pmf;
  return pick;
}

// One level of a light's trail below `node` (`index`: that node's): to the child the trail's bit names (`second`),
// the pmf times that child's probability. False where neither child has importance at q (the pmf is then 0).
template <bool kSg>
PN_FN bool light_bvh_pmf_step(const LightBvhView& v, const LightBvhQuery& q, bool second, uint32_t* node,
                              uint32_t* index, float* pmf) {
  const LightBvhNode c0 = load_light_bvh_node(v.nodes, *node + 1), c1 = load_light_bvh_node(v.nodes, *index);
  const float p0 = light_bvh_first_probability<kSg>(c0, c1, q);
  if (p0 < 0.f) return false;
  if (second) {
    *pmf *= 1.f - p0;
    *node = *index;
    *index = c1.index;
  } else {
    *pmf *= p0;
    *node = *node + 1;
    *index = c0.index;
  }
  return true;
}

// The probability that light_bvh_select() picks `light` at ctx: the same
// ratios, in the same floating-point operations, along the light's trail.
template <bool kSg = false>
PN_FN float light_bvh_pmf(const LightBvhView& v, const LightSampleContext& ctx, uint32_t light) {
  if (!v.nodes) return 0.f;
  const LightBvhQuery q = light_bvh_query<kSg>(ctx);
  uint64_t trail = v.trails[light];
  if (trail == 0) return 0.f;
  uint32_t node = 0, index = load_light_bvh_node(v.nodes, 0).index;
  float pmf = 1.f;
  for (; trail > 1u; trail >>= 1)
    if (!light_bvh_pmf_step<kSg>(v, q, (trail & 1u) != 0, &node, &index, &pmf)) return 0.f;
  if (node == 0 && !light_bvh_root_leaf_visible(v, q)) return 0.f;
  return pmf;
}

// --- Stochastic lightcuts (slc) -------------------------------------------------------
//
// Yuksel, "Stochastic Lightcuts", HPG 2019: a cut through the tree at the
// shading point (nodes whose subtrees hold every light once) and one light
// drawn in each node of it by the traversal from that node, each with its own
// shadow ray; their sum estimates the direct light. A light's probability is its
// traversal's from the one node of the cut above it (light_cut_pmf), which is
// what weighs a BSDF-sampled hit on it by MIS.
//
// The cut grows from the root: the node of the cut with the largest importance
// (the bound above) is replaced by its children, until the cut holds `max_nodes`
// nodes or leaves only. A child of importance 0 is left out (none of its lights
// can contribute at p). Yuksel refines by an error bound, the node's importance
// times how much its lights' geometric terms can differ; the importance alone is
// a simplification: it refines where the most light may come from. The cut is a
// function of the shading point alone (no random numbers), as the pmf needs.
constexpr uint32_t kMaxLightCut = 64;

struct LightCut {
  uint32_t count = 0;
  uint32_t node[kMaxLightCut];
};

// Whether `node` is in the cut.
PN_FN bool light_cut_holds(const LightCut& c, uint32_t node) {
  for (uint32_t k = 0; k < c.count; ++k)
    if (c.node[k] == node) return true;
  return false;
}

// The cut of at most max_nodes (1..kMaxLightCut) nodes at q (the bound's importance; empty where no light can
// contribute).
PN_FN_CALLED LightCut light_bvh_cut(const LightBvhView& v, const LightBvhQuery& q, uint32_t max_nodes) {
  LightCut c;
  if (!v.nodes) return c;
  max_nodes = pn_min(pn_max(max_nodes, 1u), kMaxLightCut);
  float importance[kMaxLightCut];
  uint32_t index[kMaxLightCut];  // each node's `index`: its second child, or its light with kLightBvhLeaf
  const LightBvhNode root = load_light_bvh_node(v.nodes, 0);
  importance[0] = light_bvh_importance(root, q.p, q.n);
  if (!(importance[0] > 0.f)) return c;
  c.node[0] = 0;
  index[0] = root.index;
  c.count = 1;
  for (;;) {
    uint32_t best = kMaxLightCut;
    float most = 0.f;
    for (uint32_t k = 0; k < c.count; ++k)
      if (!(index[k] & kLightBvhLeaf) && importance[k] > most) {
        best = k;
        most = importance[k];
      }
    if (best == kMaxLightCut) break;  // leaves only
    const uint32_t a = c.node[best] + 1, b = index[best];
    const LightBvhNode na = load_light_bvh_node(v.nodes, a), nb = load_light_bvh_node(v.nodes, b);
    const float ia = light_bvh_importance(na, q.p, q.n), ib = light_bvh_importance(nb, q.p, q.n);
    if (ia > 0.f && ib > 0.f) {
      if (c.count == max_nodes) break;  // no room for both
      c.node[c.count] = b;
      importance[c.count] = ib;
      index[c.count] = nb.index;
      ++c.count;
    }
    if (ia > 0.f || ib > 0.f) {  // the node replaced by its child of importance (the first where both have)
      const bool first = ia > 0.f;
      c.node[best] = first ? a : b;
      importance[best] = first ? ia : ib;
      index[best] = first ? na.index : nb.index;
    } else {  // neither child has importance: the node leaves the cut
      --c.count;
      c.node[best] = c.node[c.count];
      importance[best] = importance[c.count];
      index[best] = index[c.count];
      if (c.count == 0) break;
    }
  }
  return c;
}

// The probability that the cut's sample of the node above `light` picks it (light_bvh_select_below from that
// node): the traversal's ratios below it, in the same floating-point operations; 0 where no node of the cut holds
// the light (it is outside the tree, or below a node of no importance at q).
PN_FN_CALLED float light_cut_pmf(const LightBvhView& v, const LightBvhQuery& q, const LightCut& c, uint32_t light) {
  if (!v.nodes) return 0.f;
  uint64_t trail = v.trails[light];
  if (trail == 0) return 0.f;
  uint32_t node = 0, index = load_light_bvh_node(v.nodes, 0).index;
  bool below = light_cut_holds(c, 0);
  float pmf = 1.f;
  for (; trail > 1u; trail >>= 1) {
    if (!below) {  // above the cut: follow the trail
      node = (trail & 1u) ? index : node + 1;
      index = load_light_bvh_node(v.nodes, node).index;
      below = light_cut_holds(c, node);
      continue;
    }
    if (!light_bvh_pmf_step<false>(v, q, (trail & 1u) != 0, &node, &index, &pmf)) return 0.f;
  }
  return below ? pmf : 0.f;
}

}  // namespace pn
