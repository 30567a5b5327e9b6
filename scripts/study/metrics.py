"""The ratios and fits the reports print, from `penumbra converge`'s summaries
(tests/scripts/test_study_metrics.py works their answers out by hand)."""
import csv
import math
import statistics

from .planner import BOX


def light_distance(center):
    """Distance from a point to the nearest wall, floor or ceiling of the box."""
    return min(min(c, e - c) for c, e in zip(center, BOX))


def speedup(summary, key="fit_rmse", to="ms_to_threshold"):
    """Time-to-quality ratio area / solid-angle (> 1: solid-angle is faster); to="spp_to_threshold": samples.
    A time that never comes is infinite in converge's summary, null in its summary.json (JSON has no infinity)."""
    def needed(st):
        t = summary["strategies"][st].get(key, {}).get(to)
        return math.inf if t is None else t
    a, s = needed("area"), needed("solid-angle")
    return a / s if s > 0 and math.isfinite(a) and math.isfinite(s) else float("nan")


def wall_times(summaries):
    """Whether the runs timed their renders on the GPU and also measured the wall time of each render call
    (`wall_ms_per_spp`, the film's read-back included): the reports then show it beside the GPU time. On the CPU
    a render's time is its wall time already; runs made before converge measured it have none."""
    summaries = list(summaries)
    return bool(summaries) and all(s.get("backend") != "cpu" and all("wall_ms_per_spp" in js
                                                                     for js in s["strategies"].values())
                                   for s in summaries)


def efficiency_ratio(summary, key="efficiency"):
    a = summary["strategies"]["area"][key]
    s = summary["strategies"]["solid-angle"][key]
    return s / a if a > 0 else float("nan")


def fit_time_to(summary, technique, threshold, key="fit_rmse"):
    """ms for `technique` to reach `threshold` along its fitted line (inf if it never does)."""
    js = summary["strategies"].get(technique)
    if not js or key not in js:
        return math.inf
    f = js[key]
    if not f["slope"] < 0:
        return math.inf
    spp = math.exp((math.log(threshold) - f["intercept"]) / f["slope"])
    return spp * js["ms_per_spp"]


def fit_extrapolated(summary, technique, threshold, key="fit_rmse"):
    """Whether `threshold` lies outside the RMSEs `technique` was measured at: its time to it is then read off its
    fitted line beyond its points."""
    js = summary["strategies"].get(technique)
    if not js or key not in js or not js[key]["slope"] < 0:
        return True
    measured = [p["rmse_nolight" if key.endswith("_nolight") else "rmse"] for p in js["points"]]
    return not min(measured) <= threshold <= max(measured)


def lab_threshold(summary):
    """A per-scene RMSE target that every light-sampling technique reaches within its measured spp: the largest
    of their RMSEs at the largest spp (bsdf, far noisier on small lights, left out: its time is an estimate)."""
    last = [js["points"][-1]["rmse"] for t, js in summary["strategies"].items() if t != "bsdf"]
    return max(last or [js["points"][-1]["rmse"] for js in summary["strategies"].values()])


def lab_speedups(summary, key="fit_rmse"):
    """Time-to-quality of each technique relative to area with MIS none (> 1: faster)."""
    thr = lab_threshold(summary)
    base = fit_time_to(summary, "area", thr, key)
    return {t: base / fit_time_to(summary, t, thr, key) for t in summary["strategies"]}


def lab_efficiency(summary, t, key="efficiency"):
    return summary["strategies"][t][key] / summary["strategies"]["area"][key]


def many_technique(strategy):
    return f"{strategy}+power"


def mse_nolight(point):
    """A point's MSE without the lamp pixels: the mean over seeds of RMSE^2 (summaries before converge wrote it:
    the square of the mean RMSE, smaller by the seeds' variance of RMSE)."""
    return point.get("mse_nolight", point["rmse_nolight"] ** 2)


# Many-light scenes show their lamps: pixels that see a light directly carry the
# lamps' own (pixel-coverage) noise, alike for every method and far above the
# rest. Errors are measured without them (converge's *_nolight metrics).
def many_efficiency(runs, sel, strategy, base="power", key="efficiency_nolight"):
    t = many_technique(strategy)
    return runs[sel]["strategies"][t][key] / runs[base]["strategies"][t][key]


def many_relmse_efficiency(summary, strategy):
    """1 / (relMSE x time) at the largest spp, without the pixels that see a light."""
    last = summary["strategies"][many_technique(strategy)]["points"][-1]
    e = last["relmse_nolight"] * last["time_ms"]
    return 1.0 / e if e > 0 else float("nan")


