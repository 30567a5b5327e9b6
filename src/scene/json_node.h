// The JSON helper of the scene parser: a value together with where it lives in
// the document, so that every rejection is one line naming the file and the
// field. Internal to src/scene (scene.cpp, model_io.cpp).
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <set>
#include <sstream>
#include <string>

#include <nlohmann/json.hpp>

#include "scene/scene.h"

namespace pn {
namespace scene_detail {

using json = nlohmann::json;

// Coordinates beyond this are rejected (absurd values would overflow later).
constexpr float kMaxCoordinate = 1e7f;
// A light's radiance or power, per RGB channel, at most this.
constexpr float kMaxEmission = 1e9f;

// A JSON value together with where it lives, for error messages.
struct Node {
  const json& j;
  std::string path;  // e.g. "lights[0].radius"
  const std::string& source;

  [[noreturn]] void fail(const std::string& msg) const {
    throw SceneError(source, path.empty() ? std::string("(top level)") : path, msg);
  }
  Node at(const std::string& key) const {
    return Node{j.at(key), path.empty() ? key : path + "." + key, source};
  }
  Node at(size_t i) const { return Node{j.at(i), path + "[" + std::to_string(i) + "]", source}; }
  bool has(const std::string& key) const { return j.contains(key); }

  void expect_object(const std::set<std::string>& allowed) const {
    if (!j.is_object()) fail("expected an object, got " + std::string(j.type_name()));
    for (auto it = j.begin(); it != j.end(); ++it) {
      if (!allowed.count(it.key())) {
        std::string list;
        for (const auto& a : allowed) list += (list.empty() ? "" : ", ") + a;
        at(it.key()).fail("unknown key (expected one of: " + list + ")");
      }
    }
  }
  void require(const std::string& key) const {
    if (!has(key)) fail("missing required key '" + key + "'");
  }

  double number() const {
    if (!j.is_number()) fail("expected a number, got " + std::string(j.type_name()));
    double v = j.get<double>();
    if (!std::isfinite(v)) fail("must be a finite number");
    return v;
  }
  float real(double lo, double hi) const {
    double v = number();
    if (v < lo || v > hi) {
      std::ostringstream os;
      os << "must be in [" << lo << ", " << hi << "] (got " << v << ")";
      fail(os.str());
    }
    return float(v);
  }
  float positive(double hi) const {
    double v = number();
    if (!(v > 0.0) || v > hi) {
      std::ostringstream os;
      os << "must be > 0 and <= " << hi << " (got " << v << ")";
      fail(os.str());
    }
    return float(v);
  }
  int integer(long lo, long hi) const {
    if (!j.is_number_integer() && !j.is_number_unsigned()) {
      if (j.is_number_float()) fail("expected an integer, got " + j.dump());
      fail("expected an integer, got " + std::string(j.type_name()));
    }
    long long v = j.is_number_unsigned() ? (long long)std::min<uint64_t>(j.get<uint64_t>(), uint64_t(1) << 62)
                                         : j.get<long long>();
    if (v < lo || v > hi) fail("must be in [" + std::to_string(lo) + ", " + std::to_string(hi) + "] (got " + std::to_string(v) + ")");
    return int(v);
  }
  bool boolean() const {
    if (!j.is_boolean()) fail("expected true or false, got " + j.dump());
    return j.get<bool>();
  }
  std::string string() const {
    if (!j.is_string()) fail("expected a string, got " + std::string(j.type_name()));
    return j.get<std::string>();
  }
  Vec3 vec3(float limit = kMaxCoordinate) const {
    if (!j.is_array() || j.size() != 3) fail("expected an array of 3 numbers");
    Vec3 v;
    for (int i = 0; i < 3; ++i) v[i] = at(size_t(i)).real(-limit, limit);
    return v;
  }
  // A colour: one number (grey) or [r, g, b], each in [0, hi].
  Vec3 color(float hi) const {
    if (j.is_number()) {
      float g = real(0.0, hi);
      return Vec3(g);
    }
    if (!j.is_array() || j.size() != 3) fail("expected a number or an array of 3 numbers");
    Vec3 v;
    for (int i = 0; i < 3; ++i) v[i] = at(size_t(i)).real(0.0, hi);
    return v;
  }
};

}  // namespace scene_detail
}  // namespace pn
