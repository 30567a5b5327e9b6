"""The ratios the study puts in its reports (scripts/study/metrics.py), on summaries whose answers are worked
out here by hand.

Each technique of a synthetic summary (the shape of `penumbra converge`'s summary.json) converges as
RMSE = c / sqrt(spp) at ms_per_spp milliseconds a sample, unless said otherwise: then it reaches RMSE t after
(c / t)^2 samples, and its efficiency 1 / (MSE x time) at any spp is 1 / (c^2 x ms_per_spp / 1000). CTest runs
this file (study_metrics)."""
import csv
import math
import os
import sys

import pytest

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), os.pardir, os.pardir, "scripts"))
from study import metrics, planner  # noqa: E402

SPPS = [1, 2, 4, 8]


def technique(c, ms_per_spp, slope=-0.5, threshold=0.1, spps=SPPS):
    """A summary's entry for RMSE = c spp^slope, no-light RMSE half that, relMSE (c / 10)^2 / spp, as converge
    writes it (its fits' spp and ms to `threshold` included)."""
    points = [dict(spp=n, rmse=c * n ** slope, rmse_nolight=c / 2 * n ** slope, relmse=(c / 10) ** 2 / n,
                   relmse_nolight=(c / 20) ** 2 / n, time_ms=ms_per_spp * n) for n in spps]

    def fit(c_):
        spp = (threshold / c_) ** (1 / slope)
        return dict(slope=slope, intercept=math.log(c_), spp_to_threshold=spp, ms_to_threshold=spp * ms_per_spp)
    last = points[-1]
    return dict(points=points, ms_per_spp=ms_per_spp, fit_rmse=fit(c), fit_rmse_nolight=fit(c / 2),
                efficiency=1 / (last["rmse"] ** 2 * last["time_ms"] / 1000),
                efficiency_nolight=1 / (last["rmse_nolight"] ** 2 * last["time_ms"] / 1000))


# area: RMSE 0.8 / sqrt(spp) at 2 ms a sample; solid-angle: 0.4 / sqrt(spp) at 3 ms; bsdf: 1.6 / sqrt(spp) at 1 ms.
# To RMSE 0.1: area (0.8 / 0.1)^2 = 64 spp = 128 ms, solid-angle 16 spp = 48 ms, bsdf 256 spp = 256 ms.
THESIS = dict(strategies=dict(area=technique(0.8, 2.0), **{"solid-angle": technique(0.4, 3.0)}))
LAB = dict(strategies=dict(area=technique(0.8, 2.0), bsdf=technique(1.6, 1.0), **{"solid-angle": technique(0.4, 3.0)}))


def test_synthetic_summary_is_what_it_says():
    a = THESIS["strategies"]["area"]
    assert a["points"][-1]["rmse"] == pytest.approx(0.8 / math.sqrt(8))
    assert a["fit_rmse"]["spp_to_threshold"] == pytest.approx(64)
    assert a["fit_rmse"]["ms_to_threshold"] == pytest.approx(128)
    assert a["efficiency"] == pytest.approx(1 / (0.08 * 0.016))  # MSE 0.64 / 8 at 16 ms


def test_speedup_is_area_time_over_solid_angle_time():
    assert metrics.speedup(THESIS) == pytest.approx(128 / 48)
    assert metrics.speedup(THESIS, to="spp_to_threshold") == pytest.approx(64 / 16)
    # Without the lamp pixels both errors halve: to 0.1, area 16 spp = 32 ms, solid-angle 4 spp = 12 ms.
    assert metrics.speedup(THESIS, "fit_rmse_nolight") == pytest.approx(32 / 12)
    assert metrics.speedup(THESIS, "fit_rmse_nolight", "spp_to_threshold") == pytest.approx(4)


