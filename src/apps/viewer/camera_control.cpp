#include "apps/viewer/camera_control.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <sstream>
#include <stdexcept>

#include "io/output.h"

namespace pn::viewer {
namespace {

constexpr float kMaxElevation = 89.f * kPi / 180.f;
constexpr float kMinDistance = 1e-4f;

float radians(float deg) { return deg * kPi / 180.f; }

// Rodrigues: v rotated by `angle` (right-handed) about the unit `axis`.
Vec3 rotate(Vec3 v, Vec3 axis, float angle) {
  float c = std::cos(angle), s = std::sin(angle);
  return v * c + cross(axis, v) * s + axis * (dot(axis, v) * (1.f - c));
}

// Turns v by `yaw` about the unit `up` and raises its elevation above the plane
// normal to `up` by `pitch`, clamped to +-89 degrees; keeps its length.
Vec3 turn(Vec3 v, Vec3 up, float yaw, float pitch) {
  float len = length(v);
  v = rotate(v, up, yaw);
  Vec3 h = v - up * dot(v, up);
  float hl = length(h);
  if (!(hl > 0.f)) return v;  // straight up or down: loaded that way; only the yaw applies
  float elevation = std::atan2(dot(v, up), hl);
  float e = std::clamp(elevation + pitch, -kMaxElevation, kMaxElevation);
  return (h / hl * std::cos(e) + up * std::sin(e)) * len;
}

}  // namespace

nlohmann::json shortest_number(float v) {
  char buf[32];
  for (int digits = 6; digits <= 9; ++digits) {
    std::snprintf(buf, sizeof buf, "%.*g", digits, double(v));
    if (std::strtof(buf, nullptr) == v) break;
  }
  return std::strtod(buf, nullptr);
}

namespace {

nlohmann::json vec_json(Vec3 v) { return {shortest_number(v.x), shortest_number(v.y), shortest_number(v.z)}; }

}  // namespace

Vec3 CameraControl::up() const { return normalize(cam_.up); }
Vec3 CameraControl::forward() const { return normalize(cam_.target - cam_.eye); }
Vec3 CameraControl::right() const { return normalize(cross(forward(), up())); }
float CameraControl::distance() const { return length(cam_.target - cam_.eye); }

void CameraControl::set_fov(float degrees) { cam_.fov = std::clamp(degrees, 1.f, 170.f); }

void CameraControl::orbit(float yaw_deg, float pitch_deg) {
  // The eye's offset from the target turns; d(offset)/d(yaw) = up x offset,
  // which points along the camera's right vector, as documented.
  Vec3 offset = turn(cam_.eye - cam_.target, up(), radians(yaw_deg), radians(pitch_deg));
  cam_.eye = cam_.target + offset;
}

void CameraControl::look(float yaw_deg, float pitch_deg) {
  // Turning the view direction right is a negative rotation about up.
  Vec3 dir = turn(cam_.target - cam_.eye, up(), -radians(yaw_deg), radians(pitch_deg));
  cam_.target = cam_.eye + dir;
}

void CameraControl::pan(float dx, float dy) {
  float view_height = 2.f * distance() * std::tan(0.5f * radians(cam_.fov));
  Vec3 r = right(), u = cross(r, forward());  // the image plane's axes
  Vec3 shift = (r * -dx + u * dy) * view_height;
  cam_.eye += shift;
  cam_.target += shift;
}

void CameraControl::dolly(float factor) {
  if (!(factor > 0.f)) return;
  float d = distance();
  float nd = std::max(d * factor, kMinDistance);
  cam_.eye = cam_.target - forward() * nd;
}

void CameraControl::move(float right_amount, float up_amount, float forward_amount) {
  Vec3 shift = right() * right_amount + up() * up_amount + forward() * forward_amount;
  cam_.eye += shift;
  cam_.target += shift;
}

nlohmann::json camera_to_json(const CameraDesc& c) {
  nlohmann::json j;
  j["eye"] = vec_json(c.eye);
  j["target"] = vec_json(c.target);
  j["up"] = vec_json(c.up);
  j["fov"] = shortest_number(c.fov);
  return j;
}

void save_camera(const std::string& path, const CameraDesc& c, const nlohmann::json& whole_scene) {
  nlohmann::json doc;
  std::ifstream in(path, std::ios::binary);
  if (in) {
    std::stringstream buf;
    buf << in.rdbuf();
    doc = nlohmann::json::parse(buf.str(), nullptr, /*allow_exceptions=*/false);
    if (doc.is_discarded() || !doc.is_object())
      throw std::runtime_error(path + ": exists and is not a scene file (JSON object); not overwritten");
  } else {
    doc = whole_scene;
  }
  doc["camera"] = camera_to_json(c);
  write_file_atomic(path, doc.dump(2) + "\n");
}

CameraDesc load_camera(const std::string& path) { return load_scene(path).camera; }

}  // namespace pn::viewer
