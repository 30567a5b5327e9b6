#include "apps/viewer/camera_path.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <functional>
#include <map>
#include <sstream>

#include "io/image.h"
#include "io/output.h"
#include "scene/scene.h"

namespace pn::viewer {
namespace {

using ojson = nlohmann::ordered_json;  // keeps the keys of an entry in file order
using Check = std::function<void(const ojson& v, const std::string& where)>;

[[noreturn]] void fail(const std::string& where, const std::string& what) { throw SceneError(where + ": " + what); }

std::string shortest(double x) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%g", x);
  return buf;
}

bool is_number(const ojson& v) { return v.is_number() && std::isfinite(v.get<double>()); }

Check numbers(size_t n) {
  return [n](const ojson& v, const std::string& where) {
    bool ok = v.is_array() && v.size() == n;
    for (size_t i = 0; ok && i < n; ++i) ok = is_number(v[i]);
    if (!ok) fail(where, "must be an array of " + std::to_string(n) + " numbers (got " + v.dump() + ")");
  };
}
Check number_in(double lo, double hi, bool open_lo = false) {
  return [=](const ojson& v, const std::string& where) {
    if (!is_number(v)) fail(where, "must be a number (got " + v.dump() + ")");
    double x = v.get<double>();
    if (x > hi || x < lo || (open_lo && x == lo))
      fail(where, "must be " + std::string(open_lo ? "> " : ">= ") + shortest(lo) + " and <= " + shortest(hi) +
                      " (got " + v.dump() + ")");
  };
}
Check integer_in(long lo, long hi) {
  return [=](const ojson& v, const std::string& where) {
    if (!v.is_number_integer() || v.get<long>() < lo || v.get<long>() > hi)
      fail(where, "must be an integer in " + std::to_string(lo) + ".." + std::to_string(hi) + " (got " + v.dump() + ")");
  };
}
Check boolean(bool only_true = false) {
  return [=](const ojson& v, const std::string& where) {
    if (!v.is_boolean() || (only_true && !v.get<bool>()))
      fail(where, std::string(only_true ? "must be true" : "must be true or false") + " (got " + v.dump() + ")");
  };
}
Check strategy() {
  return [](const ojson& v, const std::string& where) {
    if (!v.is_string()) fail(where, "must be a strategy name: " + strategy_names() + " (got " + v.dump() + ")");
    parse_strategy(v.get<std::string>(), where);
  };
}
Check mis() {
  return [](const ojson& v, const std::string& where) {
    if (!v.is_string()) fail(where, "must be an MIS mode: " + mis_names() + " (got " + v.dump() + ")");
    parse_mis(v.get<std::string>(), where);
  };
}
Check light_selection() {
  return [](const ojson& v, const std::string& where) {
    if (!v.is_string())
      fail(where, "must be a light-selection method: " + light_selection_names() + " (got " + v.dump() + ")");
    parse_light_selection(v.get<std::string>(), where);
  };
}
// A file an action reads, or writes (`output`: checked now, before the first
// frame, as every output of a command is).
Check file(bool output, bool image, bool png_only = false) {
  return [=](const ojson& v, const std::string& where) {
    if (!v.is_string() || v.get<std::string>().empty()) fail(where, "must be a file name (got " + v.dump() + ")");
    std::string f = v.get<std::string>();
    if (png_only && (f.size() < 4 || f.substr(f.size() - 4) != ".png")) fail(where, "must name a .png file (got " + f + ")");
    try {
      if (image) check_image_path(f);
      if (output) check_output_file(f, "the file");
    } catch (const std::exception& e) {
      fail(where, e.what());
    }
  };
}
Check camera() {
  return [](const ojson& v, const std::string& where) {
    if (!v.is_object()) fail(where, "must be a camera block {\"eye\", \"target\", \"up\", \"fov\"}");
    // Validated exactly like a scene file's camera block.
    parse_scene(nlohmann::json{{"camera", nlohmann::json::parse(v.dump())}}, where, ".");
  };
}
Check key() {
  return [](const ojson& v, const std::string& where) {
    if (v.is_string() && is_viewer_key(v.get<std::string>())) return;
    std::string names;
    for (const std::string& k : viewer_keys()) names += (names.empty() ? "" : ", ") + k;
    fail(where, "must be a key: " + names + " (got " + v.dump() + ")");
  };
}
Check light_power() {
  return [](const ojson& v, const std::string& where) {
    if (is_number(v) && v.get<double>() >= 0) return;
    numbers(3)(v, where);
    for (const auto& x : v)
      if (x.get<double>() < 0) fail(where, "must not be negative (got " + v.dump() + ")");
  };
}

const std::map<std::string, Check>& checks() {
  static const std::map<std::string, Check> table = {
      {"orbit", numbers(2)},          {"look", numbers(2)},
      {"pan", numbers(2)},            {"dolly", number_in(0, 100, true)},
      {"move", numbers(3)},           {"camera", camera()},
      {"reset", boolean(true)},       {"fov", number_in(1, 170)},
      {"fly", boolean()},             {"fly_speed", number_in(0, 1e9, true)},
      {"strategy", strategy()},       {"mis", mis()},
      {"light_selection", light_selection()}, {"restir_temporal", boolean()},
      {"restir_pairwise", boolean()}, {"restir_bvh_candidates", boolean()},
      {"restir_visibility_reuse", boolean()},
      {"restir_candidates", integer_in(1, long(kMaxRestirCandidates))},
      {"restir_spatial", integer_in(0, long(kMaxRestirPasses))},
      {"spp_per_frame", integer_in(1, 4096)},
      {"max_depth", integer_in(0, 1000)},
      {"exposure", number_in(-64, 64)}, {"scale", number_in(0.05, 4)},
      {"light_radius", number_in(0, 1e9, true)},
      {"light_center", numbers(3)},   {"light_power", light_power()},
      {"split", boolean()},           {"split_left", strategy()},
      {"split_right", strategy()},    {"divider", number_in(0, 1)},
      {"equal_time", boolean()},      {"panel", boolean()},
      {"denoise", boolean()},
      {"screenshot", file(true, true)},     {"window_screenshot", file(true, false, true)},
      {"save_camera", file(true, false)},   {"load_camera", file(false, false)},
      {"key", key()},                 {"quit", boolean(true)},
  };
  return table;
}

}  // namespace

