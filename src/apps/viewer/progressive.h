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
//  - host (the CPU backend, and the OptiX backend where interop fails): the
//    backend accumulates into a host Film; tone_map() writes host memory
//    (DisplayPixels::device == false) and the viewer uploads it with
//    glTexSubImage2D;
//  - CUDA-OpenGL interop (the OptiX backend, device_image.h): the accumulation
//    stays on the GPU; the viewer maps a GL pixel-unpack buffer into CUDA
//    (cudaGraphicsGLRegisterBuffer once per size, cudaGraphicsMapResources per
//    frame) and passes its device pointer with device == true; a CUDA kernel
//    writes the pixels and the texture is filled from the buffer without a trip
//    through host memory. Such an image answers writes_device_pixels() == true.
//    Both paths tone-map each pixel with the same function (tone_map.h).
#pragma once

#include <cstdint>
#include <functional>
#include <memory>
#include <string>
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
  // Device images only (writes_device_pixels()): columns [x_begin, x_end) of the
  // linear mean into `rgb`, a device image of this size (3 floats a pixel), a
  // value that is not finite as 0; written when it returns. The default throws
  // std::logic_error.
  virtual void write_mean_device(float* rgb, int x_begin, int x_end) const;
};

// How the image reaches the screen, chosen once the window is open.
enum class DisplayPath { HostUpload, Interop };
struct DisplayChoice {
  DisplayPath path = DisplayPath::HostUpload;
  std::string note;  // one line for stderr and the panel: the path, and why
};
// `mode` is --display: "auto" (interop with the OptiX backend where it works,
// else host upload with a note saying why), "interop" (or a one-line error
// with the hint to use `render`) or "host". `try_interop` is called only when
// interop is worth trying (this build has it and the backend is "optix"): it
// returns "" once the display buffer is registered with CUDA, else the reason.
DisplayChoice choose_display_path(const std::string& mode, const std::string& backend, bool interop_built,
                                  const std::function<std::string()>& try_interop);
// "CUDA-OpenGL interop" or "host upload".
const char* display_path_name(DisplayPath path);

// The host path: any Backend renders into a host Film, tone-mapped on the CPU.
// `backend` must outlive the image.
std::unique_ptr<ProgressiveImage> make_host_image(Backend& backend);

// Linear -> sRGB 8-bit, identical to io/image.h's to_srgb8 (which writes PNGs)
// but by a binary search in a 255-entry threshold table instead of a pow().
unsigned char srgb8_fast(float linear);
// That table: entry k - 1 is the smallest float v with to_srgb8(v) >= k, so
// to_srgb8(v) is the number of entries <= v (tone_map.h). 255 floats, host
// memory; the interop path copies it to the device.
const float* srgb8_thresholds();

}  // namespace pn::viewer
