#include "apps/viewer/gl_display.h"

#include <algorithm>
#include <cstdio>
#include <stdexcept>

#include <GL/glcorearb.h>

#if PN_VIEWER_INTEROP
#include "apps/viewer/device_image.h"
#endif

namespace pn::viewer {
namespace {

// Every OpenGL function the viewer calls. Loaded by name through the context's
// own loader (GLFW's, or EGL's headless) rather than linked: libGL's exports
// stop at OpenGL 1.x on some systems, and this keeps the viewer free of a
// loader library.
#define PN_GL_FUNCTIONS(X)                                        \
  X(PFNGLGETSTRINGPROC, GetString)                                \
  X(PFNGLGETINTEGERVPROC, GetIntegerv)                            \
  X(PFNGLGETERRORPROC, GetError)                                  \
  X(PFNGLVIEWPORTPROC, Viewport)                                  \
  X(PFNGLCLEARCOLORPROC, ClearColor)                              \
  X(PFNGLCLEARPROC, Clear)                                        \
  X(PFNGLPIXELSTOREIPROC, PixelStorei)                            \
  X(PFNGLREADBUFFERPROC, ReadBuffer)                              \
  X(PFNGLREADPIXELSPROC, ReadPixels)                              \
  X(PFNGLGENTEXTURESPROC, GenTextures)                            \
  X(PFNGLDELETETEXTURESPROC, DeleteTextures)                      \
  X(PFNGLBINDTEXTUREPROC, BindTexture)                            \
  X(PFNGLACTIVETEXTUREPROC, ActiveTexture)                        \
  X(PFNGLTEXPARAMETERIPROC, TexParameteri)                        \
  X(PFNGLTEXIMAGE2DPROC, TexImage2D)                              \
  X(PFNGLTEXSUBIMAGE2DPROC, TexSubImage2D)                        \
  X(PFNGLBINDBUFFERPROC, BindBuffer)                              \
  X(PFNGLGENBUFFERSPROC, GenBuffers)                              \
  X(PFNGLDELETEBUFFERSPROC, DeleteBuffers)                        \
  X(PFNGLBUFFERDATAPROC, BufferData)                              \
  X(PFNGLCREATESHADERPROC, CreateShader)                          \
  X(PFNGLSHADERSOURCEPROC, ShaderSource)                          \
  X(PFNGLCOMPILESHADERPROC, CompileShader)                        \
  X(PFNGLGETSHADERIVPROC, GetShaderiv)                            \
  X(PFNGLGETSHADERINFOLOGPROC, GetShaderInfoLog)                  \
  X(PFNGLDELETESHADERPROC, DeleteShader)                          \
  X(PFNGLCREATEPROGRAMPROC, CreateProgram)                        \
  X(PFNGLATTACHSHADERPROC, AttachShader)                          \
  X(PFNGLLINKPROGRAMPROC, LinkProgram)                            \
  X(PFNGLGETPROGRAMIVPROC, GetProgramiv)                          \
  X(PFNGLGETPROGRAMINFOLOGPROC, GetProgramInfoLog)                \
  X(PFNGLDELETEPROGRAMPROC, DeleteProgram)                        \
  X(PFNGLUSEPROGRAMPROC, UseProgram)                              \
  X(PFNGLGETUNIFORMLOCATIONPROC, GetUniformLocation)              \
  X(PFNGLUNIFORM1IPROC, Uniform1i)                                \
  X(PFNGLGENVERTEXARRAYSPROC, GenVertexArrays)                    \
  X(PFNGLBINDVERTEXARRAYPROC, BindVertexArray)                    \
  X(PFNGLDELETEVERTEXARRAYSPROC, DeleteVertexArrays)              \
  X(PFNGLDRAWARRAYSPROC, DrawArrays)                              \
  X(PFNGLFINISHPROC, Finish)                                      \
  X(PFNGLGENFRAMEBUFFERSPROC, GenFramebuffers)                    \
  X(PFNGLBINDFRAMEBUFFERPROC, BindFramebuffer)                    \
  X(PFNGLDELETEFRAMEBUFFERSPROC, DeleteFramebuffers)              \
  X(PFNGLGENRENDERBUFFERSPROC, GenRenderbuffers)                  \
  X(PFNGLBINDRENDERBUFFERPROC, BindRenderbuffer)                  \
  X(PFNGLDELETERENDERBUFFERSPROC, DeleteRenderbuffers)            \
  X(PFNGLRENDERBUFFERSTORAGEPROC, RenderbufferStorage)            \
  X(PFNGLFRAMEBUFFERRENDERBUFFERPROC, FramebufferRenderbuffer)    \
  X(PFNGLCHECKFRAMEBUFFERSTATUSPROC, CheckFramebufferStatus)

struct GlFunctions {
#define PN_X(type, name) type name = nullptr;
  PN_GL_FUNCTIONS(PN_X)
#undef PN_X
};
GlFunctions gl;

// A triangle that covers the viewport (no vertex buffer: positions from
// gl_VertexID); texture row 0 is the image's top row, hence the flipped v.
const char* kVertexShader = R"(#version 330 core
out vec2 uv;
void main() {
  vec2 p = vec2(float((gl_VertexID << 1) & 2), float(gl_VertexID & 2));
  uv = vec2(p.x, 1.0 - p.y);
  gl_Position = vec4(p * 2.0 - 1.0, 0.0, 1.0);
}
)";
const char* kFragmentShader = R"(#version 330 core
in vec2 uv;
uniform sampler2D image;
out vec4 color;
void main() { color = vec4(texture(image, uv).rgb, 1.0); }
)";