const std::vector<std::string>& viewer_keys() {
  static const std::vector<std::string> keys = [] {
    std::vector<std::string> k;
    for (const char* prefix : {"", "shift+"})
      for (char digit = '1'; digit <= '9'; ++digit) k.push_back(prefix + std::string(1, digit));
    for (const char* letter : {"R", "F", "P", "N", "Tab"}) k.push_back(letter);
    return k;
  }();
  return keys;
}

bool is_viewer_key(const std::string& name) {
  return std::find(viewer_keys().begin(), viewer_keys().end(), name) != viewer_keys().end();
}

const std::vector<std::string>& camera_path_keys() {
  static const std::vector<std::string> keys = [] {
    std::vector<std::string> k;
    for (const auto& kv : checks()) k.push_back(kv.first);
    return k;
  }();
  return keys;
}

std::vector<PathAction> parse_camera_path(const std::string& text, const std::string& source) {
  ojson doc = ojson::parse(text, nullptr, /*allow_exceptions=*/false);
  if (doc.is_discarded()) fail(source, "invalid JSON");
  if (!doc.is_array()) fail(source, "must be a JSON list of actions [{\"frame\": N, ...}, ...]");
  std::vector<PathAction> actions;
  for (size_t i = 0; i < doc.size(); ++i) {
    const ojson& entry = doc[i];
    std::string where = source + ": [" + std::to_string(i) + "]";
    if (!entry.is_object()) fail(where, "must be an object {\"frame\": N, \"<action>\": value}");
    if (!entry.contains("frame")) fail(where, "has no \"frame\"");
    const ojson& f = entry["frame"];
    if (!f.is_number_unsigned() && !(f.is_number_integer() && f.get<long long>() >= 0))
      fail(where + ".frame", "must be an integer >= 0 (got " + f.dump() + ")");
    if (entry.size() < 2) fail(where, "has no action besides \"frame\"");
    for (const auto& kv : entry.items()) {
      if (kv.key() == "frame") continue;
      auto it = checks().find(kv.key());
      if (it == checks().end()) {
        std::string names;
        for (const auto& k : camera_path_keys()) names += (names.empty() ? "" : ", ") + k;
        fail(where, "unknown action '" + kv.key() + "' (known: " + names + ")");
      }
      it->second(kv.value(), where + "." + kv.key());
      if (kv.key() == "screenshot" && f.get<uint64_t>() == 0)
        fail(where + ".screenshot", "needs a frame >= 1: there is no image before the first frame");
      actions.push_back({f.get<uint64_t>(), kv.key(), nlohmann::json::parse(kv.value().dump()), where + "." + kv.key()});
    }
  }
  std::stable_sort(actions.begin(), actions.end(),
                   [](const PathAction& a, const PathAction& b) { return a.frame < b.frame; });
  return actions;
}

std::vector<PathAction> load_camera_path(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw SceneError(path + ": cannot open the camera path");
  std::stringstream buf;
  buf << in.rdbuf();
  return parse_camera_path(buf.str(), path);
}

}  // namespace pn::viewer
