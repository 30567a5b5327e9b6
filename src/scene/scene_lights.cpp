// A parsed scene's lights completed (finalize_scene): a triangle light for
// every emissive triangle of every instance, the environment's light and its
// sampling distribution, the power-proportional selection CDF and the light BVH;
// and a sphere light edited in place (set_sphere_light).
#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

#include "scene/json_node.h"
#include "scene/scene.h"

namespace pn {

namespace {

// Normalizes a piecewise-constant function into a CDF; returns its integral
// (sum / n). An all-zero function gets a uniform CDF and integral 0.
float build_cdf(const float* func, size_t n, float* cdf) {
  double sum = 0.0;
  cdf[0] = 0.f;
  std::vector<double> acc(n + 1, 0.0);
  for (size_t i = 0; i < n; ++i) acc[i + 1] = acc[i] + double(func[i]);
  sum = acc[n];
  for (size_t i = 1; i <= n; ++i) cdf[i] = sum > 0.0 ? float(acc[i] / sum) : float(double(i) / double(n));
  cdf[n] = 1.f;
  return float(sum / double(n));
}

// The density max(0, lum - minus) x sin(theta) over a W x H image (lum row by row, sin_theta by row), as its
// marginal and conditional CDFs; every value 0 (nothing above `minus`) gives integral 0, an empty distribution.
// A texel within 1e-5 (relative) of `minus` counts as at it: a constant image, whose mean rounds a little below
// some texels, gives an empty distribution, not a few texels of rounding noise.
void build_environment_distribution(const std::vector<float>& lum, const std::vector<float>& sin_theta, int W, int H,
                                    float minus, EnvironmentDistribution* d) {
  d->conditional_func.assign(size_t(W) * H, 0.f);
  d->conditional_cdf.assign(size_t(W + 1) * H, 0.f);
  d->marginal_func.assign(size_t(H), 0.f);
  d->marginal_cdf.assign(size_t(H) + 1, 0.f);
  for (int y = 0; y < H; ++y) {
    float* f = &d->conditional_func[size_t(y) * W];
    for (int x = 0; x < W; ++x) {
      const float excess = lum[size_t(y) * W + size_t(x)] - minus;
      f[x] = excess > 1e-5f * minus ? excess * sin_theta[size_t(y)] : 0.f;
    }
    d->marginal_func[size_t(y)] = build_cdf(f, size_t(W), &d->conditional_cdf[size_t(y) * (W + 1)]);
  }
  d->integral = build_cdf(d->marginal_func.data(), size_t(H), d->marginal_cdf.data());
}

float average_luminance(const TextureImage& t) {
  if (t.width <= 0 || t.height <= 0) return 1.f;
  TextureView v = t.view();
  double sum = 0.0;
  for (int y = 0; y < t.height; ++y)
    for (int x = 0; x < t.width; ++x) sum += luminance(texel_fetch(v, x, y).rgb);
  return float(sum / (double(t.width) * t.height));
}

void build_light_selection(Scene& s, std::vector<float>& tex_avg);

}  // namespace

void finalize_scene(Scene& s) {
  // Emissive triangles become triangle lights, instance by instance, in world space.
  s.lights.erase(std::remove_if(s.lights.begin(), s.lights.end(),
                                [](const Light& l) { return l.type == LightType::Triangle || l.type == LightType::Environment; }),
                 s.lights.end());
  for (TriangleMesh& m : s.meshes) m.face_lights.clear();
  std::vector<float> tex_avg(s.textures.size(), -1.f);
  auto emits = [&](uint32_t mat) { return !is_black(s.materials[mat].emission); };
  for (Instance& inst : s.instances) {
    inst.light_base = -1;
    // Quad lights are lights already; an instance none of whose materials emits has none.
    if (inst.light >= 0 || !s.instance_emits(inst)) continue;
    TriangleMesh& m = s.meshes[inst.mesh];
    // Ranks are per mesh, so every instance of it numbers its triangles alike.
    auto& fl = m.face_lights;
    if (fl.empty()) fl.assign(m.indices.size(), -1);
    inst.light_base = int32_t(s.lights.size());
    int32_t rank = 0;
    for (size_t t = 0; t < m.indices.size(); ++t) {
      uint32_t mat = m.face_materials.empty() ? inst.material : m.face_materials[t];
      const auto& tri = m.indices[t];
      Vec3 p0 = inst.to_world.point(m.positions[tri[0]]), p1 = inst.to_world.point(m.positions[tri[1]]),
           p2 = inst.to_world.point(m.positions[tri[2]]);
      if (!emits(mat) || !(length(cross(p1 - p0, p2 - p0)) > 0.f)) {
        fl[t] = -1;
        continue;
      }
      fl[t] = rank++;
      const Material& mm = s.materials[mat];
      Light l = Light::triangle(p0, p1, p2, mm.emission);
      // A mirroring transform reverses the world-space winding; the side that
      // emits is the one hits call front (the object normal's inverse transpose).
      if (inst.to_world.linear_determinant() < 0.f) l.n = -l.n;
      if (!m.uvs.empty()) {
        l.uv0 = m.uvs[tri[0]];
        l.uv1 = m.uvs[tri[1]];
        l.uv2 = m.uvs[tri[2]];
      }
      l.emission_tex = mm.emission_tex;
      s.lights.push_back(l);
    }
  }

  // The environment: its light and the distribution that samples it.
  Environment& env = s.environment;
  if (env.texture >= 0) {
    const TextureImage& img = s.textures[size_t(env.texture)];
    const int W = img.width, H = img.height;
    TextureView v = img.view();
    std::vector<float> lum(size_t(W) * size_t(H)), sin_theta(static_cast<size_t>(H));
    double weighted = 0.0, weights = 0.0;  // the mean luminance over the sphere: texels weighted by their solid angle
    for (int y = 0; y < H; ++y) {
      sin_theta[size_t(y)] = std::sin(kPi * (float(y) + 0.5f) / float(H));
      for (int x = 0; x < W; ++x) {
        const float l = pn_max(0.f, luminance(texel_fetch(v, x, y).rgb));
        lum[size_t(y) * W + size_t(x)] = l;
        weighted += double(l) * sin_theta[size_t(y)];
        weights += sin_theta[size_t(y)];
      }
    }
    const float mean = weights > 0.0 ? float(weighted / weights) : 0.f;
    build_environment_distribution(lum, sin_theta, W, H, 0.f, &env.distribution);
    build_environment_distribution(lum, sin_theta, W, H, mean, &env.compensated);
    Light l;
    l.type = LightType::Environment;
    l.radiance = env.scale;
    s.lights.push_back(l);
  }

  build_light_selection(s, tex_avg);
}

namespace {

// Selection in proportion to power (the luminance of Phi), and the light BVH. `tex_avg`: each texture's average
// luminance where known, else -1 (filled here as needed).
void build_light_selection(Scene& s, std::vector<float>& tex_avg) {
  const Environment& env = s.environment;
  const float R = s.bounding_radius();
  s.light_cdf.assign(s.lights.size() + 1, 0.f);
  std::vector<float> power(s.lights.size(), 0.f);
  for (size_t i = 0; i < s.lights.size(); ++i) {
    const Light& l = s.lights[i];
    float p = 0.f;
    if (l.type == LightType::Environment) {
      // Phi = pi R^2 * integral of L over the sphere of directions.
      p = kPi * R * R * 2.f * kPi * kPi * env.distribution.integral * luminance(env.scale);
    } else {
      float tex = 1.f;
      if (l.type == LightType::Triangle && l.emission_tex >= 0) {
        float& a = tex_avg[size_t(l.emission_tex)];
        if (a < 0.f) a = average_luminance(s.textures[size_t(l.emission_tex)]);
        tex = a;
      }
      p = kPi * l.area * luminance(l.radiance) * tex;
    }
    power[i] = std::isfinite(p) ? pn_max(0.f, p) : 0.f;
  }
  if (!s.lights.empty()) build_cdf(power.data(), power.size(), s.light_cdf.data());
  else s.light_cdf.clear();

  // The light BVH over the lights with a surface; the environment beside it
  // with its share of the power, clamped (core/light_selection.h).
  s.light_bvh = build_light_bvh(s.lights, power);
  s.infinite_light_probability = 0.f;
  double total = 0, infinite = 0;
  for (size_t i = 0; i < s.lights.size(); ++i) {
    total += power[i];
    if (s.lights[i].type == LightType::Environment) infinite += power[i];
  }
  if (env.texture >= 0) {
    if (s.light_bvh.nodes.empty()) s.infinite_light_probability = 1.f;
    else
      s.infinite_light_probability = float(std::clamp(total > 0 ? infinite / total : 0.5, double(kMinInfiniteProbability),
                                                      1.0 - double(kMinInfiniteProbability)));
  }
}

}  // namespace

Vec3 sphere_light_radiance(Vec3 power, float radius) {
  const float area = 4.f * kPi * radius * radius;
  return power / (kPi * area);
}

void set_sphere_light(Scene& s, size_t light, Vec3 center, float radius, Vec3 power) {
  auto fail = [&](const std::string& msg) {
    throw SceneError(s.source + ": light " + std::to_string(light) + ": " + msg);
  };
  if (light >= s.lights.size() || s.lights[light].type != LightType::Sphere) fail("is not a sphere light");
  // The scene format's limits (scene/json_node.h).
  using scene_detail::kMaxCoordinate;
  using scene_detail::kMaxEmission;
  for (int i = 0; i < 3; ++i) {
    if (!(std::abs(center[i]) <= kMaxCoordinate)) fail("centre out of range [-1e7, 1e7]");
    if (!(power[i] >= 0.f && power[i] <= kMaxEmission)) fail("power out of range [0, 1e9]");
  }
  if (!(radius > 0.f && radius <= kMaxCoordinate)) fail("radius out of range (0, 1e7]");
  const Vec3 L = sphere_light_radiance(power, radius);
  if (!is_finite(L)) fail("radius too small for the given power (radiance overflows)");
  s.lights[light] = Light::sphere(center, radius, L);
  for (Sphere& sp : s.spheres)
    if (sp.light == int32_t(light)) {
      sp.center = center;
      sp.radius = radius;
    }
  std::vector<float> tex_avg(s.textures.size(), -1.f);
  build_light_selection(s, tex_avg);
}

}  // namespace pn
