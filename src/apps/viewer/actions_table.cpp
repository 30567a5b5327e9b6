// The checks of the viewer's actions (actions_table.h): each throws SceneError
// with one line, "where: what", naming the file and the entry.
#include "apps/viewer/actions_table.h"

#include <cmath>
#include <cstdio>
#include <exception>

#include "apps/viewer/camera_path.h"
#include "io/image.h"
#include "io/output.h"

namespace pn::viewer {
namespace {

using ojson = nlohmann::ordered_json;

[[noreturn]] void fail(const std::string& where, const std::string& what) { throw SceneError(where + ": " + what); }

std::string shortest(double x) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%g", x);
  return buf;
}

bool is_number(const ojson& v) { return v.is_number() && std::isfinite(v.get<double>()); }

}  // namespace

namespace check {

ActionCheck numbers(size_t n) {
  return [n](const ojson& v, const std::string& where) {
    bool ok = v.is_array() && v.size() == n;
    for (size_t i = 0; ok && i < n; ++i) ok = is_number(v[i]);
    if (!ok) fail(where, "must be an array of " + std::to_string(n) + " numbers (got " + v.dump() + ")");
  };
}
ActionCheck number_in(double lo, double hi, bool open_lo) {
  return [=](const ojson& v, const std::string& where) {
    if (!is_number(v)) fail(where, "must be a number (got " + v.dump() + ")");
    double x = v.get<double>();
    if (x > hi || x < lo || (open_lo && x == lo))
      fail(where, "must be " + std::string(open_lo ? "> " : ">= ") + shortest(lo) + " and <= " + shortest(hi) +
                      " (got " + v.dump() + ")");
  };
}
ActionCheck integer_in(long lo, long hi) {
  return [=](const ojson& v, const std::string& where) {
    if (!v.is_number_integer() || v.get<long>() < lo || v.get<long>() > hi)
      fail(where, "must be an integer in " + std::to_string(lo) + ".." + std::to_string(hi) + " (got " + v.dump() + ")");
  };
}
ActionCheck boolean(bool only_true) {
  return [=](const ojson& v, const std::string& where) {
    if (!v.is_boolean() || (only_true && !v.get<bool>()))
      fail(where, std::string(only_true ? "must be true" : "must be true or false") + " (got " + v.dump() + ")");
  };
}
ActionCheck strategy() {
  return [](const ojson& v, const std::string& where) {
    if (!v.is_string()) fail(where, "must be a strategy name: " + strategy_names() + " (got " + v.dump() + ")");
    parse_strategy(v.get<std::string>(), where);
  };
}
ActionCheck mis() {
  return [](const ojson& v, const std::string& where) {
    if (!v.is_string()) fail(where, "must be an MIS mode: " + mis_names() + " (got " + v.dump() + ")");
    parse_mis(v.get<std::string>(), where);
  };
}
ActionCheck light_selection() {
  return [](const ojson& v, const std::string& where) {
    if (!v.is_string())
      fail(where, "must be a light-selection method: " + light_selection_names() + " (got " + v.dump() + ")");
    parse_light_selection(v.get<std::string>(), where);
  };
}
ActionCheck file(bool output, bool image, bool png_only) {
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
ActionCheck camera() {
  return [](const ojson& v, const std::string& where) {
    if (!v.is_object()) fail(where, "must be a camera block {\"eye\", \"target\", \"up\", \"fov\"}");
    // Validated exactly like a scene file's camera block.
    parse_scene(nlohmann::json{{"camera", nlohmann::json::parse(v.dump())}}, where, ".");
  };
}
ActionCheck key() {
  return [](const ojson& v, const std::string& where) {
    if (v.is_string() && is_viewer_key(v.get<std::string>())) return;
    std::string names;
    for (const std::string& k : viewer_keys()) names += (names.empty() ? "" : ", ") + k;
    fail(where, "must be a key: " + names + " (got " + v.dump() + ")");
  };
}
ActionCheck light_power() {
  return [](const ojson& v, const std::string& where) {
    if (is_number(v) && v.get<double>() >= 0) return;
    numbers(3)(v, where);
    for (const auto& x : v)
      if (x.get<double>() < 0) fail(where, "must not be negative (got " + v.dump() + ")");
  };
}

}  // namespace check
}  // namespace pn::viewer
