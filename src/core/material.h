// Materials. Lambertian reflection for now: f = albedo / pi, two-sided.
#pragma once

#include "common.h"
#include "sampling.h"
#include "vec.h"

namespace pn {

struct Material {
  Vec3 albedo;  // diffuse reflectance in [0, 1]^3
};

// BSDF sample in world space. `weight` is f * |cos| / pdf, the throughput factor.
struct BsdfSample {
  Vec3 wi;
  Vec3 weight;
  float pdf = 0.f;
};

// Shading normal n faces the side the path arrived from.
PN_FN Vec3 bsdf_eval(const Material& m, Vec3 /*n*/, Vec3 /*wo*/, Vec3 /*wi*/) {
  return m.albedo * kInvPi;
}

PN_FN BsdfSample bsdf_sample(const Material& m, Vec3 n, Vec3 /*wo*/, Vec2 u) {
  BsdfSample s;
  Vec3 local = sample_cosine_hemisphere(u);
  s.wi = Frame::from_z(n).to_world(local);
  s.pdf = cosine_hemisphere_pdf(local.z);
  // f cos / pdf = (albedo / pi) cos / (cos / pi) = albedo
  s.weight = s.pdf > 0.f ? m.albedo : Vec3(0.f);
  return s;
}

}  // namespace pn
