// The GPU backend's film in device memory, as the accumulation kernels add to it (launch_sums.h: film_add).
// No CUDA types: host code passes it around.
#pragma once

namespace pn {

// Per pixel, the samples' sums and sums of squares in doubles (3 a pixel) and the non-finite samples skipped;
// the rays traced and the non-finite samples of the whole image in `counters` (two 64-bit counters).
struct DeviceFilm {
  double* sum = nullptr;
  double* sum_sq = nullptr;
  unsigned long long* counters = nullptr;
  unsigned* bad_pixels = nullptr;
};

}  // namespace pn
