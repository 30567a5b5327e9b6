"""Denoising: does better sampling still pay after the denoiser? Measures,
reports (denoise/README.md) and checks."""
import csv
import datetime
import importlib
import importlib.util
import json
import math
import os

from .common import checks_passed, log, write_atomic, write_text
from .metrics import denoise_equal_time, denoise_ratios, denoise_table, denoise_times
from .planner import DENOISE_PRESETS, DENOISE_SCENES, DENOISE_SELECTIONS, DENOISE_TECHNIQUES
from .report import COLORS, dirty_warning, fmt, plt

# For each scene and technique, progressive renders at 1, 2, 4, ... max_spp spp (a
# few seeds), each denoised by Intel Open Image Denoise (albedo and normal guides;
# its CPU device on the CPU backend, its CUDA device on the GPU), and the RMSE of
# the raw and the denoised image against `penumbra converge`'s ground truth of that
# scene and size (found in, or rendered into, its cache), over all pixels and over
# those that see no light (docs/metrics.md). Needs the Python module and OIDN
# (pip install pyoidn); elsewhere the part says it is skipped, in one line.


def ssim(a, b):
    """Structural similarity of two linear images (H, W, 3) after the same tone map (x / (1 + x), sRGB-like gamma),
    by scikit-image (Wang et al. 2004, 7x7 windows); None where scikit-image is not installed."""
    try:
        from skimage.metrics import structural_similarity
    except ImportError:
        return None
    import numpy as np
    def tone(x):
        x = np.maximum(np.asarray(x, np.float64), 0.0)
        return (x / (1.0 + x)) ** (1 / 2.2)
    return float(structural_similarity(tone(a), tone(b), channel_axis=2, data_range=1.0))


def denoise_name(strategy, mis):
    return strategy if mis == "none" else f"{strategy}+{mis}"


def denoise_unavailable(args):
    """Why the denoise part cannot run here (one line), or None."""
    try:
        importlib.import_module("penumbra")
    except ImportError as e:
        return f"it needs the Python module penumbra ({e}): pip install ., or PYTHONPATH=build/python"
    if importlib.util.find_spec("pyoidn") is None:
        return "it needs Intel Open Image Denoise: pip install pyoidn (scripts/install-deps.sh does)"
    return None


def denoise_reference(args, scene, cfg):
    """The converge ground truth of `scene` at the part's size: from the cache, or
    rendered into it chunk by chunk (render_reference_chunk, store_reference); a float32 (H, W, 3)."""
    import penumbra
    opts = dict(width=cfg["width"], height=cfg["height"], reference_spp=cfg["reference_spp"],
                reference_chunk=cfg["reference_chunk"], backend=args.backend, gpus=args.gpus, cache=args.cache)
    ref = penumbra.converge_plan(scene, **opts)["reference"]
    if not ref["cached"]:  # its chunks, added in order and stored as converge() would
        log(f"study: denoise: {scene}: rendering its ground truth ({ref['spp']} spp, {ref['chunks']} chunks)")
        sums = sums_sq = None
        for i in range(ref["chunks"]):
            c = penumbra.render_reference_chunk(scene, i, **opts)
            sums = c.sum if sums is None else sums + c.sum
            sums_sq = c.sum_sq if sums_sq is None else sums_sq + c.sum_sq
        penumbra.store_reference(scene, sums, sums_sq, **opts)
    return penumbra.read_exr(ref["path"]), ref


