// restir's reuse and shading passes through the wavefront's trace stage (core/restir.h's record and replay of
// their shadow rays), beside the path stages of wavefront.h: run by the CPU's Wavefront schedule and by the GPU
// kernels (wavefront_gpu.cu).
#pragma once

#include "backends/wavefront/wavefront.h"

namespace pn {

// --- restir's reuse and shading passes through the trace stage --------------------------------------------------
//
// A reuse pass makes its shadow rays inside the combination (core/restir.h), where they depend on the neighbours
// found, and so does the biased combination's shading. A pixel therefore runs its pass twice: recording (every
// query pushed to the shadow queue and answered "clear"; the result is dropped), then, once the trace stage has
// traced the queue, replaying (each query answered from the blocked bits, in the order it was made). Which queries
// a pass makes depends only on its inputs, never on an answer (the combinations trace wherever a target is
// positive, and use the answer only after), so both runs make the same ones, and the replay computes what tracing
// each query on the spot would, bit for bit (the CPU's Wavefront schedule against depth-first:
// tests/core/test_path_schedule.cpp). A chunk of pixels at a time: each pixel keeps the queue positions of its at most
// max_rays queries (restir_reuse_max_rays, restir_shade_max_rays) in ray queue 0's slots, which a frame pass does
// not otherwise use, so chunk.count * max_rays must not exceed the pool's capacity.

// A chunk of a frame pass: pixels [first, first + count), at most max_rays queries each.
struct RestirChunk {
  uint32_t first = 0;
  uint32_t count = 0;
  uint32_t max_rays = 0;
};

// A pass that made more queries than its bound: a logic error (the bound is the combination's loop lengths).
PN_FN void restir_rays_overflow() {
#if defined(__CUDA_ARCH__)
  __trap();
#else
  throw std::logic_error("restir: a frame pass made more shadow queries than its bound");
#endif
}

struct RecordShadowQueries {
  static constexpr bool kRecordsOnly = true;  // core/reservoir.h: the recording run's result is discarded
  ShadowQueue queue;
  uint32_t* positions;  // this pixel's max_rays
  uint32_t max_rays;
  mutable uint32_t n = 0;
  PN_FN bool occluded(const Ray& ray, float tmax) const {
    if (n == max_rays) restir_rays_overflow();
    const uint32_t k = queue_push(queue.count);
    store_trace_ray(queue.rays + k, ray, tmax);
    positions[n++] = k;
    return false;
  }
};

struct ReplayShadowQueries {
  const uint32_t* blocked_bits;
  const uint32_t* positions;
  uint32_t max_rays;
  mutable uint32_t n = 0;
  PN_FN bool occluded(const Ray&, float) const {
    if (n == max_rays) restir_rays_overflow();
    const uint32_t j = positions[n++];
    return ((blocked_bits[j / 32u] >> (j % 32u)) & 1u) != 0u;
  }
};

// Pixels a chunk may hold with the pool's capacity (host code: the backends' pass loops). A pool smaller than one
// pixel's queries is an error, not an endless loop of empty chunks.
inline uint32_t restir_chunk_pixels(const WavefrontView& w, uint32_t max_rays) {
  if (max_rays > w.capacity)
    throw std::invalid_argument("restir: a wavefront pool of " + std::to_string(w.capacity) +
                                " paths holds less than one pixel's " + std::to_string(max_rays) +
                                " shadow queries (--tune wavefront_paths sets the GPU's pool)");
  return max_rays ? w.capacity / max_rays : w.capacity;
}

// Before a chunk is recorded: the shadow queue starts empty (one thread).
PN_FN void begin_shadow_batch(const WavefrontView& w) { *w.shadow.count = 0; }

// One frame pass over `pixels` pixels in chunks (host code, each backend's steps as callbacks taking the chunk):
// where the pass makes queries (max_rays > 0), begin() an empty shadow queue, record(), trace() it; then replay().
template <class Begin, class Record, class Trace, class Replay>
void restir_frame_pass(const WavefrontView& w, uint32_t pixels, uint32_t max_rays, Begin&& begin, Record&& record,
                       Trace&& trace, Replay&& replay) {
  const uint32_t chunk = restir_chunk_pixels(w, max_rays);
  for (uint32_t first = 0; first < pixels; first += chunk) {
    const RestirChunk c{first, chunk < pixels - first ? chunk : pixels - first, max_rays};
    if (max_rays > 0) {
      begin(c);
      record(c);
      trace(c);
    }
    replay(c);
  }
}

// Thread i of a reuse pass's chunk, recording.
template <uint32_t kFeatures = kAllFeatures>
PN_HD void restir_reuse_record(uint32_t i, const WavefrontView& w, const RestirChunk& c, const SceneView& scene,
                               const RestirSettings& rs, const RestirReuse& r) {
  if (i >= c.count) return;
  const RecordShadowQueries rec{w.shadow, w.ray[0].slot + uint64_t(i) * c.max_rays, c.max_rays};
  (void)restir_reuse<kFeatures>(rec, scene, rs, r, c.first + i);
}

// The same, replaying: the pixel's reservoir after the pass into out; returns the shadow rays it used.
template <uint32_t kFeatures = kAllFeatures>
PN_HD uint32_t restir_reuse_replay(uint32_t i, const WavefrontView& w, const RestirChunk& c, const SceneView& scene,
                                   const RestirSettings& rs, const RestirReuse& r, Reservoir* out) {
  if (i >= c.count) return 0;
  const ReplayShadowQueries rep{w.blocked_bits, w.ray[0].slot + uint64_t(i) * c.max_rays, c.max_rays};
  out[c.first + i] = restir_reuse<kFeatures>(rep, scene, rs, r, c.first + i);
  return rep.n;
}

// Thread i of the shading pass's chunk (restir_shade), recording.
template <uint32_t kFeatures = kAllFeatures>
PN_HD void restir_shade_record(uint32_t i, const WavefrontView& w, const RestirChunk& c, const SceneView& scene,
                               const IntegratorSettings& s, const RestirPixel* pixels, const Reservoir* final) {
  if (i >= c.count) return;
  const RecordShadowQueries rec{w.shadow, w.ray[0].slot + uint64_t(i) * c.max_rays, c.max_rays};
  (void)restir_shade<kFeatures>(rec, scene, s, pixels[c.first + i], final[c.first + i]);
}

// The same, replaying: the direct light of the pixel's first vertex, which the backend adds to the rest of its
// path's radiance; *rays: the shadow rays it used.
template <uint32_t kFeatures = kAllFeatures>
PN_HD Vec3 restir_shade_replay(uint32_t i, const WavefrontView& w, const RestirChunk& c, const SceneView& scene,
                               const IntegratorSettings& s, const RestirPixel* pixels, const Reservoir* final,
                               uint32_t* rays) {
  const ReplayShadowQueries rep{w.blocked_bits, w.ray[0].slot + uint64_t(i) * c.max_rays, c.max_rays};
  const Vec3 direct = restir_shade<kFeatures>(rep, scene, s, pixels[c.first + i], final[c.first + i]);
  *rays = rep.n;
  return direct;
}

}  // namespace pn