def test_speedup_when_a_technique_never_reaches_the_threshold():
    never = dict(strategies={"area": technique(0.8, 2.0), "solid-angle": technique(0.4, 3.0)})
    never["strategies"]["area"]["fit_rmse"]["ms_to_threshold"] = math.inf
    assert math.isnan(metrics.speedup(never))
    # summary.json as penumbra writes it: JSON has no infinity, and nlohmann::json writes null.
    never["strategies"]["area"]["fit_rmse"]["ms_to_threshold"] = None
    assert math.isnan(metrics.speedup(never))
    del never["strategies"]["area"]["fit_rmse"]  # fewer than two fitted points: no fit at all
    assert math.isnan(metrics.speedup(never))


def test_efficiency_ratio_is_solid_angle_over_area():
    # (c_area^2 x ms_area) / (c_sa^2 x ms_sa) = (0.64 x 2) / (0.16 x 3): for -1/2 slopes, the time-to-quality ratio.
    assert metrics.efficiency_ratio(THESIS) == pytest.approx(1.28 / 0.48)
    assert metrics.efficiency_ratio(THESIS, "efficiency_nolight") == pytest.approx(1.28 / 0.48)
    zero = dict(strategies={"area": dict(efficiency=0.0), "solid-angle": dict(efficiency=5.0)})
    assert math.isnan(metrics.efficiency_ratio(zero))


def test_fit_time_to():
    assert metrics.fit_time_to(LAB, "area", 0.1) == pytest.approx(128)
    assert metrics.fit_time_to(LAB, "solid-angle", 0.1) == pytest.approx(48)
    assert metrics.fit_time_to(LAB, "bsdf", 0.1) == pytest.approx(256)
    assert metrics.fit_time_to(LAB, "area", 0.2) == pytest.approx(16 * 2)
    assert metrics.fit_time_to(LAB, "solid-angle", 0.1, "fit_rmse_nolight") == pytest.approx(12)
    # An RMSE that falls as 1 / spp (slope -1) from 0.8: 0.1 at 8 spp.
    fast = dict(strategies={"x": dict(ms_per_spp=2.0, fit_rmse=dict(slope=-1.0, intercept=math.log(0.8)))})
    assert metrics.fit_time_to(fast, "x", 0.1) == pytest.approx(16)
    flat = dict(strategies={"x": dict(ms_per_spp=2.0, fit_rmse=dict(slope=0.0, intercept=math.log(0.8)))})
    assert metrics.fit_time_to(flat, "x", 0.1) == math.inf
    assert metrics.fit_time_to(LAB, "missing", 0.1) == math.inf


def test_wall_times_only_for_gpu_runs_that_measured_them():
    def run(backend, wall):
        strategies = {t: dict(technique(0.8, 2.0), **({"wall_ms_per_spp": 2.5} if wall else {}))
                      for t in ("area", "solid-angle")}
        return dict(backend=backend, strategies=strategies)
    assert metrics.wall_times([run("optix", True), run("optix", True)])
    assert not metrics.wall_times([run("optix", True), run("optix", False)])  # one run from before they were timed
    assert not metrics.wall_times([run("cpu", True)])  # on the CPU the time is the wall time already
    assert not metrics.wall_times([])
    one_missing = run("optix", True)
    del one_missing["strategies"]["area"]["wall_ms_per_spp"]
    assert not metrics.wall_times([one_missing])


def test_lab_threshold_is_the_largest_last_rmse_of_light_sampling():
    # At 8 spp: area 0.8 / sqrt(8), solid-angle 0.4 / sqrt(8), bsdf 1.6 / sqrt(8) (left out): area's.
    assert metrics.lab_threshold(LAB) == pytest.approx(0.8 / math.sqrt(8))
    worse = dict(strategies={**LAB["strategies"], "x": technique(1.2, 1.0)})
    assert metrics.lab_threshold(worse) == pytest.approx(1.2 / math.sqrt(8))
    only_bsdf = dict(strategies=dict(bsdf=technique(1.6, 1.0)))
    assert metrics.lab_threshold(only_bsdf) == pytest.approx(1.6 / math.sqrt(8))