def denoise_measure(args, cfg, scenes):
    """Rows of (scene, technique, spp, seed, rmse_raw, rmse_denoised, denoise_ms), and
    what ran them (device, guide rays per pixel)."""
    import numpy as np  # also with --no-report, where matplotlib may be missing
    import penumbra
    rows, meta = [], {}
    spps = [1 << k for k in range(int(math.log2(cfg["max_spp"])) + 1)]
    for scene in scenes:
        try:
            ref, _ = denoise_reference(args, scene, cfg)
        except penumbra.SceneError as e:  # a scene whose model data is not here (scripts/fetch-scenes.sh)
            log(f"study: denoise: leaving {scene} out: {e}")
            continue
        # Pixels where a camera ray can see a light and their eight neighbours (a max-depth-0 render of 1,024
        # samples a pixel, grown by one, as converge finds them: docs/metrics.md): their noise is the same for
        # every strategy. rmse(img, keep) leaves them out.
        direct = penumbra.render(scene, max_depth=0, spp=1024, backend=args.backend, gpus=args.gpus,
                                 width=cfg["width"], height=cfg["height"]).rgb
        lit = np.pad(direct.max(axis=2) > 0, 1)
        h, w = direct.shape[:2]
        lit = np.any([lit[1 + dy:1 + dy + h, 1 + dx:1 + dx + w] for dy in (-1, 0, 1) for dx in (-1, 0, 1)], axis=0)
        keep = (~lit)[..., None]
        def rmse(img, mask=None):
            d2 = (np.asarray(img, np.float64) - ref) ** 2
            return float(np.sqrt(np.mean(d2) if mask is None else (d2 * mask).sum() / (3 * mask.sum())))
        runs = [(strategy, mis, None) for strategy, mis in DENOISE_TECHNIQUES]
        runs += [("solid-angle", "power", sel) for sel in DENOISE_SELECTIONS.get(scene, [])]
        for strategy, mis, selection in runs:
            name = denoise_name(strategy, mis) + (f"/{selection}" if selection else "")
            overrides = {"render.light_selection": selection} if selection else None
            r = penumbra.Renderer(scene, backend=args.backend, gpus=args.gpus, width=cfg["width"],
                                  height=cfg["height"], overrides=overrides)
            for seed in range(cfg["seeds"]):
                r.set(strategy=strategy, mis=mis, seed=seed + 1)  # frame settings: the backend stays
                for spp in spps:
                    r.render(spp - r.spp)
                    img = r.image(denoise=True)
                    meta = dict(device=img.stats["device"], guide_samples=img.stats.get("guide_samples"),
                                denoiser=img.stats.get("denoiser", "?"))
                    rows.append(dict(scene=scene, technique=name, spp=spp, seed=seed + 1,
                                     rmse_raw=rmse(img.rgb), rmse_denoised=rmse(img.denoised),
                                     rmse_raw_nolight=rmse(img.rgb, keep),
                                     rmse_denoised_nolight=rmse(img.denoised, keep),
                                     ssim_raw=ssim(img.rgb, ref), ssim_denoised=ssim(img.denoised, ref),
                                     render_ms=img.stats.get("render_seconds", 0.0) * 1e3,
                                     denoise_ms=img.stats.get("denoise_ms", 0.0)))
            log(f"study: denoise: {scene} {name}: 1..{spps[-1]} spp x {cfg['seeds']} seeds")
    return rows, meta


def plot_denoise(table, path, title="RMSE before (dashed) and after (solid) denoising"):
    scenes = list(table)
    cols = min(3, len(scenes))
    rows_n = (len(scenes) + cols - 1) // cols
    fig, axes = plt.subplots(rows_n, cols, figsize=(4.6 * cols, 4.0 * rows_n), squeeze=False)
    colors = {"area": COLORS["area"], "area+power": "#ff9896", "solid-angle": COLORS["solid-angle"],
              "solid-angle+power": "#2ca02c", "projected-solid-angle": "#9467bd",
              "projected-solid-angle+power": "#c5b0d5", "bsdf": "#7f7f7f"}
    for ax in axes.flat[len(scenes):]:
        ax.axis("off")
    for ax, scene in zip(axes.flat, scenes):
        for t, pts in table[scene].items():
            spp = sorted(pts)
            c = colors.get(t, "#7f7f7f")
            ax.loglog(spp, [pts[s][0] for s in spp], "--", color=c, marker="o", ms=3, label=f"{t} raw")
            ax.loglog(spp, [pts[s][1] for s in spp], "-", color=c, marker="s", ms=3, label=f"{t} denoised")
        ax.set_title(scene)
        ax.set_xlabel("samples per pixel")
        ax.set_xscale("log", base=2)
        ax.grid(True, which="both", alpha=0.3)
    axes[0][0].set_ylabel("RMSE against the ground truth")
    axes[0][0].legend(fontsize=7)
    fig.suptitle(title)
    fig.tight_layout()
    def w(tmp):
        fig.savefig(tmp, dpi=110, format="png")
    write_atomic(path, w)
    plt.close(fig)


