// The trace stage's buffers, shared by its two GPU implementations (the cuda
// traversal in backends/cuda and trace-only OptiX launches in backends/optix):
// rays in, hit records or occlusion bits out. Also the probe's rays (`penumbra
// bench --probe`, the cuda traversal's tests): random incoherent rays inside a
// scene's bounds, the same on every machine for a seed.
#pragma once

#include <cstdint>
#include <cstdio>
#include <string>
#include <vector>

#include "core/scene_view.h"
#include "core/vec.h"

namespace pn {

// One ray of a trace launch: 32 bytes, two 16-byte reads. Hits count in (0, tmax).
struct alignas(16) TraceRay {
  Vec3 o;
  float tmax = kInf;
  Vec3 d;  // unit length (spheres need it)
  uint32_t pad = 0;
};
static_assert(sizeof(TraceRay) == 32, "TraceRay is two 16-byte reads");

// A closest-hit launch writes one HitRecord per ray; a miss has this instance.
constexpr uint32_t kTraceMiss = 0xFFFFFFFFu;
static_assert(kTraceMiss != kSphereInstance, "miss and sphere markers must differ");

// A shadow launch writes bit i % 32 of word i / 32 for ray i: 1 when blocked.
PN_FN uint32_t trace_bit_words(uint32_t rays) { return (rays + 31u) / 32u; }

// Whether a scene's rays are long enough for what pays only on long traversals (the wavefront's queue orders, the
// cuda traversal's if-if loop): at least `min_visits` nodes a ray (BvhStats::sah_visits_per_ray, `visits`). *why
// gets the words that say so: "auto: rays visit 46.4 nodes, at least 24".
inline bool rays_are_long(double visits, double min_visits, std::string* why) {
  const bool long_rays = visits >= min_visits;
  char buf[96];
  std::snprintf(buf, sizeof buf, "auto: rays visit %.1f nodes, %s %.0f", visits, long_rays ? "at least" : "under",
                min_visits);
  *why = buf;
  return long_rays;
}

}  // namespace pn
