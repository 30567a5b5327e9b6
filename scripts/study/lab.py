"""The light-sampling lab (issue 10): every strategy x MIS mode on the lab's
scenes and its sweeps; figures, report (lab/README.md) and assertions."""
import json
import os

from .common import checks_passed, log, write_atomic, write_text
from .metrics import (fit_extrapolated, lab_efficiency, lab_speedups, lab_threshold, light_distance, speedup,
                      wall_times)
from .planner import LAB_POLYGON_SCENES, LAB_TECHNIQUES
from .report import finish_ratio_plot, fmt, generated_by, np, plt

LAB_COLORS = {"area": "#d62728", "solid-angle": "#1f77b4", "projected-solid-angle": "#2ca02c", "ltc": "#ff7f0e",
              "bsdf": "#7f7f7f"}
LAB_STYLES = {"none": "o-", "balance": "s:", "power": "^--"}
# A table cell of a technique a scene does not run: ltc where every light is a sphere (there it samples as
# projected-solid-angle does).
NOT_RUN = "="


def technique_parts(t):
    st, _, m = t.partition("+")
    return st, (m or "none")


def plot_lab_convergence(summary, path):
    fig, axes = plt.subplots(1, 2, figsize=(11, 4.2))
    for t, js in summary["strategies"].items():
        st, m = technique_parts(t)
        pts = js["points"]
        spp = np.array([p["spp"] for p in pts])
        rmse = np.array([p["rmse"] for p in pts])
        ms = np.array([p["time_ms"] for p in pts])
        kw = dict(color=LAB_COLORS[st], ms=3, lw=1, label=t)
        axes[0].loglog(spp, rmse, LAB_STYLES[m], **kw)
        axes[1].loglog(ms, rmse, LAB_STYLES[m], **kw)
    axes[0].set_xlabel("samples per pixel")
    axes[1].set_xlabel(f"render time (ms, {summary['backend']})")
    for ax in axes:
        ax.set_ylabel("RMSE")
        ax.grid(True, which="both", alpha=0.3)
    axes[1].legend(fontsize=6, ncol=2)
    fig.suptitle(f"{summary['scene']} at {summary['width']}x{summary['height']}: every technique")
    fig.tight_layout()
    write_atomic(path, lambda tmp: fig.savefig(tmp, dpi=110))
    plt.close(fig)


def plot_lab_sweep(xs, runs, techniques, xlabel, title, path, log_x=True):
    fig, ax = plt.subplots(figsize=(5.8, 3.9))
    for t in techniques:
        st, m = technique_parts(t)
        ax.plot(xs, [lab_efficiency(r, t) for r in runs], LAB_STYLES[m], color=LAB_COLORS[st], label=t)
    finish_ratio_plot(fig, ax, xlabel, "efficiency relative to area (MIS none)", title, path, log_x, 7)


def plot_roughness_sweep(xs, runs, techniques, key, xlabel, ylabel, path):
    """Each technique's efficiency (summary key `key`) against roughness, log-log."""
    fig, ax = plt.subplots(figsize=(5.8, 3.9))
    for t in techniques:
        st, m = technique_parts(t)
        ax.plot(xs, [r["strategies"][t][key] for r in runs], LAB_STYLES[m], color=LAB_COLORS[st], label=t)
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_xlabel(xlabel)
    ax.set_ylabel(ylabel)
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=6, ncol=2)
    fig.tight_layout()
    write_atomic(path, lambda tmp: fig.savefig(tmp, dpi=110))
    plt.close(fig)


