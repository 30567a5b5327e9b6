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
#include <imgui_stdlib.h>
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

using Clock = std::chrono::steady_clock;
double ms_since(Clock::time_point t) { return std::chrono::duration<double, std::milli>(Clock::now() - t).count(); }

const char* kRenderHint = "use `penumbra render` to render to a file instead";

// GLFW reports errors through a callback; keep the last one for our one-line message.
std::string g_glfw_error = "unknown error";
void on_glfw_error(int, const char* description) { g_glfw_error = description ? description : "unknown error"; }

bool same(Vec3 a, Vec3 b) { return a.x == b.x && a.y == b.y && a.z == b.z; }
bool same(const CameraDesc& a, const CameraDesc& b) {
  return same(a.eye, b.eye) && same(a.target, b.target) && same(a.up, b.up) && a.fov == b.fov;
}
bool same(const RestirSettings& a, const RestirSettings& b) {
  return a.candidates == b.candidates && a.spatial_passes == b.spatial_passes && a.neighbors == b.neighbors &&
         a.radius == b.radius && a.unbiased == b.unbiased && a.source == b.source && a.temporal == b.temporal &&
         a.temporal_cap == b.temporal_cap && a.pairwise == b.pairwise && a.visibility_reuse == b.visibility_reuse;
}
bool same(const IntegratorSettings& a, const IntegratorSettings& b) {
  return a.strategy == b.strategy && a.mis == b.mis && a.light_selection == b.light_selection &&
         same(a.restir, b.restir) && a.max_depth == b.max_depth && a.rr_depth == b.rr_depth;
}

// Everything that changes the rendered image (not exposure: that is display
// only). Compared every frame; any difference restarts the accumulation.
struct ImageSettings {
  CameraDesc camera;
  // The estimator; its strategy is the image's without split screen. restir's
  // settings are the scene's unless restir selects the lights (so that the
  // panel's restir controls restart nothing then).
  IntegratorSettings integrator;
  int width = 0, height = 0;
  bool split = false;  // the divider is not here: it only chooses which image each column shows
  Strategy left = Strategy::Area, right = Strategy::SolidAngle;
  bool equal_time = false;
  std::vector<std::string> scene_overrides;  // the light's edits, on top of the command line's

  bool operator==(const ImageSettings& o) const {
    return same(camera, o.camera) && same(integrator, o.integrator) && width == o.width && height == o.height &&
           split == o.split && left == o.left && right == o.right && equal_time == o.equal_time &&
           scene_overrides == o.scene_overrides;
  }
};

// The first light, when it is a sphere: the panel edits it through scene
// overrides (light.radius, light.center, light.power), so a change rebuilds the
// scene exactly as `--set` would.
struct LightEdit {
  bool sphere = false;
  float radius = 0.f;
  Vec3 center, power;
  static LightEdit of(const Scene& s) {
    LightEdit e;
    if (s.lights.empty() || s.lights[0].type != LightType::Sphere) return e;
    const Light& l = s.lights[0];
    e.sphere = true;
    e.radius = l.radius;
    e.center = l.p;
    e.power = l.radiance * (kPi * l.area);  // Phi = pi A L, the scene format's `power`
    return e;
  }
};

// A combo box over one of the registries' enums, listed by their names.
template <class E>
void enum_combo(const char* label, E* value, int count, const char* (*name)(E)) {
  struct Names {
    const char* (*name)(E);
  } names{name};
  int i = int(*value);
  if (ImGui::Combo(
          label, &i,
          [](void* data, int k, const char** out) {
            *out = static_cast<Names*>(data)->name(E(k));
            return true;
          },
          &names, count))
    *value = E(i);
}

// ImGui's widgets on the settings' own fields: a 0/1 flag, a count clamped to
// [lo, most] (typed values may leave the slider's range).
void flag_checkbox(const char* label, uint32_t* flag) {
  bool b = *flag != 0;
  if (ImGui::Checkbox(label, &b)) *flag = b ? 1u : 0u;
}
void count_slider(const char* label, uint32_t* count, int lo, int hi, int most, ImGuiSliderFlags flags = 0) {
  int v = int(*count);
  ImGui::SliderInt(label, &v, lo, hi, "%d", flags);
  *count = uint32_t(std::clamp(v, lo, most));
}

std::string num(float v) { return shortest_number(v).dump(); }
std::string vec(Vec3 v) { return "[" + num(v.x) + "," + num(v.y) + "," + num(v.z) + "]"; }

// One progressive image: the only one, or one side of the split screen. In
// the split screen each side renders the whole frame with its own strategy
// (the Backend interface renders whole frames) and shows the columns on its
// side of the divider: twice the work of one image, but the divider moves
// without restarting, and equal time compares the strategies' costs on the
// same pixels.
struct Side {
  std::unique_ptr<ProgressiveImage> image;
  Strategy strategy = Strategy::SolidAngle;
  double seconds = 0;  // render time since the restart
  double seconds_per_pixel() const {
    return image->width() ? seconds / (double(image->width()) * image->height()) : 0;
  }
};

class Viewer {
 public:
  explicit Viewer(const ViewerOptions& o);
  ~Viewer();
  int run();

 private:
  // Setup.
  void load(const std::vector<std::string>& extra_overrides);
  void open_window();
  void open_glfw_window();
  void open_headless();
  void init_gl_and_panel(GlProcLoader loader);
  void framebuffer_size(int* width, int* height) const;
  void choose_display();
  std::unique_ptr<ProgressiveImage> make_image();
  // Per frame.
  void handle_input(double dt_seconds);
  void draw_panel();
  void draw_overlay();
  void sync();
  double render_samples();
  void apply(const PathAction& a);
  // Helpers.
  ImageSettings wanted() const;
  int divider_column() const;  // first column of the right side
  void restart(const ImageSettings& s);
  std::vector<float> composed_mean() const;
  bool show_denoised();
  std::string screenshot_stem() const;
  void screenshot(const std::string& path);
  void screenshot_button();
  void window_screenshot(const std::string& path);
  void set_strategy_key(int index, bool right_side);
  void press(const std::string& key);  // a key of viewer_keys() (camera_path.h), from the window or a script
  void save_camera_file(const std::string& path);
  void load_camera_file(const std::string& path);
  std::string scene_label() const;

