// The viewer's CUDA-OpenGL interop path (docs/viewer.md, "The GPU path"): built
// when the OptiX backend is (CUDA present); no CUDA or GL types here.
//
//  - make_device_image(): a ProgressiveImage whose accumulation stays on the
//    GPU. Each add_samples() launches the OptiX backend (reset + accumulate) and
//    adds its device sums into the image's own device sums (so that the two
//    sides of the split screen, one backend, keep separate images);
//    tone_map() writes device pixels (writes_device_pixels() == true) with a
//    CUDA kernel over the column range; mean() copies to the host (screenshots).
//  - DeviceDenoiser: the denoise toggle on this path, with no image through
//    host memory but the guides (uploaded once per restart).
//  - CudaGlBuffer: a GL buffer object registered with CUDA
//    (cudaGraphicsGLRegisterBuffer, write-discard), mapped per frame to give
//    its device pointer.
#pragma once

#include <cstddef>
#include <memory>
#include <string>

#include "apps/viewer/progressive.h"
#include "render/backend.h"
#include "render/oidn.h"

namespace pn {
class OptixBackend;
}

namespace pn::viewer {

// `backend` must outlive the image. Throws std::runtime_error (one line) on a CUDA error.
std::unique_ptr<ProgressiveImage> make_device_image(OptixBackend& backend);

// The denoise toggle on the interop path: the images write their columns of the
// mean into a device image (write_mean_device), OIDN's CUDA device denoises it
// where it is (Oidn::denoise_device: shared images, its filter kept while they
// stay), and a kernel tone-maps the result into the mapped GL buffer.
class DeviceDenoiser {
 public:
  explicit DeviceDenoiser(int cuda_device);  // throws one line on a CUDA error
  ~DeviceDenoiser();
  DeviceDenoiser(const DeviceDenoiser&) = delete;
  DeviceDenoiser& operator=(const DeviceDenoiser&) = delete;
  // Sizes the device images to the guides' and uploads their albedo and normal.
  void set_guides(const GuideImages& guides);
  // The image the mean is written into: the guides' size, 3 floats a pixel.
  float* color();
  // Denoises color() with `oidn`'s CUDA device; returns its time (host clock, ms).
  double denoise(Oidn& oidn, const OidnFilterOptions& options);
  // The denoised image x 2^exposure into `out` (device pixels of the guides' size), sRGB 8-bit as a PNG.
  void tone_map(const DisplayPixels& out, float exposure) const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

class CudaGlBuffer {
 public:
  // Registers the GL buffer object `gl_buffer` (its storage allocated, the GL
  // context current) with CUDA on the backend's device (0). Throws
  // std::runtime_error with the reason in one line when CUDA cannot (the GL
  // context is not on an NVIDIA GPU: Mesa, another vendor's or another GPU).
  explicit CudaGlBuffer(unsigned gl_buffer);
  ~CudaGlBuffer();
  CudaGlBuffer(const CudaGlBuffer&) = delete;
  CudaGlBuffer& operator=(const CudaGlBuffer&) = delete;
  // Maps the buffer for CUDA: its device pointer and size. GL must not use it until unmap().
  unsigned char* map(size_t* bytes);
  void unmap();

 private:
  void* resource_ = nullptr;  // cudaGraphicsResource_t
  bool mapped_ = false;
};

}  // namespace pn::viewer
