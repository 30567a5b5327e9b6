// The viewer's windowless parts (src/apps/viewer): camera control, camera files,
// camera paths, the action table and its keys, progressive images and their
// tone-mapping. The window itself is tested under Xvfb by viewer_smoke.py.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <map>
#include <random>
#include <set>
#include <thread>

#include "apps/viewer/actions_table.h"
#include "apps/viewer/camera_control.h"
#include "apps/viewer/camera_path.h"
#include "apps/viewer/progressive.h"
#include "apps/viewer/scheduler.h"
#include "apps/viewer/tone_map.h"
#if PN_TEST_DEVICE_IMAGE
#include <cuda_runtime.h>

#include "apps/viewer/device_image.h"
#include "backends/optix/optix_backend.h"
#endif
#include "backends/make_backend.h"
#include "io/image.h"
#include "render/backend.h"
#include "scene/scene.h"

namespace pn::viewer {
namespace {

using json = nlohmann::json;

CameraDesc cornell_camera() { return load_scene("cornell-sphere").camera; }

void expect_near(Vec3 a, Vec3 b, float tol = 1e-4f) {
  EXPECT_NEAR(a.x, b.x, tol);
  EXPECT_NEAR(a.y, b.y, tol);
  EXPECT_NEAR(a.z, b.z, tol);
}

TEST(CameraControl, UntouchedIsTheScenesCameraBitForBit) {
  CameraDesc home = cornell_camera();
  CameraControl c(home);
  EXPECT_EQ(std::memcmp(&c.desc(), &home, sizeof home), 0);
  c.orbit(10, 5);
  c.reset();
  EXPECT_EQ(std::memcmp(&c.desc(), &home, sizeof home), 0);
}

TEST(CameraControl, OrbitKeepsTargetAndDistanceAndMovesTheEyeRight) {
  CameraControl c(cornell_camera());
  const Vec3 target = c.desc().target, eye = c.desc().eye, right = c.right();
  const float d = c.distance();
  c.orbit(20, 0);
  expect_near(c.desc().target, target, 0.f);
  EXPECT_NEAR(c.distance(), d, 1e-4f * d);
  EXPECT_GT(dot(c.desc().eye - eye, right), 0.f) << "positive yaw moves the eye to the camera's right";
  c.orbit(0, 30);
  EXPECT_GT(c.desc().eye.y, eye.y) << "positive pitch moves the eye up";
  // Elevation is clamped short of the pole, so the look-at frame stays valid.
  c.orbit(0, 500);
  float elevation = std::asin(dot(normalize(c.desc().eye - target), c.up())) * 180.f / kPi;
  EXPECT_NEAR(elevation, 89.f, 1e-2f);
  EXPECT_NO_THROW(Camera::look_at(c.desc().eye, c.desc().target, c.desc().up, c.desc().fov, 16, 9));
}

TEST(CameraControl, LookTurnsAboutTheEye) {
  CameraControl c(cornell_camera());
  const Vec3 eye = c.desc().eye, right = c.right(), fwd = c.forward();
  c.look(15, 0);
  expect_near(c.desc().eye, eye, 0.f);
  EXPECT_GT(dot(c.forward(), right), 0.f) << "positive yaw looks right";
  EXPECT_NEAR(dot(c.forward(), fwd), std::cos(15.f * kPi / 180.f), 1e-5f);
  c.look(0, 10);
  EXPECT_GT(dot(c.forward(), c.up()), 0.f) << "positive pitch looks up";
}

TEST(CameraControl, PanFollowsTheCursorByViewHeights) {
  CameraControl c(cornell_camera());
  const CameraDesc before = c.desc();
  const float view_height = 2.f * c.distance() * std::tan(0.5f * before.fov * kPi / 180.f);
  c.pan(0.5f, 0.f);  // drag right by half the window height: the camera moves left
  expect_near(c.desc().target - before.target, c.right() * (-0.5f * view_height));
  expect_near(c.desc().eye - before.eye, c.desc().target - before.target);
  c.set(before);
  c.pan(0.f, 1.f);  // drag down: the camera moves up
  EXPECT_NEAR(c.desc().target.y - before.target.y, view_height, 1e-4f);
}

TEST(CameraControl, DollyAndMove) {
  CameraControl c(cornell_camera());
  const CameraDesc before = c.desc();
  const float d = c.distance();
  c.dolly(0.5f);
  EXPECT_NEAR(c.distance(), 0.5f * d, 1e-4f);
  expect_near(c.desc().target, before.target, 0.f);
  c.dolly(0.f);  // ignored
  c.dolly(1e-9f);  // never reaches the target
  EXPECT_GT(c.distance(), 0.f);
  c.set(before);
  c.move(1.f, 2.f, 3.f);
  expect_near(c.desc().eye - before.eye, c.right() * 1.f + c.up() * 2.f + c.forward() * 3.f);
  EXPECT_NEAR(c.distance(), d, 1e-4f);
}

TEST(CameraFile, ShortestNumbersReadBackExactly) {
  for (float v : {2.78f, -8.f, 39.3f, 0.1f, 1e-7f, 3.14159274f, 123456.789f}) {
    json j = shortest_number(v);
    EXPECT_EQ(float(j.get<double>()), v) << j.dump();
  }
  EXPECT_EQ(shortest_number(2.78f).dump(), "2.78");
}

class TempDir : public ::testing::Test {
 protected:
  void SetUp() override {
    dir = std::filesystem::temp_directory_path() /
          ("penumbra_viewer_test_" + std::to_string(::testing::UnitTest::GetInstance()->random_seed()) + "_" +
           ::testing::UnitTest::GetInstance()->current_test_info()->name());
    std::filesystem::create_directories(dir);
  }
  void TearDown() override { std::filesystem::remove_all(dir); }
  std::filesystem::path dir;
};

using CameraSave = TempDir;

TEST_F(CameraSave, NewFileIsTheWholeSceneWithThisCamera) {
  CameraControl c(cornell_camera());
  c.orbit(12.5f, -7.f);
  c.set_fov(50.f);
  std::string path = (dir / "saved.json").string();
  save_camera(path, c.desc(), find_builtin("cornell-sphere")->make());
  Scene s = load_scene(path);  // a complete, valid scene
  EXPECT_EQ(std::memcmp(&s.camera, &c.desc(), sizeof(CameraDesc)), 0) << "the camera reads back exactly";
  EXPECT_EQ(s.lights.size(), 1u);
  CameraDesc loaded = load_camera(path);
  EXPECT_EQ(std::memcmp(&loaded, &c.desc(), sizeof(CameraDesc)), 0);
}

TEST_F(CameraSave, ExistingFileKeepsEverythingButTheCamera) {
  std::string path = (dir / "scene.json").string();
  json doc = find_builtin("cornell-near")->make();
  doc["render"]["spp"] = 3;
  std::ofstream(path) << doc.dump();
  CameraControl c(load_scene(path).camera);
  c.dolly(0.5f);
  save_camera(path, c.desc(), json::object());
  Scene s = load_scene(path);
  EXPECT_EQ(s.render.spp, 3);
  EXPECT_EQ(std::memcmp(&s.camera, &c.desc(), sizeof(CameraDesc)), 0);
  std::ofstream(dir / "not_a_scene.json") << "[1, 2]";
  EXPECT_THROW(save_camera((dir / "not_a_scene.json").string(), c.desc(), doc), std::runtime_error);
}

TEST(CameraPath, ParsesInFrameThenFileOrder) {
  auto a = parse_camera_path(R"([
    {"frame": 20, "screenshot": "b.png", "strategy": "area"},
    {"frame": 10, "orbit": [1, 2], "dolly": 0.5},
    {"frame": 20, "quit": true}
  ])", "p.json");
  ASSERT_EQ(a.size(), 5u);
  EXPECT_EQ(a[0].key, "orbit");
  EXPECT_EQ(a[1].key, "dolly");
  EXPECT_EQ(a[2].key, "screenshot");
  EXPECT_EQ(a[3].key, "strategy");
  EXPECT_EQ(a[4].key, "quit");
  EXPECT_EQ(a[0].frame, 10u);
  EXPECT_EQ(a[2].where, "p.json: [0].screenshot");
}

TEST(CameraPath, BadInputIsOneLineNamingTheEntry) {
  auto error = [](const std::string& text) {
    try {
      parse_camera_path(text, "p.json");
    } catch (const SceneError& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  EXPECT_EQ(error("{}"), "p.json: must be a JSON list of actions [{\"frame\": N, ...}, ...]");
  EXPECT_EQ(error("[{\"orbit\": [1, 2]}]"), "p.json: [0]: has no \"frame\"");
  EXPECT_EQ(error("[{\"frame\": -1, \"reset\": true}]"), "p.json: [0].frame: must be an integer >= 0 (got -1)");
  EXPECT_EQ(error("[{\"frame\": 1}]"), "p.json: [0]: has no action besides \"frame\"");
  EXPECT_NE(error("[{\"frame\": 1, \"orbitt\": [1, 2]}]").find("p.json: [0]: unknown action 'orbitt' (known: "),
            std::string::npos);
  EXPECT_EQ(error("[{\"frame\": 1, \"orbit\": [1]}]"), "p.json: [0].orbit: must be an array of 2 numbers (got [1])");
  EXPECT_EQ(error("[{\"frame\": 1, \"dolly\": 0}]"), "p.json: [0].dolly: must be > 0 and <= 100 (got 0)");
  EXPECT_NE(error("[{\"frame\": 1, \"strategy\": \"cone\"}]").find("p.json: [0].strategy"), std::string::npos);
  EXPECT_EQ(error("[{\"frame\": 1, \"key\": \"X\"}]").rfind("p.json: [0].key: must be a key: 1, 2, ", 0), 0u);
  EXPECT_EQ(error("[{\"frame\": 1, \"key\": \"shift+R\"}]").rfind("p.json: [0].key: must be a key", 0), 0u);
  EXPECT_NE(error("[{\"frame\": 1, \"screenshot\": \"x.jpg\"}]").find("p.json: [0].screenshot: x.jpg: unknown image format"),
            std::string::npos);
  EXPECT_NE(error("[{\"frame\": 1, \"camera\": {\"eye\": [0, 0, 0], \"target\": [0, 0, 0]}}]")
                .find("p.json: [0].camera: camera.target: must differ from camera.eye"),
            std::string::npos);
  EXPECT_EQ(error("[{\"frame\": 1, \"spp_per_frame\": 1.5}]"),
            "p.json: [0].spp_per_frame: must be an integer in 1..4096 (got 1.5)");
  EXPECT_EQ(error("[{\"frame\": 0, \"screenshot\": \"a.png\"}]"),
            "p.json: [0].screenshot: needs a frame >= 1: there is no image before the first frame");
  EXPECT_EQ(error("[1, 2"), "p.json: invalid JSON");
  // The denoise toggle (key N) as a scripted action: a boolean.
  EXPECT_EQ(error("[{\"frame\": 1, \"denoise\": true}]"), "no error");
  // restir's panel boxes: booleans.
  EXPECT_EQ(error("[{\"frame\": 1, \"restir_pairwise\": true}]"), "no error");
  EXPECT_NE(error("[{\"frame\": 1, \"restir_pairwise\": 1}]").find("p.json: [0].restir_pairwise"), std::string::npos);
  EXPECT_EQ(error("[{\"frame\": 1, \"restir_visibility_reuse\": false}]"), "no error");
  EXPECT_NE(error("[{\"frame\": 1, \"restir_visibility_reuse\": 0}]").find("p.json: [0].restir_visibility_reuse"),
            std::string::npos);
  // ... and its BVH candidates, candidates and spatial passes (ris-bvh: BVH candidates, no pass).
  EXPECT_EQ(error("[{\"frame\": 1, \"restir_bvh_candidates\": true, \"restir_candidates\": 8, \"restir_spatial\": 0}]"),
            "no error");
  EXPECT_NE(error("[{\"frame\": 1, \"restir_candidates\": 0}]").find("p.json: [0].restir_candidates"), std::string::npos);
  EXPECT_NE(error("[{\"frame\": 1, \"restir_spatial\": 17}]").find("p.json: [0].restir_spatial"), std::string::npos);
  EXPECT_NE(error("[{\"frame\": 1, \"restir_bvh_candidates\": \"yes\"}]").find("p.json: [0].restir_bvh_candidates"),
            std::string::npos);
  EXPECT_NE(error("[{\"frame\": 1, \"denoise\": 2}]").find("p.json: [0].denoise"), std::string::npos);
}

// The action table (actions_table.h) is the camera path's list of actions, plus
// the one the window alone has (the panel's screenshot button and P).
TEST(ViewerActions, CheckedActionsAreTheCameraPathsAndNamesAreUnique) {
  std::set<std::string> names;
  std::vector<std::string> checked, unchecked;
  for_each_action([&](const char* name, const ActionCheck& check, const auto&) {
    EXPECT_TRUE(names.insert(name).second) << name << " is in the table twice";
    (check ? checked : unchecked).push_back(name);
  });
  std::sort(checked.begin(), checked.end());
  EXPECT_EQ(checked, camera_path_keys());
  EXPECT_EQ(unchecked, std::vector<std::string>{"screenshot_button"});
}

// What the key bindings read of the viewer (members of viewer_state.h's Viewer).
struct KeyState {
  bool split_ = false, fly_ = false, denoise_ = false, panel_ = true;
};

KeyAction bound(const std::string& key, const KeyState& state) {
  KeyAction a;
  bool found = false;
  for_each_key([&](const std::string& name, const auto& bind) {
    if (name == key) a = bind(state), found = true;
  });
  EXPECT_TRUE(found) << key;
  return a;
}

TEST(ViewerActions, EveryKeyIsAnActionWithAValueItsCheckAccepts) {
  EXPECT_EQ(viewer_keys(), (std::vector<std::string>{"1", "2", "3", "4", "5", "6", "7", "8", "9", "shift+1", "shift+2",
                                                      "shift+3", "shift+4", "shift+5", "shift+6", "shift+7", "shift+8",
                                                      "shift+9", "R", "F", "P", "N", "Tab"}));
  std::map<std::string, ActionCheck> checks;
  std::set<std::string> actions;
  for_each_action([&](const char* name, const ActionCheck& check, const auto&) {
    actions.insert(name);
    if (check) checks[name] = check;
  });
  for (const bool split : {false, true}) {
    KeyState state;
    state.split_ = split;
    for (const std::string& key : viewer_keys()) {
      const KeyAction a = bound(key, state);
      const size_t digit = key.find_first_of("123456789");
      if (digit != std::string::npos && key[digit] - '1' >= kNumStrategies) {  // no strategy of that number
        EXPECT_EQ(a.action, "") << key;
        continue;
      }
      ASSERT_TRUE(actions.count(a.action)) << key << " -> '" << a.action << "'";
      if (checks.count(a.action)) {
        EXPECT_NO_THROW(checks[a.action](nlohmann::ordered_json::parse(a.value.dump()), "key " + key)) << key;
      }
    }
  }
  // 1..9 set the strategy, or in split screen the left side's (with shift the right side's).
  KeyState one, split;
  split.split_ = true;
  EXPECT_EQ(bound("1", one).action, "strategy");
  EXPECT_EQ(bound("1", one).value, strategy_name(Strategy(0)));
  EXPECT_EQ(bound("shift+2", one).action, "strategy");
  EXPECT_EQ(bound("shift+2", one).value, strategy_name(Strategy(1)));
  EXPECT_EQ(bound("1", split).action, "split_left");
  EXPECT_EQ(bound("shift+2", split).action, "split_right");
  EXPECT_EQ(bound("shift+2", split).value, strategy_name(Strategy(1)));
  // The toggles set the opposite of now.
  EXPECT_EQ(bound("N", one).action, "denoise");
  EXPECT_EQ(bound("N", one).value, true);
  one.denoise_ = true;
  EXPECT_EQ(bound("N", one).value, false);
  EXPECT_EQ(bound("F", one).value, true);
  EXPECT_EQ(bound("Tab", one).value, false);
  EXPECT_EQ(bound("R", one).action, "reset");
  EXPECT_EQ(bound("P", one).action, "screenshot_button");
}

TEST(Display, FastSrgbIsExactlyThePngEncoding) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<float> u(0.f, 1.2f);
  for (int i = 0; i < 200000; ++i) {
    float v = i < 1000 ? float(i) / 999.f : u(rng);
    ASSERT_EQ(srgb8_fast(v), to_srgb8(v)) << v;
    ASSERT_EQ(srgb8_fast(v * 1e-3f), to_srgb8(v * 1e-3f)) << v * 1e-3f;
  }
  for (int k = 0; k < 256; ++k) {  // around every step of the encoding
    float x = (float(k) + 0.5f) / 255.f;
    float lin = x <= 0.04045f ? x / 12.92f : std::pow((x + 0.055f) / 1.055f, 2.4f);
    for (float v = std::nextafter(lin, 0.f), n = 0; n < 4; ++n, v = std::nextafter(v, 2.f))
      ASSERT_EQ(srgb8_fast(v), to_srgb8(v)) << v;
  }
  EXPECT_EQ(srgb8_fast(-1.f), 0);
  EXPECT_EQ(srgb8_fast(std::nanf("")), 0);
  EXPECT_EQ(srgb8_fast(1e30f), 255);
}

TEST(Display, ProgressiveFramesAreTheRendersImageAndItsPngBytes) {
  Scene s = load_scene("cornell-sphere", {"render.width=24", "render.height=16", "render.spp=4", "render.max_depth=3"});
  std::string note;
  auto backend = make_backend("cpu", s, BackendOptions{2}, &note);
  Film one_go(24, 16);
  backend->render(frame_spec(s), one_go, 0, 4);

  auto image = make_host_image(*backend);
  image->restart(frame_spec(s));
  for (uint32_t spp : {1u, 1u, 2u}) image->add_samples(spp);
  ASSERT_EQ(image->samples(), 4u);
  EXPECT_EQ(image->mean(), one_go.mean()) << "frames of 1+1+2 spp are the 4-spp render";

  // Columns 10..19 tone-mapped, as one side of a split screen: exactly the PNG's bytes there, nothing elsewhere.
  const float exposure = 1.5f;
  std::vector<unsigned char> rgba(24 * 16 * 4, 7);
  DisplayPixels px{rgba.data(), 24 * 4, 24, 16, false};
  image->tone_map(px, 10, 20, exposure);
  std::vector<float> mean = image->mean();
  const float gain = std::exp2(exposure);
  for (int y = 0; y < 16; ++y)
    for (int x = 0; x < 24; ++x)
      for (int c = 0; c < 4; ++c) {
        unsigned char got = rgba[(size_t(y) * 24 + x) * 4 + c];
        if (x < 10 || x >= 20) ASSERT_EQ(got, 7) << "outside its columns";
        else if (c == 3) ASSERT_EQ(got, 255);
        else ASSERT_EQ(got, to_srgb8(mean[(size_t(y) * 24 + x) * 3 + c] * gain)) << x << "," << y;
      }
}

// The interop path's kernel tone-maps with tone_map_pixel (tone_map.h), the
// host path too: it must give the PNG writer's bytes for any sums and gains.
TEST(Display, SharedPixelToneMapIsThePngEncoding) {
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> u(0.0, 3.0);
  const float* t = srgb8_thresholds();
  for (int i = 0; i < 100000; ++i) {
    const uint64_t n = 1 + rng() % 4096;
    const double inv = 1.0 / double(n);
    const float gain = std::exp2(float(int(rng() % 9) - 4) * 0.5f);
    double sum[3] = {u(rng) * double(n), u(rng) * 1e-3 * double(n), i % 7 == 0 ? -1.0 : u(rng) * 0.05 * double(n)};
    unsigned char px[4] = {1, 2, 3, 4};
    tone_map_pixel(sum, inv, gain, t, px);
    for (int c = 0; c < 3; ++c) ASSERT_EQ(px[c], to_srgb8(float(sum[c] * inv) * gain)) << sum[c] << " " << n;
    ASSERT_EQ(px[3], 255);
  }
  double nan3[3] = {std::nan(""), 1e300, 0.0};
  unsigned char px[4];
  tone_map_pixel(nan3, 1.0, 1.f, t, px);
  EXPECT_EQ(px[0], 0);
  EXPECT_EQ(px[1], 255);
  EXPECT_EQ(px[2], 0);
}

TEST(Display, InteropOnlyWithOptixAndFallsBackInOneLine) {
  int tries = 0;
  auto ok = [&] { ++tries; return std::string(); };
  auto fails = [&] { ++tries; return std::string("cudaGraphicsGLRegisterBuffer: cudaErrorUnknown (unknown error)"); };

  DisplayChoice c = choose_display_path("auto", "cpu", true, ok);
  EXPECT_EQ(c.path, DisplayPath::HostUpload);
  EXPECT_EQ(tries, 0) << "the CPU backend never tries interop";
  c = choose_display_path("auto", "optix", false, ok);
  EXPECT_EQ(c.path, DisplayPath::HostUpload);
  EXPECT_NE(c.note.find("without CUDA"), std::string::npos) << c.note;
  EXPECT_EQ(tries, 0);

  c = choose_display_path("auto", "optix", true, ok);
  EXPECT_EQ(c.path, DisplayPath::Interop);
  EXPECT_EQ(tries, 1);
  EXPECT_STREQ(display_path_name(c.path), "CUDA-OpenGL interop");

  c = choose_display_path("auto", "optix", true, fails);  // e.g. Mesa's OpenGL on an NVIDIA machine
  EXPECT_EQ(c.path, DisplayPath::HostUpload);
  EXPECT_NE(c.note.find("cudaErrorUnknown"), std::string::npos) << c.note;
  EXPECT_NE(c.note.find("falling back to host upload"), std::string::npos) << c.note;
  EXPECT_EQ(c.note.find('\n'), std::string::npos);

  try {
    choose_display_path("interop", "optix", true, fails);
    FAIL() << "--display interop must fail where interop does";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("penumbra render"), std::string::npos) << e.what();
  }
  EXPECT_THROW(choose_display_path("interop", "cpu", true, ok), std::runtime_error);
  tries = 0;
  c = choose_display_path("host", "optix", true, ok);
  EXPECT_EQ(c.path, DisplayPath::HostUpload);
  EXPECT_EQ(tries, 0) << "--display host never tries interop";
}

#if PN_TEST_DEVICE_IMAGE
// The interop path's device image against the host path on the same GPU: the
// same sums (frames of 1+1+2 spp) and the same display bytes in a column range.
// Runs where a GPU is (the unit tests on a GPU machine: scripts/gpu_check.sh
// BUILD_DIR -LE gpu); skipped elsewhere.
TEST(Display, DeviceImageIsTheHostImageOnTheGpu) {
  std::string why;
  if (!optix_available(&why)) GTEST_SKIP() << why;
  Scene s = load_scene("cornell-sphere", {"render.width=40", "render.height=24", "render.max_depth=3"});
  auto backend = make_optix_backend(s);
  auto& optix = dynamic_cast<OptixBackend&>(*backend);
  auto host = make_host_image(*backend), device = make_device_image(optix);
  ASSERT_TRUE(device->writes_device_pixels());
  for (auto* image : {host.get(), device.get()}) {
    image->restart(frame_spec(s));
    for (uint32_t spp : {1u, 1u, 2u}) image->add_samples(spp);
  }
  ASSERT_EQ(device->samples(), 4u);
  EXPECT_EQ(device->mean(), host->mean());

  const size_t bytes = 40 * 24 * 4;
  std::vector<unsigned char> want(bytes, 7), got(bytes, 0);
  host->tone_map(DisplayPixels{want.data(), 40 * 4, 40, 24, false}, 13, 29, 0.5f);
  unsigned char* d = nullptr;
  ASSERT_EQ(cudaMalloc(reinterpret_cast<void**>(&d), bytes), cudaSuccess);
  ASSERT_EQ(cudaMemset(d, 7, bytes), cudaSuccess);
  device->tone_map(DisplayPixels{d, 40 * 4, 40, 24, true}, 13, 29, 0.5f);
  ASSERT_EQ(cudaMemcpy(got.data(), d, bytes, cudaMemcpyDeviceToHost), cudaSuccess);
  cudaFree(d);
  EXPECT_EQ(got, want) << "the device's display bytes differ from the host path's";
}
#endif

// --- The RenderScheduler: restarts, the split screen's sides, equal time ------

// An image whose samples cost a fixed time and whose mean names its frame (seed, strategy), for the scheduler's
// bookkeeping without a renderer.
class FakeImage final : public ProgressiveImage {
 public:
  FakeImage(double ms_per_sample, bool device, int* made) : ms_(ms_per_sample), device_(device) { ++*made; }
  void restart(const FrameSpec& f) override {
    w_ = f.camera.width;
    h_ = f.camera.height;
    n_ = 0;
    value_ = float(f.seed) + 100.f * float(int(f.integrator.strategy));
    ++restarts;
  }
  void add_samples(uint32_t spp) override {
    std::this_thread::sleep_for(std::chrono::duration<double, std::milli>(ms_ * spp));
    n_ += spp;
  }
  uint64_t samples() const override { return n_; }
  int width() const override { return w_; }
  int height() const override { return h_; }
  void tone_map(const DisplayPixels&, int, int, float) const override {}
  bool writes_device_pixels() const override { return device_; }
  std::vector<float> mean() const override { return std::vector<float>(size_t(w_) * h_ * 3, value_); }
  int restarts = 0;

