// The seam between the viewer and a backend: a progressively refined image
// seen through one camera, and the 8-bit pixels it puts on the screen.
//
// The window shows one texture, 8-bit sRGB RGBA, the size of the rendered image
// (gl_display.h). Each ProgressiveImage tone-maps its running mean into columns
// of it: all of them, or, in the split screen, the columns left or right of the
// divider (each side is a whole image of its own strategy; only the display is
// split, so the divider moves freely and both sides' costs are measured on the
// same content). Where the pixels live is the only difference between the two
// display paths:
//
//  - host (every backend, the only one built today): the backend accumulates
//    into a host Film; tone_map() writes host memory (DisplayPixels::device ==
//    false) and the viewer uploads it with glTexSubImage2D;
//  - CUDA-OpenGL interop (to come, OptiX): the accumulation stays on the GPU; the
//    viewer maps a GL pixel-unpack buffer into CUDA (cudaGraphicsGLRegisterBuffer
//    once, cudaGraphicsMapResources per frame) and passes its device pointer
//    with device == true; a CUDA kernel writes the pixels and the texture is
//    filled from the buffer without a trip through host memory. Such an image
//    answers writes_device_pixels() == true. No Backend change is needed for the
//    host path; the interop path will need a device-side accumulation handle
//    from the OptiX backend (see docs/viewer.md, "GPU path").
#pragma once

#include <cstdint>
#include <memory>
#include <vector>

#include "render/backend.h"
#include "render/film.h"

namespace pn::viewer {

// Where tone-mapped pixels go: the display image, 8-bit sRGB RGBA (alpha 255),
// row 0 at the top.
struct DisplayPixels {
  unsigned char* data = nullptr;  // pixel (0, 0) of the display image
  size_t row_bytes = 0;
  int width = 0, height = 0;      // of the whole display image
  bool device = false;            // true: a CUDA device pointer (mapped GL pixel buffer)
};

class ProgressiveImage {
 public:
  virtual ~ProgressiveImage() = default;
  // Starts over with these settings; the camera gives the size. Accumulation restarts.
  virtual void restart(const FrameSpec& frame) = 0;
  // Adds `spp` samples per pixel to the running mean.
  virtual void add_samples(uint32_t spp) = 0;
  virtual uint64_t samples() const = 0;
  virtual int width() const = 0;
  virtual int height() const = 0;
  // Writes mean x 2^exposure, sRGB-encoded, of columns [x_begin, x_end) into
  // the same columns of `out` (an image of this size): exactly the bytes a PNG
  // of mean() would hold.
  virtual void tone_map(const DisplayPixels& out, int x_begin, int x_end, float exposure) const = 0;
  // Whether tone_map() writes device memory (then `out` must be device pixels).
  virtual bool writes_device_pixels() const { return false; }
  // The linear mean, RGB float, row 0 at the top: screenshots (EXR and PNG).
  virtual std::vector<float> mean() const = 0;
};

// The host path: any Backend renders into a host Film, tone-mapped on the CPU.
// `backend` must outlive the image.
std::unique_ptr<ProgressiveImage> make_host_image(Backend& backend);

// Linear -> sRGB 8-bit, identical to io/image.h's to_srgb8 (which writes PNGs)
// but by a binary search in a 255-entry threshold table instead of a pow().
unsigned char srgb8_fast(float linear);

}  // namespace pn::viewer
