// The interactive viewer: a GLFW window with an OpenGL 3.3 core context, Dear
// ImGui controls, and one or two ProgressiveImages (progressive.h) on screen.
// Headless (--headless), the same loop draws into an offscreen framebuffer of
// an EGL context (headless_gl.h) and finishes each frame with glFinish; there
// is no input then but the camera path's actions.
//
// One frame = poll input, apply scripted actions, build the panel, restart the
// accumulation if anything that changes the image changed, add samples, tone-map
// into the display texture, draw, swap. Rendering is synchronous in the frame:
// the frame time the panel shows (and --frames prints) is the time "as
// displayed", render + tone-map + upload + UI + present.
#include "apps/viewer/viewer.h"
#include "apps/viewer/viewer_state.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <memory>
#include <numeric>
#include <stdexcept>
#include <string>
#include <vector>

#define GLFW_INCLUDE_NONE
#include <GLFW/glfw3.h>
#include <imgui.h>
#include <backends/imgui_impl_glfw.h>
#include <backends/imgui_impl_opengl3.h>

#include "apps/exit_status.h"
#include "apps/viewer/camera_control.h"
#include "apps/viewer/camera_path.h"
#include "apps/viewer/gl_display.h"
#include "apps/viewer/headless_gl.h"
#include "apps/viewer/progressive.h"
#include "io/image.h"
#include "io/output.h"
#include "backends/make_backend.h"
#include "render/backend.h"
#include "apps/options.h"
#include "backends/denoise.h"
#include "scene/scene.h"

#if PN_VIEWER_INTEROP
#include "apps/viewer/device_image.h"
#include "backends/optix/optix_backend.h"
constexpr bool kInteropBuilt = true;
#else
constexpr bool kInteropBuilt = false;
#endif

