#include "apps/viewer/headless_gl.h"

#if __has_include(<EGL/egl.h>)
#define PN_HEADLESS_EGL 1
#include <dlfcn.h>

#include <EGL/egl.h>
#include <EGL/eglext.h>
#endif

#include <algorithm>
#include <cstdio>
#include <cstring>
#include <stdexcept>
#include <vector>

#if PN_HEADLESS_EGL
namespace pn::viewer {
namespace {

PFNEGLGETPROCADDRESSPROC g_get_proc = nullptr;  // set by the first HeadlessGl

void (*egl_loader(const char* name))() { return g_get_proc ? g_get_proc(name) : nullptr; }

bool has_extension(const char* list, const char* name) {
  if (!list) return false;
  const size_t n = std::strlen(name);
  for (const char* p = list; (p = std::strstr(p, name)) != nullptr; p += n)
    if ((p == list || p[-1] == ' ') && (p[n] == ' ' || p[n] == '\0')) return true;
  return false;
}

std::string hex(EGLint e) {
  char b[16];
  std::snprintf(b, sizeof b, "0x%04x", unsigned(e));
  return b;
}

}  // namespace

struct HeadlessGl::Egl {
  void* library = nullptr;
  PFNEGLGETERRORPROC GetError = nullptr;
  PFNEGLQUERYSTRINGPROC QueryString = nullptr;
  PFNEGLINITIALIZEPROC Initialize = nullptr;
  PFNEGLTERMINATEPROC Terminate = nullptr;
  PFNEGLBINDAPIPROC BindAPI = nullptr;
  PFNEGLCHOOSECONFIGPROC ChooseConfig = nullptr;
  PFNEGLCREATECONTEXTPROC CreateContext = nullptr;
  PFNEGLDESTROYCONTEXTPROC DestroyContext = nullptr;
  PFNEGLMAKECURRENTPROC MakeCurrent = nullptr;
  PFNEGLCREATEPBUFFERSURFACEPROC CreatePbufferSurface = nullptr;
  PFNEGLDESTROYSURFACEPROC DestroySurface = nullptr;
  PFNEGLGETPLATFORMDISPLAYEXTPROC GetPlatformDisplay = nullptr;
  PFNEGLQUERYDEVICESEXTPROC QueryDevices = nullptr;
  PFNEGLQUERYDEVICESTRINGEXTPROC QueryDeviceString = nullptr;
  EGLDisplay display = EGL_NO_DISPLAY;
  EGLContext context = EGL_NO_CONTEXT;
  EGLSurface surface = EGL_NO_SURFACE;  // a 1x1 pbuffer where surfaceless contexts are not offered