unsigned compile(GLenum type, const char* source) {
  GLuint s = gl.CreateShader(type);
  gl.ShaderSource(s, 1, &source, nullptr);
  gl.CompileShader(s);
  GLint ok = 0;
  gl.GetShaderiv(s, GL_COMPILE_STATUS, &ok);
  if (!ok) {
    char log[1024] = {0};
    gl.GetShaderInfoLog(s, sizeof log, nullptr, log);
    gl.DeleteShader(s);
    for (char* c = log; *c; ++c)
      if (*c == '\n') *c = ' ';  // errors are one line
    throw std::runtime_error(std::string("the OpenGL driver rejected the display shader: ") + log);
  }
  return s;
}

}  // namespace

bool load_gl(GlProcLoader get_proc, std::string* missing) {
#define PN_X(type, name)                                                              \
  gl.name = reinterpret_cast<type>(get_proc("gl" #name));                            \
  if (!gl.name) {                                                                     \
    *missing = "gl" #name;                                                            \
    return false;                                                                     \
  }
  PN_GL_FUNCTIONS(PN_X)
#undef PN_X
  return true;
}

std::string gl_version_string() {
  const GLubyte* s = gl.GetString(GL_VERSION);
  return s ? reinterpret_cast<const char*>(s) : "unknown";
}
std::string gl_renderer_string() {
  const GLubyte* s = gl.GetString(GL_RENDERER);
  return s ? reinterpret_cast<const char*>(s) : "unknown";
}
int gl_version_number() {
  GLint major = 0, minor = 0;
  gl.GetIntegerv(GL_MAJOR_VERSION, &major);  // 3.0+; an older context leaves 0
  gl.GetIntegerv(GL_MINOR_VERSION, &minor);
  return major * 10 + minor;
}

DisplayTexture::DisplayTexture() {
  GLuint vs = compile(GL_VERTEX_SHADER, kVertexShader), fs = compile(GL_FRAGMENT_SHADER, kFragmentShader);
  program_ = gl.CreateProgram();
  gl.AttachShader(program_, vs);
  gl.AttachShader(program_, fs);
  gl.LinkProgram(program_);
  gl.DeleteShader(vs);
  gl.DeleteShader(fs);
  GLint ok = 0;
  gl.GetProgramiv(program_, GL_LINK_STATUS, &ok);
  if (!ok) throw std::runtime_error("the OpenGL driver could not link the display shader");
  gl.GenVertexArrays(1, &vao_);  // core profile: drawing needs a bound VAO, even an empty one
  gl.GenTextures(1, &texture_);
}

DisplayTexture::~DisplayTexture() {
  if (mapped_) upload_mapped();
  cuda_buffer_.reset();  // unregister before the buffer goes
  if (pbo_) gl.DeleteBuffers(1, &pbo_);
  gl.DeleteTextures(1, &texture_);
  gl.DeleteVertexArrays(1, &vao_);
  gl.DeleteProgram(program_);
}

void DisplayTexture::resize(int width, int height) {
  if (width == width_ && height == height_) return;
  width_ = width;
  height_ = height;
  host_.assign(size_t(width) * height * 4, 0);
  gl.BindTexture(GL_TEXTURE_2D, texture_);
  gl.TexImage2D(GL_TEXTURE_2D, 0, GL_RGBA8, width, height, 0, GL_RGBA, GL_UNSIGNED_BYTE, host_.data());
  // Linear filtering for resolution scales below 1; at scale 1 the viewport's
  // pixel centres fall on texel centres, so the window shows the exact bytes.
  gl.TexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MIN_FILTER, GL_LINEAR);
  gl.TexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MAG_FILTER, GL_LINEAR);
  gl.TexParameteri(GL_TEXTURE_2D, GL_TEXTURE_WRAP_S, GL_CLAMP_TO_EDGE);
  gl.TexParameteri(GL_TEXTURE_2D, GL_TEXTURE_WRAP_T, GL_CLAMP_TO_EDGE);
  if (interop_) register_buffer();
}