namespace pn::viewer {
namespace {

// GLFW reports errors through a callback; keep the last one for our one-line message.
std::string g_glfw_error = "unknown error";
void on_glfw_error(int, const char* description) { g_glfw_error = description ? description : "unknown error"; }

}  // namespace


Viewer::Viewer(const ViewerOptions& o) : opt_(o) {
  // Everything that can fail without a display fails before the window opens.
  if (!opt_.screenshot.empty()) {  // before any work, as every output
    check_image_path(opt_.screenshot);
    check_output_file(opt_.screenshot, "--screenshot");
  }
  if (!opt_.camera_path.empty()) path_ = load_camera_path(opt_.camera_path);
  if (opt_.headless && opt_.frames == 0 &&
      std::none_of(path_.begin(), path_.end(), [](const PathAction& a) { return a.key == "quit"; }))
    throw std::runtime_error("--headless needs --frames N or a --camera-path with a \"quit\" action: nothing else "
                             "ends a viewer without a window");
  scene_name_ = find_builtin(opt_.scene) ? opt_.scene : std::filesystem::path(opt_.scene).stem().string();
  load();
  // --display interop that cannot be (the CPU backend, a build without CUDA): one line, before any window.
  if (opt_.display == "interop" && (backend_->name() != "optix" || !kInteropBuilt))
    choose_display_path(opt_.display, backend_->name(), kInteropBuilt, [] { return std::string(); });  // throws
  light_initial_ = light_applied_ = light_ = LightEdit::of(*scene_);
  camera_ = CameraControl(scene_->camera);
  integrator_ = scene_->integrator();
  spp_per_frame_ = opt_.spp_per_frame;
  exposure_ = opt_.exposure;
  fly_speed_ = std::max(1e-3f, 0.25f * camera_.distance());  // a quarter of the view distance per second
  panel_ = !opt_.hide_panel;
  equal_time_ = opt_.equal_time;
  camera_file_ = find_builtin(opt_.scene) ? opt_.scene + ".json" : opt_.scene;
  if (!opt_.split.empty()) {
    auto comma = opt_.split.find(',');
    if (comma == std::string::npos) throw SceneError("--split: expected LEFT,RIGHT (e.g. area,solid-angle)");
    left_ = parse_strategy(opt_.split.substr(0, comma), "--split");
    right_ = parse_strategy(opt_.split.substr(comma + 1), "--split");
    split_ = true;
  }
}

// Loads the scene with the command line's overrides and makes a backend for it.
void Viewer::load() {
  scene_ = std::make_unique<Scene>(load_scene(opt_.scene, opt_.sets));
  ++scene_loads_;
  make_backend_for_scene();
}

void Viewer::make_backend_for_scene() {
  scheduler_.clear();
  backend_.reset();  // the old one's device memory first
  backend_ = make_backend(opt_.backend, *scene_, opt_.backend_options, &backend_note_);
  ++backend_builds_;
}

void Viewer::open_window() {
  if (opt_.headless) open_headless();
  else open_glfw_window();
  int fw, fh;
  framebuffer_size(&fw, &fh);
  if (opt_.scale > 0.f) {
    scale_ = opt_.scale;
  } else if (backend_->name() == "cpu") {
    // On the CPU a frame of a 1280x720 image takes seconds: start at about
    // 640x360 image pixels, so that navigation stays interactive.
    scale_ = float(std::min(1.0, std::sqrt(640.0 * 360.0 / (double(std::max(fw, 1)) * std::max(fh, 1)))));
  }
  std::fprintf(stderr, "%s\n", backend_note_.c_str());
  std::fprintf(stderr, "view: %s, %s %dx%d, %s\n", scene_->source.c_str(), offscreen_ ? "offscreen" : "window", fw, fh,
               gl_info_.c_str());
  choose_display();
}

void Viewer::open_glfw_window() {
  glfwSetErrorCallback(on_glfw_error);
  if (!glfwInit())
    throw std::runtime_error("cannot open a window (" + g_glfw_error + "): the viewer needs a display with OpenGL 3.3; " +
                             "`penumbra view --headless` needs none; " + kRenderHint);
  glfw_ = true;
  glfwWindowHint(GLFW_CONTEXT_VERSION_MAJOR, 3);
  glfwWindowHint(GLFW_CONTEXT_VERSION_MINOR, 3);
  glfwWindowHint(GLFW_OPENGL_PROFILE, GLFW_OPENGL_CORE_PROFILE);
  glfwWindowHint(GLFW_OPENGL_FORWARD_COMPAT, GLFW_TRUE);
  glfwWindowHint(GLFW_SRGB_CAPABLE, GLFW_FALSE);  // the texture already holds sRGB values
  int w, h;
  initial_size(/*fit=*/true, &w, &h);
  window_ = glfwCreateWindow(w, h, ("penumbra view: " + scene_label()).c_str(), nullptr, nullptr);
  if (!window_)
    throw std::runtime_error("the display offers no OpenGL 3.3 core context (" + g_glfw_error + "); " + kRenderHint);
  glfwMakeContextCurrent(window_);
  glfwSwapInterval(0);  // no vsync: a progressive renderer converges as fast as it can, and fps is measured honestly
  // Our callbacks first: ImGui's GLFW backend chains to them.
  glfwSetWindowUserPointer(window_, this);
  glfwSetKeyCallback(window_, on_key);
  glfwSetScrollCallback(window_, on_scroll);
  init_gl_and_panel(glfwGetProcAddress);
}

// The window's (or the offscreen framebuffer's) size: --width and --height, one
// of them with the scene's aspect ratio, or neither: the scene's resolution,
// fitted into 1280x720 where `fit` (a window on a screen).
void Viewer::initial_size(bool fit, int* width, int* height) const {
  const int sw = scene_->render.width, sh = scene_->render.height;
  const double aspect = double(sw) / sh;
  int w = opt_.width, h = opt_.height;
  if (!w && !h && !fit) {
    w = sw, h = sh;
  } else if (!w && !h) {
    const double f = std::min({1.0, 1280.0 / sw, 720.0 / sh});
    w = std::max(16, int(std::lround(sw * f)));
    h = std::max(16, int(std::lround(sh * f)));
  } else if (!h) {
    h = std::max(16, int(std::lround(w / aspect)));
  } else if (!w) {
    w = std::max(16, int(std::lround(h * aspect)));
  }
  *width = w;
  *height = h;
}

// No window: an EGL context made current without a surface, and a framebuffer
// object of initial_size() to draw into (the scene's resolution unless given:
// there is no screen to fit).
void Viewer::open_headless() {
  try {
    headless_ = std::make_unique<HeadlessGl>();
  } catch (const std::exception& e) {
    throw std::runtime_error(e.what() + std::string("; ") + kRenderHint);
  }
  init_gl_and_panel(HeadlessGl::loader());
  int w, h;
  initial_size(/*fit=*/false, &w, &h);
  offscreen_ = std::make_unique<OffscreenFramebuffer>(w, h);
  offscreen_->bind();
  gl_info_ += " (headless: " + headless_->description() + ")";
}

// The OpenGL functions, the display texture and Dear ImGui, in the current context.
void Viewer::init_gl_and_panel(GlProcLoader loader) {
  std::string missing;
  if (!load_gl(loader, &missing)) throw std::runtime_error("the OpenGL context lacks " + missing + "; " + kRenderHint);
  if (gl_version_number() < 33)
    throw std::runtime_error("OpenGL 3.3 is needed, the display offers " + gl_version_string() + "; " + kRenderHint);
  gl_info_ = "OpenGL " + gl_version_string() + " on " + gl_renderer_string();
  display_ = std::make_unique<DisplayTexture>();

  IMGUI_CHECKVERSION();
  ImGui::CreateContext();
  imgui_ = true;
  ImGui::GetIO().IniFilename = nullptr;  // no imgui.ini left in the working directory
  ImGui::StyleColorsDark();
  ImGui::GetStyle().Alpha = 0.92f;
  if (window_) imgui_glfw_ = ImGui_ImplGlfw_InitForOpenGL(window_, true);
  imgui_gl3_ = (imgui_glfw_ || !window_) && ImGui_ImplOpenGL3_Init("#version 330 core");
  if (!imgui_gl3_) throw std::runtime_error("cannot initialise Dear ImGui's OpenGL 3 backend; " + std::string(kRenderHint));
}

void Viewer::framebuffer_size(int* width, int* height) const {
  if (offscreen_) {
    *width = offscreen_->width();
    *height = offscreen_->height();
  } else {
    glfwGetFramebufferSize(window_, width, height);
  }
}

// Interop where it works (the OptiX backend, its GL context on the NVIDIA GPU);
// else the host path, said in one line (stderr and the panel).
void Viewer::choose_display() {
  display_path_ = choose_display_path(opt_.display, backend_->name(), kInteropBuilt, [this] {
    std::string why;
    if (display_->enable_interop(&why)) return std::string();
    return why + "; the OpenGL context runs on " + gl_renderer_string() + ", and interop needs it on the NVIDIA GPU";
  });
  if (display_path_.path != DisplayPath::Interop) display_->disable_interop();
  std::fprintf(stderr, "view: %s\n", display_path_.note.c_str());
}

std::unique_ptr<ProgressiveImage> Viewer::make_image() {
#if PN_VIEWER_INTEROP
  if (display_path_.path == DisplayPath::Interop)
    if (auto* optix = dynamic_cast<OptixBackend*>(backend_.get())) return make_device_image(*optix);
#endif
  return make_host_image(*backend_);
}

Viewer::~Viewer() {
  scheduler_.clear();
  if (imgui_gl3_) ImGui_ImplOpenGL3_Shutdown();
  if (imgui_glfw_) ImGui_ImplGlfw_Shutdown();
  if (imgui_) ImGui::DestroyContext();
  display_.reset();  // needs the context
  offscreen_.reset();
  headless_.reset();
  if (window_) glfwDestroyWindow(window_);
  if (glfw_) glfwTerminate();
  backend_.reset();
}

std::string Viewer::scene_label() const { return scene_name_; }






















int Viewer::run() {
  open_window();  // here, not in the constructor: on failure the destructor closes what was opened
  Clock::time_point previous_start = Clock::now();
  Clock::time_point last_title = Clock::now();
  for (frame_ = 0;;) {
    const auto t0 = Clock::now();
    const double dt = std::chrono::duration<double>(t0 - previous_start).count();  // for fly speed
    previous_start = t0;
    if (window_) {
      glfwPollEvents();
      if (glfwWindowShouldClose(window_)) break;
    }
    int fw, fh;
    framebuffer_size(&fw, &fh);
    if (fw == 0 || fh == 0) {  // minimised: nothing to show, nothing to restart; sleep until restored
      glfwWaitEventsTimeout(0.1);
      continue;
    }
    // Scripted actions for this frame: after `frame_` frames have been rendered.
    for (; next_action_ < path_.size() && path_[next_action_].frame <= frame_; ++next_action_) {
      if (path_[next_action_].frame == frame_) apply(path_[next_action_]);
    }
    // The end: after `--frames` frames or a "quit". Window screenshots asked
    // for now get one more pass that only draws (no samples, no restart), so
    // they show the image after exactly this many frames.
    const bool last = quit_ || (opt_.frames > 0 && frame_ == uint64_t(opt_.frames));
    if (last && (pending_window_shots_.empty() || !scheduler_.started())) break;

    ImGui_ImplOpenGL3_NewFrame();
    if (window_) {
      ImGui_ImplGlfw_NewFrame();
    } else {  // what GLFW's backend would set; no input
      ImGuiIO& io = ImGui::GetIO();
      io.DisplaySize = ImVec2(float(fw), float(fh));
      io.DeltaTime = float(std::max(dt, 1e-6));
    }
    ImGui::NewFrame();
    if (!last && window_) handle_input(dt);
    if (panel_) draw_panel();
    if (!last) sync();
    if (screenshot_requested_) {  // before this frame's samples: what is on screen now
      screenshot_requested_ = false;
      screenshot_button();
    }
    const double render_ms = last ? 0.0 : render_samples();
    const auto td = Clock::now();
    // Interop: CUDA writes the mapped GL pixel buffer; host: the staging buffer, uploaded.
    const bool device = scheduler_.writes_device_pixels();
    const bool denoised = denoise_ && show_denoised();
    if (!denoised) {
      DisplayPixels px = device ? display_->map_device_pixels() : display_->host_pixels();
      scheduler_.tone_map(px, divider_, exposure_);
      if (device) display_->upload_mapped();
      else display_->upload();
    }
    const double display_ms = ms_since(td);

    display_->draw(fw, fh);
    draw_overlay();
    ImGui::Render();
    ImGui_ImplOpenGL3_RenderDrawData(ImGui::GetDrawData());
    for (const std::string& p : pending_window_shots_) window_screenshot(p);
    pending_window_shots_.clear();
    const auto tp = Clock::now();
    if (window_) glfwSwapBuffers(window_);
    else finish_gl();  // headless: the frame is displayed when the GPU has drawn it
    const double present_ms = ms_since(tp);
    if (last) break;

    last_frame_ms_ = ms_since(t0);
    last_render_ms_ = render_ms;
    frame_ms_.push_back(last_frame_ms_);
    render_ms_.push_back(render_ms);
    display_ms_.push_back(display_ms);
    if (denoised) denoise_frame_ms_.push_back(denoise_ms_);
    present_ms_.push_back(present_ms);
    recent_ms_.push_back(float(last_frame_ms_));
    if (recent_ms_.size() > 120) recent_ms_.erase(recent_ms_.begin());
    if (ms_since(last_title) > 500.0) {
      last_title = Clock::now();
      char title[256];
      std::snprintf(title, sizeof title, "penumbra view: %s  %llu spp  %.1f ms/frame", scene_label().c_str(),
                    (unsigned long long)scheduler_.sides()[0].image->samples(), last_frame_ms_);
      if (window_) glfwSetWindowTitle(window_, title);
    }
    ++frame_;
  }

  if (!opt_.screenshot.empty() && scheduler_.started()) screenshot(opt_.screenshot);
  if (opt_.frames > 0 && !frame_ms_.empty()) {
    const size_t n = frame_ms_.size();
    const double total = std::accumulate(frame_ms_.begin(), frame_ms_.end(), 0.0);
    const double render = std::accumulate(render_ms_.begin(), render_ms_.end(), 0.0) / n;
    const double display = std::accumulate(display_ms_.begin(), display_ms_.end(), 0.0) / n;
    const double present = std::accumulate(present_ms_.begin(), present_ms_.end(), 0.0) / n;
    std::vector<double> sorted = frame_ms_;
    std::sort(sorted.begin(), sorted.end());
    std::string spp;
    for (const Side& s : scheduler_.sides())
      spp += (spp.empty() ? "" : " | ") + std::string(strategy_name(s.strategy)) + " " + std::to_string(s.image->samples()) + " spp";
    std::fprintf(stderr,
                 "view: %zu frames of %dx%d (%s): %.2f ms/frame, %.1f fps as displayed (median %.2f ms; per frame: "
                 "render %.2f ms, tone-map + upload %.2f ms, UI %.2f ms, present %.2f ms; display: %s, %s backend%s)\n",
                 n, scheduler_.applied().width, scheduler_.applied().height, spp.c_str(), total / n, 1000.0 * n / total, sorted[n / 2],
                 render, display, total / n - render - display - present, present,
                 display_path_name(display_path_.path), backend_->name().c_str(),
                 offscreen_ ? ", headless" : "");
    if (!denoise_frame_ms_.empty()) {
      std::vector<double> d = denoise_frame_ms_;
      std::sort(d.begin(), d.end());
      std::fprintf(stderr, "view: denoised %zu frames: the denoiser %.2f ms a frame (median %.2f ms; inside tone-map + "
                   "upload; %s)\n", d.size(), std::accumulate(d.begin(), d.end(), 0.0) / d.size(), d[d.size() / 2],
                   denoiser_.c_str());
    }
  }
  std::fprintf(stderr, "view: the scene was loaded %d time%s, a backend made %d time%s\n", scene_loads_,
               scene_loads_ == 1 ? "" : "s", backend_builds_, backend_builds_ == 1 ? "" : "s");
  if (nonfinite_ > 0) {
    std::fprintf(stderr,
                 "warning: %s: %llu samples were NaN or infinite and left out while the viewer ran (exit status %d)\n",
                 scene_->source.c_str(), (unsigned long long)nonfinite_, int(kExitNonFinite));
    return kExitNonFinite;
  }
  return kExitOk;
}

int run_viewer(const ViewerOptions& options) {
  Viewer viewer(options);
  return viewer.run();
}

}  // namespace pn::viewer