def write_lab_report(args, lab, head, sweeps, out_dir):
    fig_dir = os.path.join(out_dir, "figures")
    os.makedirs(fig_dir, exist_ok=True)
    env = head[0]
    lines = []
    w = lines.append
    h, s = lab["headline"], lab["sweep"]
    w("# The light-sampling lab: every strategy and MIS mode, at equal time\n")
    w(generated_by(args, " --part lab", env))
    w("## What was measured\n")
    w(f"- Scenes: {', '.join(r['scene'] for r in head)} at {h['width']}x{h['height']}, max depth 8, ground truth "
      f"{h['reference_spp']} spp (solid-angle with the power heuristic, its own seed), renders at 1, 2, 4, ..., "
      f"{h['max_spp']} spp with {h['seeds']} independent seeds per point.")
    w("- Techniques: the strategies `area`, `solid-angle`, `projected-solid-angle`, `ltc` (the GGX lobe's linearly "
      "transformed cosine mixed with projected-solid-angle on quads and triangles; projected-solid-angle on spheres), "
      "each with `--mis none` (light "
      "sampling only: the thesis's estimator), `balance` and `power` (one light and one BSDF sample per vertex, "
      "Veach's heuristics), and `bsdf` (no light sampling). Named `area`, `area+balance`, `area+power`, ...")
    w("- `ltc` runs where a scene has quad or triangle lights (" + ", ".join(LAB_POLYGON_SCENES) + "): with sphere "
      "lights only it samples exactly as `projected-solid-angle` does, and its cells read `=`.")
    w("- Time: GPU time of the launches (CUDA events) on the GPU, wall time on the CPU; per point the mean over seeds.")
    w("- **Efficiency** = 1 / (MSE x time) at the largest spp, relative to `area` (the larger, the better at equal "
      "time). **Time to quality**: time to reach the scene's RMSE target along each technique's fitted log-log line, "
      "relative to `area`; the target is the largest RMSE at the largest spp among the light-sampling techniques, "
      "so that each reaches it within its measured spp (a time read beyond them is marked). RMSE on linear, unclamped radiance (thesis eq. 4.1) over all pixels, and "
      "over the pixels that see no emitter directly (no-light pixels: docs/metrics.md), where the techniques differ "
      "and a lamp's edge noise, the same for all of them, is left out. Efficiency at the largest measured spp, for "
      "global illumination and for direct lighting alone (max depth 1: the camera's vertex lit by next-event "
      "estimation, what a light sampler changes).")
    w(f"- Sweeps at {s['width']}x{s['height']}, ground truth {s['reference_spp']} spp, up to {s['max_spp']} spp, "
      f"{s['seeds']} seeds.\n")
    w("Every measurement: `runs/*/measurements.csv`, fits and settings: `runs/*/summary.json`.\n")

    w("## Time to quality relative to `area` (MIS none)\n")
    cols = [t for t in LAB_TECHNIQUES if any(t in r["strategies"] for r in head)]
    w("| scene | RMSE target | " + " | ".join(f"`{t}`" for t in cols) + " |")
    w("| --- | ---: |" + " ---: |" * len(cols))
    extrapolated = False
    for r in head:
        sp, thr = lab_speedups(r), lab_threshold(r)
        cells = []
        for t in cols:
            if t not in r["strategies"]:
                cells.append(NOT_RUN)
                continue
            # A time read off a fitted line beyond the technique's own points (its or area's) is marked, never quoted.
            mark = "†" if fit_extrapolated(r, t, thr) or fit_extrapolated(r, "area", thr) else ""
            extrapolated = extrapolated or bool(mark)
            cells.append(f"{fmt(sp.get(t, float('nan')))}x{mark}")
        w(f"| {r['scene']} | {thr:.4f} | " + " | ".join(cells) + " |")
    if extrapolated:
        w("\n† extrapolated: the technique (or `area`) reaches the target only along its fitted line beyond the spp "
          "measured; an estimate, not a measurement (the efficiency tables below are measured).")
    def efficiency_table(runs, key):
        w("| scene | " + " | ".join(f"`{t}`" for t in cols) + " |")
        w("| --- |" + " ---: |" * len(cols))
        for r in runs:
            w(f"| {r['scene']} | " + " | ".join(fmt(lab_efficiency(r, t, key)) if t in r["strategies"] else NOT_RUN
                                                 for t in cols) + " |")
    direct = sweeps.get("direct", [])
    for title, runs in (("global illumination (max depth 8)", head), ("direct lighting only (max depth 1)", direct)):
        if not runs:
            continue
        for key, pixels in (("efficiency", "all pixels"), ("efficiency_nolight", "no-light pixels")):
            w(f"\n## Efficiency (1 / (MSE x time)) relative to `area`: {title}, {pixels}\n")
            efficiency_table(runs, key)
    comp = sweeps.get("compensation", [])
    plain = [r for r in head if r["scene"] == "glossy"]
    if comp and plain:
        c, p = comp[0], plain[0]
        w("\n## MIS compensation of glossy's sky (Karlik et al. 2019): compensated over plain\n")
        w("The environment's light samples drawn from its MIS-compensated distribution (`--mis-compensation`: the "
          "image's density less its mean, where BSDF sampling covers the rest), against the plain distribution, same "
          "technique and size; efficiency 1 / (MSE x time), global illumination.\n")
        w("| technique | all pixels | no-light pixels | ms per spp, compensated / plain |")
        w("| --- | ---: | ---: | ---: |")
        for t in c["strategies"]:
            if t not in p["strategies"]:
                continue
            a, b = c["strategies"][t], p["strategies"][t]
            w(f"| `{t}` | {fmt(a['efficiency'] / b['efficiency'])}x | "
              f"{fmt(a['efficiency_nolight'] / b['efficiency_nolight'])}x | "
              f"{a['ms_per_spp']:.3f} / {b['ms_per_spp']:.3f} |")
    w("\n## Cost: ms per spp\n")
    wall = wall_times(head)
    if wall:
        w("GPU time; below it, the wall time of the same render calls (the film's read-back included).\n")
    for i, key in enumerate(["ms_per_spp"] + (["wall_ms_per_spp"] if wall else [])):
        if i:
            w("")
        w("| scene | " + " | ".join(f"`{t}`" for t in cols) + " |")
        w("| --- |" + " ---: |" * len(cols))
        for r in head:
            w(f"| {r['scene']} | " + " | ".join(f"{r['strategies'][t][key]:.3f}" if t in r["strategies"]
                                                 else NOT_RUN for t in cols) + " |")
    w("\n## Per scene: RMSE at the largest spp, slopes\n")
    for r in head:
        w(f"**{r['scene']}** ({r['width']}x{r['height']}; reference noise adds RMSE {r['reference']['rmse_floor']:.4f} "
          "in quadrature)\n")
        w("| technique | ms/spp | RMSE @ " + str(r["strategies"]["area"]["points"][-1]["spp"]) +
          " spp | slope | efficiency vs area | time to quality vs area |")
        w("| --- | ---: | ---: | ---: | ---: | ---: |")
        sp = lab_speedups(r)
        for t in cols:
            if t not in r["strategies"]:
                continue
            js = r["strategies"][t]
            w(f"| `{t}` | {js['ms_per_spp']:.3f} | {js['points'][-1]['rmse']:.4f} | {js['fit_rmse']['slope']:.3f} | "
              f"{fmt(lab_efficiency(r, t))} | {fmt(sp[t])}x |")
        p = f"lab_convergence_{r['scene']}.png"
        plot_lab_convergence(r, os.path.join(fig_dir, p))
        w(f"\n![{r['scene']}](figures/{p})\n")

    three = ["area", "solid-angle", "projected-solid-angle"]
    def sweep_table(runs, label, values, techniques):
        w("| " + label + " | " + " | ".join(f"`{t}`" for t in techniques) + " |")
        w("|" + " ---: |" * (len(techniques) + 1))
        for v, r in zip(values, runs):
            w(f"| {v} | " + " | ".join(fmt(lab_efficiency(r, t)) for t in techniques) + " |")
        w("")
    if sweeps.get("radius"):
        rd = [r / light_distance((2.78, 4.4, 2.8)) for r in lab["radii"]]
        w("## Radius sweep (cornell-sphere), efficiency relative to area\n")
        plot_lab_sweep(rd, sweeps["radius"], three, "r / d", "cornell-sphere: radius", os.path.join(fig_dir, "lab_sweep_radius.png"))
        w("![radius](figures/lab_sweep_radius.png)\n")
        sweep_table(sweeps["radius"], "radius", [str(x) for x in lab["radii"]], three)
    if sweeps.get("distance"):
        w("## Distance sweep (cornell-near), efficiency relative to area\n")
        plot_lab_sweep([1 / k for k in lab["near_k"]], sweeps["distance"], three, "r / d", "cornell-near: distance",
                       os.path.join(fig_dir, "lab_sweep_distance.png"))
        w("![distance](figures/lab_sweep_distance.png)\n")
        sweep_table(sweeps["distance"], "d / r", [str(k) for k in lab["near_k"]], three)
    if sweeps.get("panel"):
        w("## Polygon distance sweep (polygon-near, the panel moved away from the back wall), efficiency relative to area\n")
        xs = [max(o, 0.05) for o in lab["panel_offsets"]]
        plot_lab_sweep(xs, sweeps["panel"], three, "panel offset from the wall (0 plotted at 0.05)", "polygon-near: distance",
                       os.path.join(fig_dir, "lab_sweep_panel.png"))
        w("![panel](figures/lab_sweep_panel.png)\n")
        sweep_table(sweeps["panel"], "offset", [str(o) for o in lab["panel_offsets"]], three)
    if sweeps.get("roughness"):
        w("## Roughness sweep (glossy): MIS against the single techniques\n")
        ts = ["solid-angle", "bsdf", "solid-angle+balance", "solid-angle+power"]
        plot_roughness_sweep(lab["roughness"], sweeps["roughness"], ts, "efficiency", "roughness",
                             "efficiency 1 / (MSE x ms)", os.path.join(fig_dir, "lab_sweep_roughness.png"))
        w("![roughness](figures/lab_sweep_roughness.png)\n")
        w("| roughness | " + " | ".join(f"`{t}`" for t in ts) + " | power / best single |")
        w("|" + " ---: |" * (len(ts) + 2))
        for x, r in zip(lab["roughness"], sweeps["roughness"]):
            e = {t: r["strategies"][t]["efficiency"] for t in ts}
            best = max(e["solid-angle"], e["bsdf"])
            w(f"| {x} | " + " | ".join(f"{e[t]:.4g}" for t in ts) + f" | {fmt(e['solid-angle+power'] / best)}x |")
        w("")
    for key, floor in (("roughness_polygon", "its plastic floor (F0 0.04 over a diffuse base)"),
                       ("roughness_polygon_metal", "its floor made a metal (materials.floor.metallic=1)")):
        runs = sweeps.get(key)
        if not runs:
            continue
        ts = [t for t in LAB_TECHNIQUES if t in runs[0]["strategies"]]
        w(f"## Roughness sweep (polygon-near, {floor}): `ltc` against the other samplers of polygons\n")
        w("Efficiency 1 / (MSE x time) over the no-light pixels, relative to the best technique that is not `ltc` at "
          "each roughness (the last column names it): `ltc+power` above 1 is a gain over everything else.\n")
        figure = f"lab_sweep_{key}.png"
        plot_roughness_sweep(lab["roughness"], runs, ts, "efficiency_nolight", "floor roughness",
                             "efficiency 1 / (MSE x ms), no-light pixels", os.path.join(fig_dir, figure))
        w(f"![{key}](figures/{figure})\n")
        w("| roughness | " + " | ".join(f"`{t}`" for t in ts) + " | best without ltc |")
        w("|" + " ---: |" * (len(ts) + 1) + " --- |")
        for x, r in zip(lab["roughness"], runs):
            e = {t: r["strategies"][t]["efficiency_nolight"] for t in ts}
            best = max((t for t in ts if not t.startswith("ltc")), key=lambda t: e[t])
            w(f"| {x} | " + " | ".join(fmt(e[t] / e[best]) for t in ts) + f" | `{best}` |")
        w("")
    if os.path.exists(os.path.join(out_dir, "DISCUSSION.md")):
        w("## Discussion\n")
        w("Which technique wins where, by how much, and why: [DISCUSSION.md](DISCUSSION.md).\n")
    write_text(os.path.join(out_dir, "README.md"), "\n".join(lines) + "\n")
    write_text(os.path.join(out_dir, "lab.json"), json.dumps({"headline": head, "sweeps": sweeps, "preset": lab}, indent=1))