def test_lab_speedups_are_relative_to_area():
    # Target 0.8 / sqrt(8): area 8 spp = 16 ms, solid-angle 2 spp = 6 ms, bsdf 32 spp = 32 ms.
    sp = metrics.lab_speedups(LAB)
    assert sp == pytest.approx({"area": 1.0, "solid-angle": 16 / 6, "bsdf": 16 / 32})
    # Without the lamp pixels (c halved), to the same target: area 2 spp = 4 ms, solid-angle 0.5 spp = 1.5 ms.
    assert metrics.lab_speedups(LAB, "fit_rmse_nolight")["solid-angle"] == pytest.approx(4 / 1.5)
    # With slopes that differ, the target matters. "fast": RMSE 0.4 / spp at 4 ms. At 8 spp the largest RMSE is
    # area's, 0.8 / sqrt(8) (8 spp = 16 ms): fast reaches it at sqrt(8) / 2 spp = 2 sqrt(8) ms, solid-angle at 2
    # spp = 6 ms.
    mixed = dict(strategies=dict(area=technique(0.8, 2.0), fast=technique(0.4, 4.0, slope=-1.0),
                                 **{"solid-angle": technique(0.4, 3.0)}))
    assert metrics.lab_threshold(mixed) == pytest.approx(0.8 / math.sqrt(8))
    assert metrics.lab_speedups(mixed) == pytest.approx({"area": 1.0, "solid-angle": 16 / 6,
                                                       "fast": 16 / (2 * math.sqrt(8))})


def test_fit_extrapolated_when_the_target_is_outside_the_measured_rmse():
    # bsdf's RMSE runs from 1.6 (1 spp) to 1.6 / sqrt(8) = 0.566: the target 0.283 is beyond its points.
    thr = metrics.lab_threshold(LAB)
    assert not metrics.fit_extrapolated(LAB, "area", thr)  # its own last point
    assert not metrics.fit_extrapolated(LAB, "solid-angle", thr)  # 0.4 .. 0.141 holds 0.283
    assert metrics.fit_extrapolated(LAB, "bsdf", thr)
    assert metrics.fit_extrapolated(LAB, "area", 0.1)  # area's smallest RMSE is 0.283
    # No-light RMSEs (half): area's run from 0.4 to 0.141.
    assert not metrics.fit_extrapolated(LAB, "area", 0.2, "fit_rmse_nolight")
    assert metrics.fit_extrapolated(LAB, "missing", thr)


def test_lab_efficiency_is_relative_to_area():
    # 1 / (c^2 ms): area 1 / 1.28, solid-angle 1 / 0.48, bsdf 1 / 2.56.
    assert metrics.lab_efficiency(LAB, "area") == pytest.approx(1)
    assert metrics.lab_efficiency(LAB, "solid-angle") == pytest.approx(1.28 / 0.48)
    assert metrics.lab_efficiency(LAB, "bsdf") == pytest.approx(1.28 / 2.56)
    assert metrics.lab_efficiency(LAB, "bsdf", "efficiency_nolight") == pytest.approx(0.5)


def many(c, ms_per_spp, mean_nolight=1.0):
    """A many-lights run: techniques named strategy+power, the reference's mean without lamp pixels 1."""
    st = {f"{s}+power": technique(c * k, ms_per_spp * t)
          for s, k, t in (("area", 2.0, 1.0), ("solid-angle", 1.0, 1.0), ("projected-solid-angle", 1.0, 2.0))}
    for js in st.values():
        js["points"][-1]["mean_nolight"] = mean_nolight
    return dict(strategies=st, reference=dict(mean_nolight=1.0))


def test_many_efficiency_is_relative_to_power():
    # bvh: half power's RMSE (a quarter of its MSE) at 1.5x its time: 4 / 1.5 more efficient, for every strategy.
    runs = dict(power=many(0.4, 2.0), bvh=many(0.2, 3.0))
    for st in planner.MANY_STRATEGIES:
        assert metrics.many_efficiency(runs, "bvh", st) == pytest.approx(4 / 1.5)
        assert metrics.many_efficiency(runs, "power", st) == pytest.approx(1)
        assert metrics.many_efficiency(runs, "bvh", st, key="efficiency") == pytest.approx(4 / 1.5)
    assert metrics.many_efficiency(runs, "power", "solid-angle", base="bvh") == pytest.approx(1.5 / 4)


