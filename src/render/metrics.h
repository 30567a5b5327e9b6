// Error metrics of a render against a reference, on linear radiance.
//
//   RMSE    = sqrt( 1/(3P) sum_{pixels, channels} (test - ref)^2 )       thesis eq. 4.1
//   relMSE  = 1/(3P) sum (test - ref)^2 / (ref^2 + 0.01)                 pbrt-v4's imgtool convention
//
// Both over all pixels and the three RGB channels, with no clamping or tone
// mapping. With a mask, only pixels where mask[p] is true count: the studies use
// it to leave out pixels that see a light directly, whose noise is the same for
// every strategy and would otherwise dominate the comparison.
//
// A technique's MSE at some spp is the mean over independent seeds of each
// render's RMSE^2; the square of the mean RMSE is smaller than that by the
// seeds' variance of RMSE (in docs/results, by up to a fifth for unbiased
// methods at the largest spp, with two seeds).
#pragma once

#include <cmath>
#include <cstdint>
#include <vector>

namespace pn {

struct ErrorMetrics {
  double mse = 0, rmse = 0, relmse = 0;  // rmse = sqrt(mse)
  size_t pixels = 0;  // pixels that counted
};

// The running sums of error_metrics and measure_render: a pixel's channels added one at a time (add), then the
// pixel counted (next_pixel), in the order that gives both the same bits.
struct ErrorSums {
  double se = 0, rel = 0;
  size_t pixels = 0;
  void add(double test, float ref) {
    const double d = test - ref;
    se += d * d;
    rel += d * d / (double(ref) * ref + 0.01);
  }
  void next_pixel() { ++pixels; }
  ErrorMetrics metrics() const {
    ErrorMetrics m;
    m.pixels = pixels;
    if (pixels) {
      m.mse = se / (3.0 * pixels);
      m.rmse = std::sqrt(m.mse);
      m.relmse = rel / (3.0 * pixels);
    }
    return m;
  }
};

inline ErrorMetrics error_metrics(const std::vector<float>& test, const std::vector<float>& ref,
                                  const std::vector<uint8_t>* mask = nullptr) {
  ErrorSums sums;
  for (size_t p = 0; p < ref.size() / 3; ++p) {
    if (mask && !(*mask)[p]) continue;
    for (int c = 0; c < 3; ++c) sums.add(test[3 * p + c], ref[3 * p + c]);
    sums.next_pixel();
  }
  return sums.metrics();
}

// A pixel's three channels summed in double, as the image means and the noise floor add them.
inline double rgb_sum(const float* px) { return double(px[0]) + px[1] + px[2]; }

// Mean radiance over the pixels `mask` keeps (all with none): the mean over them and their three channels.
inline double image_mean(const std::vector<float>& img, const std::vector<uint8_t>* mask = nullptr) {
  double m = 0;
  size_t n = 0;
  for (size_t p = 0; p < img.size() / 3; ++p)
    if (!mask || (*mask)[p]) {
      m += rgb_sum(&img[3 * p]);
      n += 3;
    }
  return n ? m / double(n) : 0.0;
}

// What the convergence experiment measures of one render, in one pass over its film's sums (`sum`, RGB interleaved,
// of `samples` samples a pixel): the mean image (Film::mean) into *image, its errors against `ref` over all pixels
// and over those `mask` keeps (error_metrics), and its mean radiance over both (image_mean). The same bits as those
// functions one after the other, in a third of their time at 1080p.
struct RenderMeasures {
  ErrorMetrics all, masked;
  double mean = 0, mean_masked = 0;
};
inline RenderMeasures measure_render(const double* sum, uint64_t samples, const std::vector<float>& ref,
                                     const std::vector<uint8_t>& mask, std::vector<float>* image) {
  const size_t pixels = ref.size() / 3;
  image->resize(ref.size());
  const double inv = samples ? 1.0 / double(samples) : 0.0;
  ErrorSums all, masked;
  double m = 0, m_m = 0;
  for (size_t p = 0; p < pixels; ++p) {
    const bool keep = mask[p] != 0;
    float* v = image->data() + 3 * p;
    for (int c = 0; c < 3; ++c) {
      v[c] = float(sum[3 * p + c] * inv);
      all.add(v[c], ref[3 * p + c]);
      if (keep) masked.add(v[c], ref[3 * p + c]);
    }
    all.next_pixel();
    m += rgb_sum(v);
    if (keep) masked.next_pixel(), m_m += rgb_sum(v);
  }
  RenderMeasures out;
  out.all = all.metrics();
  out.masked = masked.metrics();
  out.mean = pixels ? m / double(3 * pixels) : 0.0;
  out.mean_masked = masked.pixels ? m_m / double(3 * masked.pixels) : 0.0;
  return out;
}

// Pixels that see no light, from the mean of a render of camera rays alone (max
// depth 0: only emission seen directly): 1 where all three channels are zero, 0
// where a light covers any of the pixel.
inline std::vector<uint8_t> nolight_mask(const std::vector<float>& direct) {
  std::vector<uint8_t> mask(direct.size() / 3, 1);
  for (size_t p = 0; p < mask.size(); ++p)
    if (direct[3 * p] + direct[3 * p + 1] + direct[3 * p + 2] > 0.f) mask[p] = 0;
  return mask;
}

// The light pixels of a mask grown by their eight neighbours (0 = a light pixel). A lamp larger than a pixel
// that covers a sliver of one can be missed by every camera sample there (probability (1 - coverage)^spp), but then
// covers much of a neighbour, which the samples find: growing the set takes the sliver out too. What it cannot
// catch: a lamp smaller than a pixel that no sample hit at all.
inline std::vector<uint8_t> grow_light_pixels(const std::vector<uint8_t>& mask, int width, int height) {
  std::vector<uint8_t> out = mask;
  for (int y = 0; y < height; ++y)
    for (int x = 0; x < width; ++x) {
      if (mask[size_t(y) * width + x]) continue;
      for (int dy = -1; dy <= 1; ++dy)
        for (int dx = -1; dx <= 1; ++dx) {
          const int u = x + dx, v = y + dy;
          if (u >= 0 && u < width && v >= 0 && v < height) out[size_t(v) * width + u] = 0;
        }
    }
  return out;
}

// The reference's own noise as an RMSE: sqrt of the mean, over pixels (those the
// mask keeps) and channels, of its variance of the mean (Film::variance_of_mean).
// Its square is what the reference adds to every measured MSE in expectation; 0
// where no pixel counts.
inline double noise_floor_rmse(const std::vector<float>& var_of_mean, const std::vector<uint8_t>* mask = nullptr) {
  double v = 0;
  size_t n = 0;
  for (size_t p = 0; p < var_of_mean.size() / 3; ++p) {
    if (mask && !(*mask)[p]) continue;
    v += rgb_sum(&var_of_mean[3 * p]);
    ++n;
  }
  return n ? std::sqrt(v / (3.0 * n)) : 0.0;
}

// Efficiency 1 / (MSE x seconds): the larger, the less time to a given error; 0
// where the MSE or the time is not positive.
inline double efficiency(double mse, double seconds) {
  return mse > 0 && seconds > 0 ? 1.0 / (mse * seconds) : 0.0;
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

// The spp at which a fit of ln RMSE = a + b ln spp reaches `threshold`:
// exp((ln threshold - a) / b); infinite where the line does not fall (b >= 0).
inline double spp_to_threshold(const LineFit& fit, double threshold) {
  return fit.b < 0 ? std::exp((std::log(threshold) - fit.a) / fit.b) : INFINITY;
}

}  // namespace pn