bool DisplayTexture::enable_interop(std::string* why) {
#if PN_VIEWER_INTEROP
  if (interop_) return true;
  interop_ = true;
  try {
    register_buffer();
    return true;
  } catch (const std::exception& e) {
    disable_interop();
    *why = e.what();
    return false;
  }
#else
  *why = "this penumbra was built without CUDA";
  return false;
#endif
}

void DisplayTexture::disable_interop() {
  cuda_buffer_.reset();
  if (pbo_) gl.DeleteBuffers(1, &pbo_);
  pbo_ = 0;
  interop_ = false;
}

void DisplayTexture::register_buffer() {
#if PN_VIEWER_INTEROP
  cuda_buffer_.reset();
  if (!pbo_) gl.GenBuffers(1, &pbo_);
  gl.BindBuffer(GL_PIXEL_UNPACK_BUFFER, pbo_);
  // At least one pixel: registering a buffer without storage fails.
  gl.BufferData(GL_PIXEL_UNPACK_BUFFER, GLsizeiptr(std::max(width_, 1)) * std::max(height_, 1) * 4, nullptr,
                GL_STREAM_DRAW);
  gl.BindBuffer(GL_PIXEL_UNPACK_BUFFER, 0);
  cuda_buffer_ = std::make_shared<CudaGlBuffer>(pbo_);
#endif
}

DisplayPixels DisplayTexture::map_device_pixels() {
  DisplayPixels p;
#if PN_VIEWER_INTEROP
  if (!interop_ || !cuda_buffer_) throw std::logic_error("map_device_pixels() without interop");
  auto* buffer = static_cast<CudaGlBuffer*>(cuda_buffer_.get());
  size_t bytes = 0;
  mapped_ = buffer->map(&bytes);
  if (bytes < size_t(width_) * height_ * 4) throw std::logic_error("the mapped pixel buffer is too small");
  p.data = mapped_;
  p.row_bytes = size_t(width_) * 4;
  p.width = width_;
  p.height = height_;
  p.device = true;
#endif
  return p;
}

void DisplayTexture::upload_mapped() {
#if PN_VIEWER_INTEROP
  if (!mapped_) return;
  static_cast<CudaGlBuffer*>(cuda_buffer_.get())->unmap();  // CUDA's writes are done before GL reads
  mapped_ = nullptr;
  gl.BindBuffer(GL_PIXEL_UNPACK_BUFFER, pbo_);
  gl.PixelStorei(GL_UNPACK_ALIGNMENT, 4);
  gl.PixelStorei(GL_UNPACK_ROW_LENGTH, 0);
  gl.BindTexture(GL_TEXTURE_2D, texture_);
  gl.TexSubImage2D(GL_TEXTURE_2D, 0, 0, 0, width_, height_, GL_RGBA, GL_UNSIGNED_BYTE, nullptr);  // offset 0
  gl.BindBuffer(GL_PIXEL_UNPACK_BUFFER, 0);
#endif
}

