#include "scene/procedural.h"

#include <cmath>
#include <limits>
#include <vector>

namespace pn::scene_detail {
namespace {

constexpr int kMaxScatterLights = 1000000;

}  // namespace

TriangleMesh quad_mesh(const std::string& name, Vec3 corner, Vec3 e1, Vec3 e2) {
  TriangleMesh m;
  m.name = name;
  m.positions = {corner, corner + e1, corner + e1 + e2, corner + e2};
  m.indices = {{0, 1, 2}, {0, 2, 3}};
  return m;
}

TriangleMesh box_mesh(const std::string& name, Vec3 center, Vec3 size, float rot_y) {
  float c = std::cos(rot_y * kPi / 180.f), sn = std::sin(rot_y * kPi / 180.f);
  TriangleMesh m;
  m.name = name;
  for (int i = 0; i < 8; ++i) {
    Vec3 q((i & 1 ? 0.5f : -0.5f) * size.x, (i & 2 ? 0.5f : -0.5f) * size.y, (i & 4 ? 0.5f : -0.5f) * size.z);
    m.positions.push_back(center + Vec3(c * q.x + sn * q.z, q.y, -sn * q.x + c * q.z));
  }
  // Faces as corner quads (a, b, c, d) counter-clockwise seen from outside.
  const int faces[6][4] = {{0, 2, 3, 1}, {4, 5, 7, 6}, {0, 1, 5, 4}, {2, 6, 7, 3}, {0, 4, 6, 2}, {1, 3, 7, 5}};
  for (const auto& f : faces) {
    m.indices.push_back({uint32_t(f[0]), uint32_t(f[1]), uint32_t(f[2])});
    m.indices.push_back({uint32_t(f[0]), uint32_t(f[2]), uint32_t(f[3])});
  }
  return m;
}

uint32_t add_mesh(Scene& s, TriangleMesh m) {
  s.meshes.push_back(std::move(m));
  return uint32_t(s.meshes.size() - 1);
}

void add_instance(Scene& s, uint32_t mesh, const Affine& to_world, uint32_t material, int32_t light) {
  Instance inst;
  inst.mesh = mesh;
  inst.to_world = to_world;
  bool ok = false;
  inst.to_object = inverse(to_world, &ok);
  inst.material = material;
  inst.light = light;
  s.instances.push_back(inst);
}

// "type": "scatter": `count` sphere lights placed by a seeded generator, so
// that a scene can hold thousands of lights (and a parameter choose how many)
// without listing them (docs/scene-format.md). Centres uniform in the box
// [min, max] ("layout": "random") or evenly spaced from min to max ("line");
// radii uniform in `radius` ([lo, hi] or one number); each light's share of
// the total `power` proportional to a weight log-uniform in [1, power_spread];
// its colour one of `colors` at random (normalised to luminance 1, so that
// the share is the luminance of its power).
void parse_scatter(const Node& n, Scene& s, uint32_t material) {
  n.expect_object({"type", "count", "seed", "min", "max", "layout", "radius", "power", "power_spread", "colors",
                   "material"});
  for (auto k : {"count", "min", "max", "radius", "power"}) n.require(k);
  const int count = n.at("count").integer(1, kMaxScatterLights);
  const uint32_t seed = n.has("seed") ? uint32_t(n.at("seed").integer(0, long(std::numeric_limits<uint32_t>::max()))) : 0u;
  const Vec3 lo = n.at("min").vec3(), hi = n.at("max").vec3();
  if (!(lo.x <= hi.x && lo.y <= hi.y && lo.z <= hi.z)) n.at("max").fail("must be >= min in every coordinate");
  bool line = false;
  if (n.has("layout")) {
    const std::string layout = n.at("layout").string();
    if (layout != "random" && layout != "line")
      n.at("layout").fail("unknown layout '" + layout + "' (expected random or line)");
    line = layout == "line";
  }
  float r0, r1;
  const Node rn = n.at("radius");
  if (rn.j.is_array()) {
    if (rn.j.size() != 2) rn.fail("expected a number or [min, max]");
    r0 = rn.at(size_t(0)).positive(kMaxCoordinate);
    r1 = rn.at(size_t(1)).positive(kMaxCoordinate);
    if (r1 < r0) rn.at(size_t(1)).fail("must be >= the minimum radius");
  } else {
    r0 = r1 = rn.positive(kMaxCoordinate);
  }
  const float total = n.at("power").positive(1e9);
  const float spread = n.has("power_spread") ? n.at("power_spread").real(1.0, 1e6) : 1.f;
  std::vector<Vec3> colors;
  if (n.has("colors")) {
    const Node cn = n.at("colors");
    if (!cn.j.is_array() || cn.j.empty()) cn.fail("expected a non-empty array of colours");
    for (size_t i = 0; i < cn.j.size(); ++i) {
      const Vec3 c = cn.at(i).color(1e6f);
      if (!(luminance(c) > 0.f)) cn.at(i).fail("must not be black");
      colors.push_back(c / luminance(c));
    }
  } else {
    colors.push_back(Vec3(1.f));
  }
  // One PCG stream per scatter, from its seed: the same lights on every machine.
  Rng rng;
  rng.seed_pcg(mix64(seed), mix64(uint64_t(seed) + 0x5ca77e5ull));
  struct Placed {
    Vec3 c;
    float r, weight;
    uint32_t color;
  };
  std::vector<Placed> placed(static_cast<size_t>(count));
  double weights = 0;
  for (int i = 0; i < count; ++i) {
    Placed& p = placed[size_t(i)];
    if (line) {
      const float t = count > 1 ? float(i) / float(count - 1) : 0.5f;
      p.c = lo + (hi - lo) * t;
    } else {
      const Vec3 u(rng.uniform(), rng.uniform(), rng.uniform());
      p.c = lo + (hi - lo) * u;
    }
    p.r = r0 + (r1 - r0) * rng.uniform();
    p.weight = std::pow(spread, rng.uniform());
    p.color = pn_min(uint32_t(rng.uniform() * float(colors.size())), uint32_t(colors.size() - 1));
    weights += p.weight;
  }
  for (const Placed& p : placed) {
    const float area = 4.f * kPi * p.r * p.r;
    const Vec3 L = colors[p.color] * float(double(total) * p.weight / weights / (kPi * area));
    if (!is_finite(L)) n.at("radius").fail("too small for the given power (radiance overflows)");
    const int32_t index = int32_t(s.lights.size());
    s.lights.push_back(Light::sphere(p.c, p.r, L));
    s.spheres.push_back(Sphere{p.c, p.r, material, index});
  }
}

}  // namespace pn::scene_detail
