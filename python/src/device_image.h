// An image on the GPU: the mean and the variance of the mean of an accumulation
// whose per-pixel sums live on the device (OptixBackend::device_sums()), as
// float32 device buffers that the Python module hands out by DLPack without a
// copy to the host. Computed with the formulas of Film::mean() and
// Film::variance_of_mean(), to the bit. Compiled with the OptiX backend only;
// this header has no CUDA types.
#pragma once

#include <cstddef>
#include <cstdint>
#include <memory>

namespace pn::py {

class DeviceImage {
 public:
  // From `count` sums and sums of squares (device pointers on CUDA device
  // `device`) of `samples` samples. Throws std::runtime_error on a CUDA failure.
  static std::shared_ptr<DeviceImage> from_sums(const double* sums, const double* sums_sq, size_t count,
                                                uint64_t samples, int device);
  ~DeviceImage();
  DeviceImage(const DeviceImage&) = delete;
  DeviceImage& operator=(const DeviceImage&) = delete;

  float* rgb() const { return rgb_; }            // device pointer, `count` floats
  float* variance() const { return variance_; }  // device pointer, `count` floats
  int device() const { return device_; }         // the CUDA device holding them
  // Copies both to the host (`count` floats each).
  void download(float* rgb, float* variance) const;

 private:
  DeviceImage() = default;
  float* rgb_ = nullptr;
  float* variance_ = nullptr;
  size_t count_ = 0;
  int device_ = 0;
};

}  // namespace pn::py
