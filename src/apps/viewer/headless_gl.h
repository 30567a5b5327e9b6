// An OpenGL context without any display server, for `penumbra view --headless`:
// EGL (libEGL.so.1, opened at run time) on an NVIDIA GPU through EGL's device
// platform where one is found, so that CUDA-OpenGL interop works as in a
// window; else Mesa's surfaceless platform (llvmpipe on a machine without a
// GPU, CI's). The viewer draws into an OffscreenFramebuffer (gl_display.h) of
// this context instead of a window's back buffer.
#pragma once

#include <memory>
#include <string>

#include "apps/viewer/gl_display.h"

namespace pn::viewer {

class HeadlessGl {
 public:
  // Opens libEGL, picks a display, makes an OpenGL 3.3 core context current on
  // this thread without a surface. Throws std::runtime_error with one line
  // naming what is missing (the library, a display, a 3.3 context).
  HeadlessGl();
  ~HeadlessGl();
  HeadlessGl(const HeadlessGl&) = delete;
  HeadlessGl& operator=(const HeadlessGl&) = delete;

  // eglGetProcAddress of the opened library, for load_gl.
  static GlProcLoader loader();
  // "EGL 1.5, device platform (NVIDIA, CUDA device 0)" and the like.
  const std::string& description() const { return description_; }

 private:
  struct Egl;
  std::unique_ptr<Egl> egl_;
  std::string description_;
};

}  // namespace pn::viewer