  ~Egl() {
    if (display != EGL_NO_DISPLAY) {
      MakeCurrent(display, EGL_NO_SURFACE, EGL_NO_SURFACE, EGL_NO_CONTEXT);
      if (surface != EGL_NO_SURFACE) DestroySurface(display, surface);
      if (context != EGL_NO_CONTEXT) DestroyContext(display, context);
      Terminate(display);
    }
    // The library stays loaded: the GL functions loaded through it are in use until exit.
  }
};

HeadlessGl::HeadlessGl() : egl_(std::make_unique<Egl>()) {
  Egl& e = *egl_;
  e.library = dlopen("libEGL.so.1", RTLD_NOW | RTLD_GLOBAL);
  if (!e.library)
    throw std::runtime_error("--headless needs EGL: libEGL.so.1 was not found (Debian: libegl1, with libegl-mesa0 "
                             "for a machine without an NVIDIA GPU)");
  auto sym = [&](const char* name) {
    void* f = dlsym(e.library, name);
    if (!f) throw std::runtime_error(std::string("--headless: libEGL.so.1 lacks ") + name);
    return f;
  };
  g_get_proc = reinterpret_cast<PFNEGLGETPROCADDRESSPROC>(sym("eglGetProcAddress"));
  e.GetError = reinterpret_cast<PFNEGLGETERRORPROC>(sym("eglGetError"));
  e.QueryString = reinterpret_cast<PFNEGLQUERYSTRINGPROC>(sym("eglQueryString"));
  e.Initialize = reinterpret_cast<PFNEGLINITIALIZEPROC>(sym("eglInitialize"));
  e.Terminate = reinterpret_cast<PFNEGLTERMINATEPROC>(sym("eglTerminate"));
  e.BindAPI = reinterpret_cast<PFNEGLBINDAPIPROC>(sym("eglBindAPI"));
  e.ChooseConfig = reinterpret_cast<PFNEGLCHOOSECONFIGPROC>(sym("eglChooseConfig"));
  e.CreateContext = reinterpret_cast<PFNEGLCREATECONTEXTPROC>(sym("eglCreateContext"));
  e.DestroyContext = reinterpret_cast<PFNEGLDESTROYCONTEXTPROC>(sym("eglDestroyContext"));
  e.MakeCurrent = reinterpret_cast<PFNEGLMAKECURRENTPROC>(sym("eglMakeCurrent"));
  e.CreatePbufferSurface = reinterpret_cast<PFNEGLCREATEPBUFFERSURFACEPROC>(sym("eglCreatePbufferSurface"));
  e.DestroySurface = reinterpret_cast<PFNEGLDESTROYSURFACEPROC>(sym("eglDestroySurface"));

  // The platform: an NVIDIA GPU (a device offering EGL_NV_device_cuda), else
  // the surfaceless platform (Mesa's; NVIDIA's EGL offers it too, and serves it
  // where its device platform is not enumerated), else any device EGL enumerates.
  const char* client = e.QueryString(EGL_NO_DISPLAY, EGL_EXTENSIONS);
  e.GetPlatformDisplay = reinterpret_cast<PFNEGLGETPLATFORMDISPLAYEXTPROC>(g_get_proc("eglGetPlatformDisplayEXT"));
  if (!e.GetPlatformDisplay || !has_extension(client, "EGL_EXT_platform_base"))
    throw std::runtime_error("--headless: this EGL offers no platform displays (EGL_EXT_platform_base)");
  std::vector<EGLDeviceEXT> devices;
  if (has_extension(client, "EGL_EXT_device_enumeration") && has_extension(client, "EGL_EXT_platform_device")) {
    e.QueryDevices = reinterpret_cast<PFNEGLQUERYDEVICESEXTPROC>(g_get_proc("eglQueryDevicesEXT"));
    e.QueryDeviceString = reinterpret_cast<PFNEGLQUERYDEVICESTRINGEXTPROC>(g_get_proc("eglQueryDeviceStringEXT"));
    EGLint n = 0;
    if (e.QueryDevices && e.QueryDeviceString && e.QueryDevices(0, nullptr, &n) && n > 0) {
      devices.resize(size_t(n));
      e.QueryDevices(n, devices.data(), &n);
      devices.resize(size_t(std::max<EGLint>(n, 0)));
    }
  }
  auto try_display = [&](EGLenum platform, void* native, const std::string& what) {
    EGLDisplay d = e.GetPlatformDisplay(platform, native, nullptr);
    EGLint major = 0, minor = 0;
    if (d == EGL_NO_DISPLAY || !e.Initialize(d, &major, &minor)) return false;
    e.display = d;
    description_ = "EGL " + std::to_string(major) + "." + std::to_string(minor) + ", " + what;
    return true;
  };
  for (size_t i = 0; i < devices.size() && e.display == EGL_NO_DISPLAY; ++i)
    if (has_extension(e.QueryDeviceString(devices[i], EGL_EXTENSIONS), "EGL_NV_device_cuda"))
      try_display(EGL_PLATFORM_DEVICE_EXT, devices[i], "device platform (NVIDIA GPU)");
  if (e.display == EGL_NO_DISPLAY && has_extension(client, "EGL_MESA_platform_surfaceless"))
    try_display(EGL_PLATFORM_SURFACELESS_MESA, EGL_DEFAULT_DISPLAY,
                "surfaceless platform (EGL_MESA_platform_surfaceless)");
  for (size_t i = 0; i < devices.size() && e.display == EGL_NO_DISPLAY; ++i)
    try_display(EGL_PLATFORM_DEVICE_EXT, devices[i], "device platform");
  if (e.display == EGL_NO_DISPLAY)
    throw std::runtime_error("--headless: EGL found no display without a display server (no NVIDIA GPU through "
                             "EGL's device platform, no Mesa surfaceless platform: Debian's libegl-mesa0 gives one)");

  if (!e.BindAPI(EGL_OPENGL_API)) throw std::runtime_error("--headless: this EGL display offers no desktop OpenGL");
  const bool surfaceless = has_extension(e.QueryString(e.display, EGL_EXTENSIONS), "EGL_KHR_surfaceless_context");
  const EGLint config_attributes[] = {EGL_SURFACE_TYPE, EGL_PBUFFER_BIT, EGL_RENDERABLE_TYPE, EGL_OPENGL_BIT,
                                      EGL_RED_SIZE, 8, EGL_GREEN_SIZE, 8, EGL_BLUE_SIZE, 8, EGL_NONE};
  EGLConfig config = nullptr;
  EGLint configs = 0;
  if (!e.ChooseConfig(e.display, config_attributes, &config, 1, &configs) || configs < 1)
    throw std::runtime_error("--headless: " + description_ + " has no 8-bit RGB OpenGL configuration");
  const EGLint context_attributes[] = {EGL_CONTEXT_MAJOR_VERSION, 3, EGL_CONTEXT_MINOR_VERSION, 3,
                                       EGL_CONTEXT_OPENGL_PROFILE_MASK, EGL_CONTEXT_OPENGL_CORE_PROFILE_BIT,
                                       EGL_NONE};
  e.context = e.CreateContext(e.display, config, EGL_NO_CONTEXT, context_attributes);
  if (e.context == EGL_NO_CONTEXT)
    throw std::runtime_error("--headless: " + description_ + " offers no OpenGL 3.3 core context (EGL error " +
                             hex(e.GetError()) + "); " + "the viewer needs OpenGL 3.3");
  if (!surfaceless) {
    const EGLint pbuffer[] = {EGL_WIDTH, 1, EGL_HEIGHT, 1, EGL_NONE};
    e.surface = e.CreatePbufferSurface(e.display, config, pbuffer);
  }
  if (!e.MakeCurrent(e.display, e.surface, e.surface, e.context))
    throw std::runtime_error("--headless: cannot make the OpenGL context current (EGL error " + hex(e.GetError()) +
                             ")");
}

HeadlessGl::~HeadlessGl() = default;

GlProcLoader HeadlessGl::loader() { return egl_loader; }

}  // namespace pn::viewer
#else  // no EGL headers when this penumbra was built

namespace pn::viewer {

struct HeadlessGl::Egl {};

HeadlessGl::HeadlessGl() {
  throw std::runtime_error("--headless: this penumbra was built without EGL's headers (Debian: libegl-dev; "
                           "scripts/install-deps.sh installs it): reconfigure and rebuild");
}

HeadlessGl::~HeadlessGl() = default;

GlProcLoader HeadlessGl::loader() { return nullptr; }

}  // namespace pn::viewer

#endif