DisplayPixels DisplayTexture::host_pixels() {
  DisplayPixels p;
  p.data = host_.data();
  p.row_bytes = size_t(width_) * 4;
  p.width = width_;
  p.height = height_;
  p.device = false;
  return p;
}

void DisplayTexture::upload() {
  gl.BindBuffer(GL_PIXEL_UNPACK_BUFFER, 0);  // from host memory
  gl.PixelStorei(GL_UNPACK_ALIGNMENT, 4);
  gl.PixelStorei(GL_UNPACK_ROW_LENGTH, 0);
  gl.BindTexture(GL_TEXTURE_2D, texture_);
  gl.TexSubImage2D(GL_TEXTURE_2D, 0, 0, 0, width_, height_, GL_RGBA, GL_UNSIGNED_BYTE, host_.data());
}

void DisplayTexture::draw(int framebuffer_width, int framebuffer_height) {
  gl.Viewport(0, 0, framebuffer_width, framebuffer_height);
  gl.ClearColor(0.f, 0.f, 0.f, 1.f);
  gl.Clear(GL_COLOR_BUFFER_BIT);
  if (width_ == 0 || height_ == 0) return;
  gl.UseProgram(program_);
  gl.ActiveTexture(GL_TEXTURE0);
  gl.BindTexture(GL_TEXTURE_2D, texture_);
  gl.Uniform1i(gl.GetUniformLocation(program_, "image"), 0);
  gl.BindVertexArray(vao_);
  gl.DrawArrays(GL_TRIANGLES, 0, 3);
  gl.BindVertexArray(0);
  gl.UseProgram(0);
}

void finish_gl() { gl.Finish(); }

OffscreenFramebuffer::OffscreenFramebuffer(int width, int height) : width_(width), height_(height) {
  gl.GenRenderbuffers(1, &color_);
  gl.BindRenderbuffer(GL_RENDERBUFFER, color_);
  gl.RenderbufferStorage(GL_RENDERBUFFER, GL_RGBA8, width, height);
  gl.BindRenderbuffer(GL_RENDERBUFFER, 0);
  gl.GenFramebuffers(1, &framebuffer_);
  gl.BindFramebuffer(GL_FRAMEBUFFER, framebuffer_);
  gl.FramebufferRenderbuffer(GL_FRAMEBUFFER, GL_COLOR_ATTACHMENT0, GL_RENDERBUFFER, color_);
  const GLenum status = gl.CheckFramebufferStatus(GL_FRAMEBUFFER);
  if (status != GL_FRAMEBUFFER_COMPLETE) {
    char hex[16];
    std::snprintf(hex, sizeof hex, "0x%04x", unsigned(status));
    throw std::runtime_error("an offscreen framebuffer of " + std::to_string(width) + "x" + std::to_string(height) +
                             " is incomplete (OpenGL status " + hex + ")");
  }
}

OffscreenFramebuffer::~OffscreenFramebuffer() {
  gl.BindFramebuffer(GL_FRAMEBUFFER, 0);
  gl.DeleteFramebuffers(1, &framebuffer_);
  gl.DeleteRenderbuffers(1, &color_);
}

void OffscreenFramebuffer::bind() { gl.BindFramebuffer(GL_FRAMEBUFFER, framebuffer_); }

std::vector<unsigned char> read_framebuffer_rgb(int width, int height, bool offscreen) {
  std::vector<unsigned char> px(size_t(width) * height * 3), flipped(px.size());
  gl.BindBuffer(GL_PIXEL_PACK_BUFFER, 0);
  gl.PixelStorei(GL_PACK_ALIGNMENT, 1);
  gl.ReadBuffer(offscreen ? GL_COLOR_ATTACHMENT0 : GL_BACK);
  gl.ReadPixels(0, 0, width, height, GL_RGB, GL_UNSIGNED_BYTE, px.data());
  const size_t row = size_t(width) * 3;
  for (int y = 0; y < height; ++y)  // OpenGL's row 0 is the bottom one
    std::copy_n(px.data() + size_t(height - 1 - y) * row, row, flipped.data() + size_t(y) * row);
  return flipped;
}

}  // namespace pn::viewer
