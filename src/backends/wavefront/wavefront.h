// The wavefront path tracer's stages (issue 11, part 2; backends/optix/WAVEFRONT.md): a pool of paths in
// structure-of-arrays form, queues of rays, and one function per stage, each the work of one thread (one
// queue entry or one pool slot). They call the integrator's step functions (core/integrator.h: start_path,
// on_hit / on_miss, on_shadow_result) and nothing else shades: no second integrator.
//
// One wave, for pool slots 0..n-1 (items first_item + slot of a render call's pixels x samples):
//     generate_camera_ray(i)      every slot: start_path -> ray queue 0 (position i)
//     repeat max_depth + 1 times (iteration `it`, cur = it % 2):
//       trace closest             ray queue cur -> hits[j]                      (the trace stage)
//       trace shadow              shadow queue -> blocked bits                  (the trace stage)
//       apply_shadow_result(j)    on_shadow_result: the query's contribution into its path's L
//       begin_bounce(cur ^ 1)     the next ray queue and the shadow queue emptied
//       shade<F>(j, cur)          on_hit / on_miss: a shadow query pushed to the shadow queue, the next ray
//                                 pushed to ray queue cur ^ 1
//       queue_order_place(j)      where the queues are traced in the order of a key (QueueOrder: ShadowOrder,
//                                 RayOrder), each entry shade counted to its place in that order
//     accumulate(i)               every pixel of the wave: its samples' L, in sample order
// A path's shadow result is consumed (apply) before its next hit (shade), the one ordering rule of the step
// functions, so the image is the depth-first driver's bit for bit wherever the arithmetic is the same (the CPU:
// tests/core/test_path_schedule.cpp). Queue order is whatever the pushes make it (atomics): each entry names its slot and
// a path touches only its own slot, so the order changes nothing. max_depth + 1 iterations always suffice: shade
// at depth max_depth makes neither ray nor query, and a query made at depth d is consumed at iteration d + 1.
//
// Every camera sample has its own RNG stream (start_path), so waves may cut the items anywhere: pools smaller
// than the frame (several waves a render call) and pools holding several samples of a pixel give the same image.
//
// restir without spatial reuse resamples inside on_hit and is covered as it is. restir's frame-level passes
// (core/restir.h) run their primary pass as a wavefront (RestirFrame below): one sample of every pixel, each
// path's first vertex writing its pixel's record and reservoir (on_hit's RestirPrimaryOut), the reservoir's
// visibility query (ShadowKind::Reservoir) in the shadow queue beside the others, and the accumulation writing
// each path's radiance to its pixel's record instead of a sink. The reuse and shading passes follow over the
// whole frame, each recorded, traced and replayed in chunks of pixels (the last section of this file).
//
// Plain pointers and PN_HD code: the CPU backend runs these in loops (CpuSchedule::Wavefront), the GPU in kernels
// (wavefront_gpu.cu).
#pragma once

#include <cstddef>
#include <cstdint>
#include <cstring>
#include <stdexcept>
#include <string>

#include "backends/trace_stage.h"
#include "core/camera.h"
#include "core/integrator.h"
#include "core/restir.h"
#include "render/gpu_tuning.h"  // OrderMode