def write_denoise_report(args, cfg, rows, out_dir, meta):
    table, table_nl = denoise_table(rows), denoise_table(rows, "_nolight")
    plot_denoise(table, os.path.join(out_dir, "denoise_rmse.png"),
                 "RMSE, all pixels: before (dashed) and after (solid) denoising")
    plot_denoise(table_nl, os.path.join(out_dir, "denoise_rmse_nolight.png"),
                 "RMSE, pixels that see no light: before (dashed) and after (solid) denoising")
    lines = []
    w = lines.append
    w(dirty_warning(args) + "# Denoising: does better light sampling still pay after the denoiser?\n")
    w(f"Generated by `python3 scripts/study.py --preset {args.preset} --part denoise` on "
      f"{datetime.date.today().isoformat()}, penumbra commit `{meta.get('source_commit') or '?'}` "
      f"({meta.get('device', '?')}).\n")
    w(f"Each scene at {cfg['width']}x{cfg['height']}, rendered progressively at 1, 2, 4, ... "
      f"{cfg['max_spp']} spp with {cfg['seeds']} seeds per technique; every image denoised by "
      f"{meta.get('denoiser', '?')}\n"
      f"(albedo and world-space normal guides of the first non-specular hit, `core/aov.h`, "
      f"{meta.get('guide_samples', '?')} camera rays per pixel).\n"
      f"RMSE (thesis eq. 4.1, linear radiance) of the raw and the denoised image against `penumbra converge`'s "
      f"ground truth of the same scene and size\n({cfg['reference_spp']} spp, solid-angle + MIS power, from the "
      f"converge cache), the mean over seeds. Median denoiser time per image: {meta.get('denoise_ms', 0):.1f} ms "
      f"(host clock around the filter).\nData: `denoise.csv` (every render), `denoise.json`.\n")
    w("![RMSE vs spp without light pixels, raw dashed, denoised solid](denoise_rmse_nolight.png)\n")
    w("![RMSE vs spp over all pixels, raw dashed, denoised solid](denoise_rmse.png)\n")
    techs = [denoise_name(s, m) for s, m in DENOISE_TECHNIQUES]
    for title, tab in (("Denoised RMSE (all pixels)", table),
                       ("Denoised RMSE without the pixels that see a light", table_nl)):
        w(f"## {title}\n")
        for scene, ts in tab.items():
            present = [t for t in techs if t in ts]
            w(f"**{scene}**\n")
            w("| spp | " + " | ".join(f"{t} raw | {t} denoised" for t in present) + " |")
            w("| ---: | " + " | ".join("---: | ---:" for _ in present) + " |")
            for spp in sorted(ts[present[0]]):
                w(f"| {spp} | " + " | ".join(f"{fmt(ts[t][spp][0], 4)} | {fmt(ts[t][spp][1], 4)}" for t in present)
                  + " |")
            w("")
    w("## DISCUSSION\n")
    w("RMSE(area) / RMSE(solid-angle) at equal spp, raw / denoised (> 1: solid-angle sampling is better by that "
      "factor):\n")
    summary = {}
    for title, tab in (("all pixels", table), ("without light pixels", table_nl)):
        ratios = denoise_ratios(tab)
        summary[title] = ratios
        if not ratios:
            continue
        spps = sorted(next(iter(ratios.values())))
        w(f"| {title} | " + " | ".join(f"{spp} spp" for spp in spps) + " |")
        w("| --- |" + " ---: |" * len(spps))
        for scene, rs in ratios.items():
            w(f"| {scene} | " + " | ".join(f"{rs[spp][0]:.2f} / {rs[spp][1]:.2f}" for spp in spps) + " |")
        w("")
    # Where a denoised 4-spp image beats a raw image at the most samples measured (pixels that see no light).
    hi = cfg["max_spp"]
    w(f"Where a denoised 4-spp image of one technique has a lower RMSE than the raw {hi}-spp image of another "
      "(pixels that see no light; RMSE in brackets):\n")
    for scene, ts in table_nl.items():
        wins = []
        for a in ts:
            beaten = [b for b in ts if 4 in ts[a] and hi in ts[b] and ts[a][4][1] < ts[b][hi][0]]
            if beaten:
                wins.append(f"{a} ({ts[a][4][1]:.3g}) beats " + ", ".join(f"{b} ({ts[b][hi][0]:.3g})" for b in beaten))
        w(f"- **{scene}**: " + ("; ".join(wins) if wins else "none") + ".")
    w("")
    # Equal render time (pixels that see no light): area's image at each spp against solid-angle's at the same
    # time, read off solid-angle's measured points.
    times = denoise_times(rows)
    eq = denoise_equal_time(table_nl, times)
    if eq:
        spps = sorted({spp for rs in eq.values() for spp in rs})
        w("RMSE(area) / RMSE(solid-angle) at equal render time, pixels that see no light, raw / denoised (area's "
          "time at each spp; solid-angle's RMSE at that time interpolated between its own measured points, a point "
          "outside them left out; render time only, the denoiser's own time is the same for both):\n")
        w("| scene | " + " | ".join(f"{spp} spp" for spp in spps) + " |")
        w("| --- |" + " ---: |" * len(spps))
        for scene, rs in eq.items():
            w(f"| {scene} | " + " | ".join(f"{rs[spp][0]:.2f} / {rs[spp][1]:.2f}" if spp in rs else "n/a"
                                           for spp in spps) + " |")
        w("")
    # Light selection on many-spheres, and whether restir's correlated noise denoises worse: RMSE and SSIM.
    ssim_rows = [r for r in rows if "/" in r["technique"] or r["technique"] == "solid-angle+power"]
    sel_scenes = sorted({r["scene"] for r in ssim_rows if "/" in r["technique"]})
    for scene in sel_scenes:
        rs = [r for r in ssim_rows if r["scene"] == scene]
        techs = sorted({r["technique"] for r in rs}, key=lambda t: (t.count("/"), t))
        spps = sorted({r["spp"] for r in rs})
        def mean(t, spp, key):
            v = [r[key] for r in rs if r["technique"] == t and r["spp"] == spp and r.get(key) is not None]
            return sum(v) / len(v) if v else None
        w(f"**{scene}**, solid-angle + MIS power by light selection (power, bvh, restir): RMSE without light pixels "
          "and SSIM (scikit-image, after a tone map x / (1 + x) and gamma 2.2; 1 is the reference), raw / denoised:\n")
        w("| spp | " + " | ".join(f"{t} RMSE | {t} SSIM" for t in techs) + " |")
        w("| ---: |" + " ---: | ---: |" * len(techs))
        for spp in spps:
            cells = []
            for t in techs:
                r0, r1 = mean(t, spp, "rmse_raw_nolight"), mean(t, spp, "rmse_denoised_nolight")
                s0, s1 = mean(t, spp, "ssim_raw"), mean(t, spp, "ssim_denoised")
                cells.append(f"{fmt(r0, 3)} / {fmt(r1, 3)}")
                cells.append("n/a" if s0 is None else f"{s0:.3f} / {s1:.3f}")
            w(f"| {spp} | " + " | ".join(cells) + " |")
        w("")
    for scene, rs in summary.get("without light pixels", {}).items():
        raw, den = [a for a, _ in rs.values()], [d for _, d in rs.values()]
        gain = [table_nl[scene]["area"][spp][0] / table_nl[scene]["area"][spp][1] for spp in sorted(rs)]
        w(f"- **{scene}** (without light pixels): solid-angle's advantage over area is {min(raw):.2f}-{max(raw):.2f}x "
          f"in RMSE raw and {min(den):.2f}-{max(den):.2f}x after denoising; the denoiser alone lowers area's RMSE "
          f"{min(gain):.1f}-{max(gain):.1f}x.")
    w("")
    write_text(os.path.join(out_dir, "README.md"), "\n".join(lines) + "\n")
    return summary