  static void on_key(GLFWwindow* w, int key, int scancode, int action, int mods);
  static void on_scroll(GLFWwindow* w, double dx, double dy);

  ViewerOptions opt_;
  std::string scene_name_;
  std::unique_ptr<Scene> scene_;
  std::unique_ptr<Backend> backend_;  // refers to *scene_: destroyed first
  std::vector<Side> sides_;

  // Window and GL (headless: the EGL context and its framebuffer instead of the window).
  GLFWwindow* window_ = nullptr;
  std::unique_ptr<HeadlessGl> headless_;
  std::unique_ptr<OffscreenFramebuffer> offscreen_;
  bool glfw_ = false, imgui_ = false, imgui_glfw_ = false, imgui_gl3_ = false;  // what to shut down
  std::unique_ptr<DisplayTexture> display_;
  std::string gl_info_;
  std::string backend_note_;
  DisplayChoice display_path_;  // host upload or CUDA-OpenGL interop (progressive.h)

  // What the user controls.
  CameraControl camera_;
  IntegratorSettings integrator_;  // the estimator as the panel, keys and scripts set it; from the scene's
  int spp_per_frame_ = 1;
  float exposure_ = 0.f;
  float scale_ = 1.f;
  LightEdit light_, light_applied_, light_initial_;
  bool split_ = false, equal_time_ = false;
  Strategy left_ = Strategy::Area, right_ = Strategy::SolidAngle;
  float divider_ = 0.5f;  // fraction of the width
  bool panel_ = true;
  bool fly_ = false;
  // Denoise toggle (N, the panel): the screen shows the composed image denoised
  // by Intel Open Image Denoise, with guides rendered once per restart.
  bool denoise_ = false;
  double denoise_ms_ = 0;  // the last frame's denoiser time (host clock around the filter)
  std::string denoiser_;   // which denoiser ran, on which device
  FrameSpec guide_frame_;
  GuideImages guides_;
  float fly_speed_ = 1.f;  // scene units per second
  std::string camera_file_;
  std::string status_;  // last message in the panel

  // Input state.
  enum class Drag { None, Orbit, Pan, Look, Divider } drag_ = Drag::None;
  double last_x_ = 0, last_y_ = 0;
  double scroll_ = 0;
  bool screenshot_requested_ = false;

  // Progress and timing.
  ImageSettings applied_;
  bool started_ = false;
  uint64_t frame_ = 0;
  Clock::time_point restart_time_;
  std::vector<float> recent_ms_;  // the last frames' times, oldest first, for the graph
  double last_frame_ms_ = 0, last_render_ms_ = 0;
  std::vector<double> frame_ms_, render_ms_, display_ms_, present_ms_;  // every frame, for --frames
  std::vector<PathAction> path_;
  size_t next_action_ = 0;
  bool quit_ = false;
  std::vector<std::string> pending_window_shots_;
  uint64_t nonfinite_ = 0;  // samples left out by the backend, while the viewer runs
};

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
  load({});
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

