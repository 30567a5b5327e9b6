// A pixel's samples, summed: what every backend accumulates per pixel and what
// the film turns into a mean and a variance. A sample that is not finite (NaN
// or infinite radiance) is skipped and counted, never added: one bad sample
// must not poison a pixel silently; the host reports the count and where.
// T: double on the CPU, float on the GPU (its launch sums are float4).
#pragma once

#include <cstdint>

#include "vec.h"

namespace pn {

template <class T>
struct SampleSums {
  T sum[3] = {0, 0, 0};
  T sum_sq[3] = {0, 0, 0};
  uint32_t nonfinite = 0;

  PN_FN void add(const Vec3& L) {
    if (!is_finite(L)) {
      ++nonfinite;
      return;
    }
    for (int c = 0; c < 3; ++c) {
      sum[c] += T(L[c]);
      sum_sq[c] += T(L[c]) * T(L[c]);
    }
  }
};

}  // namespace pn
