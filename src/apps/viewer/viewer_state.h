// The viewer's state, shared by its parts (internal to src/apps/viewer): the
// Viewer, its controls and its RenderScheduler (scheduler.h: the images on
// screen and what changes them), whose member functions live by concern:
//   viewer.cpp     opening the window or the headless context, the frame loop;
//   images.cpp     what the images should be from the controls, light edits, restarts, each frame's samples
//                  (through the RenderScheduler of scheduler.h, which owns the images), the denoised image;
//   actions.cpp    the actions by name (actions_table.h) for camera paths, keys and the panel; the mouse,
//                  screenshots, camera files;
//   panel.cpp      the Dear ImGui panel and the overlay.
#pragma once

#include <chrono>
#include <memory>
#include <string>
#include <vector>

#include "apps/viewer/camera_control.h"
#include "apps/viewer/camera_path.h"
#include "apps/viewer/gl_display.h"
#include "apps/viewer/headless_gl.h"
#include "apps/viewer/progressive.h"
#include "apps/viewer/scheduler.h"
#include "apps/viewer/viewer_options.h"
#include "backends/denoise.h"
#include "render/backend.h"
#include "scene/scene.h"

struct GLFWwindow;

namespace pn::viewer {

class DeviceDenoiser;  // device_image.h (built with CUDA)


inline const char* const kRenderHint = "use `penumbra render` to render to a file instead";


class Viewer {
 public:
  explicit Viewer(const ViewerOptions& o);
  ~Viewer();
  int run();

 private:
  // Setup.
  void load();
  void make_backend_for_scene();  // a backend for *scene_ (the images go first: they refer to the old one)
  void apply_light(const LightEdit& e);
  void open_window();
  void open_glfw_window();
  void open_headless();
  void initial_size(bool fit, int* width, int* height) const;
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
  void restart(const ImageSettings& s);
  bool show_denoised();
  bool show_denoised_on_device(const DenoiseOptions& options);
  std::string screenshot_stem() const;
  void screenshot(const std::string& path);
  void screenshot_button();
  void window_screenshot(const std::string& path);
  // An action of the table in actions_table.h, by name; its applies and key bindings, friends here, set the
  // members below.
  void act(const std::string& action, const nlohmann::json& value, const std::string& where);
  template <class Visit>
  friend void for_each_action(Visit&& visit);
  template <class Visit>
  friend void for_each_key(Visit&& visit);
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
  RenderScheduler scheduler_;  // the images: restarts, split screen, equal time

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
  // by Intel Open Image Denoise, with guides rendered once per restart; on the
  // interop path on the GPU, with no image through host memory (DeviceDenoiser).
  bool denoise_ = false;
  double denoise_ms_ = 0;  // the last frame's denoiser time (host clock around the filter)
  std::string denoiser_;   // which denoiser ran, on which device
  FrameSpec guide_frame_;
  GuideImages guides_;
  bool guides_on_device_ = false;  // guides_ uploaded to device_denoiser_
  std::shared_ptr<DeviceDenoiser> device_denoiser_;  // shared_ptr: its type is complete only in CUDA builds
  float fly_speed_ = 1.f;  // scene units per second
  std::string camera_file_;
  std::string status_;  // last message in the panel

  // Input state.
  enum class Drag { None, Orbit, Pan, Look, Divider } drag_ = Drag::None;
  double last_x_ = 0, last_y_ = 0;
  double scroll_ = 0;
  bool screenshot_requested_ = false;

  // Progress and timing.
  uint64_t frame_ = 0;
  std::vector<float> recent_ms_;  // the last frames' times, oldest first, for the graph
  double last_frame_ms_ = 0, last_render_ms_ = 0;
  std::vector<double> frame_ms_, render_ms_, display_ms_, present_ms_;  // every frame, for --frames
  std::vector<double> denoise_frame_ms_;  // the denoiser's time in each frame shown denoised
  std::vector<PathAction> path_;
  size_t next_action_ = 0;
  bool quit_ = false;
  std::vector<std::string> pending_window_shots_;
  uint64_t nonfinite_ = 0;  // samples left out by the backend, while the viewer runs
  int scene_loads_ = 0, backend_builds_ = 0;  // for the summary: light edits load nothing
};

}  // namespace pn::viewer
