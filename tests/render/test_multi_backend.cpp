// MultiBackend (render/multi_backend.h): one image split across devices in
// sample ranges, on CPU "devices" (several CPU backends of one thread each):
// the code path of several GPUs, with the image of one device to the bit.
// And --gpus: which GPUs a specification selects (render/backend.h). Where there
// is a GPU, the split on it: two backends of GPU 0 as two devices.
#include <gtest/gtest.h>

#include <cstring>
#include <memory>
#include <string>
#include <stdexcept>
#include <vector>

#include "backends/cpu/cpu_backend.h"
#include "gpu_paths.h"
#include "render/multi_backend.h"
#include "scene/scene.h"

namespace pn {
namespace {

// The cornell-sphere scene with its light in view (pixels of constant radiance,
// where the order of double additions shows first in the variance), 31x23 so
// that no tile is whole.
Scene scene() {
  return load_scene("cornell-sphere", {"render.width=31", "render.height=23", "render.seed=11", "render.max_depth=4"});
}

std::unique_ptr<MultiBackend> cpu_devices(const Scene& s, int n) {
  std::vector<std::unique_ptr<Backend>> devices;
  std::vector<std::string> labels;
  for (int i = 0; i < n; ++i) {
    devices.push_back(make_cpu_backend(s, 1));
    labels.push_back("CPU " + std::to_string(i));
  }
  return std::make_unique<MultiBackend>(std::move(devices), std::move(labels));
}

bool same_bytes(const std::vector<float>& a, const std::vector<float>& b) {
  return a.size() == b.size() && std::memcmp(a.data(), b.data(), a.size() * sizeof(float)) == 0;
}

TEST(MultiBackend, SplitCoversTheRangeInWholeUnits) {
  using R = std::vector<std::pair<uint32_t, uint32_t>>;
  EXPECT_EQ(MultiBackend::split(10, 7, 3, 1), (R{{10, 3}, {13, 2}, {15, 2}}));
  EXPECT_EQ(MultiBackend::split(10, 7, 3, 2), (R{{10, 4}, {14, 2}, {16, 1}}));  // the last unit is short
  EXPECT_EQ(MultiBackend::split(0, 2, 4, 1), (R{{0, 1}, {1, 1}, {2, 0}, {2, 0}}));
  EXPECT_EQ(MultiBackend::split(0, 256, 2, 256), (R{{0, 256}, {256, 0}}));  // one launch: not split
  EXPECT_EQ(MultiBackend::split(5, 0, 2, 1), (R{{5, 0}, {5, 0}}));
}

TEST(MultiBackend, SameImageWhateverTheSplit) {
  const Scene s = scene();
  const FrameSpec f = frame_spec(s);
  const uint32_t first = 3, count = 67;
  Film one(31, 23);
  make_cpu_backend(s, 2)->render(f, one, first, count);
  const std::vector<float> mean = one.mean(), var = one.variance_of_mean();
  for (int n : {1, 2, 3, 4}) {
    auto multi = cpu_devices(s, n);
    Film film(31, 23);
    multi->render(f, film, first, count);
    EXPECT_EQ(film.samples(), count);
    EXPECT_TRUE(same_bytes(film.mean(), mean)) << n << " devices: the mean differs";
    EXPECT_TRUE(same_bytes(film.variance_of_mean(), var)) << n << " devices: the variance differs";
    const RenderStats st = multi->last_render_stats();
    ASSERT_EQ(st.devices.size(), size_t(n));
    uint32_t next = first;
    for (const DeviceTiming& d : st.devices) {  // disjoint ranges, in order, covering all
      EXPECT_EQ(d.first_sample, next);
      next += d.count;
      EXPECT_GT(d.wall_ms, 0);
      EXPECT_NE(d.device.find("CPU "), std::string::npos);
    }
    EXPECT_EQ(next, first + count);
  }
}

TEST(MultiBackend, AddsToTheFilmLikeOneDevice) {
  // Progressive: 5 samples, then 9 more on three devices, as on one.
  const Scene s = scene();
  const FrameSpec f = frame_spec(s);
  Film one(31, 23), three(31, 23);
  auto cpu = make_cpu_backend(s, 1);
  auto multi = cpu_devices(s, 3);
  cpu->render(f, one, 0, 5);
  cpu->render(f, one, 5, 9);
  multi->render(f, three, 0, 5);
  multi->render(f, three, 5, 9);
  EXPECT_EQ(three.samples(), 14u);
  EXPECT_TRUE(same_bytes(three.mean(), one.mean()));
}

TEST(MultiBackend, ProgressCountsEveryDeviceAndCanStopThemAll) {
  const Scene s = scene();
  const FrameSpec f = frame_spec(s);
  auto multi = cpu_devices(s, 3);
  Film film(31, 23);
  uint64_t last = 0, total_seen = 0;
  multi->render(f, film, 0, 6, [&](uint64_t done, uint64_t total) {
    EXPECT_GE(done, last);  // serialised and monotonic
    last = done;
    total_seen = total;
  });
  EXPECT_EQ(total_seen, uint64_t(31) * 23 * 6);
  EXPECT_EQ(last, total_seen);

  // An exception from the hook stops every device; the film keeps what it had.
  Film before = film;
  int calls = 0;
  EXPECT_THROW(multi->render(f, film, 6, 40,
                             [&](uint64_t, uint64_t) {
                               if (++calls == 2) throw std::runtime_error("stop");
                             }),
               std::runtime_error);
  EXPECT_EQ(film.samples(), before.samples());
  EXPECT_TRUE(same_bytes(film.mean(), before.mean()));
  // ... and it renders again afterwards.
  multi->render(f, film, 6, 2);
  EXPECT_EQ(film.samples(), 8u);
}

// Samples that are NaN or infinite (a sky that overflows floats): counted and
// located on every device, as one device counts them.
TEST(MultiBackend, CountsNonFiniteSamplesOfEveryDevice) {
  const Scene s = load_scene(std::string(PENUMBRA_TEST_DATA) + "/overflow_env_scene.json");
  const FrameSpec f = frame_spec(s);
  const uint32_t spp = uint32_t(s.render.spp);
  Film one(s.render.width, s.render.height), three(s.render.width, s.render.height);
  auto cpu = make_cpu_backend(s, 1);
  cpu->render(f, one, 0, spp);
  auto multi = cpu_devices(s, 3);
  multi->render(f, three, 0, spp);
  const RenderStats a = cpu->last_render_stats(), b = multi->last_render_stats();
  EXPECT_GT(a.nonfinite, 0u);
  EXPECT_EQ(b.nonfinite, a.nonfinite);
  EXPECT_EQ(b.nonfinite_pixels, a.nonfinite_pixels);
  EXPECT_TRUE(same_bytes(three.mean(), one.mean()));
}

TEST(MultiBackend, NamesItsDevices) {
  const Scene s = scene();
  auto multi = cpu_devices(s, 2);
  EXPECT_EQ(multi->name(), "cpu");
  EXPECT_EQ(multi->device_name().rfind("2 devices (CPU 0, CPU 1): 1 CPU thread", 0), 0u) << multi->device_name();
}

// Two parts of one GPU: MultiBackend over two backends of GPU 0, each with its own path pool, BVH, launch graphs
// and stream, rendering concurrently from threads of their own, as `--gpus 2` renders on two GPUs. On each GPU path
// the image (mean and variance) is the one backend's to the bit, and each part renders a range of whole launches.
// Cases: cornell-sphere at 256x144 (28 samples a launch: 100 samples split 56 + 44), and restir's spatial reuse on
// many-spheres (a launch a sample: its frame passes run on each part). Skipped without a GPU (CTest's gpu label runs
// it on one: tests/gpu, gpu.unit.multi_backend).
TEST(MultiBackendGpu, TwoPartsOfOneGpuRenderOneGpusImage) {
  struct Case {
    const char* scene;
    std::vector<std::string> sets;
    uint32_t first, count;
    bool megakernel;  // restir's reuse has no megakernel path
  };
  const Case cases[] = {
      {"cornell-sphere", {"render.width=256", "render.height=144", "render.seed=11", "render.max_depth=4"}, 3, 100,
       true},
      {"many-spheres",
       {"render.width=96", "render.height=54", "render.seed=5", "defaults.lights=2000",
        "render.light_selection=restir"},
       0, 6, false}};
  for (const Case& c : cases) {
    const Scene s = load_scene(c.scene, c.sets);
    const FrameSpec f = frame_spec(s);
    const int W = s.render.width, H = s.render.height;
    for (const GpuPath& path : kGpuPaths) {
      if (!path.wavefront && !c.megakernel) continue;
      SCOPED_TRACE(std::string(c.scene) + ", " + path.name);
      std::string why;
      std::unique_ptr<Backend> one = path.backend(s, &why);
      if (!one) GTEST_SKIP() << "no GPU backend here: " << why;
      std::vector<std::unique_ptr<Backend>> parts;
      for (int i = 0; i < 2; ++i) {
        parts.push_back(path.backend(s, &why));
        ASSERT_TRUE(parts.back()) << why;
      }
      MultiBackend two(std::move(parts), {"GPU 0 (part 0)", "GPU 0 (part 1)"});
      Film a(W, H), b(W, H);
      one->render(f, a, c.first, c.count);
      two.render(f, b, c.first, c.count);
      EXPECT_EQ(b.samples(), c.count);
      EXPECT_TRUE(same_bytes(b.mean(), a.mean())) << "the mean differs";
      EXPECT_TRUE(same_bytes(b.variance_of_mean(), a.variance_of_mean())) << "the variance differs";
      const RenderStats st = two.last_render_stats();
      ASSERT_EQ(st.devices.size(), 2u);
      const uint32_t g = one->split_granularity(f, c.count);
      EXPECT_EQ(st.devices[0].first_sample, c.first);
      EXPECT_EQ(st.devices[1].first_sample, c.first + st.devices[0].count);
      EXPECT_EQ(st.devices[0].count + st.devices[1].count, c.count);
      for (const DeviceTiming& d : st.devices) EXPECT_GT(d.count, 0u) << "a part rendered nothing";
      EXPECT_EQ(st.devices[0].count % g, 0u) << "part 0 is not whole launches of " << g;
    }
  }
}

TEST(Gpus, SelectsGpusBySpecification) {
  EXPECT_EQ(select_gpus("", 4), std::vector<int>{0});  // the viewer, bench: GPU 0
  EXPECT_EQ(select_gpus("all", 3), (std::vector<int>{0, 1, 2}));
  EXPECT_EQ(select_gpus("2", 3), (std::vector<int>{0, 1}));
  EXPECT_EQ(select_gpus("2,0", 3), (std::vector<int>{2, 0}));
  EXPECT_EQ(select_gpus("1", 1), std::vector<int>{0});  // a count, not an index
  EXPECT_EQ(select_gpus("1,", 2), std::vector<int>{1});  // a list of one: an index
  EXPECT_EQ(select_gpus("0,", 1), std::vector<int>{0});
}

TEST(Gpus, RejectsWhatIsNotThere) {
  for (const char* bad : {"0", "x", "1,x", ",", "1,,2", "1,,", ",1", "-1", "1,1", "all,1", " 1", "99999"})
    EXPECT_THROW(check_gpus(bad), std::invalid_argument) << bad;
  EXPECT_NO_THROW(check_gpus("all"));
  EXPECT_NO_THROW(check_gpus("0,3"));
  EXPECT_THROW(select_gpus("3", 2), std::invalid_argument);    // more than there are
  EXPECT_THROW(select_gpus("0,2", 2), std::invalid_argument);  // no GPU 2
  EXPECT_THROW(select_gpus("all", 0), std::invalid_argument);  // none at all
  try {
    select_gpus("0,2", 2);
  } catch (const std::invalid_argument& e) {
    EXPECT_STREQ(e.what(), "--gpus 0,2: no GPU 2 (this machine has 2 GPUs, numbered from 0)");
  }
}

}  // namespace
}  // namespace pn
