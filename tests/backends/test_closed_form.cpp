// Whole renders against exact expectations, pixel by pixel: a Lambertian plane
// lit by one sphere, quad or emissive triangle, direct lighting only
// (max_depth 1), seen from above. Each pixel's expectation is its box-filtered
// integral of the reflected radiance, computed here in double by Gauss-Legendre
// quadrature over the pixel of the closed-form irradiance:
//   sphere, wholly above the plane:  E = pi L (r / d)^2 cos(beta)
//   polygon, wholly above the plane: E = L |sum_i theta_i n . Gamma_i| / 2 (Lambert)
// and the reflected radiance is albedo E / pi. For every strategy x MIS mode,
// with the plane as two large (120 x 120) and two small (12 x 12) triangles, and
// with the light close to the plane:
//   - the image mean's relative error is within 3 standard errors of 0, and that
//     standard error is below 0.01% (so a bias of 0.03% fails);
//   - the mean of z^2 over pixels, z = (pixel - exact) / its standard error, lies
//     in [0.8, 1.25] (a pattern of per-pixel errors that averages out fails).
// The backend is the CPU's; PENUMBRA_TEST_BACKEND=optix runs the same cases on
// the GPU (CTest label gpu; PENUMBRA_TEST_TRAVERSAL=cuda|optix|auto the
// wavefront's trace stage, PENUMBRA_TEST_MEGAKERNEL=1 the megakernel), and
// PENUMBRA_TEST_SPP_SCALE multiplies every case's spp.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdlib>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

#include "backends/make_backend.h"
#include "double_vec.h"
#include "render/backend.h"
#include "scene/scene.h"

