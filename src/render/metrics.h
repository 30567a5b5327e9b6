// Error metrics of a render against a reference, on linear radiance.
//
//   RMSE    = sqrt( 1/(3P) sum_{pixels, channels} (test - ref)^2 )       thesis eq. 4.1
//   relMSE  = 1/(3P) sum (test - ref)^2 / (ref^2 + 0.01)                 pbrt-v4's imgtool convention
//
// Both over all pixels and the three RGB channels, with no clamping or tone
// mapping. With a mask, only pixels where mask[p] is true count: the studies use
// it to leave out pixels that see a light directly, whose noise is the same for
// every strategy and would otherwise dominate the comparison.
#pragma once

#include <cmath>
#include <cstdint>
#include <vector>

namespace pn {

struct ErrorMetrics {
  double rmse = 0, relmse = 0;
  size_t pixels = 0;  // pixels that counted
};

inline ErrorMetrics error_metrics(const std::vector<float>& test, const std::vector<float>& ref,
                                  const std::vector<uint8_t>* mask = nullptr) {
  double se = 0, rel = 0;
  size_t n = 0;
  for (size_t p = 0; p < ref.size() / 3; ++p) {
    if (mask && !(*mask)[p]) continue;
    for (int c = 0; c < 3; ++c) {
      double d = double(test[3 * p + c]) - ref[3 * p + c];
      se += d * d;
      rel += d * d / (double(ref[3 * p + c]) * ref[3 * p + c] + 0.01);
    }
    ++n;
  }
  ErrorMetrics m;
  m.pixels = n;
  if (n) {
    m.rmse = std::sqrt(se / (3.0 * n));
    m.relmse = rel / (3.0 * n);
  }
  return m;
}

// Least-squares line y = a + b x.
struct LineFit {
  double a = 0, b = 0;
};
inline LineFit fit_line(const std::vector<double>& x, const std::vector<double>& y) {
  double n = double(x.size()), sx = 0, sy = 0, sxx = 0, sxy = 0;
  for (size_t i = 0; i < x.size(); ++i) {
    sx += x[i];
    sy += y[i];
    sxx += x[i] * x[i];
    sxy += x[i] * y[i];
  }
  LineFit f;
  double den = n * sxx - sx * sx;
  if (den != 0) {
    f.b = (n * sxy - sx * sy) / den;
    f.a = (sy - f.b * sx) / n;
  }
  return f;
}

}  // namespace pn
