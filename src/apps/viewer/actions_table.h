// The viewer's actions in one list: each by name, with how a camera path's
// value for it is checked and what it does to the viewer; and the viewer's
// keys, each bound to one of these actions and a value. docs/viewer.md lists
// them all.
//
// Who reads the list:
//   camera_path.cpp  the checks, when a camera path is read (and the names: camera_path_keys, viewer_keys);
//   actions.cpp      the applies: Viewer::act, which runs camera-path actions (Viewer::apply) and keys
//                    (Viewer::press, from the window or a camera path's "key");
//   panel.cpp        the panel's controls that set one value, through Viewer::act.
//
// An apply is a generic lambda of the viewer (`auto& w`: the Viewer of
// viewer_state.h, whose friends these functions are). A generic lambda's body
// is compiled only where it is called, so the windowless core (camera-path
// checks, the unit tests) reads this list without the viewer's window code.
#pragma once

#include <cstddef>
#include <functional>
#include <string>

#include <nlohmann/json.hpp>

#include "scene/scene.h"

namespace pn::viewer {

// Throws SceneError "where: what" (one line) unless `value` suits the action.
using ActionCheck = std::function<void(const nlohmann::ordered_json& value, const std::string& where)>;

// The checks the actions share (defined in actions_table.cpp).
namespace check {
ActionCheck numbers(size_t n);                                     // an array of n finite numbers
ActionCheck number_in(double lo, double hi, bool open_lo = false);  // a number in [lo, hi] or (lo, hi]
ActionCheck integer_in(long lo, long hi);
ActionCheck boolean(bool only_true = false);
ActionCheck strategy();
ActionCheck mis();
ActionCheck light_selection();
// A file an action reads, or writes (`output`: checked now, before the first
// frame, as every output of a command is).
ActionCheck file(bool output, bool image, bool png_only = false);
ActionCheck camera();       // a scene file's camera block
ActionCheck key();          // a name of viewer_keys() (camera_path.h)
ActionCheck light_power();  // a number or [r, g, b], not negative
}  // namespace check

// What the applies share: a value's numbers, its strategy, the light's guard.
namespace detail {
inline float at(const nlohmann::json& v, size_t i) { return v[i].get<float>(); }
inline Vec3 vec3_or_scalar(const nlohmann::json& v) {
  return v.is_array() ? Vec3(at(v, 0), at(v, 1), at(v, 2)) : Vec3(v.get<float>());
}
inline Strategy strategy_of(const nlohmann::json& v, const std::string& where) {
  return parse_strategy(v.get<std::string>(), where);
}
// The light actions edit the scene's first light, which only a sphere allows.
template <class LightEdit>
void need_sphere(const LightEdit& light, const std::string& where) {
  if (!light.sphere) throw SceneError(where + ": the scene's first light is not a sphere");
}
}  // namespace detail

// visit(name, check, apply) for every action; apply(viewer, value, where), `where` naming the action in messages
// ("path.json: [3].strategy"). The one action without a check is not a camera-path action (see below).
template <class Visit>
void for_each_action(Visit&& visit) {
  using json = nlohmann::json;
  using std::string;
  using namespace detail;
  // The camera (camera_control.h).
  visit("orbit", check::numbers(2), [](auto& w, const json& v, const string&) { w.camera_.orbit(at(v, 0), at(v, 1)); });
  visit("look", check::numbers(2), [](auto& w, const json& v, const string&) { w.camera_.look(at(v, 0), at(v, 1)); });
  visit("pan", check::numbers(2), [](auto& w, const json& v, const string&) { w.camera_.pan(at(v, 0), at(v, 1)); });
  visit("dolly", check::number_in(0, 100, true),
        [](auto& w, const json& v, const string&) { w.camera_.dolly(v.get<float>()); });
  visit("move", check::numbers(3),
        [](auto& w, const json& v, const string&) { w.camera_.move(at(v, 0), at(v, 1), at(v, 2)); });
  visit("camera", check::camera(), [](auto& w, const json& v, const string& where) {
    w.camera_.set(parse_scene(json{{"camera", v}}, where, ".").camera);
  });
  visit("reset", check::boolean(true), [](auto& w, const json&, const string&) { w.camera_.reset(); });
  visit("fov", check::number_in(1, 170),
        [](auto& w, const json& v, const string&) { w.camera_.set_fov(v.get<float>()); });
  visit("fly", check::boolean(), [](auto& w, const json& v, const string&) { w.fly_ = v.get<bool>(); });
  visit("fly_speed", check::number_in(0, 1e9, true),
        [](auto& w, const json& v, const string&) { w.fly_speed_ = v.get<float>(); });
  // The estimator.
  visit("strategy", check::strategy(),
        [](auto& w, const json& v, const string& where) { w.integrator_.strategy = strategy_of(v, where); });
  visit("mis", check::mis(), [](auto& w, const json& v, const string& where) {
    w.integrator_.mis = parse_mis(v.get<string>(), where);
  });
  visit("light_selection", check::light_selection(), [](auto& w, const json& v, const string& where) {
    w.integrator_.light_selection = parse_light_selection(v.get<string>(), where);
  });
  visit("restir_temporal", check::boolean(),
        [](auto& w, const json& v, const string&) { w.integrator_.restir.temporal = v.get<bool>(); });
  visit("restir_pairwise", check::boolean(),
        [](auto& w, const json& v, const string&) { w.integrator_.restir.pairwise = v.get<bool>(); });
  visit("restir_bvh_candidates", check::boolean(), [](auto& w, const json& v, const string&) {
    w.integrator_.restir.source = v.get<bool>() ? LightSelection::Bvh : LightSelection::Power;
  });
  visit("restir_visibility_reuse", check::boolean(),
        [](auto& w, const json& v, const string&) { w.integrator_.restir.visibility_reuse = v.get<bool>(); });
  visit("restir_candidates", check::integer_in(1, long(kMaxRestirCandidates)),
        [](auto& w, const json& v, const string&) { w.integrator_.restir.candidates = v.get<uint32_t>(); });
  visit("restir_spatial", check::integer_in(0, long(kMaxRestirPasses)),
        [](auto& w, const json& v, const string&) { w.integrator_.restir.spatial_passes = v.get<uint32_t>(); });
  visit("spp_per_frame", check::integer_in(1, 4096),
        [](auto& w, const json& v, const string&) { w.spp_per_frame_ = v.get<int>(); });
  visit("max_depth", check::integer_in(0, 1000),
        [](auto& w, const json& v, const string&) { w.integrator_.max_depth = v.get<int>(); });
  // The display.
  visit("exposure", check::number_in(-64, 64),
        [](auto& w, const json& v, const string&) { w.exposure_ = v.get<float>(); });
  visit("scale", check::number_in(0.05, 4), [](auto& w, const json& v, const string&) { w.scale_ = v.get<float>(); });
  visit("denoise", check::boolean(), [](auto& w, const json& v, const string&) { w.denoise_ = v.get<bool>(); });
  visit("panel", check::boolean(), [](auto& w, const json& v, const string&) { w.panel_ = v.get<bool>(); });
  // The first light, a sphere (LightEdit, viewer_state.h).
  visit("light_radius", check::number_in(0, 1e9, true), [](auto& w, const json& v, const string& where) {
    need_sphere(w.light_, where);
    w.light_.radius = v.get<float>();
  });
  visit("light_center", check::numbers(3), [](auto& w, const json& v, const string& where) {
    need_sphere(w.light_, where);
    w.light_.center = vec3_or_scalar(v);
  });
  visit("light_power", check::light_power(), [](auto& w, const json& v, const string& where) {
    need_sphere(w.light_, where);
    w.light_.power = vec3_or_scalar(v);
  });
  // The split screen.
  visit("split", check::boolean(), [](auto& w, const json& v, const string&) { w.split_ = v.get<bool>(); });
  visit("split_left", check::strategy(),
        [](auto& w, const json& v, const string& where) { w.left_ = strategy_of(v, where); });
  visit("split_right", check::strategy(),
        [](auto& w, const json& v, const string& where) { w.right_ = strategy_of(v, where); });
  visit("divider", check::number_in(0, 1), [](auto& w, const json& v, const string&) { w.divider_ = v.get<float>(); });
  visit("equal_time", check::boolean(), [](auto& w, const json& v, const string&) { w.equal_time_ = v.get<bool>(); });
  // Files. A script's screenshot is written at once (frame >= 1, checked: an image exists).
  visit("screenshot", check::file(true, true),
        [](auto& w, const json& v, const string&) { w.screenshot(v.get<string>()); });
  visit("window_screenshot", check::file(true, false, true),
        [](auto& w, const json& v, const string&) { w.pending_window_shots_.push_back(v.get<string>()); });
  visit("save_camera", check::file(true, false),
        [](auto& w, const json& v, const string&) { w.save_camera_file(v.get<string>()); });
  visit("load_camera", check::file(false, false),
        [](auto& w, const json& v, const string&) { w.load_camera_file(v.get<string>()); });
  // The panel's screenshot button and P: PNG + EXR named by the settings, written before the frame's samples.
  // Not a camera-path action (no check): a script names its screenshots.
  visit("screenshot_button", ActionCheck(),
        [](auto& w, const json&, const string&) { w.screenshot_requested_ = true; });
  // The run.
  visit("key", check::key(), [](auto& w, const json& v, const string&) { w.press(v.get<string>()); });
  visit("quit", check::boolean(true), [](auto& w, const json&, const string&) { w.quit_ = true; });
}

// What a key does: an action of for_each_action and its value. No action: the
// key does nothing now (a digit past the last strategy).
struct KeyAction {
  std::string action;
  nlohmann::json value;
};

// visit(name, bind) for every key, in the order docs/viewer.md lists them;
// bind(viewer) is the key's KeyAction in the viewer's present state (a toggle
// sets the opposite of now).
template <class Visit>
void for_each_key(Visit&& visit) {
  // 1..9: the strategies in registry order, the one image's or, in split
  // screen, the left side's; with shift the right side's.
  for (const bool shift : {false, true})
    for (int i = 0; i < 9; ++i)
      visit((shift ? "shift+" : "") + std::to_string(i + 1), [i, shift](const auto& w) -> KeyAction {
        if (i >= kNumStrategies) return {};
        return {!w.split_ ? "strategy" : shift ? "split_right" : "split_left", strategy_name(Strategy(i))};
      });
  visit("R", [](const auto&) -> KeyAction { return {"reset", true}; });
  visit("F", [](const auto& w) -> KeyAction { return {"fly", !w.fly_}; });
  visit("P", [](const auto&) -> KeyAction { return {"screenshot_button", true}; });
  visit("N", [](const auto& w) -> KeyAction { return {"denoise", !w.denoise_}; });
  visit("Tab", [](const auto& w) -> KeyAction { return {"panel", !w.panel_}; });
}

}  // namespace pn::viewer