def denoise_csv(rows, path):
    def w(tmp):
        with open(tmp, "w", newline="") as f:
            wr = csv.DictWriter(f, fieldnames=list(rows[0]))
            wr.writeheader()
            wr.writerows(rows)
    write_atomic(path, w)


def run_denoise(args, out_dir):
    """The denoise part: measures (unless --report-only), writes CSV, JSON and the report.
    Returns False when --check fails; says in one line when it is skipped."""
    cfg = DENOISE_PRESETS[args.preset]
    data_path = os.path.join(out_dir, "denoise.json")
    if args.report_only:
        if not os.path.exists(data_path):
            log(f"study: denoise part skipped: no {data_path} (run it on a GPU first)")
            return True
        with open(data_path) as f:
            data = json.load(f)
        rows, meta = data["rows"], data["meta"]
    else:
        why = denoise_unavailable(args)
        if why:
            log(f"study: denoise part skipped: {why}")
            return True
        scenes = DENOISE_SCENES if not args.scene else [s for s in args.scene if s in DENOISE_SCENES]
        os.makedirs(out_dir, exist_ok=True)
        rows, meta = denoise_measure(args, cfg, scenes)
        ms = sorted(r["denoise_ms"] for r in rows)
        meta.update(denoise_ms=ms[len(ms) // 2] if ms else 0.0, preset=cfg,
                    source_commit=getattr(args, "source_commit", None), dirty=getattr(args, "source_dirty", False))
        denoise_csv(rows, os.path.join(out_dir, "denoise.csv"))
        write_text(data_path, json.dumps({"rows": rows, "meta": meta}, indent=1))
    if args.no_report:
        return True
    write_denoise_report(args, cfg, rows, out_dir, meta)
    log(f"study: wrote {os.path.join(out_dir, 'README.md')}")
    if args.check:
        # The denoiser must lower the error of the pixels that see no light at 1 spp, on every scene but
        # many-spheres: at the smoke size (32 x 32) its 4,000 lamps and their neighbours leave only dark pixels next
        # to them, into which the denoiser blurs the lamps (denoised RMSE about twice the raw one there).
        failures = [f"{sc} {t}: denoised RMSE {d:.4g} >= raw {a:.4g} at 1 spp (no-light pixels)"
                    for sc, ts in denoise_table(rows, "_nolight").items() if sc != "many-spheres"
                    for t, pts in ts.items() for a, d in [pts[min(pts)]] if d >= a]
        return checks_passed("DENOISE CHECK", failures)
    return True
