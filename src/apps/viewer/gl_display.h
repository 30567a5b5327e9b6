// The OpenGL side of the viewer: the few OpenGL 3.3 core functions it calls
// (loaded through GLFW; Dear ImGui's OpenGL backend loads its own), and the
// display texture that shows the rendered image scaled to the window.
#pragma once

#include <string>
#include <vector>

#include "apps/viewer/progressive.h"

namespace pn::viewer {

// Loads the functions below from the current context. Returns false and names
// the first missing function in `missing` if the context lacks one.
bool load_gl(std::string* missing);

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
  // (Interop path, to come: a GL_PIXEL_UNPACK_BUFFER registered with CUDA,
  // mapped to give device DisplayPixels, then glTexSubImage2D from offset 0 of
  // the bound buffer. Only this class and the frame loop change.)

  // Draws the texture over the viewport of a framebuffer of this size.
  void draw(int framebuffer_width, int framebuffer_height);

 private:
  unsigned texture_ = 0, program_ = 0, vao_ = 0;
  int width_ = 0, height_ = 0;
  std::vector<unsigned char> host_;
};

// The current framebuffer (what the window shows once swapped), RGB 8-bit,
// row 0 at the top: for documentation screenshots of the whole window.
std::vector<unsigned char> read_framebuffer_rgb(int width, int height);

}  // namespace pn::viewer