// (Re)loads the scene with the command line's overrides plus `extra`, and makes
// a backend for it. On failure the previous scene and backend stay.
void Viewer::load(const std::vector<std::string>& extra) {
  std::vector<std::string> overrides = opt_.sets;
  overrides.insert(overrides.end(), extra.begin(), extra.end());
  auto scene = std::make_unique<Scene>(load_scene(opt_.scene, overrides));
  const BackendOptions& bo = opt_.backend_options;
  std::string note;
  std::unique_ptr<Backend> backend = make_backend(opt_.backend, *scene, bo, &note);
  if (!backend_) backend_note_ = note;  // printed once the window is open: a failure to open stays one line
  sides_.clear();
  backend_.reset();
  scene_ = std::move(scene);
  backend_ = std::move(backend);
  started_ = false;  // the images refer to the old backend: make new ones
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
  int w = opt_.width, h = opt_.height;
  const double aspect = double(scene_->render.width) / scene_->render.height;
  if (!w && !h) {
    double f = std::min({1.0, 1280.0 / scene_->render.width, 720.0 / scene_->render.height});
    w = std::max(16, int(std::lround(scene_->render.width * f)));
    h = std::max(16, int(std::lround(scene_->render.height * f)));
  } else if (!h) {
    h = std::max(16, int(std::lround(w / aspect)));
  } else if (!w) {
    w = std::max(16, int(std::lround(h * aspect)));
  }
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

// No window: an EGL context made current without a surface, and a framebuffer
// object of the window's size to draw into. The size is the scene's unless
// given (there is no screen to fit).
void Viewer::open_headless() {
  try {
    headless_ = std::make_unique<HeadlessGl>();
  } catch (const std::exception& e) {
    throw std::runtime_error(e.what() + std::string("; ") + kRenderHint);
  }
  init_gl_and_panel(HeadlessGl::loader());
  const double aspect = double(scene_->render.width) / scene_->render.height;
  int w = opt_.width, h = opt_.height;
  if (!w && !h) w = scene_->render.width, h = scene_->render.height;
  else if (!h) h = std::max(16, int(std::lround(w / aspect)));
  else if (!w) w = std::max(16, int(std::lround(h * aspect)));
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
  sides_.clear();
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

ImageSettings Viewer::wanted() const {
  ImageSettings s;
  s.camera = camera_.desc();
  s.integrator = integrator_;
  RestirSettings& r = s.integrator.restir;
  if (integrator_.light_selection != LightSelection::Restir) r = scene_->render.integrator.restir;
  if (!r.unbiased) r.pairwise = 0;  // pairwise MIS is for the unbiased combination only
  int fw = 0, fh = 0;
  framebuffer_size(&fw, &fh);
  s.width = std::max(1, int(std::lround(fw * scale_)));
  s.height = std::max(1, int(std::lround(fh * scale_)));
  s.split = split_ && s.width >= 2;
  if (s.split) {
    s.left = left_;
    s.right = right_;
    s.equal_time = equal_time_;
  }
  if (light_.sphere) {
    if (light_.radius != light_initial_.radius) s.scene_overrides.push_back("light.radius=" + num(light_.radius));
    if (!same(light_.center, light_initial_.center)) s.scene_overrides.push_back("light.center=" + vec(light_.center));
    if (!same(light_.power, light_initial_.power)) s.scene_overrides.push_back("light.power=" + vec(light_.power));
  }
  return s;
}

int Viewer::divider_column() const {
  return applied_.split ? std::clamp(int(std::lround(divider_ * applied_.width)), 0, applied_.width) : applied_.width;
}

// Brings the images in line with the controls; restarts them when the image changes.
void Viewer::sync() {
  ImageSettings want = wanted();
  if (started_ && want == applied_) return;
  if (want.scene_overrides != applied_.scene_overrides) {
    try {
      // A light change rebuilds the scene and the backend (for OptiX: pipeline,
      // acceleration structures): see docs/viewer.md, "Light edits".
      const auto t0 = Clock::now();
      load(want.scene_overrides);
      std::fprintf(stderr, "view: light changed: scene and %s backend rebuilt in %.0f ms\n", backend_->name().c_str(),
                   ms_since(t0));
      light_applied_ = light_;
    } catch (const std::exception& e) {  // e.g. a light moved into a wall's plane: keep the last good scene
      status_ = e.what();
      light_ = light_applied_;
      want = wanted();
      if (want.scene_overrides != applied_.scene_overrides) load(want.scene_overrides);
    }
  }
  restart(want);
}

void Viewer::restart(const ImageSettings& s) {
  applied_ = s;
  started_ = true;
  restart_time_ = Clock::now();
  FrameSpec base = frame_spec(*scene_);
  const CameraDesc& c = s.camera;
  base.camera = Camera::look_at(c.eye, c.target, c.up, c.fov, s.width, s.height);
  base.integrator = s.integrator;
  try {
    display_->resize(s.width, s.height);
  } catch (const std::exception& e) {  // registering the new size's pixel buffer with CUDA failed
    if (!display_->interop() || opt_.display == "interop") throw;
    display_->disable_interop();
    display_->resize(s.width, s.height);
    display_path_ = {DisplayPath::HostUpload, std::string("display: CUDA-OpenGL interop failed at ") +
                                                  std::to_string(s.width) + "x" + std::to_string(s.height) + " (" +
                                                  e.what() + "): falling back to host upload"};
    std::fprintf(stderr, "view: %s\n", display_path_.note.c_str());
  }

  // The images of the last restart are reused (same backend: load() clears
  // them): a device image keeps its GPU buffers while the camera moves.
  std::vector<std::unique_ptr<ProgressiveImage>> spare;
  for (Side& old : sides_) spare.push_back(std::move(old.image));
  const bool device = display_path_.path == DisplayPath::Interop;
  auto make_side = [&](Strategy strategy, uint32_t seed) {
    Side side;
    if (!spare.empty() && spare.front() && spare.front()->writes_device_pixels() == device) {
      side.image = std::move(spare.front());
      spare.erase(spare.begin());
    } else {
      side.image = make_image();
    }
    side.strategy = strategy;
    FrameSpec f = base;
    f.integrator.strategy = strategy;
    f.seed = seed;
    side.image->restart(f);
    return side;
  };
  guide_frame_ = base;
  guides_ = GuideImages();  // rendered again when next shown denoised
  sides_.clear();
  if (!s.split) {
    sides_.push_back(make_side(s.integrator.strategy, base.seed));
  } else {
    // The right side gets its own seed, so that the two sides' errors are
    // independent (and equal strategies show a seam: they are two estimates).
    sides_.push_back(make_side(s.left, base.seed));
    sides_.push_back(make_side(s.right, base.seed + 1));
  }
}

// Adds this frame's samples; returns the render time in ms.
double Viewer::render_samples() {
  auto t0 = Clock::now();
  const uint32_t spp = uint32_t(spp_per_frame_);
  std::vector<uint32_t> n(sides_.size(), spp);
  bool measured = std::all_of(sides_.begin(), sides_.end(), [](const Side& s) { return s.image->samples() > 0; });
  if (applied_.split && applied_.equal_time && measured) {
    // Equal time: both images get the same render time. The one that is ahead
    // adds `spp`; the other catches up at its own measured cost per sample
    // (feedback on the totals, so one frame's timing noise is corrected by the
    // next). Both render the same pixels, so the costs compare the strategies.
    double target = 0;
    std::vector<double> tpp(sides_.size()), cost(sides_.size());
    for (size_t i = 0; i < sides_.size(); ++i) {
      tpp[i] = sides_[i].seconds_per_pixel();
      cost[i] = tpp[i] / double(sides_[i].image->samples());
      target = std::max(target, tpp[i] + spp * cost[i]);
    }
    for (size_t i = 0; i < sides_.size(); ++i)
      n[i] = cost[i] > 0 ? uint32_t(std::clamp(std::lround((target - tpp[i]) / cost[i]), 0l, 64l * spp)) : spp;
  }
  for (size_t i = 0; i < sides_.size(); ++i) {
    auto ts = Clock::now();
    try {
      sides_[i].image->add_samples(n[i]);
    } catch (const std::invalid_argument& e) {  // settings this backend cannot render (restir's reuse on --megakernel)
      status_ = e.what();
      continue;
    }
    sides_[i].seconds += ms_since(ts) * 1e-3;
    // Samples that were NaN or infinite: left out by the backend; said once, and in the exit status.
    const RenderStats st = backend_->last_render_stats();
    if (st.nonfinite > 0 && nonfinite_ == 0) {
      std::fprintf(stderr, "warning: %s: %s\n", scene_->source.c_str(), describe_nonfinite(st).c_str());
      status_ = describe_nonfinite(st);
    }
    nonfinite_ += st.nonfinite;
  }
  return ms_since(t0);
}

std::vector<float> Viewer::composed_mean() const {
  if (sides_.size() == 1) return sides_[0].image->mean();
  const int W = applied_.width, H = applied_.height, d = divider_column();
  std::vector<float> out = sides_[0].image->mean(), right = sides_[1].image->mean();
  for (int y = 0; y < H; ++y)
    std::copy_n(right.data() + (size_t(y) * W + d) * 3, size_t(W - d) * 3, out.data() + (size_t(y) * W + d) * 3);
  return out;
}

// Settings in the file name: scene, strategies and their spp, depth, light radius, size, exposure.
std::string Viewer::screenshot_stem() const {
  char buf[256];
  std::string stem = scene_name_ + "_";
  if (sides_.size() == 1) {
    stem += std::string(strategy_name(sides_[0].strategy)) + "_" + std::to_string(sides_[0].image->samples()) + "spp";
  } else {
    stem += std::string(strategy_name(sides_[0].strategy)) + "-" + std::to_string(sides_[0].image->samples()) +
            "spp_vs_" + strategy_name(sides_[1].strategy) + "-" + std::to_string(sides_[1].image->samples()) + "spp";
    stem += applied_.equal_time ? "_equal-time" : "_equal-spp";
  }
  std::snprintf(buf, sizeof buf, "_d%d", applied_.integrator.max_depth);
  stem += buf;
  if (light_applied_.sphere) {
    std::snprintf(buf, sizeof buf, "_r%g", double(light_applied_.radius));
    stem += buf;
  }
  std::snprintf(buf, sizeof buf, "_%dx%d", applied_.width, applied_.height);
  stem += buf;
  if (exposure_ != 0.f) {
    std::snprintf(buf, sizeof buf, "_e%+g", double(exposure_));
    stem += buf;
  }
  return stem;
}

void Viewer::screenshot(const std::string& path) {
  write_image(path, applied_.width, applied_.height, composed_mean(), exposure_);
  std::fprintf(stderr, "wrote %s\n", path.c_str());
}

// The panel's button (and P): PNG and EXR side by side, never overwriting.
void Viewer::screenshot_button() {
  if (!started_) return;
  namespace fs = std::filesystem;
  std::string stem = screenshot_stem(), base = stem;
  for (int k = 2; fs::exists(base + ".png") || fs::exists(base + ".exr"); ++k) base = stem + "_" + std::to_string(k);
  try {
    screenshot(base + ".png");
    screenshot(base + ".exr");
    status_ = "wrote " + base + ".png and .exr";
  } catch (const std::exception& e) {
    status_ = e.what();
  }
}

void Viewer::window_screenshot(const std::string& path) {
  int fw, fh;
  framebuffer_size(&fw, &fh);
  std::vector<unsigned char> px = read_framebuffer_rgb(fw, fh, offscreen_ != nullptr);
  const std::vector<uint8_t> png = encode_png(path, fw, fh, 3, px.data());
  write_file_atomic(path, png.data(), png.size());
  std::fprintf(stderr, "wrote %s (the %s, %dx%d)\n", path.c_str(), offscreen_ ? "offscreen framebuffer" : "window", fw,
               fh);
}

void Viewer::save_camera_file(const std::string& path) {
  // A new file is the whole scene as the viewer shows it: the command line's
  // and the panel's overrides, the strategy and depth, and this camera.
  std::vector<std::string> overrides = opt_.sets;
  overrides.insert(overrides.end(), applied_.scene_overrides.begin(), applied_.scene_overrides.end());
  const IntegratorSettings& in = integrator_;
  const RestirSettings& r = in.restir;
  overrides.push_back("render.strategy=\"" + std::string(strategy_name(in.strategy)) + "\"");
  overrides.push_back("render.mis=\"" + std::string(mis_name(in.mis)) + "\"");
  overrides.push_back("render.light_selection=\"" + std::string(light_selection_name(in.light_selection)) + "\"");
  overrides.push_back(std::string("render.restir.temporal=") + (r.temporal ? "true" : "false"));
  if (r.unbiased)  // pairwise MIS is for the unbiased combination only
    overrides.push_back(std::string("render.restir.pairwise=") + (r.pairwise ? "true" : "false"));
  overrides.push_back(std::string("render.restir.visibility_reuse=") + (r.visibility_reuse ? "true" : "false"));
  overrides.push_back(std::string("render.restir.source=\"") + light_selection_name(r.source) + "\"");
  overrides.push_back("render.restir.candidates=" + std::to_string(r.candidates));
  overrides.push_back("render.restir.spatial_passes=" + std::to_string(r.spatial_passes));
  overrides.push_back("render.max_depth=" + std::to_string(in.max_depth));
  std::string source;
  nlohmann::json doc = load_scene_json(opt_.scene, overrides, &source);
  save_camera(path, camera_.desc(), doc);
  status_ = "saved the camera to " + path;
  std::fprintf(stderr, "%s\n", status_.c_str());
}

void Viewer::load_camera_file(const std::string& path) {
  camera_.set(load_camera(path));
  status_ = "loaded the camera of " + path;
}

void Viewer::set_strategy_key(int index, bool right_side) {
  if (index < 0 || index >= kNumStrategies) return;
  Strategy s = Strategy(index);
  if (!split_) integrator_.strategy = s;
  else (right_side ? right_ : left_) = s;
}

void Viewer::press(const std::string& key) {
  const bool shift = key.rfind("shift+", 0) == 0;
  const std::string k = shift ? key.substr(6) : key;
  if (k.size() == 1 && k[0] >= '1' && k[0] <= '9') set_strategy_key(k[0] - '1', shift);
  else if (k == "R") camera_.reset();
  else if (k == "F") fly_ = !fly_;
  else if (k == "P") screenshot_requested_ = true;
  else if (k == "N") denoise_ = !denoise_;
  else if (k == "Tab") panel_ = !panel_;
}

// The window's keys, by their names in viewer_keys(), unless the panel is typing or has the keyboard (Tab always
// reaches the viewer but while typing).
void Viewer::on_key(GLFWwindow* w, int key, int, int action, int mods) {
  auto* v = static_cast<Viewer*>(glfwGetWindowUserPointer(w));
  if (action != GLFW_PRESS || !v->imgui_) return;
  const ImGuiIO& io = ImGui::GetIO();
  if (io.WantTextInput) return;  // typing a file name
  if (key == GLFW_KEY_TAB) return v->press("Tab");
  if (io.WantCaptureKeyboard) return;
  std::string name;
  if (key >= GLFW_KEY_1 && key <= GLFW_KEY_9) name = std::string(1, char('1' + (key - GLFW_KEY_1)));
  else if (key == GLFW_KEY_R) name = "R";
  else if (key == GLFW_KEY_F) name = "F";
  else if (key == GLFW_KEY_P) name = "P";
  else if (key == GLFW_KEY_N) name = "N";
  else return;
  if (mods & GLFW_MOD_SHIFT && name.size() == 1 && name[0] >= '1' && name[0] <= '9') name = "shift+" + name;
  v->press(name);
}

void Viewer::on_scroll(GLFWwindow* w, double, double dy) {
  auto* v = static_cast<Viewer*>(glfwGetWindowUserPointer(w));
  if (v->imgui_ && ImGui::GetIO().WantCaptureMouse) return;
  v->scroll_ += dy;
}

void Viewer::handle_input(double dt) {
  const ImGuiIO& io = ImGui::GetIO();
  int ww, wh;
  glfwGetWindowSize(window_, &ww, &wh);
  double x, y;
  glfwGetCursorPos(window_, &x, &y);
  const double dx = x - last_x_, dy = y - last_y_;
  last_x_ = x;
  last_y_ = y;
  const bool left = glfwGetMouseButton(window_, GLFW_MOUSE_BUTTON_LEFT) == GLFW_PRESS;
  const bool middle = glfwGetMouseButton(window_, GLFW_MOUSE_BUTTON_MIDDLE) == GLFW_PRESS;
  const bool shift = glfwGetKey(window_, GLFW_KEY_LEFT_SHIFT) == GLFW_PRESS ||
                     glfwGetKey(window_, GLFW_KEY_RIGHT_SHIFT) == GLFW_PRESS;

  // A drag starts outside the panel and lasts until its button is released.
  if (!left && !middle) drag_ = Drag::None;
  bool starting = false;
  if (drag_ == Drag::None && (left || middle) && !io.WantCaptureMouse) {
    double divider_x = applied_.split ? double(divider_column()) / applied_.width * ww : -1e9;
    if (left && !shift && std::abs(x - divider_x) <= 6.0) drag_ = Drag::Divider;
    else if (middle || shift) drag_ = Drag::Pan;
    else drag_ = fly_ ? Drag::Look : Drag::Orbit;
    starting = true;  // the cursor may have travelled far since the last (slow) frame: no jump
  }
  const float deg_per_pixel = 0.3f;
  switch (starting ? Drag::None : drag_) {
    case Drag::Orbit:  // the scene follows the cursor
      if (dx || dy) camera_.orbit(-float(dx) * deg_per_pixel, float(dy) * deg_per_pixel);
      break;
    case Drag::Look:
      if (dx || dy) camera_.look(float(dx) * deg_per_pixel * 0.5f, -float(dy) * deg_per_pixel * 0.5f);
      break;
    case Drag::Pan:
      if (dx || dy) camera_.pan(float(dx / wh), float(dy / wh));
      break;
    case Drag::Divider:
      divider_ = float(std::clamp(x / std::max(ww, 1), 0.0, 1.0));
      break;
    case Drag::None:
      break;
  }
  if (scroll_ != 0) {
    if (fly_) fly_speed_ *= float(std::pow(1.25, scroll_));
    else camera_.dolly(float(std::pow(0.85, scroll_)));  // wheel up: closer
    scroll_ = 0;
  }
  if (fly_ && !io.WantCaptureKeyboard) {
    auto down = [&](int k) { return glfwGetKey(window_, k) == GLFW_PRESS ? 1.f : 0.f; };
    float step = fly_speed_ * float(std::min(dt, 0.1)) * (shift ? 4.f : 1.f);  // a slow frame never jumps far
    float r = down(GLFW_KEY_D) - down(GLFW_KEY_A), u = down(GLFW_KEY_E) - down(GLFW_KEY_Q),
          f = down(GLFW_KEY_W) - down(GLFW_KEY_S);
    if (r || u || f) camera_.move(r * step, u * step, f * step);
  }
}

void Viewer::draw_panel() {
  ImGui::SetNextWindowPos(ImVec2(8, 8), ImGuiCond_FirstUseEver);
  ImGui::SetNextWindowSize(ImVec2(330, 0), ImGuiCond_FirstUseEver);
  if (!ImGui::Begin("penumbra (Tab hides)")) {
    ImGui::End();
    return;
  }
  ImGui::Text("%s", scene_->source.c_str());
  ImGui::TextWrapped("%s: %s", backend_->name().c_str(), backend_->device_name().c_str());
  ImGui::Text("image %dx%d, display: %s", applied_.width, applied_.height, display_path_name(display_path_.path));
  if (display_path_.path != DisplayPath::Interop && backend_->name() == "optix")
    ImGui::TextWrapped("%s", display_path_.note.c_str());  // why not interop

  // Timing: ms/frame and fps as displayed, with a rolling graph.
  double avg = recent_ms_.empty() ? 0.0
                                  : std::accumulate(recent_ms_.begin(), recent_ms_.end(), 0.0) / recent_ms_.size();
  char overlay[64];
  std::snprintf(overlay, sizeof overlay, "%.1f ms/frame  %.1f fps", avg, avg > 0 ? 1000.0 / avg : 0.0);
  ImGui::PlotLines("##frame", recent_ms_.data(), int(recent_ms_.size()), 0, overlay, 0.f,
                   float(std::max(1.0, 2.0 * avg)), ImVec2(ImGui::GetContentRegionAvail().x, 48));
  ImGui::Text("render %.1f ms/frame, %.1f s since restart", last_render_ms_,
              std::chrono::duration<double>(Clock::now() - restart_time_).count());
  for (const Side& s : sides_)
    ImGui::Text("%s%-11s %5llu spp %6.3g us/px", sides_.size() > 1 ? (&s == &sides_[0] ? "left  " : "right ") : "",
                strategy_name(s.strategy), (unsigned long long)s.image->samples(), s.seconds_per_pixel() * 1e6);

  auto strategy_combo = [](const char* label, Strategy* s) {
    int i = int(*s);
    bool changed = ImGui::Combo(
        label, &i,
        [](void*, int k, const char** out) {
          static char names[kNumStrategies][32];
          std::snprintf(names[k], sizeof names[k], "%d: %s", k + 1, strategy_name(Strategy(k)));
          *out = names[k];
          return true;
        },
        nullptr, kNumStrategies);
    if (changed) *s = Strategy(i);
  };
  ImGui::Separator();
  IntegratorSettings& in = integrator_;
  if (!split_) strategy_combo("strategy", &in.strategy);
  enum_combo("MIS", &in.mis, kNumMisModes, mis_name);
  // How the light of each sample is chosen (restir with the scene's
  // render.restir settings; temporal reuse between frames as the panel says).
  enum_combo("light selection", &in.light_selection, kNumLightSelections, light_selection_name);
  if (in.light_selection == LightSelection::Restir) {
    RestirSettings& r = in.restir;
    flag_checkbox("temporal reuse", &r.temporal);
    if (r.unbiased) flag_checkbox("pairwise MIS", &r.pairwise);
    // Off: unshadowed targets in the reuse, one shadow ray when shading (the study's restir-unshadowed).
    flag_checkbox("visibility reuse", &r.visibility_reuse);
    // ris-bvh of the study: BVH candidates, no spatial pass, no temporal reuse.
    bool bvh = r.source == LightSelection::Bvh;
    if (ImGui::Checkbox("BVH candidates", &bvh)) r.source = bvh ? LightSelection::Bvh : LightSelection::Power;
    count_slider("candidates", &r.candidates, 1, 256, int(kMaxRestirCandidates), ImGuiSliderFlags_Logarithmic);
    count_slider("spatial passes", &r.spatial_passes, 0, 4, int(kMaxRestirPasses));
    ImGui::TextDisabled("%s", light_selection_label(in.light_selection, r).c_str());
  }
  ImGui::TextDisabled("%zu lights", scene_->lights.size());
  ImGui::SliderInt("spp / frame", &spp_per_frame_, 1, 256, "%d", ImGuiSliderFlags_Logarithmic);
  ImGui::SliderInt("max depth", &in.max_depth, 0, 32);
  ImGui::SliderFloat("exposure", &exposure_, -8.f, 8.f, "%+.1f stops");
  ImGui::SliderFloat("resolution", &scale_, 0.05f, 2.f, "x %.2f", ImGuiSliderFlags_Logarithmic);
  ImGui::Checkbox("denoise (N)", &denoise_);
  ImGui::SameLine();
  if (denoise_ && !denoiser_.empty())
    ImGui::TextDisabled("%s: %.1f ms a frame", denoiser_.c_str(), denoise_ms_);
  else
    ImGui::TextDisabled("Intel Open Image Denoise, albedo + normal guides");

  if (ImGui::CollapsingHeader("Split screen", ImGuiTreeNodeFlags_DefaultOpen)) {
    ImGui::Checkbox("split", &split_);
    ImGui::SameLine();
    ImGui::Checkbox("equal time", &equal_time_);
    if (split_) {
      strategy_combo("left", &left_);
      strategy_combo("right", &right_);
      ImGui::TextDisabled("keys 1-4: left side, shift+1-4: right side");
      ImGui::SliderFloat("divider", &divider_, 0.f, 1.f, "%.2f");
    }
  }
  if (ImGui::CollapsingHeader("Light", ImGuiTreeNodeFlags_DefaultOpen)) {
    if (!light_.sphere) {
      ImGui::TextDisabled("the first light is not a sphere");
    } else {
      ImGui::DragFloat("radius", &light_.radius, 0.002f * std::max(1.f, light_initial_.radius * 4), 1e-3f, 1e3f, "%.4g",
                       ImGuiSliderFlags_Logarithmic);
      light_.radius = std::max(light_.radius, 1e-4f);
      float c[3] = {light_.center.x, light_.center.y, light_.center.z};
      if (ImGui::DragFloat3("centre", c, 0.01f * std::max(1.f, camera_.distance() * 0.2f))) light_.center = {c[0], c[1], c[2]};
      float p[3] = {light_.power.x, light_.power.y, light_.power.z};
      if (ImGui::DragFloat3("power", p, 0.5f, 0.f, 1e9f)) light_.power = {std::max(p[0], 0.f), std::max(p[1], 0.f), std::max(p[2], 0.f)};
      if (ImGui::Button("reset light")) light_ = light_initial_;
    }
  }
  if (ImGui::CollapsingHeader("Camera")) {
    float fov = camera_.desc().fov;
    if (ImGui::SliderFloat("fov", &fov, 5.f, 120.f, "%.1f deg")) camera_.set_fov(fov);
    ImGui::Checkbox("fly (F)", &fly_);
    ImGui::SameLine();
    ImGui::SetNextItemWidth(120);
    ImGui::DragFloat("speed", &fly_speed_, fly_speed_ * 0.01f, 1e-4f, 1e6f, "%.3g/s", ImGuiSliderFlags_Logarithmic);
    if (ImGui::Button("reset (R)")) camera_.reset();
    ImGui::InputText("file", &camera_file_);
    if (ImGui::Button("save camera")) {
      try {
        save_camera_file(camera_file_);
      } catch (const std::exception& e) {
        status_ = e.what();
      }
    }
    ImGui::SameLine();
    if (ImGui::Button("load camera")) {
      try {
        load_camera_file(camera_file_);
      } catch (const std::exception& e) {
        status_ = e.what();
      }
    }
  }
  ImGui::Separator();
  if (ImGui::Button("screenshot (P)")) screenshot_requested_ = true;
  ImGui::SameLine();
  ImGui::TextDisabled("PNG + EXR");
  if (!status_.empty()) ImGui::TextWrapped("%s", status_.c_str());
  if (ImGui::CollapsingHeader("Controls")) {
    ImGui::TextWrapped(
        "left drag: orbit (fly: look)   middle or shift+left drag: pan   wheel: dolly (fly: speed)   "
        "F: fly mode, WASD/QE to move, shift: faster   R: reset camera   1-4: strategy (split: left; "
        "shift: right)   drag the divider   P: screenshot   Tab: panel");
  }
  ImGui::TextDisabled("%s", gl_info_.c_str());
  ImGui::End();
}

// The divider and the strategy of each side, drawn over the image (not part of screenshots of the image).
void Viewer::draw_overlay() {
  if (sides_.size() < 2) return;
  ImDrawList* dl = ImGui::GetBackgroundDrawList();
  const ImVec2 size = ImGui::GetIO().DisplaySize;
  const float x = float(divider_column()) / applied_.width * size.x;
  dl->AddLine(ImVec2(x, 0), ImVec2(x, size.y), IM_COL32(255, 255, 255, 200), 1.5f);
  for (const Side& s : sides_) {
    char label[64];
    std::snprintf(label, sizeof label, "%s  %llu spp", strategy_name(s.strategy), (unsigned long long)s.image->samples());
    ImVec2 ts = ImGui::CalcTextSize(label);
    float lx = &s == &sides_[0] ? x - ts.x - 8 : x + 8;
    float ly = size.y - ts.y - 6;
    dl->AddRectFilled(ImVec2(lx - 3, ly - 2), ImVec2(lx + ts.x + 3, ly + ts.y + 2), IM_COL32(0, 0, 0, 150));
    dl->AddText(ImVec2(lx, ly), IM_COL32(255, 255, 255, 255), label);
  }
}

// The denoise toggle: this frame's composed image, denoised, tone-mapped on the
// host and uploaded (the host path also under interop: the denoiser's output is
// a host image). False, and the toggle off with a status line, where it cannot
// run (Intel Open Image Denoise not installed: one line saying how to get it).
bool Viewer::show_denoised() {
  try {
    // Intel Open Image Denoise (backends/denoise.h), its library found once (apps/options.h).
    static const DenoiseOptions options = denoise_options(DenoiseArgs{});
    check_denoise_backend("denoise", *backend_, options);
    if (guides_.width != applied_.width || guides_.height != applied_.height)
      guides_ = backend_->render_guides(guide_frame_, kGuideSamples);
    const std::vector<float> rgb =
        denoise_image(*backend_, composed_mean(), guides_, options, &denoise_ms_, &denoiser_);
    const DisplayPixels px = display_->host_pixels();
    const float gain = std::exp2(exposure_);
    for (int y = 0; y < px.height; ++y) {
      unsigned char* row = px.data + size_t(y) * px.row_bytes;
      for (int x = 0; x < px.width; ++x) {
        const float* p = rgb.data() + (size_t(y) * px.width + x) * 3;
        for (int c = 0; c < 3; ++c) row[4 * x + c] = to_srgb8(p[c] * gain);
        row[4 * x + 3] = 255;
      }
    }
    display_->upload();
    return true;
  } catch (const std::exception& e) {
    status_ = e.what();
    std::fprintf(stderr, "view: %s\n", e.what());
    denoise_ = false;
    return false;
  }
}

void Viewer::apply(const PathAction& a) {
  const auto& v = a.value;
  auto f = [&](size_t i) { return v[i].get<float>(); };
  auto v3 = [&]() { return v.is_array() ? Vec3(f(0), f(1), f(2)) : Vec3(v.get<float>()); };
  auto strategy = [&]() { return parse_strategy(v.get<std::string>(), a.where); };
  const std::string& k = a.key;
  if (k == "orbit") camera_.orbit(f(0), f(1));
  else if (k == "look") camera_.look(f(0), f(1));
  else if (k == "pan") camera_.pan(f(0), f(1));
  else if (k == "dolly") camera_.dolly(v.get<float>());
  else if (k == "move") camera_.move(f(0), f(1), f(2));
  else if (k == "camera") camera_.set(parse_scene(nlohmann::json{{"camera", v}}, a.where, ".").camera);
  else if (k == "reset") camera_.reset();
  else if (k == "fov") camera_.set_fov(v.get<float>());
  else if (k == "fly") fly_ = v.get<bool>();
  else if (k == "fly_speed") fly_speed_ = v.get<float>();
  else if (k == "strategy") integrator_.strategy = strategy();
  else if (k == "mis") integrator_.mis = parse_mis(v.get<std::string>(), a.where);
  else if (k == "light_selection") integrator_.light_selection = parse_light_selection(v.get<std::string>(), a.where);
  else if (k == "restir_temporal") integrator_.restir.temporal = v.get<bool>();
  else if (k == "restir_pairwise") integrator_.restir.pairwise = v.get<bool>();
  else if (k == "restir_bvh_candidates")
    integrator_.restir.source = v.get<bool>() ? LightSelection::Bvh : LightSelection::Power;
  else if (k == "restir_visibility_reuse") integrator_.restir.visibility_reuse = v.get<bool>();
  else if (k == "restir_candidates") integrator_.restir.candidates = v.get<uint32_t>();
  else if (k == "restir_spatial") integrator_.restir.spatial_passes = v.get<uint32_t>();
  else if (k == "spp_per_frame") spp_per_frame_ = v.get<int>();
  else if (k == "max_depth") integrator_.max_depth = v.get<int>();
  else if (k == "exposure") exposure_ = v.get<float>();
  else if (k == "scale") scale_ = v.get<float>();
  else if (k == "light_radius" || k == "light_center" || k == "light_power") {
    if (!light_.sphere) throw SceneError(a.where + ": the scene's first light is not a sphere");
    if (k == "light_radius") light_.radius = v.get<float>();
    else if (k == "light_center") light_.center = v3();
    else light_.power = v3();
  } else if (k == "split") split_ = v.get<bool>();
  else if (k == "split_left") left_ = strategy();
  else if (k == "split_right") right_ = strategy();
  else if (k == "divider") divider_ = v.get<float>();
  else if (k == "equal_time") equal_time_ = v.get<bool>();
  else if (k == "panel") panel_ = v.get<bool>();
  else if (k == "denoise") denoise_ = v.get<bool>();
  else if (k == "screenshot") screenshot(v.get<std::string>());  // frame >= 1 (checked): an image exists
  else if (k == "window_screenshot") pending_window_shots_.push_back(v.get<std::string>());
  else if (k == "save_camera") save_camera_file(v.get<std::string>());
  else if (k == "load_camera") load_camera_file(v.get<std::string>());
  else if (k == "key") press(v.get<std::string>());
  else if (k == "quit") quit_ = true;
}

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
    if (last && (pending_window_shots_.empty() || !started_)) break;

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
    const bool device = sides_[0].image->writes_device_pixels();
    if (!(denoise_ && show_denoised())) {
      DisplayPixels px = device ? display_->map_device_pixels() : display_->host_pixels();
      const int d = divider_column();
      sides_[0].image->tone_map(px, 0, d, exposure_);
      if (sides_.size() > 1) sides_[1].image->tone_map(px, d, applied_.width, exposure_);
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
    present_ms_.push_back(present_ms);
    recent_ms_.push_back(float(last_frame_ms_));
    if (recent_ms_.size() > 120) recent_ms_.erase(recent_ms_.begin());
    if (ms_since(last_title) > 500.0) {
      last_title = Clock::now();
      char title[256];
      std::snprintf(title, sizeof title, "penumbra view: %s  %llu spp  %.1f ms/frame", scene_label().c_str(),
                    (unsigned long long)sides_[0].image->samples(), last_frame_ms_);
      if (window_) glfwSetWindowTitle(window_, title);
    }
    ++frame_;
  }

  if (!opt_.screenshot.empty() && started_) screenshot(opt_.screenshot);
  if (opt_.frames > 0 && !frame_ms_.empty()) {
    const size_t n = frame_ms_.size();
    const double total = std::accumulate(frame_ms_.begin(), frame_ms_.end(), 0.0);
    const double render = std::accumulate(render_ms_.begin(), render_ms_.end(), 0.0) / n;
    const double display = std::accumulate(display_ms_.begin(), display_ms_.end(), 0.0) / n;
    const double present = std::accumulate(present_ms_.begin(), present_ms_.end(), 0.0) / n;
    std::vector<double> sorted = frame_ms_;
    std::sort(sorted.begin(), sorted.end());
    std::string spp;
    for (const Side& s : sides_)
      spp += (spp.empty() ? "" : " | ") + std::string(strategy_name(s.strategy)) + " " + std::to_string(s.image->samples()) + " spp";
    std::fprintf(stderr,
                 "view: %zu frames of %dx%d (%s): %.2f ms/frame, %.1f fps as displayed (median %.2f ms; per frame: "
                 "render %.2f ms, tone-map + upload %.2f ms, UI %.2f ms, present %.2f ms; display: %s, %s backend%s)\n",
                 n, applied_.width, applied_.height, spp.c_str(), total / n, 1000.0 * n / total, sorted[n / 2],
                 render, display, total / n - render - display - present, present,
                 display_path_name(display_path_.path), backend_->name().c_str(),
                 offscreen_ ? ", headless" : "");
  }
  if (nonfinite_ > 0) {
    std::fprintf(stderr,
                 "warning: %s: %llu samples were NaN or infinite and left out while the viewer ran (exit status %d)\n",
                 scene_->source.c_str(), (unsigned long long)nonfinite_, int(kExitNonFinite));
    return kExitNonFinite;
  }
  return kExitOk;
}

}  // namespace

int run_viewer(const ViewerOptions& options) {
  Viewer viewer(options);
  return viewer.run();
}

}  // namespace pn::viewer