 private:
  double ms_;
  bool device_;
  int w_ = 0, h_ = 0;
  uint64_t n_ = 0;
  float value_ = 0;
};

class NoBackend final : public Backend {
 public:
  std::string name() const override { return "none"; }
  std::string device_name() const override { return "none"; }
  void render(const FrameSpec&, Film&, uint32_t, uint32_t, const ProgressFn&) override {}
};

ImageSettings split_settings(bool equal_time) {
  ImageSettings s;
  s.width = 16;
  s.height = 4;
  s.split = true;
  s.left = Strategy::Area;
  s.right = Strategy::SolidAngle;
  s.equal_time = equal_time;
  return s;
}

FrameSpec frame_of(const ImageSettings& s, uint32_t seed) {
  FrameSpec f;
  f.camera = Camera::look_at(Vec3(0.f), Vec3(0.f, 0.f, -1.f), Vec3(0.f, 1.f, 0.f), 40.f, s.width, s.height);
  f.seed = seed;
  return f;
}

TEST(RenderScheduler, SplitScreenSidesHaveTheirStrategiesAndSeedsAndMeetAtTheDivider) {
  RenderScheduler r;
  int made = 0;
  const ImageSettings s = split_settings(false);
  r.restart(s, frame_of(s, 7), false, [&] { return std::make_unique<FakeImage>(0.0, false, &made); });
  ASSERT_EQ(r.sides().size(), 2u);
  EXPECT_EQ(r.sides()[0].strategy, Strategy::Area);
  EXPECT_EQ(r.sides()[1].strategy, Strategy::SolidAngle);
  const float left = 7.f + 100.f * int(Strategy::Area), right = 8.f + 100.f * int(Strategy::SolidAngle);
  EXPECT_EQ(r.sides()[0].image->mean()[0], left);   // the frame's seed
  EXPECT_EQ(r.sides()[1].image->mean()[0], right);  // its seed + 1: independent errors
  EXPECT_EQ(r.divider_column(0.25f), 4);
  const std::vector<float> m = r.composed_mean(0.25f);
  for (int y = 0; y < s.height; ++y)
    for (int x = 0; x < s.width; ++x)
      EXPECT_EQ(m[(size_t(y) * s.width + x) * 3], x < 4 ? left : right) << x << "," << y;
  NoBackend none;
  r.render(3, none);
  EXPECT_EQ(r.sides()[0].image->samples(), 3u);  // equal samples: each side its 3
  EXPECT_EQ(r.sides()[1].image->samples(), 3u);
}

TEST(RenderScheduler, RestartReusesTheImagesThatWriteTheSamePixels) {
  RenderScheduler r;
  int made = 0;
  ImageSettings s = split_settings(false);
  auto host = [&] { return std::make_unique<FakeImage>(0.0, false, &made); };
  auto device = [&] { return std::make_unique<FakeImage>(0.0, true, &made); };
  r.restart(s, frame_of(s, 1), false, host);
  EXPECT_EQ(made, 2);
  s.width = 20;  // a new size: the same images, restarted
  r.restart(s, frame_of(s, 1), false, host);
  EXPECT_EQ(made, 2);
  EXPECT_EQ(r.sides()[0].image->width(), 20);
  r.restart(s, frame_of(s, 1), true, device);  // the display path changed: new images
  EXPECT_EQ(made, 4);
  r.clear();
  EXPECT_FALSE(r.started());
  r.restart(s, frame_of(s, 1), true, device);  // cleared (a new backend): new images
  EXPECT_EQ(made, 6);
}

// Equal time: a side whose samples cost a quarter as much gets about four times the samples, the render time of
// each side about the same. Sleeps stand for the costs; the bounds allow for their overshoot on a loaded machine.
TEST(RenderScheduler, EqualTimeGivesTheCheaperSideMoreSamplesForTheSameTime) {
  RenderScheduler r;
  int made = 0;
  const ImageSettings s = split_settings(true);
  bool cheap = true;  // the left side is made first
  r.restart(s, frame_of(s, 1), false, [&] {
    auto image = std::make_unique<FakeImage>(cheap ? 1.0 : 4.0, false, &made);
    cheap = false;
    return image;
  });
  NoBackend none;
  for (int frame = 0; frame < 16; ++frame) r.render(1, none);
  const double a = double(r.sides()[0].image->samples()), b = double(r.sides()[1].image->samples());
  EXPECT_GT(a / b, 2.0) << a << " against " << b << " samples";
  EXPECT_LT(a / b, 6.0) << a << " against " << b << " samples";
  const double ta = r.sides()[0].seconds, tb = r.sides()[1].seconds;
  EXPECT_LT(std::abs(ta - tb), 0.35 * std::max(ta, tb)) << ta << " s against " << tb << " s";
}

}  // namespace
}  // namespace pn::viewer
