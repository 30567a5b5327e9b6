// The OpenGL side of the viewer: the few OpenGL 3.3 core functions it calls
// (loaded through the context's loader, GLFW's or EGL's; Dear ImGui's OpenGL
// backend loads its own), the display texture that shows the rendered image
// scaled to the window, and the offscreen framebuffer of a headless viewer.
#pragma once

#include <memory>
#include <string>
#include <vector>

#include "apps/viewer/progressive.h"

namespace pn::viewer {

// A context's function loader: glfwGetProcAddress, eglGetProcAddress.
using GlProcLoader = void (*(*)(const char*))();

// Loads the functions below from the current context. Returns false and names
// the first missing function in `missing` if the context lacks one.
bool load_gl(GlProcLoader get_proc, std::string* missing);

// glFinish: a headless frame is done when the GPU has drawn it.
void finish_gl();

// What a headless viewer draws into instead of a window: an RGBA8 colour
// renderbuffer of a fixed size behind a framebuffer object. bind() makes it the
// target of every draw and read.
class OffscreenFramebuffer {
 public:
  OffscreenFramebuffer(int width, int height);  // throws (one line) if incomplete
  ~OffscreenFramebuffer();
  OffscreenFramebuffer(const OffscreenFramebuffer&) = delete;
  OffscreenFramebuffer& operator=(const OffscreenFramebuffer&) = delete;
  void bind();
  int width() const { return width_; }
  int height() const { return height_; }

 private:
  unsigned framebuffer_ = 0, color_ = 0;
  int width_ = 0, height_ = 0;
};

// "4.5 (Core Profile) Mesa 22.3.6" and "llvmpipe (LLVM 15.0.6, 256 bits)".
std::string gl_version_string();
std::string gl_renderer_string();
// The context's version, e.g. 33 for 3.3.
int gl_version_number();

// One RGBA8 texture holding the display image (8-bit sRGB values, shown as
// they are: no framebuffer sRGB conversion), drawn over the whole viewport.
class DisplayTexture {
 public:
  DisplayTexture();
  ~DisplayTexture();
  DisplayTexture(const DisplayTexture&) = delete;
  DisplayTexture& operator=(const DisplayTexture&) = delete;

  // (Re)allocates the texture and its host staging buffer.
  void resize(int width, int height);
  int width() const { return width_; }
  int height() const { return height_; }

  // Host path: the staging buffer to tone-map into, then upload() it.
  DisplayPixels host_pixels();
  void upload();

  // Interop path (builds with CUDA, device_image.h): a GL_PIXEL_UNPACK_BUFFER of
  // width x height x 4 bytes, registered with CUDA once per size. Returns false
  // with the reason in one line in *why where this build or this GL context
  // cannot (then the host path stays); resize() re-registers at each new size
  // and throws if that fails.
  bool enable_interop(std::string* why);
  void disable_interop();
  bool interop() const { return interop_; }
  // Maps the buffer into CUDA: device DisplayPixels to tone-map into; then
  // upload_mapped() unmaps it and fills the texture from it (glTexSubImage2D
  // from offset 0 of the bound buffer: no trip through host memory).
  DisplayPixels map_device_pixels();
  void upload_mapped();

  // Draws the texture over the viewport of a framebuffer of this size.
  void draw(int framebuffer_width, int framebuffer_height);

 private:
  void register_buffer();  // (re)allocates and registers the pixel buffer at the current size

  unsigned texture_ = 0, program_ = 0, vao_ = 0;
  int width_ = 0, height_ = 0;
  std::vector<unsigned char> host_;
  bool interop_ = false;
  unsigned pbo_ = 0;                        // GL_PIXEL_UNPACK_BUFFER
  std::shared_ptr<void> cuda_buffer_;       // its CUDA registration (a CudaGlBuffer)
  unsigned char* mapped_ = nullptr;
};

// The current framebuffer (what the window shows once swapped, or the bound
// offscreen one), RGB 8-bit, row 0 at the top: for screenshots of the whole
// window.
std::vector<unsigned char> read_framebuffer_rgb(int width, int height, bool offscreen);

}  // namespace pn::viewer
