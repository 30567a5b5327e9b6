// The viewer's CUDA-OpenGL interop path (docs/viewer.md, "The GPU path"): built
// when the OptiX backend is (CUDA present); no CUDA or GL types here.
//
//  - make_device_image(): a ProgressiveImage whose accumulation stays on the
//    GPU. Each add_samples() launches the OptiX backend (reset + accumulate) and
//    adds its device sums into the image's own device sums (so that the two
//    sides of the split screen, one backend, keep separate images);
//    tone_map() writes device pixels (writes_device_pixels() == true) with a
//    CUDA kernel over the column range; mean() copies to the host (screenshots).
//  - CudaGlBuffer: a GL buffer object registered with CUDA
//    (cudaGraphicsGLRegisterBuffer, write-discard), mapped per frame to give
//    its device pointer.
#pragma once

#include <cstddef>
#include <memory>
#include <string>

#include "apps/viewer/progressive.h"

namespace pn {
class OptixBackend;
}

namespace pn::viewer {

// `backend` must outlive the image. Throws std::runtime_error (one line) on a CUDA error.
std::unique_ptr<ProgressiveImage> make_device_image(OptixBackend& backend);

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
