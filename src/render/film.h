// The accumulation target of every backend: per-pixel sums of sample values
// and of their squares, in double, so that the mean and its standard error can
// be read at any time (progressive display, equality tests, convergence runs).
#pragma once

#include <cstdint>
#include <vector>

#include "core/vec.h"

namespace pn {

class Film {
 public:
  Film() = default;
  Film(int width, int height) { reset(width, height); }

  void reset(int width, int height) {
    width_ = width;
    height_ = height;
    samples_ = 0;
    sum_.assign(size_t(width) * height * 3, 0.0);
    sum_sq_.assign(size_t(width) * height * 3, 0.0);
  }
  int width() const { return width_; }
  int height() const { return height_; }
  size_t pixel_count() const { return size_t(width_) * height_; }
  // Samples per pixel accumulated so far (the same for every pixel).
  uint64_t samples() const { return samples_; }
  void add_samples(uint64_t n) { samples_ += n; }

  // Adds the sums and samples of `other` (a film of the same size): the film of
  // both sets of samples. Element by element, in double: adding films in a fixed
  // order gives the same bits wherever it is done.
  void add(const Film& other) {
    add_values(other, 0, sum_.size());
    samples_ += other.samples_;
  }
  // The sums of values [begin, end) of `other` (RGB interleaved, 3 a pixel)
  // alone, samples not counted: add() by parts, e.g. on several threads.
  void add_values(const Film& other, size_t begin, size_t end) {
    for (size_t i = begin; i < end; ++i) {
      sum_[i] += other.sum_[i];
      sum_sq_[i] += other.sum_sq_[i];
    }
  }

  double* sum() { return sum_.data(); }
  double* sum_sq() { return sum_sq_.data(); }
  const double* sum() const { return sum_.data(); }
  const double* sum_sq() const { return sum_sq_.data(); }

  // Per-pixel mean radiance, RGB interleaved, row 0 at the top.
  std::vector<float> mean() const {
    std::vector<float> out(sum_.size());
    double inv = samples_ ? 1.0 / double(samples_) : 0.0;
    for (size_t i = 0; i < sum_.size(); ++i) out[i] = float(sum_[i] * inv);
    return out;
  }
  // Per-pixel variance of the mean (squared standard error), RGB interleaved.
  std::vector<float> variance_of_mean() const {
    std::vector<float> out(sum_.size(), 0.f);
    if (samples_ < 2) return out;
    double n = double(samples_);
    for (size_t i = 0; i < sum_.size(); ++i) {
      double m = sum_[i] / n;
      double var = (sum_sq_[i] / n - m * m) * n / (n - 1.0);  // unbiased sample variance
      out[i] = float(var > 0.0 ? var / n : 0.0);
    }
    return out;
  }

 private:
  int width_ = 0, height_ = 0;
  uint64_t samples_ = 0;
  std::vector<double> sum_, sum_sq_;
};

}  // namespace pn
