// Pinhole camera: look-at frame, vertical field of view, aspect = width/height.
#pragma once

#include "common.h"
#include "vec.h"

namespace pn {

struct Camera {
  Vec3 eye;
  Vec3 forward, right, up;  // unit forward; right and up scaled to the image plane at distance 1
  int width = 1, height = 1;

  PN_HD static Camera look_at(Vec3 eye, Vec3 target, Vec3 up_hint, float vfov_deg, int width,
                              int height) {
    Camera c;
    c.eye = eye;
    c.width = width;
    c.height = height;
    c.forward = normalize(target - eye);
    Vec3 r = normalize(cross(c.forward, up_hint));
    Vec3 u = cross(r, c.forward);
    float half_h = std::tan(0.5f * vfov_deg * kPi / 180.f);
    float half_w = half_h * float(width) / float(height);
    c.right = r * half_w;
    c.up = u * half_h;
    return c;
  }

  // Ray through image position (px, py) in pixels; (0,0) is the top-left corner
  // of the image, (width, height) the bottom-right.
  PN_HD Ray generate_ray(float px, float py) const {
    float sx = 2.f * px / float(width) - 1.f;
    float sy = 1.f - 2.f * py / float(height);
    return Ray(eye, normalize(forward + right * sx + up * sy));
  }
};

}  // namespace pn
