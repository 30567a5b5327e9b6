// The viewer's interactive camera: orbit around a target, pan, dolly, and a fly
// mode (move the eye, look around it). No windowing here, so it is unit-tested.
//
// The state is the scene file's own camera description (eye, target, up, fov):
// an untouched camera is bit for bit the scene's (the viewer's image is then the
// one `penumbra render` makes), and saving writes back exactly what is shown.
#pragma once

#include <string>

#include <nlohmann/json.hpp>

#include "scene/scene.h"

namespace pn::viewer {

class CameraControl {
 public:
  explicit CameraControl(const CameraDesc& home = {}) : cam_(home), home_(home) {}

  const CameraDesc& desc() const { return cam_; }
  void set(const CameraDesc& c) { cam_ = c; }
  void reset() { cam_ = home_; }
  void set_fov(float degrees);

  // Rotates the eye around the target: positive yaw moves it to the camera's
  // right (about the up vector), positive pitch moves it up. Degrees. The
  // elevation stays within +-89 degrees so the look-at frame never degenerates.
  void orbit(float yaw_deg, float pitch_deg);
  // Fly mode: turns the view about the eye; positive yaw looks right, positive pitch up.
  void look(float yaw_deg, float pitch_deg);
  // Moves eye and target together in the image plane by (dx, dy) view heights
  // at the target's distance, in the direction that makes the scene follow a
  // mouse drag (right, down), so a drag over the whole window moves the point
  // at the target with the cursor.
  void pan(float dx, float dy);
  // Multiplies the eye's distance to the target (factor > 0).
  void dolly(float factor);
  // Fly mode: moves eye and target together by `right` along the camera's
  // right vector, `up` along the world up, `forward` along the view direction.
  void move(float right, float up, float forward);

  float distance() const;
  Vec3 forward() const;  // unit view direction
  Vec3 right() const;    // unit, horizontal
  Vec3 up() const;       // unit world up (the camera's up hint)

 private:
  CameraDesc cam_, home_;
};

// The shortest decimal that reads back as the same float, as a JSON number:
// scene files stay readable (2.78, not 2.7799999713897705) and exact.
nlohmann::json shortest_number(float v);

// A camera block of a scene file: {"eye", "target", "up", "fov"}, each number
// the shortest decimal that reads back as the same float (2.78, not 2.7799999).
nlohmann::json camera_to_json(const CameraDesc& c);

// Writes the camera into a scene file. If `path` exists (a scene file), only
// its "camera" block is replaced; otherwise `whole_scene` (a complete scene
// document, e.g. the dump of a built-in scene) is written with this camera.
// Throws std::runtime_error with one line naming the file.
void save_camera(const std::string& path, const CameraDesc& c, const nlohmann::json& whole_scene);

// Reads the camera block of a scene file, validated like any scene
// (throws SceneError naming the file and the field).
CameraDesc load_camera(const std::string& path);

}  // namespace pn::viewer
