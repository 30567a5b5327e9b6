// What changes the viewer (viewer_state.h): its actions by name (the table in
// actions_table.h) for camera paths, keys and the panel; keys by name
// (viewer_keys, camera_path.h); the mouse; screenshots and camera files.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <functional>
#include <map>
#include <stdexcept>
#include <string>
#include <vector>

#define GLFW_INCLUDE_NONE
#include <GLFW/glfw3.h>
#include <imgui.h>

#include "apps/viewer/actions_table.h"
#include "apps/viewer/viewer_state.h"
#include "io/image.h"
#include "io/output.h"

namespace pn::viewer {

// Settings in the file name: scene, strategies and their spp, depth, light radius, size, exposure.
std::string Viewer::screenshot_stem() const {
  char buf[256];
  std::string stem = scene_name_ + "_";
  const std::vector<Side>& sides = scheduler_.sides();
  const ImageSettings& applied = scheduler_.applied();
  if (sides.size() == 1) {
    stem += std::string(strategy_name(sides[0].strategy)) + "_" + std::to_string(sides[0].image->samples()) + "spp";
  } else {
    stem += std::string(strategy_name(sides[0].strategy)) + "-" + std::to_string(sides[0].image->samples()) +
            "spp_vs_" + strategy_name(sides[1].strategy) + "-" + std::to_string(sides[1].image->samples()) + "spp";
    stem += applied.equal_time ? "_equal-time" : "_equal-spp";
  }
  std::snprintf(buf, sizeof buf, "_d%d", applied.integrator.max_depth);
  stem += buf;
  if (light_applied_.sphere) {
    std::snprintf(buf, sizeof buf, "_r%g", double(light_applied_.radius));
    stem += buf;
  }
  std::snprintf(buf, sizeof buf, "_%dx%d", applied.width, applied.height);
  stem += buf;
  if (exposure_ != 0.f) {
    std::snprintf(buf, sizeof buf, "_e%+g", double(exposure_));
    stem += buf;
  }
  return stem;
}

void Viewer::screenshot(const std::string& path) {
  const ImageSettings& applied = scheduler_.applied();
  write_image(path, applied.width, applied.height, scheduler_.composed_mean(divider_), exposure_);
  std::fprintf(stderr, "wrote %s\n", path.c_str());
}

// The panel's button (and P): PNG and EXR side by side, never overwriting.
void Viewer::screenshot_button() {
  if (!scheduler_.started()) return;
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
  // overrides, the panel's light, the strategy and depth, and this camera.
  std::vector<std::string> overrides = opt_.sets;
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
  if (!same(light_, light_initial_) && doc.contains("lights") && doc["lights"].is_array() &&
      !doc["lights"].empty() && doc["lights"][0].is_object()) {
    // The edited light by its power, as the viewer edits it (a file may have given its radiance).
    nlohmann::json& l = doc["lights"][0];
    const LightEdit& e = light_;
    l["center"] = {shortest_number(e.center.x), shortest_number(e.center.y), shortest_number(e.center.z)};
    l["radius"] = shortest_number(e.radius);
    l.erase("radiance");
    l["power"] = {shortest_number(e.power.x), shortest_number(e.power.y), shortest_number(e.power.z)};
  }
  save_camera(path, camera_.desc(), doc);
  status_ = "saved the camera to " + path;
  std::fprintf(stderr, "%s\n", status_.c_str());
}

void Viewer::load_camera_file(const std::string& path) {
  camera_.set(load_camera(path));
  status_ = "loaded the camera of " + path;
}

// A key by its name (viewer_keys): the action and value it is bound to now (for_each_key, actions_table.h).
void Viewer::press(const std::string& key) {
  static const std::map<std::string, std::function<KeyAction(const Viewer&)>> bindings = [] {
    std::map<std::string, std::function<KeyAction(const Viewer&)>> t;
    for_each_key([&](const std::string& name, auto bind) { t.emplace(name, bind); });
    return t;
  }();
  auto it = bindings.find(key);
  if (it == bindings.end()) return;
  const KeyAction a = it->second(*this);
  if (!a.action.empty()) act(a.action, a.value, "key " + key);
}

// The window's keys, by their names in viewer_keys(), unless the panel is typing or has the keyboard (Tab always
// reaches the viewer but while typing). Shift names a key of its own where viewer_keys() has one ("shift+1"), else
// it is the key without shift.
void Viewer::on_key(GLFWwindow* w, int key, int, int action, int mods) {
  auto* v = static_cast<Viewer*>(glfwGetWindowUserPointer(w));
  if (action != GLFW_PRESS || !v->imgui_) return;
  const ImGuiIO& io = ImGui::GetIO();
  if (io.WantTextInput) return;  // typing a file name
  if (key == GLFW_KEY_TAB) return v->press("Tab");
  if (io.WantCaptureKeyboard) return;
  // GLFW's codes of the digit and letter keys are their characters ('1', 'R').
  if (!(key >= GLFW_KEY_0 && key <= GLFW_KEY_9) && !(key >= GLFW_KEY_A && key <= GLFW_KEY_Z)) return;
  const std::string name(1, char(key));
  if (mods & GLFW_MOD_SHIFT && is_viewer_key("shift+" + name)) v->press("shift+" + name);
  else if (is_viewer_key(name)) v->press(name);
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
    double divider_x = scheduler_.applied().split
                           ? double(scheduler_.divider_column(divider_)) / scheduler_.applied().width * ww
                           : -1e9;
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

// An action of the table (actions_table.h) by name, with a valid value: checked when the camera path was read, or
// made by a key or the panel.
void Viewer::act(const std::string& action, const nlohmann::json& value, const std::string& where) {
  using Apply = void (*)(Viewer&, const nlohmann::json&, const std::string&);
  static const std::map<std::string, Apply> applies = [] {
    std::map<std::string, Apply> t;
    for_each_action([&](const char* name, const ActionCheck&, Apply apply) { t.emplace(name, apply); });
    return t;
  }();
  applies.at(action)(*this, value, where);
}

void Viewer::apply(const PathAction& a) { act(a.key, a.value, a.where); }

}  // namespace pn::viewer