def many_mean_bias(summary, strategy):
    """(image mean - reference mean) / reference mean at the largest spp, over seeds: the bias (plus noise)."""
    ref = summary["reference"].get("mean_nolight", 0)
    m = summary["strategies"][many_technique(strategy)]["points"][-1].get("mean_nolight")
    return (m - ref) / ref if ref and m is not None else float("nan")


def median_seed_slope(csv_path, technique):
    """The log-log slope of the no-lamp RMSE against spp, each spp's RMSE the median over the seeds (not their mean,
    which converge's own fit uses): one seed's rare large sample cannot flatten it, a bias in every seed can."""
    by_spp = {}
    with open(csv_path) as f:
        for row in csv.DictReader(f):
            if row["strategy"] == technique:
                by_spp.setdefault(int(row["spp"]), []).append(float(row["rmse_nolight"]))
    xs = [math.log(n) for n in sorted(by_spp)]
    ys = [math.log(statistics.median(by_spp[n])) for n in sorted(by_spp)]
    mx, my = sum(xs) / len(xs), sum(ys) / len(ys)
    return sum((x - mx) * (y - my) for x, y in zip(xs, ys)) / sum((x - mx) ** 2 for x in xs)


def denoise_table(rows, suffix=""):
    """{scene: {technique: {spp: (mean raw RMSE, mean denoised RMSE)}}} over seeds; suffix "_nolight":
    without the pixels that see a light."""
    acc = {}
    for r in rows:
        d = acc.setdefault(r["scene"], {}).setdefault(r["technique"], {}).setdefault(r["spp"], [[], []])
        d[0].append(r["rmse_raw" + suffix])
        d[1].append(r["rmse_denoised" + suffix])
    return {sc: {t: {spp: (sum(v[0]) / len(v[0]), sum(v[1]) / len(v[1])) for spp, v in sorted(ts.items())}
                 for t, ts in techs.items()} for sc, techs in acc.items()}


def denoise_times(rows):
    """{scene: {technique: {spp: mean render ms}}} over seeds (the image's cumulative render time)."""
    acc = {}
    for r in rows:
        acc.setdefault(r["scene"], {}).setdefault(r["technique"], {}).setdefault(r["spp"], []).append(
            r.get("render_ms", 0.0))
    return {sc: {t: {spp: sum(v) / len(v) for spp, v in sorted(ts.items())} for t, ts in techs.items()}
            for sc, techs in acc.items()}


def at_time(points, t):
    """log-log interpolation of [(time, rmse), ...] (increasing time) at time t; None outside the measured times."""
    pts = [(a, b) for a, b in points if a > 0 and b > 0]
    for (t0, r0), (t1, r1) in zip(pts, pts[1:]):
        if t0 <= t <= t1:
            if t1 == t0:
                return r0
            f = (math.log(t) - math.log(t0)) / (math.log(t1) - math.log(t0))
            return math.exp(math.log(r0) + f * (math.log(r1) - math.log(r0)))
    return None


def denoise_equal_time(table, times, a="area", b="solid-angle"):
    """{scene: {spp of a: (raw ratio, denoised ratio)}}: RMSE(a) / RMSE(b) at a's render time at that spp, b's RMSE
    read off its own measured points (log-log); a point outside b's measured times is left out (never
    extrapolated)."""
    out = {}
    for scene, ts in table.items():
        if a not in ts or b not in ts:
            continue
        ta, tb = times[scene][a], times[scene][b]
        row = {}
        for spp in sorted(ts[a]):
            t = ta[spp]
            raw_b = at_time([(tb[s], ts[b][s][0]) for s in sorted(ts[b])], t)
            den_b = at_time([(tb[s], ts[b][s][1]) for s in sorted(ts[b])], t)
            if raw_b and den_b:
                row[spp] = (ts[a][spp][0] / raw_b, ts[a][spp][1] / den_b)
        if row:
            out[scene] = row
    return out


def denoise_ratios(table):
    """{scene: {spp: (area/solid-angle raw, area/solid-angle denoised)}}: RMSE ratios at equal spp."""
    out = {}
    for scene, ts in table.items():
        if "area" in ts and "solid-angle" in ts:
            out[scene] = {spp: (ts["area"][spp][0] / ts["solid-angle"][spp][0],
                                ts["area"][spp][1] / ts["solid-angle"][spp][1]) for spp in sorted(ts["area"])}
    return out