def test_mse_nolight_is_the_mean_square_over_seeds():
    # Seeds of RMSE 0.1 and 0.3: MSE (0.01 + 0.09) / 2 = 0.05, not the square of the mean RMSE, 0.04.
    assert metrics.mse_nolight(dict(rmse_nolight=0.2, mse_nolight=0.05)) == 0.05
    # Summaries from before converge wrote mse_nolight: the square of the mean RMSE, all there is.
    assert metrics.mse_nolight(dict(rmse_nolight=0.2)) == pytest.approx(0.04)


def test_many_relmse_efficiency():
    # Largest spp 8: relMSE_nolight (c / 20)^2 / 8 at 8 ms_per_spp milliseconds.
    e = metrics.many_relmse_efficiency(many(0.4, 2.0), "solid-angle")
    assert e == pytest.approx(1 / ((0.4 / 20) ** 2 / 8 * 16))
    assert metrics.many_relmse_efficiency(many(0.2, 3.0), "solid-angle") / e == pytest.approx(4 / 1.5)
    zero = many(0.4, 2.0)
    zero["strategies"]["solid-angle+power"]["points"][-1]["relmse_nolight"] = 0.0
    assert math.isnan(metrics.many_relmse_efficiency(zero, "solid-angle"))


def test_many_mean_bias():
    assert metrics.many_mean_bias(many(0.4, 2.0, mean_nolight=1.02), "solid-angle") == pytest.approx(0.02)
    assert metrics.many_mean_bias(many(0.4, 2.0, mean_nolight=0.95), "solid-angle") == pytest.approx(-0.05)
    no_ref = many(0.4, 2.0)
    no_ref["reference"] = {}
    assert math.isnan(metrics.many_mean_bias(no_ref, "solid-angle"))


DENOISE_ROWS = [dict(scene=scene, technique=t, spp=spp, seed=seed, rmse_raw=raw * k / math.sqrt(spp),
                     rmse_denoised=den * k / math.sqrt(spp), rmse_raw_nolight=raw * k / 2 / math.sqrt(spp),
                     rmse_denoised_nolight=den * k / 4 / math.sqrt(spp))
                for scene in ("a", "b")
                for t, raw, den in (("area", 0.8, 0.2), ("solid-angle", 0.4, 0.16), ("solid-angle+power", 0.3, 0.1))
                for spp in (1, 4)
                for seed, k in ((1, 0.9), (2, 1.1))]  # the seeds' mean: k = 1


def test_denoise_table_averages_the_seeds():
    table = metrics.denoise_table(DENOISE_ROWS)
    assert set(table) == {"a", "b"}
    assert table["a"]["area"][1] == pytest.approx((0.8, 0.2))
    assert table["a"]["area"][4] == pytest.approx((0.4, 0.1))
    assert table["b"]["solid-angle"][4] == pytest.approx((0.2, 0.08))
    nolight = metrics.denoise_table(DENOISE_ROWS, "_nolight")
    assert nolight["a"]["solid-angle+power"][1] == pytest.approx((0.15, 0.025))


def test_denoise_ratios_are_area_over_solid_angle_at_equal_spp():
    ratios = metrics.denoise_ratios(metrics.denoise_table(DENOISE_ROWS))
    assert ratios == {sc: {1: pytest.approx((2.0, 1.25)), 4: pytest.approx((2.0, 1.25))} for sc in ("a", "b")}
    # A scene without area has no ratio.
    only_sa = metrics.denoise_table([r for r in DENOISE_ROWS if r["technique"] != "area"])
    assert metrics.denoise_ratios(only_sa) == {}
    no_sa = metrics.denoise_table([r for r in DENOISE_ROWS if r["technique"] != "solid-angle"])
    assert metrics.denoise_ratios(no_sa) == {}