namespace pn {

// A queue's next position: an atomic counter on both sides (any number of threads push).
PN_FN uint32_t queue_push(uint32_t* count) {
#if defined(__CUDA_ARCH__)
  return atomicAdd(count, 1u);
#else
  return __atomic_fetch_add(count, 1u, __ATOMIC_RELAXED);
#endif
}

// Which items a wave holds: item k of a render call is sample first_sample + k / pixels of pixel k % pixels
// (a pixel's samples in order of k); the wave holds items [first_item, first_item + count), slot k - first_item.
struct WaveSpec {
  uint64_t first_item = 0;
  uint32_t count = 0;
  uint32_t first_sample = 0;
  uint32_t pixels = 0;
  uint32_t seed = 0;
};

// Two 16-byte words of a path's PrevVertex: the pool keeps its first two and its last two in arrays of their own,
// so that configurations that never read the lobes move their words at the stride they had before the lobes were
// added (with the four words at a stride of 64 bytes, MIS power lost 1.4-4.6% a sample on the H200).
struct alignas(16) PrevWords {
  float v[8];
};

// What a path keeps between stages, one array per field (PathState less what the queues hold: the ray lives
// in its ray queue entry; pixel and sample index follow from the slot).
struct PathPool {
  Vec3* beta = nullptr;
  Vec3* L = nullptr;
  Rng* rng = nullptr;
  PrevWords* prev = nullptr;        // PrevVertex's first two 16-byte words (point, normal, pdf, candidates)
  PrevWords* prev_lobes = nullptr;  // its last two (the BSDF's lobes: ltc, sg-bvh), an array of their own
  int32_t* depth = nullptr;
  uint32_t* rays = nullptr;  // rays traced for the path (camera, continuation and shadow rays): the stats' count
};

// Rays waiting for their closest hit: the trace stage reads `rays` (TraceRay, backends/trace_stage.h).
struct RayQueue {
  TraceRay* rays = nullptr;
  uint32_t* slot = nullptr;
  uint32_t* count = nullptr;
};

// Shadow queries (ShadowKind::Radiance: the only kind a wavefront makes) waiting for their shadow ray.
struct ShadowQueue {
  TraceRay* rays = nullptr;
  uint32_t* slot = nullptr;
  Vec3* contribution = nullptr;
  uint32_t* count = nullptr;
};

// A queue traced in the order of a key instead of its own (the order its pushes made): the stage that pushes an
// entry counts it into its key's cell (cell_count) and keeps its cell and its rank there; a scan turns the counts
// into cells' first positions (cell_start) and empties the counts; queue_order_place puts each entry's queue
// position at its place in `order`; the trace stage traces order[0], order[1], ... Null pointers: queue order.
// Which entry is traced when changes no answer (each names its own path), so the image is the same.
struct QueueOrder {
  uint32_t* cell_count = nullptr;  // one a cell
  uint32_t* cell_start = nullptr;  // one a cell
  uint32_t* cell = nullptr;        // per queue position: its key's cell
  uint32_t* rank = nullptr;        // per queue position: the entries counted into its cell before it
  uint32_t* order = nullptr;       // per position in the traced order: the queue position
};

// Entry k counted into cell c, its rank there kept (the pushing stage).
PN_FN void queue_order_count(const QueueOrder& o, uint32_t k, uint32_t c) {
  o.cell[k] = c;
#if defined(__CUDA_ARCH__)
  // One atomic per cell a warp: lanes of one warp often share a cell, and one atomic a lane, queued on the few
  // cells around a small light's direction, was part of what the first form cost (cornell-sphere, commit a01e762).
  const unsigned peers = __match_any_sync(__activemask(), c);
  const int lane = int(threadIdx.x & 31u), leader = __ffs(int(peers)) - 1;
  uint32_t first = 0;
  if (lane == leader) first = atomicAdd(o.cell_count + c, uint32_t(__popc(int(peers))));
  first = __shfl_sync(peers, first, leader);
  o.rank[k] = first + uint32_t(__popc(int(peers & ((1u << lane) - 1u))));
#else
  o.rank[k] = queue_push(o.cell_count + c);
#endif
}

// Entry j (< its queue's count) to its place in the traced order, once cell_start holds the scan.
PN_FN void queue_order_place(uint32_t j, const QueueOrder& o) {
  o.order[o.cell_start[o.cell[j]] + o.rank[j]] = j;
}

// The cell of unit direction d: its point on the octahedron |x| + |y| + |z| = 1, the lower half folded out over
// the square's corners, on a grid of 2^bits a side.
PN_FN uint32_t octahedral_cell(Vec3 d, uint32_t bits) {
  const float a = std::fabs(d.x) + std::fabs(d.y) + std::fabs(d.z);
  float u = d.x / a, v = d.y / a;
  if (d.z < 0.f) {
    const float fu = (1.f - std::fabs(v)) * (u < 0.f ? -1.f : 1.f);
    v = (1.f - std::fabs(u)) * (v < 0.f ? -1.f : 1.f);
    u = fu;
  }
  const float side = float(1u << bits);
  const uint32_t iu = uint32_t(pn_min(pn_max((u * 0.5f + 0.5f) * side, 0.f), side - 1.f));
  const uint32_t iv = uint32_t(pn_min(pn_max((v * 0.5f + 0.5f) * side, 0.f), side - 1.f));
  return iu << bits | iv;  // a NaN direction lands in cell 0
}

// The shadow queue in the order of its rays' directions (commit a01e762): shadow rays end on the lights, so rays of
// nearly one direction toward one light run along nearly one line and traverse nearly the same nodes, where rays
// in queue order (their paths' order: scattered shading points after the first bounce) share little. shade
// counts each query into its direction's cell.
constexpr uint32_t kShadowCellBits = 7;  // 128 x 128 octahedral cells of the sphere of directions
// The queries of vertices from this depth on are ordered: the camera's hits are in pixel order, whose shadow rays
// are coherent already (its cost is then not paid back: commit a01e762, cornell-sphere).
constexpr int kShadowOrderDepth = 1;
constexpr uint32_t kShadowCells = 1u << (2 * kShadowCellBits);
struct ShadowOrder : QueueOrder {
  uint32_t reverse = 0;  // 1: ordered queries traced from the light back (reversed_shadow_ray)
};

PN_FN uint32_t shadow_direction_cell(Vec3 d) { return octahedral_cell(d, kShadowCellBits); }

// The closest-hit rays of the bounces in the order of their directions, then their origins (commit a6913f3): the
// rays shade makes go from scattered shading points in directions the BSDFs draw, so a warp's rays in queue order
// share few nodes; grouped by direction (8 x 8 octahedral cells) and, within one, by where they start (a Morton
// order of 8 x 8 x 8 cells of the scene's box), they share more: a model of the warps' lock step put the work
// issued on Sponza's first two bounces at 1080p 19% lower (commit a6913f3's docs/results, in git history), and the H200
// traced them 16% faster (its closest hits 5.13 -> 4.35 ms a sample; counting, scanning and placing cost 0.37).
// Finer keys would save more (16 x 16 directions: 23%) but need a scan of 2^17 cells and more. The camera's rays
// stay in pixel order, coherent already. Only the tracing follows the order: shade reads its queue in queue
// order, whose slots follow one another (shading in the traced order scattered the pool's reads: Sponza's
// shading 2.44 -> 5.17 ms).
constexpr uint32_t kRayDirectionBits = 3, kRayOriginBits = 3;
constexpr uint32_t kRayCells = 1u << (2 * kRayDirectionBits + 3 * kRayOriginBits);
struct RayOrder : QueueOrder {
  Vec3 lo;     // the scene's box: origins' cells are (o - lo) * scale, clamped to the grid
  Vec3 scale;  // 2^kRayOriginBits / the box's extent (0 on a flat axis)
};

// The cell of a ray: its direction's octahedral cell, then its origin's Morton cell.
PN_FN uint32_t ray_order_cell(const RayOrder& o, const Ray& r) {
  constexpr float kSide = float(1u << kRayOriginBits);
  auto axis = [](float v) {  // kRayOriginBits bits, spread to every third bit
    uint32_t q = uint32_t(pn_min(pn_max(v, 0.f), kSide - 1.f));
    q = (q | (q << 4)) & 0x0C3u;
    q = (q | (q << 2)) & 0x249u;
    return q;
  };
  static_assert(kRayOriginBits <= 3, "axis() spreads three bits");
  const Vec3 q = (r.o - o.lo) * o.scale;
  const uint32_t morton = axis(q.x) | axis(q.y) << 1 | axis(q.z) << 2;
  return octahedral_cell(r.d, kRayDirectionBits) << (3 * kRayOriginBits) | morton;
}

// Whether a queue is traced in the order of a key, and why in a few words ("cell order (auto: rays visit 46.4 nodes,
// at least 24)"): never where the trace stage cannot (`unable` says why), as `mode` says where it is not Auto (the
// tuning key `key`: GpuTuning::shadow_order, ::ray_order), else where the scene's rays visit at least `min_visits`
// nodes. `ordered`: the order's name.
inline bool choose_order(bool able, const char* unable, OrderMode mode, const char* key, const char* ordered,
                         double visits, double min_visits, std::string* reason) {
  if (!able) {
    *reason = std::string("queue order (") + unable + ")";
    return false;
  }
  if (mode != OrderMode::Auto) {
    const bool on = mode == OrderMode::Ordered;
    *reason = std::string(on ? ordered : "queue") + " order (" + key + ")";
    return on;
  }
  std::string why;
  const bool on = rays_are_long(visits, min_visits, &why);
  *reason = std::string(on ? ordered : "queue") + " order (" + why + ")";
  return on;
}

// The same shadow segment traced from its far end (on the light) back toward the shading point: ordered by
// direction, rays toward one light then also start together, and share the nodes around the light first
// (commit a01e762: Sponza's shadow stage 1.79 -> 1.55 ms a sample on the H200, after the order's 2.68 -> 1.79).
// It stops short of the origin by a slack that covers the rounding of the far end (1e-5 of the coordinates'
// magnitude, about 80 ulps), so that the ray does not find the surface it was sent from; occluders closer than
// that to the shading point are not seen, as the forward ray sees none within kShadowEpsilon of the light.
// What that costs: light behind an occluder within 1e-5 (|o| + |y| + distance) of the shading point counts as
// visible (test ShadowOrder.ReversedSlackIsBounded). An infinite segment is left as it is. Since ray origins sit
// at the hit point's own error bound off the surface (offset_ray_origin: about 1e-7 of the coordinates, where the
// older integer offset put them near the slack's 1e-5), the slack is the larger of the two, and Sponza's image
// traced this way was 0.021% brighter than traced forward with the same paths (H200, 128 x 72, 256 spp): occluders
// that close to a shading point are real there (walls meeting floors). So this is off by default
// (--tune shadow_reverse=true turns it on); it wants a slack from each ray's own cosine and bound to come back.
PN_FN Ray reversed_shadow_ray(const Ray& r, float* tmax) {
  if (!(*tmax < kInf)) return r;
  const Vec3 far = r.o + r.d * *tmax;
  auto magnitude = [](Vec3 v) { return pn_max(pn_max(std::fabs(v.x), std::fabs(v.y)), std::fabs(v.z)); };
  const float slack = 1e-5f * (magnitude(r.o) + magnitude(far) + *tmax);
  *tmax = pn_max(*tmax - slack, 0.f);
  return Ray(far, -r.d);
}

// restir's primary pass (null pointers: an ordinary render): pixel p's record and reservoir, written by the
// first vertex of its path; a wave then holds one sample of each pixel (first_sample: the frame's).
struct RestirFrame {
  RestirPixel* pixels = nullptr;
  Reservoir* reservoirs = nullptr;
};

// A shadow queue entry whose slot has this bit is a reservoir's visibility query (ShadowKind::Reservoir): its
// contribution's x holds the W it sets. Slots are below the pool's capacity, at most 2^26.
constexpr uint32_t kReservoirQuery = 1u << 31;

// Every array of a wavefront, sized for `capacity` paths.
struct WavefrontView {
  const WaveSpec* wave = nullptr;
  PathPool pool;
  RayQueue ray[2];          // ping-pong: iteration it reads ray[it % 2] and writes ray[(it + 1) % 2]
  ShadowQueue shadow;
  HitRecord* hits = nullptr;        // hits[j]: ray[cur].rays[j]'s closest hit, instance kTraceMiss for a miss
  uint32_t* blocked_bits = nullptr;  // bit j: shadow.rays[j] is blocked (trace_bit_words(capacity) words)
  ShadowOrder shadow_order;          // null pointers: the shadow queue traced in queue order
  RayOrder ray_order;                // null pointers: the bounces' ray queues traced in queue order
  uint32_t capacity = 0;
  RestirFrame restir;
  // 1: a path may have several shadow queries in the queue at once (slc: one per node of its cut), whose results
  // are added to its radiance atomically, in no set order.
  uint32_t shared_slots = 0;
};

// How a wave is laid out for these settings: the paths a wave of a pool of `capacity` holds, fewer than the pool
// where a vertex makes several shadow queries (slc), so that the shadow queue, as long as the pool, holds every
// query of a bounce; and whether a path's queries share its slots (WavefrontView::shared_slots). `environment`:
// the scene has an environment light (SceneView::selection.infinite_light >= 0), which slc samples besides its cut.
struct WaveShape {
  uint32_t paths = 0;
  uint32_t shared_slots = 0;
};
PN_FN WaveShape wave_shape(uint32_t capacity, const IntegratorSettings& s, bool environment) {
  const uint32_t per_vertex = light_samples_per_vertex(s, environment);
  WaveShape w;
  w.paths = pn_max(capacity / per_vertex, 1u);
  w.shared_slots = per_vertex > 1 ? 1u : 0u;
  return w;
}

// Bytes of one path's state and queue entries: what the pool costs per slot.
constexpr uint64_t kWavefrontBytesPerPath =
    sizeof(Vec3) * 2 + sizeof(Rng) + 2 * sizeof(PrevWords) + sizeof(int32_t) + sizeof(uint32_t) +  // pool
    2 * (sizeof(TraceRay) + sizeof(uint32_t)) +                                                 // ray queues
    sizeof(TraceRay) + sizeof(uint32_t) + sizeof(Vec3) +                                        // shadow queue
    sizeof(HitRecord) +                                                                         // hits
    3 * sizeof(uint32_t) +                                                                      // ShadowOrder
    3 * sizeof(uint32_t);                                                                       // RayOrder
// The whole pool of `capacity` paths, blocked bits, the three counters and the orders' cells included.
PN_FN uint64_t wavefront_bytes(uint32_t capacity) {
  return uint64_t(capacity) * kWavefrontBytesPerPath + uint64_t(trace_bit_words(capacity)) * 4u + 3u * 4u +
         2u * kShadowCells * 4u + 2u * kRayCells * 4u;
}

// --- 16-byte words -----------------------------------------------------------------------------------------------

// TraceRay and PrevVertex move as 16-byte accesses on the GPU (PrevVertex two, four where light sampling weighs by
// the BSDF's lobes: ltc, sg-bvh). Copied as structs of Vec3s they moved a float at a time: eight 4-byte accesses,
// each spanning its warp's 1 KiB (ncu, commit cf489d0: three quarters of the shade kernel's L2 sectors were excess
// ones of these).
static_assert(sizeof(PrevVertex) == 64 && offsetof(PrevVertex, bsdf_pdf) == 24 &&
                  offsetof(PrevVertex, light_candidates) == 28 && offsetof(PrevVertex, wo) == 32 &&
                  offsetof(PrevVertex, specular) == 48,
              "PrevVertex is four 16-byte words: p, n.x | n.y, n.z, bsdf_pdf, light_candidates | wo, alpha | "
              "specular, diffuse");

PN_FN Ray load_trace_ray(const TraceRay* p, float* tmax = nullptr) {
#if defined(__CUDA_ARCH__)
  const float4* q = reinterpret_cast<const float4*>(p);
  const float4 a = q[0], b = q[1];
  if (tmax) *tmax = a.w;
  return Ray(Vec3(a.x, a.y, a.z), Vec3(b.x, b.y, b.z));
#else
  if (tmax) *tmax = p->tmax;
  return Ray(p->o, p->d);
#endif
}

PN_FN void store_trace_ray(TraceRay* p, const Ray& r, float tmax) {
#if defined(__CUDA_ARCH__)
  float4* q = reinterpret_cast<float4*>(p);
  q[0] = make_float4(r.o.x, r.o.y, r.o.z, tmax);
  q[1] = make_float4(r.d.x, r.d.y, r.d.z, 0.f);
#else
  TraceRay t;
  t.o = r.o;
  t.d = r.d;
  t.tmax = tmax;
  *p = t;
#endif
}

// The previous vertex: its first two words, and its BSDF's lobes (the last two) where `lobes`
// (path_reads_prev_lobes: ltc, sg-bvh).
PN_FN PrevVertex load_prev(const PathPool& pool, uint32_t slot, bool lobes) {
  PrevVertex v;
#if defined(__CUDA_ARCH__)
  const float4* q = reinterpret_cast<const float4*>(pool.prev + slot);
  const float4 a = q[0], b = q[1];
  v.p = Vec3(a.x, a.y, a.z);
  v.n = Vec3(a.w, b.x, b.y);
  v.bsdf_pdf = b.z;
  v.light_candidates = b.w;
  if (lobes) {
    const float4* r = reinterpret_cast<const float4*>(pool.prev_lobes + slot);
    const float4 c = r[0], d = r[1];
    v.wo = Vec3(c.x, c.y, c.z);
    v.alpha = c.w;
    v.specular = d.x;
    v.diffuse = d.y;
  }
#else
  static_assert(sizeof(PrevVertex) == 2 * sizeof(PrevWords), "PrevVertex is the two halves");
  char* bytes = reinterpret_cast<char*>(static_cast<void*>(&v));  // PrevVertex's bytes, its halves in turn
  std::memcpy(bytes, pool.prev + slot, sizeof(PrevWords));
  if (lobes) std::memcpy(bytes + sizeof(PrevWords), pool.prev_lobes + slot, sizeof(PrevWords));
#endif
  return v;
}

PN_FN void store_prev(const PathPool& pool, uint32_t slot, const PrevVertex& v, bool lobes) {
#if defined(__CUDA_ARCH__)
  float4* q = reinterpret_cast<float4*>(pool.prev + slot);
  q[0] = make_float4(v.p.x, v.p.y, v.p.z, v.n.x);
  q[1] = make_float4(v.n.y, v.n.z, v.bsdf_pdf, v.light_candidates);
  if (lobes) {
    float4* r = reinterpret_cast<float4*>(pool.prev_lobes + slot);
    r[0] = make_float4(v.wo.x, v.wo.y, v.wo.z, v.alpha);
    r[1] = make_float4(v.specular, v.diffuse, 0.f, 0.f);
  }
#else
  const char* bytes = reinterpret_cast<const char*>(static_cast<const void*>(&v));
  std::memcpy(pool.prev + slot, bytes, sizeof(PrevWords));
  if (lobes) std::memcpy(pool.prev_lobes + slot, bytes + sizeof(PrevWords), sizeof(PrevWords));
#endif
}

// --- Loading and storing a path -----------------------------------------------------------------------------

// What a step reads and writes of the pool, less than the whole PathState (shading is bound by these bytes: ~300 a
// path and bounce, 0.6 GB a 1080p bounce). Pixel and sample index are left 0: no step reads them after start_path
// (restir's first vertex takes its pixel from item_pixel), and the 64-bit division they cost showed in shade's
// profile. The radiance starts at 0: a step adds to it at most once (on_hit without a tracer of its own, on_miss,
// on_shadow_result), so adding what it holds afterwards to the pool's (add_radiance) is the same sum, and a path
// whose step adds nothing reads and writes no radiance (tests/core/test_path_schedule.cpp: the same image bit for bit
// as the depth-first driver's). The
// previous vertex moves only where a step reads it (path_reads_prev: MIS).
PN_FN PathState load_path(const WavefrontView& w, uint32_t slot, const TraceRay* ray, bool prev, bool lobes) {
  PathState st;
  st.ray = load_trace_ray(ray);
  st.beta = w.pool.beta[slot];
  st.L = Vec3(0.f);
  st.rng = w.pool.rng[slot];
  if (prev) st.prev = load_prev(w.pool, slot, lobes);
  st.depth = w.pool.depth[slot];
  st.active = 1;
  return st;
}

// The radiance a step added (L, from 0) into the pool's; NaN and infinities go in too, as they would have.
PN_FN void add_radiance(const WavefrontView& w, uint32_t slot, const Vec3& L) {
  if (L.x != 0.f || L.y != 0.f || L.z != 0.f) w.pool.L[slot] = w.pool.L[slot] + L;
}

// x += v by any number of threads at once.
PN_FN void atomic_add(float* x, float v) {
#if defined(__CUDA_ARCH__)
  atomicAdd(x, v);
#else
  float old, sum;
  __atomic_load(x, &old, __ATOMIC_RELAXED);
  do {
    sum = old + v;
  } while (!__atomic_compare_exchange(x, &old, &sum, true, __ATOMIC_RELAXED, __ATOMIC_RELAXED));
#endif
}

// add_radiance where other threads may add to the same slot (WavefrontView::shared_slots).
PN_FN void add_radiance_shared(const WavefrontView& w, uint32_t slot, const Vec3& L) {
  if (L.x == 0.f && L.y == 0.f && L.z == 0.f) return;
  float* x = &w.pool.L[slot].x;
  atomic_add(x, L.x);
  atomic_add(x + 1, L.y);
  atomic_add(x + 2, L.z);
}

// The pixel of the item in `slot`.
PN_FN uint32_t item_pixel(const WavefrontView& w, uint32_t slot) {
  return uint32_t((w.wave->first_item + slot) % w.wave->pixels);
}

// The state a path keeps in the pool besides its radiance (the ray goes to a queue); the previous vertex only
// where a step will read it (path_reads_prev).
PN_FN void store_state(const WavefrontView& w, uint32_t slot, const PathState& st, bool prev, bool lobes) {
  w.pool.beta[slot] = st.beta;
  w.pool.rng[slot] = st.rng;
  if (prev) store_prev(w.pool, slot, st.prev, lobes);
  w.pool.depth[slot] = st.depth;
}

// Where pixel p's primary pass writes (restir's frame).
PN_FN RestirPrimaryOut restir_primary_out(const WavefrontView& w, uint32_t pixel) {
  return RestirPrimaryOut{&w.restir.pixels[pixel], &w.restir.reservoirs[pixel]};
}

// --- The stages ------------------------------------------------------------------------------------------------

// Slot i (< capacity) takes item wave.first_item + i: its camera ray into ray queue 0 at position i. Thread 0
// also sets the queues' counts for the first iteration (no other thread of this stage reads them).
PN_FN void generate_camera_ray(uint32_t i, const WavefrontView& w, const Camera& camera, const IntegratorSettings& s) {
  const WaveSpec& wave = *w.wave;
  if (i == 0) {
    *w.ray[0].count = wave.count;
    *w.ray[1].count = 0;
    *w.shadow.count = 0;
  }
  if (i >= wave.count) return;
  const uint64_t k = wave.first_item + i;
  const uint32_t pixel = uint32_t(k % wave.pixels);
  const uint32_t width = uint32_t(camera.width);
  RestirPrimaryOut out;  // restir's primary pass: the pixel's record and reservoir start empty
  if (w.restir.pixels) out = restir_primary_out(w, pixel);
  PathState st = start_path(camera, int(pixel % width), int(pixel / width),
                            wave.first_sample + uint32_t(k / wave.pixels), wave.seed,
                            w.restir.pixels ? &out : nullptr);
  store_state(w, i, st, path_reads_prev(s), path_reads_prev_lobes(s));
  w.pool.L[i] = st.L;
  w.pool.rays[i] = 1;
  store_trace_ray(w.ray[0].rays + i, st.ray, kInf);
  w.ray[0].slot[i] = i;
}

// Shadow query j's answer: on_shadow_result adds its contribution to its path's radiance if the ray was clear.
// A reservoir's query (restir's frame): its W set if the ray was clear. The trace stage's blocked bits, or the
// answer of a kernel that traces and applies at once (the cuda traversal's, wavefront_shadow.cu).
PN_FN void apply_shadow_result(uint32_t j, const WavefrontView& w, bool blocked) {
  const uint32_t entry = w.shadow.slot[j];
  PathState st;
  ShadowQuery q;
  if (entry & kReservoirQuery) {
    const uint32_t slot = entry & ~kReservoirQuery;
    q.kind = ShadowKind::Reservoir;
    q.reservoir_W = w.shadow.contribution[j].x;
    RestirPrimaryOut out = restir_primary_out(w, item_pixel(w, slot));
    on_shadow_result(st, q, blocked, &out);
    return;
  }
  if (blocked) return;  // on_shadow_result would add nothing
  q.kind = ShadowKind::Radiance;
  q.contribution = w.shadow.contribution[j];
  on_shadow_result(st, q, blocked);  // st.L from 0, as in shade
  if (w.shared_slots) add_radiance_shared(w, entry, st.L);
  else add_radiance(w, entry, st.L);
}

PN_FN void apply_shadow_result(uint32_t j, const WavefrontView& w) {
  apply_shadow_result(j, w, ((w.blocked_bits[j / 32u] >> (j % 32u)) & 1u) != 0u);
}

// Between apply and shade: the queues shade pushes to start empty (one thread).
PN_FN void begin_bounce(const WavefrontView& w, int next) {
  *w.ray[next].count = 0;
  *w.shadow.count = 0;
}

// Shadow query q of the path in `slot` at position k of the shadow queue (counted into its direction's cell where
// the queue is traced in that order).
PN_FN void store_shadow_query(const WavefrontView& w, uint32_t k, uint32_t slot, const ShadowQuery& q, bool ordered) {
  if (ordered) queue_order_count(w.shadow_order, k, shadow_direction_cell(q.ray.d));
  store_trace_ray(w.shadow.rays + k, q.ray, q.tmax);
  const bool reservoir = q.kind == ShadowKind::Reservoir;
  w.shadow.slot[k] = reservoir ? slot | kReservoirQuery : slot;
  w.shadow.contribution[k] = reservoir ? Vec3(q.reservoir_W, 0.f, 0.f) : q.contribution;
}

// Where shade puts a vertex's queries beyond the one on_hit returns (slc's, on_hit's `more`): the shadow queue.
struct ShadowQueueSink {
  const WavefrontView* w;
  uint32_t slot;
  bool ordered;
  uint32_t pushed = 0;
  PN_FN void push(const ShadowQuery& q) {
    store_shadow_query(*w, queue_push(w->shadow.count), slot, q, ordered);
    ++pushed;
  }
};

// Ray j of ray queue `cur`, its closest hit known: on_hit or on_miss; the light sample's shadow query (if any)
// to the shadow queue, the next ray (if the path goes on) to ray queue cur ^ 1. Inlined whole into the shading
// kernel, on_miss (PN_FN) and on_hit (one call site) with it: as calls, the path state lived in local memory
// (commit a6913f3, H200: Sponza's shading 2.74 -> 2.37 ms a 1080p sample, the same image bit for bit).
template <uint32_t kFeatures = kAllFeatures>
PN_FN void shade(uint32_t j, const WavefrontView& w, int cur, const SceneView& scene, const IntegratorSettings& s) {
  const RayQueue& in = w.ray[cur];
  const uint32_t slot = in.slot[j];
  const bool prev = path_reads_prev(s);
  const bool lobes = path_reads_prev_lobes<kFeatures>(s);
  PathState st = load_path(w, slot, in.rays + j, prev, lobes);
  const bool ordered = w.shadow_order.cell_count && st.depth >= kShadowOrderDepth;
  const HitRecord rec = w.hits[j];
  ShadowQuery q;
  uint32_t extra = 0;  // slc's queries, in the queue already
  if (rec.instance == kTraceMiss) {
    on_miss<kFeatures>(st, scene, s);
  } else {
    // restir's frame: the first vertex writes its pixel's record and reservoir.
    const bool restir = w.restir.pixels && st.depth == 0;
    RestirPrimaryOut out;
    if (restir) out = restir_primary_out(w, item_pixel(w, slot));
    ShadowQueueSink more{&w, slot, ordered};  // slc's queries
    q = on_hit<kFeatures>(st, scene, s, rec, restir ? &out : nullptr, static_cast<const NoShadowTracer*>(nullptr),
                          &more);
    extra = more.pushed;
  }
  const RayQueue& out = w.ray[cur ^ 1];
  const bool query = q.kind != ShadowKind::None, next = st.active != 0;
  uint32_t kq = 0, kn = 0;
  if (query) kq = queue_push(w.shadow.count);  // the compiler aggregates these per warp (a pair of pushes
  if (next) kn = queue_push(out.count);        // aggregated by hand, both atomics in flight at once, was slower)
  if (query) store_shadow_query(w, kq, slot, q, ordered);
  if (next) {
    store_trace_ray(out.rays + kn, st.ray, kInf);
    out.slot[kn] = slot;
    if (w.ray_order.cell_count) queue_order_count(w.ray_order, kn, ray_order_cell(w.ray_order, st.ray));
  }
  const uint32_t rays = uint32_t(query) + uint32_t(next) + extra;
  store_state(w, slot, st, prev, lobes);
  add_radiance(w, slot, st.L);
  if (rays) w.pool.rays[slot] += rays;
}

// Thread i < min(wave.count, pixels) of the accumulation: pixel (first_item + i) % pixels, every sample the wave
// holds of it in sample order: sink.begin(pixel, first) (first: the pixel's first sample of the render call),
// sink.add(L, rays) per sample, sink.end(pixel). Each pixel has one thread, so sinks need no atomics.
template <class Sink>
PN_HD void accumulate(uint32_t i, const WavefrontView& w, Sink& sink) {
  const WaveSpec& wave = *w.wave;
  if (i >= wave.count || i >= wave.pixels) return;
  const uint64_t end = wave.first_item + wave.count;
  uint64_t k = wave.first_item + i;
  const uint32_t pixel = uint32_t(k % wave.pixels);
  sink.begin(pixel, k < wave.pixels);
  for (; k < end; k += wave.pixels) {
    const uint32_t slot = uint32_t(k - wave.first_item);
    sink.add(w.pool.L[slot], w.pool.rays[slot]);
  }
  sink.end(pixel);
}

}  // namespace pn
