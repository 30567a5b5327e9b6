// Kernels of the viewer's CUDA-OpenGL interop path (device_image_kernels.h).
#include "apps/viewer/device_image_kernels.h"
#include "apps/viewer/tone_map.h"

namespace pn::viewer {
namespace {

__global__ void add_sums_kernel(double* __restrict__ acc, const double* __restrict__ add, size_t n) {
  for (size_t i = size_t(blockIdx.x) * blockDim.x + threadIdx.x; i < n; i += size_t(gridDim.x) * blockDim.x)
    acc[i] += add[i];
}

// One thread per pixel of the column range; the threshold table in shared memory.
__global__ void tone_map_columns_kernel(const double* __restrict__ sum, int width, int height, int x_begin,
                                        int columns, double inv, float gain, const float* __restrict__ thresholds,
                                        unsigned char* __restrict__ out, size_t row_bytes) {
  __shared__ float t[255];
  for (int i = threadIdx.y * blockDim.x + threadIdx.x; i < 255; i += blockDim.x * blockDim.y) t[i] = thresholds[i];
  __syncthreads();
  const int x = x_begin + int(blockIdx.x * blockDim.x + threadIdx.x), y = int(blockIdx.y * blockDim.y + threadIdx.y);
  if (x >= x_begin + columns || y >= height) return;
  unsigned char px[4];
  tone_map_pixel(sum + (size_t(y) * width + x) * 3, inv, gain, t, px);
  *reinterpret_cast<uchar4*>(out + size_t(y) * row_bytes + size_t(x) * 4) = make_uchar4(px[0], px[1], px[2], px[3]);
}

__global__ void mean_columns_kernel(const double* __restrict__ sum, int width, int height, int x_begin, int columns,
                                    double inv, float* __restrict__ out) {
  const int x = x_begin + int(blockIdx.x * blockDim.x + threadIdx.x), y = int(blockIdx.y * blockDim.y + threadIdx.y);
  if (x >= x_begin + columns || y >= height) return;
  const size_t i = (size_t(y) * width + x) * 3;
  for (int c = 0; c < 3; ++c) {
    const float v = float(sum[i + c] * inv);
    out[i + c] = isfinite(v) ? v : 0.f;
  }
}

__global__ void tone_map_rgb_kernel(const float* __restrict__ rgb, int width, int height, float gain,
                                    const float* __restrict__ thresholds, unsigned char* __restrict__ out,
                                    size_t row_bytes) {
  __shared__ float t[255];
  for (int i = threadIdx.y * blockDim.x + threadIdx.x; i < 255; i += blockDim.x * blockDim.y) t[i] = thresholds[i];
  __syncthreads();
  const int x = int(blockIdx.x * blockDim.x + threadIdx.x), y = int(blockIdx.y * blockDim.y + threadIdx.y);
  if (x >= width || y >= height) return;
  unsigned char px[4];
  tone_map_rgb(rgb + (size_t(y) * width + x) * 3, gain, t, px);
  *reinterpret_cast<uchar4*>(out + size_t(y) * row_bytes + size_t(x) * 4) = make_uchar4(px[0], px[1], px[2], px[3]);
}

// The launch of a kernel over columns [x_begin, x_end) of every row (clamped to the image), a thread a pixel in
// blocks of kColumnBlock; false where there is no pixel to do.
constexpr dim3 kColumnBlock(32, 8);
bool column_grid(int width, int height, int* x_begin, int* x_end, dim3* grid) {
  if (*x_begin < 0) *x_begin = 0;
  if (*x_end > width) *x_end = width;
  if (*x_end <= *x_begin || height <= 0) return false;
  *grid = dim3(unsigned((*x_end - *x_begin + 31) / 32), unsigned((height + 7) / 8));
  return true;
}

}  // namespace

cudaError_t launch_add_sums(double* acc, const double* add, size_t n, cudaStream_t stream) {
  if (n == 0) return cudaSuccess;
  size_t blocks = (n + 255) / 256;
  if (blocks > 4096) blocks = 4096;
  add_sums_kernel<<<unsigned(blocks), 256, 0, stream>>>(acc, add, n);
  return cudaGetLastError();
}

cudaError_t launch_tone_map_columns(const double* sum, int width, int height, int x_begin, int x_end, double inv,
                                    float gain, const float* thresholds, unsigned char* out, size_t row_bytes,
                                    cudaStream_t stream) {
  dim3 grid;
  if (!column_grid(width, height, &x_begin, &x_end, &grid)) return cudaSuccess;
  tone_map_columns_kernel<<<grid, kColumnBlock, 0, stream>>>(sum, width, height, x_begin, x_end - x_begin, inv, gain,
                                                             thresholds, out, row_bytes);
  return cudaGetLastError();
}

cudaError_t launch_mean_columns(const double* sum, int width, int height, int x_begin, int x_end, double inv,
                                float* out, cudaStream_t stream) {
  dim3 grid;
  if (!column_grid(width, height, &x_begin, &x_end, &grid)) return cudaSuccess;
  mean_columns_kernel<<<grid, kColumnBlock, 0, stream>>>(sum, width, height, x_begin, x_end - x_begin, inv, out);
  return cudaGetLastError();
}

cudaError_t launch_tone_map_rgb(const float* rgb, int width, int height, float gain, const float* thresholds,
                                unsigned char* out, size_t row_bytes, cudaStream_t stream) {
  int x_begin = 0, x_end = width;
  dim3 grid;
  if (!column_grid(width, height, &x_begin, &x_end, &grid)) return cudaSuccess;
  tone_map_rgb_kernel<<<grid, kColumnBlock, 0, stream>>>(rgb, width, height, gain, thresholds, out, row_bytes);
  return cudaGetLastError();
}

}  // namespace pn::viewer
