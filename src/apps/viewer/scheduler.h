// The viewer's images and how each frame's samples go to them (no window: unit-tested in
// tests/apps/test_viewer.cpp): what changes the image (ImageSettings, with the light being edited), and the
// RenderScheduler, which owns the images, restarts them when the settings change, and gives each frame's
// samples to the one image or to the split screen's two sides, at equal samples or at equal time.
#pragma once

#include <chrono>
#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "apps/viewer/progressive.h"
#include "render/backend.h"
#include "scene/scene.h"

namespace pn::viewer {

using Clock = std::chrono::steady_clock;
inline double ms_since(Clock::time_point t) {
  return std::chrono::duration<double, std::milli>(Clock::now() - t).count();
}

inline bool same(Vec3 a, Vec3 b) { return a.x == b.x && a.y == b.y && a.z == b.z; }
inline bool same(const CameraDesc& a, const CameraDesc& b) {
  return same(a.eye, b.eye) && same(a.target, b.target) && same(a.up, b.up) && a.fov == b.fov;
}

// The first light, when it is a sphere: the panel, keys and scripts edit its
// centre, radius and power (a radius change keeps the power, so the scene's
// brightness stays). The scene and the backend take an edit in place
// (set_sphere_light, Backend::update_lights): nothing is loaded again, and the
// meshes' acceleration structures are kept; a backend that cannot update is
// made again from the edited scene.
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
inline bool same(const LightEdit& a, const LightEdit& b) {
  return a.sphere == b.sphere && a.radius == b.radius && same(a.center, b.center) && same(a.power, b.power);
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
  LightEdit light;  // the first light's centre, radius and power, where it is a sphere

  bool operator==(const ImageSettings& o) const {
    return same(camera, o.camera) && integrator == o.integrator && width == o.width && height == o.height &&
           split == o.split && left == o.left && right == o.right && equal_time == o.equal_time &&
           same(light, o.light);
  }
};


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

class RenderScheduler {
 public:
  bool started() const { return started_; }                   // false until the first restart, and after clear()
  const ImageSettings& applied() const { return applied_; }   // the settings of the images on screen
  const std::vector<Side>& sides() const { return sides_; }  // one, or the split screen's left and right
  double seconds_since_restart() const;

  // Starts the images over for `s`: each side a frame of `base` with the side's strategy, the right side with
  // base's seed + 1 (so that the two sides' errors are independent: equal strategies show a seam, two estimates).
  // The last restart's images are reused where they write the same kind of pixels (`device_pixels`: a device
  // image keeps its GPU buffers while the camera moves); else `make_image` makes one.
  void restart(const ImageSettings& s, const FrameSpec& base, bool device_pixels,
               const std::function<std::unique_ptr<ProgressiveImage>()>& make_image);
  // Drops the images (their backend is going); the next restart makes new ones.
  void clear();

  struct Frame {
    double ms = 0;           // render time of the frame's samples
    uint64_t nonfinite = 0;  // samples the backend left out (NaN or infinite)
    std::string refused;     // why a side rendered nothing, where the backend refused its settings
  };
  // This frame's samples: `spp` to each image; at equal time (split screen) the side that is ahead adds `spp`
  // and the other catches up at its own measured cost per sample, so that both have had the same render time.
  // `backend` is the images' (for its statistics of each render).
  Frame render(uint32_t spp, const Backend& backend);

  int divider_column(float divider) const;  // the right side's first column; the width without split screen
  // The screen's image: the left side's columns left of the divider, the right side's from it.
  std::vector<float> composed_mean(float divider) const;
  // The same into a device image (device images only, ProgressiveImage::write_mean_device).
  void write_mean_device(float* rgb, float divider) const;
  void tone_map(const DisplayPixels& px, float divider, float exposure) const;
  bool writes_device_pixels() const { return !sides_.empty() && sides_[0].image->writes_device_pixels(); }

 private:
  std::vector<Side> sides_;
  ImageSettings applied_;
  bool started_ = false;
  Clock::time_point restart_time_;
};

}  // namespace pn::viewer
