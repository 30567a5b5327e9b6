// DeviceImage: see device_image.h. Compiled without FMA contraction so that
// the mean and variance equal Film's host arithmetic bit for bit.
#include "device_image.h"

#include <cuda_runtime.h>

#include <algorithm>
#include <stdexcept>
#include <string>

namespace pn::py {
namespace {

void check(cudaError_t e, const char* what) {
  if (e != cudaSuccess)
    throw std::runtime_error(std::string("CUDA: ") + what + ": " + cudaGetErrorString(e));
}

// Film::mean() and Film::variance_of_mean(), one element per thread.
__global__ void mean_variance(const double* sum, const double* sum_sq, size_t count, uint64_t samples, double inv,
                              float* mean, float* variance) {
  for (size_t i = blockIdx.x * size_t(blockDim.x) + threadIdx.x; i < count; i += size_t(gridDim.x) * blockDim.x) {
    mean[i] = float(sum[i] * inv);
    if (samples < 2) {
      variance[i] = 0.f;
      continue;
    }
    double n = double(samples);
    double m = sum[i] / n;
    double var = (sum_sq[i] / n - m * m) * n / (n - 1.0);
    variance[i] = float(var > 0.0 ? var / n : 0.0);
  }
}

}  // namespace

std::shared_ptr<DeviceImage> DeviceImage::from_sums(const double* sums, const double* sums_sq, size_t count,
                                                    uint64_t samples, int device) {
  check(cudaSetDevice(device), "cudaSetDevice");
  // Launches still running on the backend's stream (an interrupted render) first.
  check(cudaDeviceSynchronize(), "before the mean/variance kernel");
  std::shared_ptr<DeviceImage> img(new DeviceImage());
  img->count_ = count;
  img->device_ = device;
  check(cudaMalloc(&img->rgb_, count * sizeof(float)), "cudaMalloc (image mean)");
  check(cudaMalloc(&img->variance_, count * sizeof(float)), "cudaMalloc (image variance)");
  const double inv = samples ? 1.0 / double(samples) : 0.0;
  const unsigned threads = 256;
  const unsigned blocks = unsigned(std::min<size_t>((count + threads - 1) / threads, 65535));
  if (count) mean_variance<<<blocks, threads>>>(sums, sums_sq, count, samples, inv, img->rgb_, img->variance_);
  check(cudaGetLastError(), "mean/variance kernel");
  // Complete before anyone reads it, on any stream (DLPack consumers included).
  check(cudaDeviceSynchronize(), "mean/variance kernel");
  return img;
}

DeviceImage::~DeviceImage() {
  cudaSetDevice(device_);
  cudaFree(rgb_);
  cudaFree(variance_);
}

void DeviceImage::download(float* rgb, float* variance) const {
  check(cudaSetDevice(device_), "cudaSetDevice");
  check(cudaMemcpy(rgb, rgb_, count_ * sizeof(float), cudaMemcpyDeviceToHost), "cudaMemcpy (image mean)");
  check(cudaMemcpy(variance, variance_, count_ * sizeof(float), cudaMemcpyDeviceToHost), "cudaMemcpy (image variance)");
}

}  // namespace pn::py