namespace pn {
namespace {

using json = nlohmann::json;

using test::D3;
using test::cross;
using test::dot;
using test::len;
using test::unit;

enum class LightKind { Sphere, Quad, Triangle };

struct Case {
  std::string name;
  LightKind kind = LightKind::Sphere;
  double half_size = 60;  // the plane is [-h, h]^2 at y = 0, two triangles
  double height = 1.0;    // of the light's lowest point above the plane
  bool every_technique = false;  // the noisy techniques too (else the precise ones only)
  // The standard error a case accepts on the CPU, in units of its techniques' bounds: a light close to the
  // plane lights the view from near the horizon, where every technique's variance is several times larger;
  // CI's budget takes them to 0.02-0.05% (the bias of moved hit points was 0.1% and 0.4% here).
  double cpu_error_factor = 1;
  int size = 32;                 // image width = height
  int spp = 1024;
};

constexpr double kAlbedo = 0.5;
constexpr double kRadiance = 4.0;
const D3 kEye{0, 2, 0};
constexpr double kFov = 40;

// The light: a sphere of radius 0.3, a 0.6 x 1.0 quad or a triangle, all outside
// the camera's view (which covers |x|, |z| < 0.73 of the plane) and facing it.
struct LightGeometry {
  D3 center;
  double radius = 0;
  std::vector<D3> polygon;  // counter-clockwise seen from below (they emit downwards)
};

LightGeometry light_geometry(const Case& c) {
  LightGeometry g;
  if (c.kind == LightKind::Sphere) {
    g.radius = 0.3;
    g.center = {1.0, c.height + g.radius, 0.2};
  } else if (c.kind == LightKind::Quad) {
    const double y = c.height;
    g.polygon = {{1.0, y, -0.5}, {1.6, y, -0.5}, {1.6, y, 0.5}, {1.0, y, 0.5}};
  } else {
    const double y = c.height;
    g.polygon = {{1.0, y, -0.6}, {1.7, y, 0.1}, {1.0, y, 0.7}};
  }
  return g;
}

json vec(D3 v) { return json::array({v.x, v.y, v.z}); }

json scene_json(const Case& c, const std::string& strategy, const std::string& mis, uint32_t seed) {
  const double h = c.half_size;
  json s;
  s["camera"] = {{"eye", vec(kEye)}, {"target", json::array({0, 0, 0})}, {"up", json::array({0, 0, -1})},
                 {"fov", kFov}};
  s["render"] = {{"width", c.size},         {"height", c.size}, {"spp", c.spp}, {"max_depth", 1},
                 {"strategy", strategy},    {"mis", mis},       {"seed", seed}, {"light_selection", "uniform"}};
  s["materials"] = {{"floor", {{"albedo", kAlbedo}}}, {"lamp", {{"albedo", 0.0}, {"emission", kRadiance}}}};
  s["shapes"] = json::array({{{"type", "quad"},
                              {"corner", json::array({-h, 0, -h})},
                              {"edge1", json::array({0, 0, 2 * h})},
                              {"edge2", json::array({2 * h, 0, 0})},
                              {"material", "floor"}}});
  const LightGeometry g = light_geometry(c);
  if (c.kind == LightKind::Sphere) {
    s["lights"] = json::array(
        {{{"type", "sphere"}, {"center", vec(g.center)}, {"radius", g.radius}, {"radiance", kRadiance}}});
  } else if (c.kind == LightKind::Quad) {
    // Emits on the side of edge1 x edge2: downwards.
    s["lights"] = json::array({{{"type", "quad"},
                                {"corner", vec(g.polygon[0])},
                                {"edge1", vec(g.polygon[1] - g.polygon[0])},
                                {"edge2", vec(g.polygon[3] - g.polygon[0])},
                                {"radiance", kRadiance}}});
  } else {
    // An emissive triangle emits on the side its winding makes front: downwards.
    json pos = json::array({vec(g.polygon[0]), vec(g.polygon[1]), vec(g.polygon[2])});
    s["shapes"].push_back({{"type", "mesh"},
                           {"positions", pos},
                           {"indices", json::array({json::array({0, 1, 2})})},
                           {"material", "lamp"}});
  }
  return s;
}

// Irradiance at a point x of the plane (normal +y).
double irradiance(const LightGeometry& g, D3 x) {
  const D3 n{0, 1, 0};
  if (g.polygon.empty()) {
    const D3 to = g.center - x;
    const double d = len(to);
    return M_PI * kRadiance * (g.radius / d) * (g.radius / d) * dot(n, to) / d;
  }
  double sum = 0;
  const size_t k = g.polygon.size();
  for (size_t i = 0; i < k; ++i) {
    const D3 a = unit(g.polygon[i] - x), b = unit(g.polygon[(i + 1) % k] - x);
    const D3 c = cross(a, b);
    const double theta = std::atan2(len(c), dot(a, b));
    sum += theta * dot(n, c) / len(c);
  }
  return kRadiance * 0.5 * std::fabs(sum);
}

// A pixel's exact value: the mean over the pixel's square of the radiance
// reflected towards the camera (the camera's rays as core/camera.h makes them).
std::vector<double> exact_image(const Case& c) {
  static const double kNodes[8] = {-0.9602898564975363, -0.7966664774136267, -0.5255324099163290,
                                   -0.1834346424956498, 0.1834346424956498,  0.5255324099163290,
                                   0.7966664774136267,  0.9602898564975363};
  static const double kWeights[8] = {0.1012285362903763, 0.2223810344533745, 0.3137066458778873,
                                     0.3626837833783620, 0.3626837833783620, 0.3137066458778873,
                                     0.2223810344533745, 0.1012285362903763};
  const LightGeometry g = light_geometry(c);
  const D3 forward{0, -1, 0};
  const D3 right = unit(cross(forward, D3{0, 0, -1}));
  const D3 up = cross(right, forward);
  const double half = std::tan(0.5 * kFov * M_PI / 180.0);
  std::vector<double> img(size_t(c.size) * c.size);
  for (int py = 0; py < c.size; ++py)
    for (int px = 0; px < c.size; ++px) {
      double v = 0;
      for (int i = 0; i < 8; ++i)
        for (int j = 0; j < 8; ++j) {
          const double fx = px + 0.5 + 0.5 * kNodes[i], fy = py + 0.5 + 0.5 * kNodes[j];
          const double sx = 2 * fx / c.size - 1, sy = 1 - 2 * fy / c.size;
          const D3 d = forward + right * (half * sx) + up * (half * sy);
          const D3 x = kEye + d * (-kEye.y / d.y);
          v += kWeights[i] * kWeights[j] * 0.25 * kAlbedo / M_PI * irradiance(g, x);
        }
      img[size_t(py) * c.size + px] = v;
    }
  return img;
}

std::string env_or(const char* name, const char* fallback) {
  const char* v = std::getenv(name);
  return v && *v ? v : fallback;
}
double spp_scale() {
  const char* s = std::getenv("PENUMBRA_TEST_SPP_SCALE");
  return s && *s ? std::atof(s) : 1.0;
}

struct Verdict {
  double rel_error = 0, std_error = 0, mean_z2 = 0;
};

// A scene rendered at its spp by the backend the environment names (the header says which).
Film render_scene(const Scene& s) {
  std::string note;
  BackendOptions options;
  const std::string traversal = env_or("PENUMBRA_TEST_TRAVERSAL", "auto");
  if (!find_traversal(traversal, &options.traversal))
    throw std::invalid_argument("PENUMBRA_TEST_TRAVERSAL: " + traversal + " is none of " + traversal_names());
  options.wavefront = env_or("PENUMBRA_TEST_MEGAKERNEL", "0") == std::string("0");
  auto backend = make_backend(env_or("PENUMBRA_TEST_BACKEND", "cpu"), s, options, &note);
  Film film(s.render.width, s.render.height);
  backend->render(frame_spec(s), film, 0, uint32_t(s.render.spp));
  return film;
}

Verdict check_against_exact(const Case& c, const std::string& strategy, const std::string& mis, uint32_t seed) {
  Case scaled = c;
  scaled.spp = std::max(2, int(std::lround(c.spp * spp_scale())));
  const Film film = render_scene(parse_scene(scene_json(scaled, strategy, mis, seed), "closed_form.json", "."));
  const std::vector<float> mean = film.mean(), var = film.variance_of_mean();
  const std::vector<double> exact = exact_image(c);
  double sum = 0, sum_exact = 0, sum_var = 0, z2 = 0;
  for (size_t i = 0; i < exact.size(); ++i) {
    const double m = mean[3 * i], v = var[3 * i];  // white light, grey floor: the channels are equal
    sum += m;
    sum_exact += exact[i];
    sum_var += v;
    z2 += (m - exact[i]) * (m - exact[i]) / std::max(v, 1e-30);
  }
  Verdict r;
  r.rel_error = (sum - sum_exact) / sum_exact;
  r.std_error = std::sqrt(sum_var) / sum_exact;
  r.mean_z2 = z2 / double(exact.size());
  return r;
}

// A technique, its samples per pixel in CI (on the CPU) and the largest standard
// error of the image mean its check accepts there. Where a light sampler does its
// work (solid angle, projected solid angle, with or without MIS) 1-8 million
// samples bring the standard error below 0.01%; area sampling of a sphere wastes
// half its samples on the far side and bsdf finds the light by chance, so CI's
// budget takes them to about 0.06% and 0.15%. With PENUMBRA_TEST_SPP_SCALE = s
// (the GPU run) every bound becomes max(0.01%, bound / sqrt(s)), the case's factor
// included.
struct Technique {
  std::string strategy, mis;
  int spp = 1024;
  double max_std_error = 1e-4;
};

const std::vector<Technique>& precise_techniques() {
  static const std::vector<Technique> t = {
      {"projected-solid-angle", "none", 1024}, {"projected-solid-angle", "power", 1024},
      {"solid-angle", "none", 2048},           {"solid-angle", "power", 2048},
      {"solid-angle", "balance", 12288},       {"projected-solid-angle", "balance", 12288}};
  return t;
}
const std::vector<Technique>& noisy_techniques() {
  static const std::vector<Technique> t = {{"area", "none", 8192, 1e-3},
                                           {"area", "power", 8192, 1e-3},
                                           {"area", "balance", 8192, 1e-3},
                                           {"bsdf", "none", 16384, 2.5e-3}};
  return t;
}

void expect_exact(const Case& c, const Technique& t, uint32_t seed) {
  Case cc = c;
  cc.spp = t.spp;
  const double scale = spp_scale();
  const double bound = t.max_std_error * c.cpu_error_factor;
  const double max_se = scale > 1 ? std::max(1e-4, bound / std::sqrt(scale)) : bound;
  const Verdict v = check_against_exact(cc, t.strategy, t.mis, seed);
  std::ostringstream what;
  what << c.name << " " << t.strategy << " mis " << t.mis << ": rel. error " << v.rel_error * 100 << "% +- "
       << v.std_error * 100 << "%, mean z^2 " << v.mean_z2;
  std::printf("  %s\n", what.str().c_str());
  EXPECT_LT(v.std_error, max_se) << what.str() << " (too few samples for the test's power)";
  EXPECT_LT(std::fabs(v.rel_error), 3 * v.std_error) << what.str();
  EXPECT_GE(v.mean_z2, 0.8) << what.str();
  EXPECT_LE(v.mean_z2, 1.25) << what.str();
}

void PrintTo(const Case& c, std::ostream* os) { *os << c.name; }

class ClosedForm : public ::testing::TestWithParam<Case> {};

TEST_P(ClosedForm, TechniquesMatchTheExactImage) {
  const Case& c = GetParam();
  uint32_t seed = 1;
  for (const Technique& t : precise_techniques()) expect_exact(c, t, seed++);
  if (c.every_technique)
    for (const Technique& t : noisy_techniques()) expect_exact(c, t, seed++);
}

// A lone plane cannot be hit again by a ray that leaves it: with global
// illumination (max_depth 4) its image is the direct-lighting one (max_depth 1)
// with the same seed, sample for sample. A bounce that finds the plane it left
// (a self-intersection: the trace stage's rounding beyond the hit point's error
// bound) adds a vertex there and light. The plane is tilted, off the origin and
// tessellated into 5,000 triangles, so that its vertices round and its bounce
// rays leave one triangle over its coplanar neighbours, at every angle the
// cosine-weighted BSDF sample takes, grazing ones included.
json lone_plane_scene(int max_depth) {
  const int n = 50;
  const double size = 120;
  // Rotation by 23.7 degrees about the unit axis a (Rodrigues), then a shift.
  const D3 a = unit(D3{0.3, 0.2, 0.9});
  const double ang = 23.7 * M_PI / 180.0, c = std::cos(ang), s = std::sin(ang);
  auto rotate = [&](D3 v) { return v * c + cross(a, v) * s + a * (dot(a, v) * (1 - c)); };
  const D3 shift{37.31, 11.27, -21.73};
  json positions = json::array(), indices = json::array();
  for (int i = 0; i <= n; ++i)
    for (int k = 0; k <= n; ++k)
      positions.push_back(vec(rotate(D3{(double(i) / n - 0.5) * size, 0, (double(k) / n - 0.5) * size}) + shift));
  for (int i = 0; i < n; ++i)
    for (int k = 0; k < n; ++k) {
      const int v00 = i * (n + 1) + k, v01 = v00 + 1, v10 = v00 + n + 1, v11 = v10 + 1;
      indices.push_back(json::array({v00, v01, v11}));
      indices.push_back(json::array({v00, v11, v10}));
    }
  const D3 normal = rotate(D3{0, 1, 0});
  json sc;
  sc["camera"] = {{"eye", vec(shift + normal * 6 + rotate(D3{-9, 0, -7}))},
                  {"target", vec(shift + rotate(D3{1, 0, 0.5}))},
                  {"up", vec(normal)},
                  {"fov", 60}};
  sc["render"] = {{"width", 48},        {"height", 32},  {"spp", 64},  {"max_depth", max_depth}, {"rr_depth", 5},
                  {"strategy", "solid-angle"}, {"mis", "power"}, {"seed", 7}};
  sc["materials"] = {{"floor", {{"albedo", 0.8}}}};
  sc["shapes"] = json::array({{{"type", "mesh"}, {"positions", positions}, {"indices", indices}, {"material", "floor"}}});
  sc["lights"] = json::array({{{"type", "sphere"},
                               {"center", vec(shift + normal * 0.8 + rotate(D3{2, 0, 1}))},
                               {"radius", 0.5},
                               {"radiance", 20}}});
  return sc;
}

std::vector<float> render_mean(json doc) {
  doc["render"]["spp"] = std::max(1, int(std::lround(doc["render"]["spp"].get<int>() * spp_scale())));
  return render_scene(parse_scene(doc, "lone_plane.json", ".")).mean();
}

TEST(LonePlane, ABounceNeverFindsThePlaneItLeft) {
  const std::vector<float> direct = render_mean(lone_plane_scene(1)), global = render_mean(lone_plane_scene(4));
  ASSERT_EQ(direct.size(), global.size());
  double sum_direct = 0, sum_global = 0;
  size_t brighter = 0;
  for (size_t i = 0; i < direct.size(); ++i) {
    sum_direct += direct[i];
    sum_global += global[i];
    // The same samples summed (on the GPU perhaps in another order): equal to float rounding.
    if (global[i] > direct[i] * (1 + 1e-5f) + 1e-12f) ++brighter;
  }
  ASSERT_GT(sum_direct, 0.0) << "the plane is not lit in view";
  std::printf("  lone plane: image mean depth 1 %.9g, depth 4 %.9g (rel. %.3g), %zu of %zu values brighter\n",
              sum_direct / double(direct.size()), sum_global / double(direct.size()),
              sum_global / sum_direct - 1, brighter, direct.size());
  EXPECT_EQ(brighter, 0u) << "bounce rays found the plane they left";
  EXPECT_LT(std::fabs(sum_global / sum_direct - 1), 1e-6);
}

std::string case_name(const ::testing::TestParamInfo<Case>& info) { return info.param.name; }

INSTANTIATE_TEST_SUITE_P(Planes, ClosedForm,
                         ::testing::Values(Case{"SphereLargeTriangles", LightKind::Sphere, 60, 1.0, true},
                                           Case{"SphereSmallTriangles", LightKind::Sphere, 6, 1.0},
                                           Case{"SphereClose", LightKind::Sphere, 60, 0.1, false, 5},
                                           Case{"QuadLargeTriangles", LightKind::Quad, 60, 1.0, true},
                                           Case{"QuadSmallTriangles", LightKind::Quad, 6, 1.0},
                                           Case{"QuadClose", LightKind::Quad, 60, 0.1, false, 5},
                                           Case{"TriangleLargeTriangles", LightKind::Triangle, 60, 1.0, true},
                                           Case{"TriangleSmallTriangles", LightKind::Triangle, 6, 1.0}),
                         case_name);

}  // namespace
}  // namespace pn
