// The arithmetic of the convergence experiment (render/metrics.h, apps/converge.cpp): RMSE and relMSE over all
// pixels and over those that see no light, the reference's noise floor, efficiency 1 / (MSE x time), the log-log
// fit and the spp to reach a threshold, each on images whose answer is written here by hand; then a small
// `converge` run whose summary is recomputed here from its own renders and ground truth.
#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <map>
#include <string>
#include <vector>

#include "io/image.h"
#include "render/backend.h"
#include "apps/converge.h"
#include "backends/make_backend.h"
#include "core/rng.h"
#include "render/film.h"
#include "render/metrics.h"
#include "scene/scene.h"

namespace pn {
namespace {

using json = nlohmann::json;

// --- On images with known answers -------------------------------------------------------------------------------

TEST(ErrorMetrics, ConstantOffsetIsTheRmse) {
  std::vector<float> ref = {0.f, 1.f, 2.f, 3.f, 4.f, 5.f, 0.5f, 0.25f, 8.f};
  std::vector<float> above = ref, below = ref;
  for (float& v : above) v += 0.5f;
  for (float& v : below) v -= 0.5f;
  EXPECT_DOUBLE_EQ(error_metrics(above, ref).rmse, 0.5);
  EXPECT_DOUBLE_EQ(error_metrics(below, ref).rmse, 0.5);
  EXPECT_EQ(error_metrics(above, ref).pixels, 3u);
  EXPECT_EQ(error_metrics(ref, ref).rmse, 0.0);
  EXPECT_EQ(error_metrics(ref, ref).relmse, 0.0);
}

TEST(ErrorMetrics, MeanOverPixelsAndChannels) {
  // Pixel 0: reference black, red off by 0.1: d^2 = 0.01, relative 0.01 / (0 + 0.01) = 1.
  // Pixel 1: reference 1, blue off by 3: d^2 = 9, relative 9 / (1 + 0.01).
  std::vector<float> ref = {0.f, 0.f, 0.f, 1.f, 1.f, 1.f};
  std::vector<float> test = {0.1f, 0.f, 0.f, 1.f, 1.f, 4.f};
  const double d0 = double(0.1f) * double(0.1f);  // the float 0.1 as stored
  ErrorMetrics all = error_metrics(test, ref);
  EXPECT_EQ(all.pixels, 2u);
  EXPECT_NEAR(all.mse, (d0 + 9.0) / 6.0, 1e-12);
  EXPECT_NEAR(all.rmse, std::sqrt((d0 + 9.0) / 6.0), 1e-12);
  EXPECT_NEAR(all.relmse, (d0 / 0.01 + 9.0 / 1.01) / 6.0, 1e-12);

  // Without pixel 0 (it sees a light): one pixel, three channels.
  std::vector<uint8_t> nolight = {0, 1};
  ErrorMetrics n = error_metrics(test, ref, &nolight);
  EXPECT_EQ(n.pixels, 1u);
  EXPECT_NEAR(n.mse, 9.0 / 3.0, 1e-12);
  EXPECT_NEAR(n.rmse, std::sqrt(9.0 / 3.0), 1e-12);
  EXPECT_NEAR(n.relmse, 9.0 / 1.01 / 3.0, 1e-12);

  // Without pixel 1.
  std::vector<uint8_t> only0 = {1, 0};
  EXPECT_NEAR(error_metrics(test, ref, &only0).rmse, std::sqrt(d0 / 3.0), 1e-12);
  EXPECT_NEAR(error_metrics(test, ref, &only0).relmse, d0 / 0.01 / 3.0, 1e-12);

  // No pixel counts: zeros, not NaN.
  std::vector<uint8_t> none = {0, 0};
  ErrorMetrics z = error_metrics(test, ref, &none);
  EXPECT_EQ(z.pixels, 0u);
  EXPECT_EQ(z.rmse, 0.0);
  EXPECT_EQ(z.relmse, 0.0);
}

TEST(ErrorMetrics, RelMseDividesByTheReferenceSquaredPlusOneHundredth) {
  // The same absolute error counts 1 / (ref^2 + 0.01) times: 100x where the reference is black, 1/4.01 at 2.
  std::vector<float> ref = {0.f, 2.f, 10.f}, test = {1.f, 3.f, 11.f};
  EXPECT_NEAR(error_metrics(test, ref).relmse, (1 / 0.01 + 1 / 4.01 + 1 / 100.01) / 3, 1e-12);
  EXPECT_NEAR(error_metrics(test, ref).rmse, 1.0, 1e-12);
}

// measure_render's one pass gives the bits of Film::mean, error_metrics (all pixels, masked) and image_mean.
TEST(ErrorMetrics, OnePassMeasuresAreTheSeparateOnesBitForBit) {
  const int W = 37, H = 23;
  Rng rng(1, 2, 3);
  Film film(W, H);
  std::vector<float> ref(size_t(W) * H * 3);
  std::vector<uint8_t> mask(size_t(W) * H);
  for (size_t i = 0; i < ref.size(); ++i) {
    film.sum()[i] = 7.0 * double(rng.uniform()) * (i % 5 == 0 ? 100.0 : 1.0);
    ref[i] = rng.uniform() * (i % 7 == 0 ? 30.f : 1.f);
  }
  for (uint8_t& m : mask) m = rng.uniform() < 0.8f ? 1 : 0;
  film.add_samples(7);
  std::vector<float> image;
  const RenderMeasures r = measure_render(film.sum(), film.samples(), ref, mask, &image);
  const std::vector<float> mean = film.mean();
  EXPECT_EQ(image, mean);
  const ErrorMetrics all = error_metrics(mean, ref), masked = error_metrics(mean, ref, &mask);
  EXPECT_EQ(r.all.mse, all.mse);
  EXPECT_EQ(r.all.rmse, all.rmse);
  EXPECT_EQ(r.all.relmse, all.relmse);
  EXPECT_EQ(r.all.pixels, all.pixels);
  EXPECT_EQ(r.masked.mse, masked.mse);
  EXPECT_EQ(r.masked.rmse, masked.rmse);
  EXPECT_EQ(r.masked.relmse, masked.relmse);
  EXPECT_EQ(r.masked.pixels, masked.pixels);
  EXPECT_LT(masked.pixels, all.pixels);
  EXPECT_EQ(r.mean, image_mean(mean));
  EXPECT_EQ(r.mean_masked, image_mean(mean, &mask));
  EXPECT_NE(r.mean, r.mean_masked);
  // image_mean by hand: the mean over the kept pixels and their channels.
  double sum = 0;
  size_t n = 0;
  for (size_t p = 0; p < mask.size(); ++p)
    if (mask[p]) sum += double(mean[3 * p]) + mean[3 * p + 1] + mean[3 * p + 2], n += 3;
  EXPECT_DOUBLE_EQ(image_mean(mean, &mask), sum / double(n));
}

TEST(NolightMask, AnyEmissionSeenDirectlyLeavesAPixelOut) {
  // A camera-ray-only render: black, a lamp in the red channel only, a lamp's edge (a little blue), black.
  std::vector<float> direct = {0.f, 0.f, 0.f, 5.f, 0.f, 0.f, 0.f, 0.f, 1e-6f, 0.f, 0.f, 0.f};
  EXPECT_EQ(nolight_mask(direct), (std::vector<uint8_t>{1, 0, 0, 1}));
}

TEST(NolightMask, LightPixelsGrowByTheirEightNeighbours) {
  // 4 x 3 pixels, one light pixel at (1, 1) and one at the corner (3, 0): every pixel within one step of either
  // (diagonals too) becomes a light pixel: all but (3, 2).
  std::vector<uint8_t> mask = {1, 1, 1, 0,
                               1, 0, 1, 1,
                               1, 1, 1, 1};
  std::vector<uint8_t> grown = {0, 0, 0, 0,
                                0, 0, 0, 0,
                                0, 0, 0, 1};
  EXPECT_EQ(grow_light_pixels(mask, 4, 3), grown);
  // No light pixel: unchanged; every one: unchanged.
  EXPECT_EQ(grow_light_pixels(std::vector<uint8_t>(6, 1), 3, 2), std::vector<uint8_t>(6, 1));
  EXPECT_EQ(grow_light_pixels(std::vector<uint8_t>(6, 0), 3, 2), std::vector<uint8_t>(6, 0));
  // A 5 x 5 image with its centre lit: the 3 x 3 block around it, and no more.
  std::vector<uint8_t> c(25, 1);
  c[12] = 0;
  const std::vector<uint8_t> g = grow_light_pixels(c, 5, 5);
  for (int y = 0; y < 5; ++y)
    for (int x = 0; x < 5; ++x)
      EXPECT_EQ(g[y * 5 + x], (std::abs(x - 2) <= 1 && std::abs(y - 2) <= 1) ? 0 : 1) << x << "," << y;
}

TEST(NoiseFloor, RootOfTheMeanVarianceOfTheMean) {
  // Variances of the mean, per channel: pixel 0 (1, 1, 1), pixel 1 (4, 4, 4), pixel 2 (0, 3, 6).
  std::vector<float> var = {1.f, 1.f, 1.f, 4.f, 4.f, 4.f, 0.f, 3.f, 6.f};
  EXPECT_NEAR(noise_floor_rmse(var), std::sqrt((3 + 12 + 9) / 9.0), 1e-12);
  std::vector<uint8_t> mask = {1, 0, 1};
  EXPECT_NEAR(noise_floor_rmse(var, &mask), std::sqrt((3 + 9) / 6.0), 1e-12);
  std::vector<uint8_t> only1 = {0, 1, 0};
  EXPECT_NEAR(noise_floor_rmse(var, &only1), 2.0, 1e-12);
  std::vector<uint8_t> none = {0, 0, 0};
  EXPECT_EQ(noise_floor_rmse(var, &none), 0.0);
}

TEST(NoiseFloor, OfAFilmWithKnownSamples) {
  // Two pixels of two samples each. Pixel 0: 0 and 2 in every channel: mean 1, sample variance 2, variance of
  // the mean 1. Pixel 1: 1 and 1: no variance. Floor: sqrt((3 x 1 + 3 x 0) / 6).
  Film film(2, 1);
  for (int c = 0; c < 3; ++c) {
    film.sum()[c] = 0 + 2;
    film.sum_sq()[c] = 0 + 4;
    film.sum()[3 + c] = 1 + 1;
    film.sum_sq()[3 + c] = 1 + 1;
  }
  film.add_samples(2);
  EXPECT_NEAR(noise_floor_rmse(film.variance_of_mean()), std::sqrt(0.5), 1e-7);
}

TEST(Efficiency, InverseOfMseTimesSeconds) {
  EXPECT_DOUBLE_EQ(efficiency(0.04, 2.0), 12.5);
  // Half the RMSE at equal time: 4x; twice the time at equal MSE: half.
  EXPECT_DOUBLE_EQ(efficiency(0.01, 2.0) / efficiency(0.04, 2.0), 4.0);
  EXPECT_DOUBLE_EQ(efficiency(0.04, 4.0) / efficiency(0.04, 2.0), 0.5);
  // Nothing to divide by: 0, not infinity.
  EXPECT_EQ(efficiency(0.0, 2.0), 0.0);
  EXPECT_EQ(efficiency(0.04, 0.0), 0.0);
}

TEST(LineFit, ExactAndLeastSquares) {
  LineFit f = fit_line({0, 1, 2, 3}, {2, 1.5, 1, 0.5});  // y = 2 - x / 2
  EXPECT_NEAR(f.a, 2.0, 1e-12);
  EXPECT_NEAR(f.b, -0.5, 1e-12);
  // (0, 0), (1, 2), (2, 1): slope sum((x - 1)(y - 1)) / sum((x - 1)^2) = 1 / 2, through the means (1, 1).
  LineFit g = fit_line({0, 1, 2}, {0, 2, 1});
  EXPECT_NEAR(g.b, 0.5, 1e-12);
  EXPECT_NEAR(g.a, 0.5, 1e-12);
}

TEST(SppToThreshold, AlongTheFittedLine) {
  // RMSE = 0.8 / sqrt(spp): 0.1 at spp = (0.8 / 0.1)^2 = 64.
  std::vector<double> x, y;
  for (int spp : {1, 2, 4, 8, 16}) {
    x.push_back(std::log(double(spp)));
    y.push_back(std::log(0.8 / std::sqrt(double(spp))));
  }
  LineFit f = fit_line(x, y);
  EXPECT_NEAR(spp_to_threshold(f, 0.1), 64.0, 1e-9);
  EXPECT_NEAR(spp_to_threshold(f, 0.8), 1.0, 1e-12);
  // RMSE = 0.8 / spp: 0.1 at 8 spp.
  EXPECT_NEAR(spp_to_threshold(LineFit{std::log(0.8), -1.0}, 0.1), 8.0, 1e-12);
  // An error that does not fall never reaches it.
  EXPECT_TRUE(std::isinf(spp_to_threshold(LineFit{std::log(0.8), 0.0}, 0.1)));
  EXPECT_TRUE(std::isinf(spp_to_threshold(LineFit{std::log(0.8), 0.1}, 0.1)));
}

// --- A converge run, recomputed ---------------------------------------------------------------------------------

// Hand-written RMSE over pixels p where keep(p): sqrt(sum of squared channel differences / (3 x count)); and
// relMSE: the mean of (a - ref)^2 / (ref^2 + 0.01).
template <class Keep>
double rmse_where(const std::vector<float>& a, const std::vector<float>& ref, Keep keep) {
  double se = 0;
  size_t n = 0;
  for (size_t i = 0; i < ref.size(); ++i)
    if (keep(i / 3)) {
      se += (double(a[i]) - ref[i]) * (double(a[i]) - ref[i]);
      ++n;
    }
  return std::sqrt(se / double(n));
}
template <class Keep>
double relmse_where(const std::vector<float>& a, const std::vector<float>& ref, Keep keep) {
  double rel = 0;
  size_t n = 0;
  for (size_t i = 0; i < ref.size(); ++i)
    if (keep(i / 3)) {
      rel += (double(a[i]) - ref[i]) * (double(a[i]) - ref[i]) / (double(ref[i]) * ref[i] + 0.01);
      ++n;
    }
  return rel / double(n);
}

// The light masks converge keeps in a cache folder (mask-<key>.pgm).
std::vector<std::filesystem::path> cached_masks(const std::string& cache) {
  std::vector<std::filesystem::path> out;
  for (const auto& e : std::filesystem::directory_iterator(cache))
    if (e.path().filename().string().rfind("mask-", 0) == 0) out.push_back(e.path());
  return out;
}

TEST(Converge, SummaryIsItsRendersArithmetic) {
  const std::string scene_name = "cornell-sphere";
  const int W = 24, H = 16, max_spp = 8, seeds = 2;
  ConvergeOptions o;
  o.scene = scene_name;
  o.backend = "cpu";
  o.backend_options.threads = 2;
  o.width = W;
  o.height = H;
  o.max_spp = max_spp;
  o.seeds = seeds;
  o.reference_spp = 64;
  o.reference_chunk = 64;
  o.fit_min_spp = 2;
  o.frame_spp = 4;
  o.threshold = 0.02;
  o.strategies = {"area", "solid-angle"};
  o.mis = {"none"};
  o.verbose = false;
  // Its own ground truth, never one a build left (the sanitizer build may run this at the same time).
  o.cache = (std::filesystem::temp_directory_path() / ("penumbra-test-metrics-" + std::to_string(::getpid()))).string();
  std::filesystem::remove_all(o.cache);
  ConvergeResult r = run_converge(o);
  const json& s = r.summary;

  // The ground truth as cached, and its noise floor.
  const ReferencePlan plan = plan_converge(o).reference;
  int w, h;
  const std::vector<float> ref = read_exr(plan.path, &w, &h);
  const std::vector<float> ref_var = read_exr(plan.var_path, &w, &h);
  ASSERT_EQ(w, W);
  ASSERT_EQ(h, H);

  // Pixels that see the lamp: a render of camera rays alone, with any light in them, and their neighbours.
  Scene scene = load_scene(scene_name, {"render.width=" + std::to_string(W), "render.height=" + std::to_string(H)});
  std::string note;
  auto backend = make_backend("cpu", scene, BackendOptions{2}, &note);
  std::vector<bool> lamp(size_t(W) * H, false);
  {
    FrameSpec f = frame_spec(scene);
    f.integrator.max_depth = 0;
    Film film(W, H);
    backend->render(f, film, 0, 1024);
    std::vector<float> m = film.mean();
    std::vector<bool> seen(lamp.size());
    for (size_t p = 0; p < lamp.size(); ++p) seen[p] = m[3 * p] > 0 || m[3 * p + 1] > 0 || m[3 * p + 2] > 0;
    // ... and its eight neighbours.
    for (int y = 0; y < H; ++y)
      for (int x = 0; x < W; ++x)
        for (int v = std::max(0, y - 1); v <= std::min(H - 1, y + 1); ++v)
          for (int u = std::max(0, x - 1); u <= std::min(W - 1, x + 1); ++u)
            if (seen[size_t(v) * W + u]) lamp[size_t(y) * W + x] = true;
  }
  size_t lamps = 0;
  for (bool l : lamp) lamps += l;
  ASSERT_GT(lamps, 0u) << "the lamp should be in view";
  ASSERT_LT(lamps, lamp.size() / 2);
  EXPECT_EQ(s["light_pixels"].get<size_t>(), lamps);
  // ... as the cache keeps it: one binary PGM, 0 on those pixels, 255 elsewhere.
  const std::vector<std::filesystem::path> masks = cached_masks(o.cache);
  ASSERT_EQ(masks.size(), 1u);
  {
    std::ifstream f(masks[0], std::ios::binary);
    const std::string pgm((std::istreambuf_iterator<char>(f)), std::istreambuf_iterator<char>());
    const std::string header = "P5\n" + std::to_string(W) + " " + std::to_string(H) + "\n255\n";
    ASSERT_EQ(pgm.size(), header.size() + lamp.size());
    EXPECT_EQ(pgm.substr(0, header.size()), header);
    for (size_t p = 0; p < lamp.size(); ++p) EXPECT_EQ(uint8_t(pgm[header.size() + p]), lamp[p] ? 0 : 255) << p;
  }

  auto all = [](size_t) { return true; };
  auto nolight = [&](size_t p) { return !lamp[p]; };
  double var_all = 0, var_nolight = 0;
  for (size_t i = 0; i < ref_var.size(); ++i) {
    var_all += ref_var[i];
    if (!lamp[i / 3]) var_nolight += ref_var[i];
  }
  EXPECT_NEAR(s["reference"]["rmse_floor"].get<double>(), std::sqrt(var_all / ref_var.size()), 1e-9);
  EXPECT_NEAR(s["reference"]["rmse_floor_nolight"].get<double>(),
              std::sqrt(var_nolight / (3.0 * (lamp.size() - lamps))), 1e-9);

  // Every render again, its errors by hand; then the points, fits, efficiency and frame from them.
  std::map<std::string, std::map<int, std::vector<const ConvergeMeasurement*>>> rows;
  for (const ConvergeMeasurement& m : r.measurements) rows[m.strategy][m.spp].push_back(&m);
  ASSERT_EQ(rows.size(), 2u);
  for (const std::string& technique : {std::string("area"), std::string("solid-angle")}) {
    SCOPED_TRACE(technique);
    const json& js = s["strategies"][technique];
    FrameSpec f = frame_spec(scene);
    f.integrator.strategy = parse_strategy(technique, "test");
    f.integrator.mis = Mis::None;
    std::vector<double> lx, ly, lyn;
    double frame_rmse_nolight = 0, frame_mse_nolight = 0;
    const json& points = js["points"];
    ASSERT_EQ(points.size(), 4u);  // 1, 2, 4, 8
    for (size_t k = 0; k < points.size(); ++k) {
      const int spp = 1 << k;
      const json& pt = points[k];
      ASSERT_EQ(pt["spp"].get<int>(), spp);
      ASSERT_EQ(rows[technique][spp].size(), size_t(seeds));
      double rm = 0, rmn = 0, mse = 0, msen = 0, reln = 0, ms = 0, wall = 0;
      for (int seed = 1; seed <= seeds; ++seed) {
        const ConvergeMeasurement& m = *rows[technique][spp][seed - 1];
        ASSERT_EQ(m.seed, seed);
        f.seed = uint32_t(seed);
        Film film(W, H);
        backend->render(f, film, 0, uint32_t(spp));
        const std::vector<float> img = film.mean();
        const double e = rmse_where(img, ref, all), en = rmse_where(img, ref, nolight);
        EXPECT_NEAR(m.rmse, e, 1e-9 * e) << spp << " spp, seed " << seed;
        EXPECT_NEAR(m.rmse_nolight, en, 1e-9 * en) << spp << " spp, seed " << seed;
        const double rel = relmse_where(img, ref, all), reln_seed = relmse_where(img, ref, nolight);
        EXPECT_NEAR(m.relmse, rel, 1e-9 * rel) << spp << " spp, seed " << seed;
        EXPECT_NEAR(m.relmse_nolight, reln_seed, 1e-9 * reln_seed) << spp << " spp, seed " << seed;
        EXPECT_GT(m.time_ms, 0.0);
        EXPECT_EQ(m.wall_ms, m.time_ms);  // on the CPU the time is the wall time of the call
        rm += m.rmse / seeds;
        rmn += m.rmse_nolight / seeds;
        mse += e * e / seeds;
        msen += en * en / seeds;
        reln += m.relmse_nolight / seeds;
        ms += m.time_ms / seeds;
        wall += m.wall_ms / seeds;
        if (spp == o.frame_spp) {  // sample 4 alone: the 4-spp sums less the 3-spp sums
          Film before(W, H);
          backend->render(f, before, 0, uint32_t(spp - 1));
          std::vector<float> last(img.size());
          for (size_t i = 0; i < last.size(); ++i) last[i] = float(film.sum()[i] - before.sum()[i]);
          const double fe = rmse_where(last, ref, nolight);
          frame_rmse_nolight += fe / seeds;
          frame_mse_nolight += fe * fe / seeds;
        }
      }
      EXPECT_NEAR(pt["rmse"].get<double>(), rm, 1e-12 * rm);
      EXPECT_NEAR(pt["rmse_nolight"].get<double>(), rmn, 1e-12 * rmn);
      EXPECT_NEAR(pt["relmse_nolight"].get<double>(), reln, 1e-12 * reln);
      // The MSE over seeds: the mean of the squares, not the square of the mean RMSE.
      EXPECT_NEAR(pt["mse"].get<double>(), mse, 1e-9 * mse);
      EXPECT_NEAR(pt["mse_nolight"].get<double>(), msen, 1e-9 * msen);
      EXPECT_NEAR(pt["time_ms"].get<double>(), ms, 1e-12 * ms);
      EXPECT_NEAR(pt["wall_ms"].get<double>(), wall, 1e-12 * wall);
      if (spp >= o.fit_min_spp) {
        lx.push_back(std::log(double(spp)));
        ly.push_back(std::log(rm));
        lyn.push_back(std::log(rmn));
      }
    }
    const double ms_per_spp = points.back()["time_ms"].get<double>() / max_spp;
    EXPECT_NEAR(js["ms_per_spp"].get<double>(), ms_per_spp, 1e-12 * ms_per_spp);
    const double wall_ms_per_spp = points.back()["wall_ms"].get<double>() / max_spp;
    EXPECT_NEAR(js["wall_ms_per_spp"].get<double>(), wall_ms_per_spp, 1e-12 * wall_ms_per_spp);

    // Least squares by hand: slope = cov(x, y) / var(x), through the means; then the spp where the line meets
    // the threshold and that many spp's time.
    auto check_fit = [&](const std::vector<double>& y, const char* key) {
      SCOPED_TRACE(key);
      double mx = 0, my = 0;
      for (size_t i = 0; i < lx.size(); ++i) mx += lx[i] / lx.size(), my += y[i] / lx.size();
      double sxy = 0, sxx = 0;
      for (size_t i = 0; i < lx.size(); ++i) sxy += (lx[i] - mx) * (y[i] - my), sxx += (lx[i] - mx) * (lx[i] - mx);
      const double slope = sxy / sxx, intercept = my - slope * mx;
      const json& fit = js[key];
      EXPECT_NEAR(fit["slope"].get<double>(), slope, 1e-9);
      EXPECT_NEAR(fit["intercept"].get<double>(), intercept, 1e-9);
      ASSERT_LT(slope, 0.0);
      const double n = std::pow(o.threshold / std::exp(intercept), 1.0 / slope);  // threshold = e^a n^b
      EXPECT_NEAR(fit["spp_to_threshold"].get<double>(), n, 1e-9 * n);
      EXPECT_NEAR(fit["ms_to_threshold"].get<double>(), n * ms_per_spp, 1e-9 * n * ms_per_spp);
    };
    check_fit(ly, "fit_rmse");
    check_fit(lyn, "fit_rmse_nolight");

    // Efficiency at the largest spp: 1 / (MSE x seconds), the MSE the mean over seeds of each render's RMSE^2.
    // (The square of the mean RMSE is smaller by the seeds' variance of RMSE: over all pixels here, where the two
    // seeds' lamp pixels differ, by a fifth and more.)
    double mse = 0, mse_n = 0;
    for (const ConvergeMeasurement* m : rows[technique][max_spp]) {
      mse += m->rmse * m->rmse / seeds;
      mse_n += m->rmse_nolight * m->rmse_nolight / seeds;
    }
    const double secs = points.back()["time_ms"].get<double>() / 1000;
    EXPECT_NEAR(js["efficiency"].get<double>(), 1 / (mse * secs), 1e-9 / (mse * secs));
    EXPECT_NEAR(js["efficiency_nolight"].get<double>(), 1 / (mse_n * secs), 1e-9 / (mse_n * secs));
    EXPECT_NEAR(js["frame"]["rmse_nolight"].get<double>(), frame_rmse_nolight, 1e-9 * frame_rmse_nolight);
    // A frame's: its MSE (over seeds) x the time of one sample.
    const double frame_eff = 1 / (frame_mse_nolight * ms_per_spp / 1000);
    EXPECT_NEAR(js["frame"]["efficiency_nolight"].get<double>(), frame_eff, 1e-9 * frame_eff);
  }
  std::filesystem::remove_all(o.cache);
}

// Why the light mask can be rendered with fixed settings (converge.cpp, light_mask_frame): a render of camera rays
// alone (max depth 0) is the same image, to the bit, whatever the strategy, MIS mode and light selection, on scenes
// with sphere lights, many lights, polygon lights (ltc) and, where its bunny is on this machine (../shared/scenes or
// PENUMBRA_SCENES), glossy's sun and sky.
TEST(Converge, CameraRaysAloneDoNotDependOnTheTechnique) {
  for (const char* name : {"cornell-sphere", "many-spheres", "polygon-near", "glossy"}) {
    SCOPED_TRACE(name);
    std::vector<std::string> sets = {"render.width=16", "render.height=9", "render.max_depth=0"};
    if (std::string(name) == "many-spheres") sets.push_back("defaults.lights=300");
    Scene scene;
    try {
      scene = load_scene(name, sets);
    } catch (const SceneError& e) {
      if (std::string(name) != "glossy" || std::string(e.what()).find("not found") == std::string::npos) throw;
      continue;  // its model data is not here: the other scenes stand
    }
    std::string note;
    auto backend = make_backend("cpu", scene, BackendOptions{2}, &note);
    auto image = [&](const char* strategy, const char* mis, const char* selection) {
      FrameSpec f = frame_spec(scene);
      f.integrator.strategy = parse_strategy(strategy, "test");
      f.integrator.mis = parse_mis(mis, "test");
      f.integrator.light_selection = parse_light_selection(selection, "test");
      Film film(16, 9);
      backend->render(f, film, 0, 64);
      return film.mean();
    };
    const std::vector<float> fixed = image("area", "none", "power");
    double sum = 0;
    for (float v : fixed) sum += v;
    EXPECT_GT(sum, 0.0) << "no light seen directly";
    for (const char* strategy : {"area", "solid-angle", "projected-solid-angle", "ltc", "bsdf"})
      for (const char* mis : {"none", "balance", "power"})
        for (const char* selection : {"uniform", "power", "bvh", "sg-bvh", "slc", "restir"})
          EXPECT_EQ(image(strategy, mis, selection), fixed) << strategy << "+" << mis << ", " << selection;
  }
}

// A tiny converge on the CPU (area, no MIS, one seed, spp 1..max_spp) of `scene` at W x H, with a cache of its own
// (emptied) named by `tag`.
ConvergeOptions tiny_converge(const std::string& scene, int W, int H, int max_spp, int reference_spp,
                              const std::string& tag) {
  ConvergeOptions o;
  o.scene = scene;
  o.backend = "cpu";
  o.backend_options.threads = 2;
  o.width = W;
  o.height = H;
  o.max_spp = max_spp;
  o.seeds = 1;
  o.reference_spp = reference_spp;
  o.reference_chunk = reference_spp;
  o.fit_min_spp = 1;
  o.strategies = {"area"};
  o.mis = {"none"};
  o.verbose = false;
  const std::string folder = "penumbra-test-" + tag + "-" + std::to_string(::getpid());
  o.cache = (std::filesystem::temp_directory_path() / folder).string();
  std::filesystem::remove_all(o.cache);
  return o;
}

// The light mask is rendered once for a scene at a size and seed, whatever the techniques, and then read from the
// cache: the runs measure the same pixel set, and a mask file of another size is rendered again.
TEST(Converge, LightMaskIsCachedForEveryTechnique) {
  const ConvergeOptions o = tiny_converge("cornell-sphere", 20, 12, 2, 16, "mask");
  const json first = run_converge(o).summary;
  const auto files = cached_masks(o.cache);
  ASSERT_EQ(files.size(), 1u);
  const auto written = std::filesystem::last_write_time(files[0]);

  // Other techniques, MIS, light selection and depth: the same mask, read (the file untouched), the same pixel set.
  ConvergeOptions other = o;
  other.strategies = {"projected-solid-angle", "bsdf"};
  other.mis = {"power"};
  other.sets = {"render.light_selection=bvh", "render.max_depth=2"};
  const json second = run_converge(other).summary;
  ASSERT_EQ(cached_masks(o.cache), files);
  EXPECT_EQ(std::filesystem::last_write_time(files[0]), written);
  EXPECT_EQ(second["light_pixels"], first["light_pixels"]);
  EXPECT_GT(first["light_pixels"].get<size_t>(), 0u);

  // A file that is not this size's mask (another size's, cut short) is rendered again and replaced.
  std::filesystem::resize_file(files[0], 10);
  const json third = run_converge(o).summary;
  EXPECT_EQ(third["light_pixels"], first["light_pixels"]);
  const json &a = first["strategies"]["area"]["points"], &b = third["strategies"]["area"]["points"];
  ASSERT_EQ(a.size(), b.size());
  for (size_t k = 0; k < a.size(); ++k) EXPECT_EQ(b[k]["rmse_nolight"], a[k]["rmse_nolight"]) << k;
  EXPECT_GT(std::filesystem::file_size(files[0]), 10u);
  std::filesystem::remove_all(o.cache);
}

// A mask whose render met NaN or infinite samples (a sky that overflows floats, seen by camera rays) is not
// cached: every run renders it and counts them.
TEST(Converge, LightMaskWithNonFiniteSamplesIsNotCached) {
  const ConvergeOptions o =
      tiny_converge(std::string(PENUMBRA_TEST_DATA) + "/overflow_env_scene.json", 12, 8, 1, 4, "mask-nan");
  for (int run = 0; run < 2; ++run) {
    const json s = run_converge(o).summary;
    EXPECT_GT(s["nonfinite_by_part"]["mask"].get<uint64_t>(), 0u) << "run " << run;
    EXPECT_TRUE(cached_masks(o.cache).empty()) << "run " << run;
  }
  std::filesystem::remove_all(o.cache);
}

}  // namespace
}  // namespace pn