def test_at_time_interpolates_in_log_log_and_never_extrapolates():
    pts = [(1.0, 1.0), (4.0, 0.5), (16.0, 0.25)]  # RMSE = t^(-1/2)
    assert metrics.at_time(pts, 2.0) == pytest.approx(2.0 ** -0.5)
    assert metrics.at_time(pts, 9.0) == pytest.approx(1 / 3)
    assert metrics.at_time(pts, 16.0) == pytest.approx(0.25)
    assert metrics.at_time(pts, 0.5) is None and metrics.at_time(pts, 17.0) is None


def test_denoise_equal_time_reads_solid_angle_at_area_s_time():
    # area: RMSE 0.8 / sqrt(spp) raw, 0.4 / sqrt(spp) denoised, 1 ms a sample; solid-angle: 0.4 / sqrt(spp) raw,
    # 0.1 / sqrt(spp) denoised, 2 ms a sample. At area's time t = spp ms, solid-angle has spp / 2 samples:
    # raw ratio 0.8 / 0.4 / sqrt(2) = sqrt(2), denoised 0.4 / 0.1 / sqrt(2) = 2 sqrt(2); area's 1 spp (1 ms) is
    # before solid-angle's first point (2 ms): left out.
    spps = (1, 2, 4, 8)
    table = {"s": {"area": {n: (0.8 / math.sqrt(n), 0.4 / math.sqrt(n)) for n in spps},
                   "solid-angle": {n: (0.4 / math.sqrt(n), 0.1 / math.sqrt(n)) for n in spps}}}
    times = {"s": {"area": {n: 1.0 * n for n in spps}, "solid-angle": {n: 2.0 * n for n in spps}}}
    eq = metrics.denoise_equal_time(table, times)
    assert set(eq["s"]) == {2, 4, 8}
    for n in (2, 4, 8):
        assert eq["s"][n] == pytest.approx((math.sqrt(2), 2 * math.sqrt(2)))
    rows = [dict(scene="s", technique="area", spp=n, render_ms=t) for n, t in ((1, 1.0), (1, 3.0), (2, 4.0))]
    assert metrics.denoise_times(rows) == {"s": {"area": {1: 2.0, 2: 4.0}}}


def test_median_seed_slope(tmp_path):
    # Seeds 1 and 2 fall as 1 / sqrt(spp); seed 3 is stuck at 5 (a rare huge sample). Each spp's median is seed 2's,
    # 1.1 / sqrt(spp): slope -1/2 exactly (the mean over seeds would be far flatter).
    path = tmp_path / "measurements.csv"
    with open(path, "w", newline="") as f:
        w = csv.DictWriter(f, ["scene", "strategy", "spp", "seed", "time_ms", "rmse", "rmse_nolight", "relmse",
                               "relmse_nolight"])
        w.writeheader()
        for spp in (1, 2, 4, 8, 16):
            for seed, rm in ((1, 1.0 / math.sqrt(spp)), (2, 1.1 / math.sqrt(spp)), (3, 5.0)):
                w.writerow(dict(scene="s", strategy="solid-angle+power", spp=spp, seed=seed, time_ms=1, rmse=rm,
                                rmse_nolight=rm, relmse=0, relmse_nolight=0))
                w.writerow(dict(scene="s", strategy="area+power", spp=spp, seed=seed, time_ms=1, rmse=1,
                                rmse_nolight=2.0 / spp, relmse=0, relmse_nolight=0))
    assert metrics.median_seed_slope(str(path), "solid-angle+power") == pytest.approx(-0.5)
    assert metrics.median_seed_slope(str(path), "area+power") == pytest.approx(-1.0)


def test_light_distance():
    # The Cornell box is 5.56 x 5.488 x 5.592: the thesis sweeps' d, from a point to the nearest wall.
    assert metrics.light_distance((2.78, 4.4, 2.8)) == pytest.approx(5.488 - 4.4)
    assert metrics.light_distance((0.5, 2.0, 2.0)) == pytest.approx(0.5)
    assert metrics.light_distance((2.78, 2.744, 5.0)) == pytest.approx(5.592 - 5.0)