def lab_check(head):
    """The CI smoke test's assertions on the lab: -1/2 slopes for the light-sampling
    techniques, and spherical polygons beating area on polygon-near (in samples)."""
    failures = []
    for r in head:
        if r["scene"] == "glossy":
            continue  # at smoke sizes its reference's own noise is reached within a few spp
        for t, js in r["strategies"].items():
            if t == "bsdf":
                continue  # too noisy at smoke sizes for a slope
            slope = js["fit_rmse"]["slope"]
            if not -0.75 <= slope <= -0.3:
                failures.append(f"{r['scene']} {t}: slope {slope:.3f} outside -0.5 +- 0.25")
    pn = [r for r in head if r["scene"] == "polygon-near"]
    if not pn:
        failures.append("polygon-near was not run")
    for r in pn:  # per sample (see check()): timings on a loaded machine are not the technique's
        gain = speedup(r, "fit_rmse", "spp_to_threshold")
        if not gain > 1.0:
            failures.append(f"polygon-near: solid-angle does not beat area ({gain:.3f}x fewer samples)")
    return checks_passed("LAB CHECK", failures)


def finish_lab(args, lab, out_dir, head, sweeps):
    """The lab's report and (with --check) its assertions. False: a check failed."""
    if head and not args.no_report:
        write_lab_report(args, lab, head, sweeps, out_dir)
        log(f"study: wrote {os.path.join(out_dir, 'README.md')}")
    return not (args.check and head and not lab_check(head))
