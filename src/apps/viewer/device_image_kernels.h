// CUDA kernels of the viewer's interop path (device_image.cpp), with host-side
// launchers; each returns the launch's error status. Plain pointers only, so
// that the C++ side needs no CUDA compiler.
#pragma once

#include <cstddef>

#include <cuda_runtime.h>

namespace pn::viewer {

// acc[i] += add[i] for n doubles (a progressive image's own sums += one frame's).
cudaError_t launch_add_sums(double* acc, const double* add, size_t n, cudaStream_t stream);

// Columns [x_begin, x_end) of every row of a width x height image: out (row
// `row_bytes` apart, RGBA8) = tone_map_pixel(sum, inv, gain) (tone_map.h) with
// `thresholds` (255 floats, device memory).
cudaError_t launch_tone_map_columns(const double* sum, int width, int height, int x_begin, int x_end, double inv,
                                    float gain, const float* thresholds, unsigned char* out, size_t row_bytes,
                                    cudaStream_t stream);

// Columns [x_begin, x_end) of the float mean of a width x height image from its
// sums: out[i] = float(sum[i] x inv) (Film::mean()), a value that is not finite
// written as 0 (what the host path's denoiser does with it).
cudaError_t launch_mean_columns(const double* sum, int width, int height, int x_begin, int x_end, double inv,
                                float* out, cudaStream_t stream);

// Every pixel of a width x height linear RGB float image (a denoised one): out
// (RGBA8, row `row_bytes` apart) = tone_map_rgb(rgb, gain) with `thresholds`.
cudaError_t launch_tone_map_rgb(const float* rgb, int width, int height, float gain, const float* thresholds,
                                unsigned char* out, size_t row_bytes, cudaStream_t stream);

}  // namespace pn::viewer
