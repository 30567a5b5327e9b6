#!/usr/bin/env python3
"""The thesis's chapter 4, measured: runs `penumbra converge` over the headline
scenes and the sweeps, then writes a self-contained report (Markdown + PNG
figures + CSV/JSON of every measurement).

    python3 scripts/study.py --out docs/results              # the full study (GPU)
    python3 scripts/study.py --preset smoke --out /tmp/smoke --check   # CI: tiny, on the CPU
    PYTHONPATH=build/python python3 scripts/study.py --engine python ...   # through the Python module
    python3 scripts/study.py --executor ray --address HEAD:6379 ...        # as tasks on a Ray cluster (docs/cluster.md)

Presets say what each figure uses; the report repeats it. Ground truths are
cached by `penumbra converge` (see --cache), so a rerun only renders what changed.
"""
import argparse
import csv
import datetime
import glob
import json
import math
import os
import shutil
import statistics
import subprocess
import sys
import tempfile
from collections import namedtuple

try:  # only the report needs numpy and matplotlib (--no-report runs without them)
    import numpy as np
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    import matplotlib.ticker
except ImportError:
    np = plt = None

STRATEGIES = ["area", "solid-angle"]
COLORS = {"area": "#d62728", "solid-angle": "#1f77b4"}
BOX = (5.56, 5.488, 5.592)  # the Cornell box's extent (x, y, z) in the built-in scenes

PRESETS = {
    # Headline scenes at the thesis's resolution and ground truth; sweeps smaller.
    "full": dict(headline=dict(width=1920, height=1080, reference_spp=65536, max_spp=1024, seeds=4, reference_chunk=4096),
                 sweep=dict(width=480, height=270, reference_spp=8192, max_spp=256, seeds=2, reference_chunk=4096),
                 radii=[0.02, 0.05, 0.1, 0.2, 0.4, 0.8], near_k=[1.1, 1.5, 2, 4, 8, 16],
                 slat_widths=[0.02, 0.08, 0.14, 0.2, 0.23]),
    # What one GPU session's device time affords (about 10 minutes on the H100): the
    # headline scenes at full resolution with a smaller ground truth.
    "gpu": dict(headline=dict(width=1920, height=1080, reference_spp=8192, max_spp=512, seeds=4, reference_chunk=4096),
                sweep=dict(width=480, height=270, reference_spp=8192, max_spp=256, seeds=2, reference_chunk=4096),
                radii=[0.02, 0.05, 0.1, 0.2, 0.4, 0.8], near_k=[1.1, 1.5, 2, 4, 8, 16],
                slat_widths=[0.02, 0.08, 0.14, 0.2, 0.23]),
    # What fits in a CI run on two CPU cores: the same pipeline, tiny.
    "smoke": dict(headline=dict(width=32, height=32, reference_spp=4096, max_spp=256, seeds=4, reference_chunk=1024),
                  sweep=dict(width=24, height=24, reference_spp=1024, max_spp=64, seeds=2, reference_chunk=512),
                  radii=[0.05, 0.4], near_k=[2, 8], slat_widths=[0.08, 0.2]),
}
# The light-sampling lab (issue 10): every strategy x MIS mode on the lab's
# scenes, and its sweeps. Sizes per preset.
LAB_PRESETS = {
    "full": dict(headline=dict(width=960, height=540, reference_spp=16384, max_spp=256, seeds=2, reference_chunk=4096),
                 sweep=dict(width=480, height=270, reference_spp=4096, max_spp=128, seeds=2, reference_chunk=4096),
                 radii=[0.02, 0.05, 0.1, 0.2, 0.4, 0.8], near_k=[1.1, 1.5, 2, 4, 8, 16],
                 roughness=[0.02, 0.05, 0.1, 0.2, 0.4, 0.7, 1.0], panel_offsets=[0.0, 0.2, 0.5, 1.0, 2.0]),
    "gpu": dict(headline=dict(width=640, height=360, reference_spp=8192, max_spp=256, seeds=2, reference_chunk=4096),
                sweep=dict(width=320, height=180, reference_spp=4096, max_spp=128, seeds=2, reference_chunk=4096),
                radii=[0.02, 0.05, 0.1, 0.2, 0.4, 0.8], near_k=[1.1, 1.5, 2, 4, 8, 16],
                roughness=[0.02, 0.05, 0.1, 0.2, 0.4, 0.7, 1.0], panel_offsets=[0.0, 0.2, 0.5, 1.0, 2.0]),
    "smoke": dict(headline=dict(width=24, height=24, reference_spp=2048, max_spp=64, seeds=2, reference_chunk=1024),
                  sweep=dict(width=16, height=16, reference_spp=1024, max_spp=32, seeds=2, reference_chunk=512),
                  radii=[0.05, 0.4], near_k=[2, 8], roughness=[0.05, 0.6], panel_offsets=[0.0, 1.0]),
}
LAB_SCENES = ["cornell-sphere", "cornell-near", "occlusion", "cornell-quad", "polygon-near", "glossy"]
LAB_STRATEGIES = ["area", "solid-angle", "projected-solid-angle", "bsdf"]
MIS_MODES = ["none", "balance", "power"]
# Technique names as `penumbra converge` writes them: "area" (MIS none), "area+power".
LAB_TECHNIQUES = [st if m == "none" else f"{st}+{m}" for st in LAB_STRATEGIES[:3] for m in MIS_MODES] + ["bsdf"]
LAB_COLORS = {"area": "#d62728", "solid-angle": "#1f77b4", "projected-solid-angle": "#2ca02c", "bsdf": "#7f7f7f"}
LAB_STYLES = {"none": "o-", "balance": "s:", "power": "^--"}
HEADLINE = ["cornell-sphere", "cornell-near", "occlusion"]
CONFIRM_SECONDS = 3600  # past this estimate on the CPU, --yes is needed (as `penumbra converge` asks)
THESIS_TABLE_41 = {1: (0.245, 0.082), 4: (0.128, 0.035), 16: (0.065, 0.012), 64: (0.031, 0.004)}
THESIS_TABLE_42 = {"Cornell Box": (4.2, 4.5), "Sponza Crytek": (11.8, 12.4)}


def log(msg):
    print(msg, file=sys.stderr, flush=True)


def parse_set(assignment):
    """"key=value" (penumbra's --set) as a key and a value (JSON where it parses, else a string)."""
    key, _, text = assignment.partition("=")
    try:
        return key, json.loads(text)
    except ValueError:
        return key, text


# One `penumbra converge` run of the study. `group`: where set, the run is
# optional and the whole group is left out when one of its runs cannot be
# made on this machine (the glossy scene needs ../shared/scenes).
Run = namedtuple("Run", "name scene cfg sets strategies mis out_dir group",
                 defaults=((), tuple(STRATEGIES), ("none",), None, None))


class RunFailed(Exception):
    """A run failed; penumbra said why (on stderr, or in the message)."""

    def __init__(self, message, status=1):
        super().__init__(message)
        self.status = status


def format_seconds(s):
    if s < 60:
        return f"{s:.1f}s"
    if s < 3600:
        return f"{int(s) // 60}m{int(s) % 60:02d}s"
    return f"{int(s) // 3600}h{(int(s) % 3600) // 60:02d}m"


def run_dir(args, r):
    return os.path.join(r.out_dir or args.out, "runs", r.name)


def converge_cmd(args, r):
    cmd = [args.penumbra, "converge", r.scene, "--out", run_dir(args, r), "--backend", args.backend,
           "--gpus", args.gpus, "--width", str(r.cfg["width"]), "--height", str(r.cfg["height"]),
           "--reference-spp", str(r.cfg["reference_spp"]), "--reference-chunk", str(r.cfg["reference_chunk"]),
           "--max-spp", str(r.cfg["max_spp"]), "--seeds", str(r.cfg["seeds"]),
           "--strategies", ",".join(r.strategies), "--mis", ",".join(r.mis)]
    if r.cfg.get("frame_spp"):
        cmd += ["--frame-spp", str(r.cfg["frame_spp"])]
    if r.cfg.get("reference_selection"):
        cmd += ["--reference-selection", r.cfg["reference_selection"]]
    if args.cache:
        cmd += ["--cache", args.cache]
    for s in r.sets:
        cmd += ["--set", s]
    return cmd


def run_cmd(cmd, **kw):
    """A penumbra command; RunFailed with its exit status when it fails (its message is on stderr)."""
    p = subprocess.run(cmd, **kw)
    if p.returncode == 130:
        raise KeyboardInterrupt
    if p.returncode not in (0, 4):  # 4: outputs written, some samples dropped (penumbra said where)
        raise RunFailed(f"`{' '.join(cmd[:3])} ...` exited with status {p.returncode}", p.returncode)
    return p


def converge_options(args, r):
    """A run as penumbra.converge()'s keyword arguments (the CLI's options of the same names)."""
    return dict(backend=args.backend, gpus=args.gpus, width=r.cfg["width"], height=r.cfg["height"],
                reference_spp=r.cfg["reference_spp"], reference_chunk=r.cfg["reference_chunk"],
                max_spp=r.cfg["max_spp"], seeds=r.cfg["seeds"], strategies=list(r.strategies), mis=list(r.mis),
                frame_spp=r.cfg.get("frame_spp", 0), reference_selection=r.cfg.get("reference_selection", "power"),
                cache=args.cache, overrides=dict(parse_set(s) for s in r.sets))


def python_converge(args, r, **kw):
    """The same experiment in this process: penumbra.converge() is the CLI's code."""
    import penumbra
    try:
        return penumbra.converge(r.scene, **converge_options(args, r), **kw)
    except (penumbra.PenumbraError, ValueError) as e:
        raise RunFailed(str(e)) from e


def estimate(args, r):
    """penumbra's estimate of one run (it measures the backend): (seconds, backend name)."""
    if args.engine == "python":
        e = python_converge(args, r, estimate_only=True).summary
    else:
        p = subprocess.run(converge_cmd(args, r) + ["--estimate-only"], stdout=subprocess.PIPE,
                           stderr=subprocess.PIPE, text=True)
        if p.returncode == 130:
            raise KeyboardInterrupt
        if p.returncode != 0:
            raise RunFailed(p.stderr.strip().splitlines()[-1] if p.stderr.strip() else
                            f"penumbra converge exited with status {p.returncode}", p.returncode)
        e = json.loads(p.stdout.strip().splitlines()[-1])
    return e["estimated_seconds"], e["backend"]


def plan(args, runs):
    """Estimates every run before any starts; leaves out the optional groups that
    cannot run here; stops when the CPU would take over an hour without --yes."""
    log(f"study: estimating {len(runs)} runs on --backend {args.backend} ...")
    total, backend, dropped = 0.0, args.backend, set()
    for r in runs:
        if r.group in dropped:
            continue
        try:
            seconds, backend = estimate(args, r)
        except RunFailed as e:
            if r.group is None:
                raise
            log(f"study: leaving {r.group} out: {e}")
            dropped.add(r.group)
            continue
        total += seconds
    # Groups dropped midway contributed to the total; a slight overestimate is harmless.
    log(f"study: estimated run time {format_seconds(total)} on the {backend} backend")
    if backend == "cpu" and total > CONFIRM_SECONDS and not args.yes:
        raise RunFailed(f"the estimated run time, {format_seconds(total)} on the CPU, is more than an hour: "
                        "pass --yes to run it (or a smaller --preset)", 2)
    return [r for r in runs if r.group not in dropped]


def plan_on_ray(args, runs):
    """The Ray executor's plan: every run's ground truth and techniques
    (penumbra.converge_plan(), which loads the scene here); the optional groups
    whose scene cannot be loaded are left out. No run time is estimated: the
    tasks run on the cluster's machines, not this one."""
    import penumbra
    kept, dropped = [], set()
    for r in runs:
        if r.group in dropped:
            continue
        try:
            kept.append((r, penumbra.converge_plan(r.scene, **converge_options(args, r))))
        except (penumbra.PenumbraError, ValueError) as e:
            if r.group is None:
                raise RunFailed(str(e)) from e
            log(f"study: leaving {r.group} out: {e}")
            dropped.add(r.group)
    return [(r, p) for r, p in kept if r.group not in dropped]


# What the Ray executor needs of a run: its files' folder, and the Run for its options.
RayRun = namedtuple("RayRun", "name scene sets out run")


def run_on_ray(args, planned):
    """Runs the planned runs as Ray tasks (scripts/study_ray.py), which leave each
    run's files in its folder as `penumbra converge` would. {run folder: error}
    for the runs that failed."""
    import study_ray
    runs = [(RayRun(r.name, r.scene, r.sets, run_dir(args, r), r), p) for r, p in planned]
    return study_ray.execute(args, runs, lambda a, ray_run: converge_options(a, ray_run.run), write_atomic)


def run_key(r):
    return (r.out_dir, r.name)


def converge(args, r):
    """Runs one experiment (unless --report-only, or done by the Ray executor) and returns its summary."""
    out = run_dir(args, r)
    if out in args.ray_failed:
        raise RunFailed(args.ray_failed[out])
    if not args.report_only and args.executor == "local":
        if args.engine == "python":
            log(f"study: penumbra.converge({r.scene!r}, out={out!r}, {r.cfg}, overrides={list(r.sets)})")
            python_converge(args, r, out=out, verbose=True, yes=True)  # the study's own estimate was accepted
        else:
            cmd = converge_cmd(args, r)
            log("study: " + " ".join(cmd))
            run_cmd(cmd + ["--yes"])
    return load_summary(out, r.name)


def load_summary(out, name):
    with open(os.path.join(out, "summary.json")) as f:
        summary = json.load(f)
    summary["run_dir"] = out
    summary["name"] = name
    return summary


def write_atomic(path, write):
    """write(tmp_path) makes the file; it replaces `path` only when complete (never a half-written report)."""
    folder, base = os.path.split(os.path.abspath(path))
    stem, ext = os.path.splitext(base)
    fd, tmp = tempfile.mkstemp(prefix="." + stem + ".tmp-", suffix=ext, dir=folder)
    os.close(fd)
    try:
        write(tmp)
        with open(tmp, "rb") as f:
            os.fsync(f.fileno())
        os.chmod(tmp, 0o644)
        os.replace(tmp, path)
    except BaseException:
        if os.path.exists(tmp):
            os.remove(tmp)
        raise


def write_text(path, text):
    def w(tmp):
        with open(tmp, "w") as f:
            f.write(text)
    write_atomic(path, w)


def committed(path):
    """Whether git tracks files under `path` (a report folder someone committed)."""
    here = os.path.abspath(path)
    while not os.path.isdir(here):
        here = os.path.dirname(here)
    try:
        r = subprocess.run(["git", "-C", here, "ls-files", "--", os.path.abspath(path)], capture_output=True,
                           text=True)
    except OSError:
        return False
    return r.returncode == 0 and r.stdout.strip() != ""


def check_out(args):
    """Before any work: --out can be written, and is not a committed report unless --force."""
    out = os.path.abspath(args.out)
    here = out
    while not os.path.exists(here):
        here = os.path.dirname(here)
    if not os.path.isdir(here):
        sys.exit(f"study: --out {args.out}: {here} is a file, not a folder")
    if not os.access(here, os.W_OK | os.X_OK):
        sys.exit(f"study: --out {args.out}: {here} is not writable")
    if committed(out) and not args.force and not args.report_only:
        sys.exit(f"study: --out {args.out} holds a committed report; pass --force to overwrite it "
                 "(or choose another folder)")


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


def efficiency_ratio(summary, key="efficiency"):
    a = summary["strategies"]["area"][key]
    s = summary["strategies"]["solid-angle"][key]
    return s / a if a > 0 else float("nan")


# --- Figures -------------------------------------------------------------------

def plot_convergence(summary, path):
    fig, axes = plt.subplots(1, 2, figsize=(10, 4))
    for st in STRATEGIES:
        pts = summary["strategies"][st]["points"]
        spp = np.array([p["spp"] for p in pts])
        rmse = np.array([p["rmse"] for p in pts])
        rmse_n = np.array([p["rmse_nolight"] for p in pts])
        t = np.array([p["time_ms"] for p in pts])
        slope = summary["strategies"][st]["fit_rmse"]["slope"]
        axes[0].loglog(spp, rmse, "o-", color=COLORS[st], label=f"{st} (slope {slope:.2f})")
        axes[0].loglog(spp, rmse_n, "x--", color=COLORS[st], alpha=0.6, label=f"{st}, without light pixels")
        axes[1].loglog(t, rmse, "o-", color=COLORS[st], label=st)
    for ax in axes:
        ax.axhline(summary["threshold_rmse"], color="grey", lw=0.8, ls=":")
        ax.grid(True, which="both", alpha=0.3)
        ax.set_ylabel("RMSE")
    # 1/sqrt(N) guide through area's first point
    pts = summary["strategies"]["area"]["points"]
    n = np.array([p["spp"] for p in pts], dtype=float)
    axes[0].loglog(n, pts[0]["rmse"] / np.sqrt(n / n[0]), color="black", lw=0.8, ls="-.", label="1/sqrt(N)")
    axes[0].set_xlabel("samples per pixel")
    axes[1].set_xlabel(f"render time (ms, {summary['backend']})")
    axes[0].legend(fontsize=7)
    axes[1].legend(fontsize=7)
    fig.suptitle(f"{summary['scene']} at {summary['width']}x{summary['height']}")
    fig.tight_layout()
    write_atomic(path, lambda tmp: fig.savefig(tmp, dpi=110))
    plt.close(fig)


def srgb(x):
    x = np.clip(x, 0, 1)
    return np.where(x <= 0.0031308, 12.92 * x, 1.055 * np.power(x, 1 / 2.4) - 0.055)


def plot_crops(summary, path):
    run = summary["run_dir"]
    ref = np.load(os.path.join(run, "crop_reference.npy"))
    imgs = {st: np.load(os.path.join(run, f"crop_{st}.npy")) for st in STRATEGIES}
    err = {st: np.sqrt(np.mean((imgs[st] - ref) ** 2, axis=2)) for st in STRATEGIES}
    vmax = max(np.percentile(e, 99) for e in err.values()) or 1.0
    fig, axes = plt.subplots(2, len(STRATEGIES) + 1, figsize=(3.2 * (len(STRATEGIES) + 1), 6.4))
    axes[0, 0].imshow(srgb(ref))
    axes[0, 0].set_title(f"reference ({summary['reference']['spp']} spp)", fontsize=8)
    axes[1, 0].axis("off")
    for i, st in enumerate(STRATEGIES, 1):
        axes[0, i].imshow(srgb(imgs[st]))
        rm = math.sqrt(float(np.mean((imgs[st] - ref) ** 2)))
        axes[0, i].set_title(f"{st}, {summary['crop_spp']} spp (crop RMSE {rm:.3f})", fontsize=8)
        im = axes[1, i].imshow(err[st], cmap="inferno", vmin=0, vmax=vmax)
        axes[1, i].set_title(f"{st}: per-pixel error |test - ref|", fontsize=8)
    for ax in axes.flat:
        ax.set_xticks([])
        ax.set_yticks([])
    fig.colorbar(im, ax=axes[1, 1:].tolist(), shrink=0.8, label="RMS over RGB (linear radiance)")
    write_atomic(path, lambda tmp: fig.savefig(tmp, dpi=110, bbox_inches="tight"))
    plt.close(fig)


def finish_ratio_plot(fig, ax, xlabel, ylabel, title, path, log_x, legend_size=8):
    """The axes of an efficiency-ratio sweep figure (log y, a line at 1), saved."""
    ax.axhline(1.0, color="grey", lw=0.8, ls=":")
    if log_x:
        ax.set_xscale("log")
        ax.xaxis.set_minor_formatter(matplotlib.ticker.NullFormatter())
    ax.set_yscale("log")
    ax.set_xlabel(xlabel)
    ax.set_ylabel(ylabel)
    ax.set_title(title, fontsize=9)
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=legend_size)
    fig.tight_layout()
    write_atomic(path, lambda tmp: fig.savefig(tmp, dpi=110))
    plt.close(fig)


def plot_sweep(xs, runs, xlabel, title, path, log_x=True):
    fig, ax = plt.subplots(figsize=(5.5, 3.8))
    for key, label, style in [("efficiency", "all pixels", "o-"), ("efficiency_nolight", "without light pixels", "x--")]:
        ax.plot(xs, [efficiency_ratio(r, key) for r in runs], style, label=label)
    finish_ratio_plot(fig, ax, xlabel, "efficiency solid-angle / area", title, path, log_x)


# --- Report --------------------------------------------------------------------

def fmt(x, digits=3):
    if x is None or (isinstance(x, float) and not math.isfinite(x)):
        return "n/a"
    return f"{x:.{digits}g}"


def source_state():
    """(short commit, dirty) of the checkout this script runs from; (None, False) outside a git checkout. Dirty:
    tracked files changed or files git does not ignore added."""
    here = os.path.dirname(os.path.abspath(__file__))
    try:
        commit = subprocess.run(["git", "-C", here, "rev-parse", "--short=12", "HEAD"], capture_output=True,
                                text=True, check=True).stdout.strip()
        status = subprocess.run(["git", "-C", here, "status", "--porcelain"], capture_output=True, text=True,
                                check=True).stdout.strip()
    except (OSError, subprocess.CalledProcessError):
        return None, False
    return commit, bool(status)


def dirty_warning(args):
    """The lines a report starts with where its numbers are not the science: the smoke preset's (tiny renders that
    check the pipeline) and --allow-dirty's (a tree with uncommitted changes)."""
    out = ""
    if getattr(args, "preset", None) == "smoke":
        out += ("**Smoke run: these numbers check the study's pipeline, not the science (tiny images, few samples); "
                "the results are the gpu and full presets'.**\n\n")
    if getattr(args, "source_dirty", False):
        out += (f"**Made with --allow-dirty from a tree with uncommitted changes on `{args.source_commit}`: these "
                "numbers cannot be rebuilt from git.**\n\n")
    return out


def generated_by(args, part, env, commit=None):
    """A report's first line: the command (`part`: its options after --preset), the date, the commit of the binary
    that made the runs and the backend with its device."""
    info = env.get("device_info", {})
    return dirty_warning(args) + (f"Generated by `python3 scripts/study.py --preset {args.preset}{part}` on "
            f"{datetime.date.today().isoformat()}, penumbra commit `{commit or env.get('git_commit', 'unknown')}`, "
            f"backend **{env['backend']}** ({env['device']}" + "".join(f", {k} {v}" for k, v in info.items()) + ").\n")


def write_report(args, preset, head, radius_runs, near_runs, slat_runs, radii, near_k, widths):
    fig_dir = os.path.join(args.out, "figures")
    os.makedirs(fig_dir, exist_ok=True)
    env = head[0]
    # The commit of the binary that made the runs (older summaries lack it: then the checkout's).
    commit = env.get("git_commit") or subprocess.run(["git", "rev-parse", "--short", "HEAD"],
                                                     capture_output=True, text=True).stdout.strip()
    lines = []
    w = lines.append
    w("# Results: area versus solid-angle sampling of sphere lights\n")
    w(generated_by(args, "", env, commit or "unknown"))
    h = preset["headline"]
    s = preset["sweep"]
    w("## What was measured\n")
    w(f"- Headline scenes ({', '.join(HEADLINE)}): {h['width']}x{h['height']}, ground truth {h['reference_spp']} spp "
      f"(strategy `solid-angle`, its own seed), renders at 1, 2, 4, ..., {h['max_spp']} spp, {h['seeds']} independent "
      f"seeds per point, max depth 8.")
    w(f"- Sweeps: {s['width']}x{s['height']}, ground truth {s['reference_spp']} spp, up to {s['max_spp']} spp, "
      f"{s['seeds']} seeds per point.")
    w("- Time: GPU time of the launches (CUDA events: path tracing + accumulation) on the GPU backend, wall time on the "
      "CPU backend; per point, the mean over seeds. ms per frame = time of the largest render / its spp.")
    w("- **RMSE** (thesis eq. 4.1): sqrt of the mean over all pixels and the three RGB channels of (test - reference)^2, "
      "on linear, unclamped radiance. **relMSE**: mean of (test - ref)^2 / (ref^2 + 0.01) (pbrt's convention). "
      "*Without light pixels*: the same, leaving out every pixel in which a camera ray can see a light directly "
      "(found by a max-depth-0 render); their noise is the same for every strategy.")
    w(f"- Slopes: least-squares lines of log RMSE against log spp over spp >= {env['fit_min_spp']}; an unbiased "
      "estimator with independent samples has slope -1/2. Time to quality: spp (and ms) at which the fitted line "
      f"reaches RMSE {env['threshold_rmse']}; speed-up = area's time / solid-angle's time. Efficiency = "
      "1 / (MSE x time) at the largest spp.\n")
    w("All measurements: `runs/*/measurements.csv` (every render) and `runs/*/summary.json` (fits, settings).\n")

    # Table 4.1
    w("## Table 4.1, measured: RMSE per spp\n")
    for r in head:
        w(f"**{r['scene']}** ({r['width']}x{r['height']}, {r['light_pixels']} light pixels; the reference's own "
          f"noise adds RMSE {r['reference']['rmse_floor']:.4f}, {r['reference']['rmse_floor_nolight']:.4f} without "
          "light pixels, in quadrature)\n")
        w("| spp | RMSE area | RMSE solid-angle | ratio | RMSE area (no light px) | RMSE solid-angle (no light px) |")
        w("| ---: | ---: | ---: | ---: | ---: | ---: |")
        pa = {p["spp"]: p for p in r["strategies"]["area"]["points"]}
        ps = {p["spp"]: p for p in r["strategies"]["solid-angle"]["points"]}
        for n in sorted(pa):
            w(f"| {n} | {pa[n]['rmse']:.4f} | {ps[n]['rmse']:.4f} | {pa[n]['rmse'] / ps[n]['rmse']:.2f} | "
              f"{pa[n]['rmse_nolight']:.4f} | {ps[n]['rmse_nolight']:.4f} |")
        fa, fs = r["strategies"]["area"]["fit_rmse"], r["strategies"]["solid-angle"]["fit_rmse"]
        w(f"| slope | {fa['slope']:.3f} | {fs['slope']:.3f} | | "
          f"{r['strategies']['area']['fit_rmse_nolight']['slope']:.3f} | "
          f"{r['strategies']['solid-angle']['fit_rmse_nolight']['slope']:.3f} |\n")
        off = [st for st, f in (("area", fa), ("solid-angle", fs)) if abs(f["slope"] + 0.5) > 0.1]
        if off:
            w(f"Slope differs from -1/2 by more than 0.1 for {', '.join(off)}: at low spp the error is dominated by rare "
              "high-value samples, so the log-log line bends before it settles to -1/2.\n")
    w("The thesis's table 4.1 (Cornell box, no resolution or scene details given):\n")
    w("| spp | RMSE uniform | RMSE solid angle |")
    w("| ---: | ---: | ---: |")
    for n, (a, b) in THESIS_TABLE_41.items():
        w(f"| {n} | {a} | {b} |")
    ta = np.polyfit(np.log(list(THESIS_TABLE_41)), np.log([v[0] for v in THESIS_TABLE_41.values()]), 1)[0]
    tb = np.polyfit(np.log(list(THESIS_TABLE_41)), np.log([v[1] for v in THESIS_TABLE_41.values()]), 1)[0]
    w(f"\nIts uniform column falls with slope {ta:.2f}, plausible for an unbiased estimator; its solid-angle column "
      f"falls with slope {tb:.2f} (0.082 to 0.004 over 64x the samples, 20x less error where 1/sqrt(N) allows 8x). "
      "No unbiased Monte Carlo estimator with independent samples converges faster than N^-1/2: the variance of a "
      "mean of N i.i.d. samples is sigma^2/N. Those numbers cannot come from such a renderer; ours fall at "
      "-1/2 for both strategies (above), and the gain of solid-angle sampling is a constant factor, not a faster rate.\n")

    # Table 4.2
    w("## Table 4.2, measured: ms per frame\n")
    w(f"1 frame = 1 spp at {h['width']}x{h['height']}, max depth 8 (from the largest converge render).\n")
    w("| scene | area (ms) | solid-angle (ms) | overhead |")
    w("| --- | ---: | ---: | ---: |")
    for r in head:
        a, b = r["strategies"]["area"]["ms_per_spp"], r["strategies"]["solid-angle"]["ms_per_spp"]
        w(f"| {r['scene']} | {a:.3f} | {b:.3f} | {100 * (b / a - 1):+.1f}% |")
    w("\nThe thesis reports 4.2 ms vs 4.5 ms (+7.1%) for its Cornell box and 11.8 vs 12.4 ms (+5.0%) for Crytek Sponza "
      "on an RTX GPU. `penumbra bench` measures the same per launch with warm-up and medians; see the bench JSON in "
      "this folder when present.\n")

    # Time to quality
    w(f"## Time to quality (RMSE {env['threshold_rmse']})\n")
    w("| scene | area: spp | area: ms | solid-angle: spp | solid-angle: ms | speed-up | speed-up (no light px) |")
    w("| --- | ---: | ---: | ---: | ---: | ---: | ---: |")
    def to_threshold(fit, key):  # "*": read off the fitted line beyond the spp it was fitted to
        return fmt(fit[key]) + ("*" if fit.get("extrapolated") else "")
    for r in head:
        fa, fs = r["strategies"]["area"]["fit_rmse"], r["strategies"]["solid-angle"]["fit_rmse"]
        w(f"| {r['scene']} | {to_threshold(fa, 'spp_to_threshold')} | {to_threshold(fa, 'ms_to_threshold')} | "
          f"{to_threshold(fs, 'spp_to_threshold')} | {to_threshold(fs, 'ms_to_threshold')} | {fmt(speedup(r))}x | "
          f"{fmt(speedup(r, 'fit_rmse_nolight'))}x |")
    w("\nThe thesis claims solid-angle needs 4 spp where uniform needs 32 (7.6x faster in total time). Every time "
      "to quality is read off the technique's fitted line, none is measured; * marks those extrapolated beyond "
      "the spp the line was fitted to (summary.json: fit_rmse.extrapolated).\n")

    # Figures
    for r in head:
        p = f"convergence_{r['scene']}.png"
        plot_convergence(r, os.path.join(fig_dir, p))
        w(f"![convergence {r['scene']}](figures/{p})\n")
    near = [r for r in head if r["scene"] == "cornell-near"]
    if near:
        plot_crops(near[0], os.path.join(fig_dir, "figure_4_1_cornell_near.png"))
        w("## Figure 4.1, measured: the near light at 32 spp\n")
        w("![crops](figures/figure_4_1_cornell_near.png)\n")
        full = glob.glob(os.path.join(near[0]["run_dir"], "image_*_32spp.png"))
        w("Crops around the light of cornell-near, one seed, with per-pixel error maps on a shared scale."
          + (f" Full images: `runs/{near[0]['name']}/image_*_32spp.png`." if full else "") + "\n")

    if os.path.exists(os.path.join(args.out, "DISCUSSION.md")):
        w("## Discussion\n")
        w("How these numbers compare with the thesis, and what they say: [DISCUSSION.md](DISCUSSION.md).\n")
    def sweep(title, runs, xs, xlabel, plot_title, figure, columns):
        """A sweep's figure and table; columns: (header, values) shown before the measured ones."""
        w(f"## {title}\n")
        plot_sweep(xs, runs, xlabel, plot_title, os.path.join(fig_dir, figure))
        w(f"![{title}](figures/{figure})\n")
        w("| " + " | ".join([h for h, _ in columns] + ["efficiency ratio", "(no light px)", "speed-up"]) + " |")
        w("|" + " ---: |" * (len(columns) + 3))
        for i, run in enumerate(runs):
            cells = [v[i] for _, v in columns]
            cells += [fmt(efficiency_ratio(run)), fmt(efficiency_ratio(run, "efficiency_nolight")), fmt(speedup(run))]
            w("| " + " | ".join(cells) + " |")
        w("")

    rd = [r / light_distance((2.78, 4.4, 2.8)) for r in radii]
    sweep("Radius sweep (cornell-sphere, constant power)", radius_runs, rd, "r / d (d: light centre to the ceiling)",
          "cornell-sphere: radius sweep", "sweep_radius.png",
          [("radius", [str(r) for r in radii]), ("r/d", [f"{x:.3f}" for x in rd])])
    sweep("Distance sweep (cornell-near, light moved away from the back wall)", near_runs, [1 / k for k in near_k],
          "r / d (d: light centre to the back wall)", "cornell-near: distance sweep", "sweep_distance.png",
          [("d / r", [str(k) for k in near_k])])
    pitch = 0.25
    open_frac = [((pitch - wd) / pitch) ** 2 for wd in widths]
    sweep("Occlusion study (occlusion scene, slat width varied)", slat_runs, open_frac, "open fraction of the blinds",
          "occlusion: how much light gets through", "sweep_occlusion.png",
          [("slat width", [str(wd) for wd in widths]), ("open fraction", [f"{of:.3f}" for of in open_frac])])
    write_text(os.path.join(args.out, "README.md"), "\n".join(lines) + "\n")
    # Every summary in one file, for plotting elsewhere.
    write_text(os.path.join(args.out, "study.json"),
               json.dumps({"headline": head, "radius": radius_runs, "distance": near_runs, "occlusion": slat_runs,
                           "radii": radii, "near_k": near_k, "slat_widths": widths}, indent=1))


# --- The light-sampling lab ----------------------------------------------------

def technique_parts(t):
    st, _, m = t.partition("+")
    return st, (m or "none")


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


def lab_threshold(summary):
    """A per-scene RMSE target every technique reaches or nearly reaches: the
    median over techniques of the RMSE at the largest spp."""
    last = sorted(js["points"][-1]["rmse"] for js in summary["strategies"].values())
    return last[len(last) // 2]


def lab_speedups(summary, key="fit_rmse"):
    """Time-to-quality of each technique relative to area with MIS none (> 1: faster)."""
    thr = lab_threshold(summary)
    base = fit_time_to(summary, "area", thr, key)
    return {t: base / fit_time_to(summary, t, thr, key) for t in summary["strategies"]}


def lab_efficiency(summary, t, key="efficiency"):
    return summary["strategies"][t][key] / summary["strategies"]["area"][key]


def lab_plan(args, lab, out_dir):
    """Every technique on every lab scene, then the sweeps: (headline runs, {sweep: runs}).
    The glossy scene and its sweep are optional (their model data lives in ../shared/scenes)."""
    h, sw = lab["headline"], lab["sweep"]
    scenes = LAB_SCENES if not args.scene else [s for s in LAB_SCENES if s in args.scene]
    head = [Run(sc, sc, h, (), LAB_STRATEGIES, MIS_MODES, out_dir, "glossy" if sc == "glossy" else None)
            for sc in scenes] if args.only not in ("sweeps", "params") else []
    sweeps = {}
    if args.only not in ("headline", "params"):
        three = LAB_STRATEGIES[:3]
        sweeps["radius"] = [Run(f"radius-{r}", "cornell-sphere", sw, (f"light.radius={r}",), three, out_dir=out_dir)
                            for r in lab["radii"]]
        sweeps["distance"] = [Run(f"near-{k}", "cornell-near", sw, (f"light.center=[1.6,3.2,{BOX[2] - k * 0.15:.4f}]",),
                                  three, out_dir=out_dir) for k in lab["near_k"]]
        sweeps["panel"] = [Run(f"panel-{o}", "polygon-near", sw, (f"defaults.panel_z={-o}",), three, out_dir=out_dir)
                           for o in lab["panel_offsets"]]
        sweeps["roughness"] = [Run(f"roughness-{r}", "glossy", sw, (f"defaults.roughness={r}",), ("solid-angle", "bsdf"),
                                   MIS_MODES, out_dir, "the roughness sweep") for r in lab["roughness"]]
    return head, sweeps


def thesis_plan(args, preset):
    """Chapter 4's runs: (headline runs, {sweep: runs})."""
    scenes = HEADLINE if args.report_only or not args.scene else [s for s in args.scene if s in HEADLINE]
    head = [Run(s, s, preset["headline"]) for s in scenes] if args.only not in ("sweeps", "params") else []
    sweeps = {}
    if args.only not in ("headline", "params"):
        sw = preset["sweep"]
        sweeps["radius"] = [Run(f"radius-{r}", "cornell-sphere", sw, (f"light.radius={r}",)) for r in preset["radii"]]
        sweeps["distance"] = [Run(f"near-{k}", "cornell-near", sw, (f"light.center=[1.6,3.2,{BOX[2] - k * 0.15:.4f}]",))
                              for k in preset["near_k"]]
        sweeps["occlusion"] = [Run(f"slats-{wd}", "occlusion", sw, (f"meshes.slat-x.size=[{wd},0.04,{BOX[2]}]",
                                                                    f"meshes.slat-z.size=[{BOX[0]},0.04,{wd}]"))
                               for wd in preset["slat_widths"]]
    return head, sweeps


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
    w("- Techniques: the strategies `area`, `solid-angle`, `projected-solid-angle`, each with `--mis none` (light "
      "sampling only: the thesis's estimator), `balance` and `power` (one light and one BSDF sample per vertex, "
      "Veach's heuristics), and `bsdf` (no light sampling). Named `area`, `area+balance`, `area+power`, ...")
    w("- Time: GPU time of the launches (CUDA events) on the GPU, wall time on the CPU; per point the mean over seeds.")
    w("- **Efficiency** = 1 / (MSE x time) at the largest spp, relative to `area` (the larger, the better at equal "
      "time). **Time to quality**: time to reach the scene's RMSE target along each technique's fitted log-log line, "
      "relative to `area`; the target is the median over techniques of the RMSE at the largest spp, so that it is "
      "reached or nearly reached by all. RMSE on linear, unclamped radiance over all pixels (thesis eq. 4.1).")
    w(f"- Sweeps at {s['width']}x{s['height']}, ground truth {s['reference_spp']} spp, up to {s['max_spp']} spp, "
      f"{s['seeds']} seeds.\n")
    w("Every measurement: `runs/*/measurements.csv`, fits and settings: `runs/*/summary.json`.\n")

    w("## Time to quality relative to `area` (MIS none)\n")
    cols = [t for t in LAB_TECHNIQUES if any(t in r["strategies"] for r in head)]
    w("| scene | RMSE target | " + " | ".join(f"`{t}`" for t in cols) + " |")
    w("| --- | ---: |" + " ---: |" * len(cols))
    for r in head:
        sp = lab_speedups(r)
        w(f"| {r['scene']} | {lab_threshold(r):.4f} | " + " | ".join(f"{fmt(sp.get(t, float('nan')))}x" for t in cols) + " |")
    w("\n## Efficiency (1 / (MSE x time)) relative to `area`\n")
    w("| scene | " + " | ".join(f"`{t}`" for t in cols) + " |")
    w("| --- |" + " ---: |" * len(cols))
    for r in head:
        w(f"| {r['scene']} | " + " | ".join(f"{fmt(lab_efficiency(r, t))}" for t in cols) + " |")
    w("\n## Cost: ms per spp\n")
    w("| scene | " + " | ".join(f"`{t}`" for t in cols) + " |")
    w("| --- |" + " ---: |" * len(cols))
    for r in head:
        w(f"| {r['scene']} | " + " | ".join(f"{r['strategies'][t]['ms_per_spp']:.3f}" for t in cols) + " |")
    w("\n## Per scene: RMSE at the largest spp, slopes\n")
    for r in head:
        w(f"**{r['scene']}** ({r['width']}x{r['height']}; reference noise adds RMSE {r['reference']['rmse_floor']:.4f} "
          "in quadrature)\n")
        w("| technique | ms/spp | RMSE @ " + str(r["strategies"]["area"]["points"][-1]["spp"]) +
          " spp | slope | efficiency vs area | time to quality vs area |")
        w("| --- | ---: | ---: | ---: | ---: | ---: |")
        sp = lab_speedups(r)
        for t in cols:
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
        fig, ax = plt.subplots(figsize=(5.8, 3.9))
        for t in ts:
            st, m = technique_parts(t)
            ax.plot(lab["roughness"], [r["strategies"][t]["efficiency"] for r in sweeps["roughness"]], LAB_STYLES[m],
                    color=LAB_COLORS[st], label=t)
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.set_xlabel("roughness")
        ax.set_ylabel("efficiency 1 / (MSE x ms)")
        ax.grid(True, which="both", alpha=0.3)
        ax.legend(fontsize=7)
        fig.tight_layout()
        write_atomic(os.path.join(fig_dir, "lab_sweep_roughness.png"), lambda tmp: fig.savefig(tmp, dpi=110))
        plt.close(fig)
        w("![roughness](figures/lab_sweep_roughness.png)\n")
        w("| roughness | " + " | ".join(f"`{t}`" for t in ts) + " | power / best single |")
        w("|" + " ---: |" * (len(ts) + 2))
        for x, r in zip(lab["roughness"], sweeps["roughness"]):
            e = {t: r["strategies"][t]["efficiency"] for t in ts}
            best = max(e["solid-angle"], e["bsdf"])
            w(f"| {x} | " + " | ".join(f"{e[t]:.4g}" for t in ts) + f" | {fmt(e['solid-angle+power'] / best)}x |")
        w("")
    if os.path.exists(os.path.join(out_dir, "DISCUSSION.md")):
        w("## Discussion\n")
        w("Which technique wins where, by how much, and why: [DISCUSSION.md](DISCUSSION.md).\n")
    write_text(os.path.join(out_dir, "README.md"), "\n".join(lines) + "\n")
    write_text(os.path.join(out_dir, "lab.json"), json.dumps({"headline": head, "sweeps": sweeps, "preset": lab}, indent=1))


def checks_passed(what, failures):
    """Logs each failure as 'study: <what> FAILED: ...'; True when there is none."""
    for f in failures:
        log(f"study: {what} FAILED: " + f)
    return not failures


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


def check(head):
    """The CI smoke test's assertions: -1/2 slopes, and solid-angle wins on the near light (in samples)."""
    failures = []
    for r in head:
        for st in STRATEGIES:
            slope = r["strategies"][st]["fit_rmse"]["slope"]
            if not -0.65 <= slope <= -0.35:
                failures.append(f"{r['scene']} {st}: slope {slope:.3f} outside -0.5 +- 0.15")
    if not any(r["scene"] == "cornell-near" for r in head):
        failures.append("cornell-near was not run: nothing to check the near-light win on")
    # Per sample, not per millisecond: fixed seeds make the samples needed the same on every run, while the
    # times of a loaded machine are not (CI's study_ray once measured 0.82x in time with 3x fewer samples).
    for near, key in [(r, k) for r in head if r["scene"] == "cornell-near" for k in ("fit_rmse", "fit_rmse_nolight")]:
        gain = speedup(near, key, "spp_to_threshold")
        if not gain > 1.0:
            failures.append(f"cornell-near: solid-angle does not beat area ({key}: {gain:.3f}x fewer samples)")
    return checks_passed("CHECK", failures)


def keep(plan_, kept):
    """A (headline, sweeps) plan less the runs `plan()` left out; a sweep loses all or nothing."""
    head, sweeps = plan_
    return ([r for r in head if run_key(r) in kept],
            {k: v for k, v in sweeps.items() if all(run_key(r) in kept for r in v)})


def run_all(args, plan_):
    """Runs a plan (or, with --report-only, loads what an earlier run left: a missing run is left out)."""
    head, sweeps = plan_
    if args.report_only:
        have = lambda r: os.path.exists(os.path.join(run_dir(args, r), "summary.json"))  # noqa: E731
        return ([converge(args, r) for r in head if have(r)],
                {k: [converge(args, r) for r in v] for k, v in sweeps.items() if all(have(r) for r in v)})
    return [converge(args, r) for r in head], {k: [converge(args, r) for r in v] for k, v in sweeps.items()}


def finish_lab(args, lab, out_dir, head, sweeps):
    """The lab's report and (with --check) its assertions. False: a check failed."""
    if head and not args.no_report:
        write_lab_report(args, lab, head, sweeps, out_dir)
        log(f"study: wrote {os.path.join(out_dir, 'README.md')}")
    return not (args.check and head and not lab_check(head))


# --- Many lights (issue 14): light selection at equal time ------------------------
#
# Every selection method with every light-sampling strategy (MIS power) on the
# many-light scenes, one `penumbra converge` run per method (the ground truth,
# selected by the preset's reference_selection, is shared through the cache); the lights-count sweep of
# many-spheres; and `penumbra bench` for cost and memory per method.
# The ground truths select lights by the light BVH: for the same time, its noise is a fifth of power selection's.
# A reference's own noise adds to every run's MSE alike, and so compresses the ratios between methods: with 4,096
# spp selected by power (session 22), it was 14% of bvh's MSE at 128 spp and 27-33% of the ReSTIR variants'.
MANY_PRESETS = {
    "full": dict(headline=dict(width=960, height=540, reference_spp=8192, max_spp=256, seeds=2, reference_chunk=4096,
                               frame_spp=32, reference_selection="bvh"),
                 lights=10000, counts=[10, 100, 1000, 10000, 100000],
                 sweep=dict(width=320, height=180, reference_spp=4096, max_spp=64, seeds=2, reference_chunk=4096,
                            reference_selection="bvh")),
    # The issue's numbers: 10,000 lights at 1080p on the GPU.
    "gpu": dict(headline=dict(width=1920, height=1080, reference_spp=16384, max_spp=128, seeds=2, reference_chunk=4096,
                              frame_spp=32, reference_selection="bvh"),
                lights=10000, counts=[10, 100, 1000, 10000, 100000],
                sweep=dict(width=480, height=270, reference_spp=16384, max_spp=64, seeds=2, reference_chunk=4096,
                           reference_selection="bvh")),
    # At 24x16 every lamp is smaller than a pixel, and the pixels it covers in part escape the mask of lamp
    # pixels: the smoke runs look at the floor from below the lamps (none in view).
    # Four seeds: with two, one unbiased method's fitted slope fell to -0.12 in the sanitizer build (restir-bvh
    # with area sampling; -0.26 to -0.73 over pairs of seeds in the g++ build, -0.44 over twelve).
    "smoke": dict(headline=dict(width=24, height=16, reference_spp=1024, max_spp=32, seeds=4, reference_chunk=512,
                                frame_spp=16),
                  lights=500, counts=[10, 100, 1000],
                  sweep=dict(width=16, height=12, reference_spp=512, max_spp=16, seeds=2, reference_chunk=256),
                  sets=["camera.eye=[0,0.18,-3]", "camera.target=[0,0,-2.505]", "camera.fov=30"]),
}
# Report key -> (built-in scene, its lights-count key or None, extra settings). many-spheres-direct is the same
# scene with direct lighting only (one scattering vertex: x1's light sample and BSDF sample, MIS-weighted), the
# setting of Bitterli et al. 2020's ReSTIR DI numbers; with global illumination the indirect light's noise, which
# no light-selection method touches at x1, bounds what any of them can gain.
MANY_SCENES = {"many-spheres": ("many-spheres", "defaults.lights", ()),
               "many-spheres-direct": ("many-spheres", "defaults.lights", ("render.max_depth=1",)),
               "sponza-lanterns": ("sponza-lanterns", None, ())}
# name -> scene overrides. restir: the paper's defaults (32 candidates by power, 2 spatial passes of 3 neighbours)
# with pairwise MIS, unbiased (2k shadow rays a pass where the generalized balance heuristic, the renderer's default,
# needs k^2 + k: on the H200 at 10,000 lights and 1080p, 18.9 against 27.3 ms a sample, both unbiased);
# restir-bvh the same with 8 candidates drawn by the light BVH (each one a traversal: 32 of them cost 13 ms a
# sample there); restir-temporal adds temporal reuse (each sample also takes the pixel's last final reservoir, so a
# render's samples are correlated: its error at the largest spp is measured as it is, its slope is not -1/2);
# restir-biased is the paper's biased combination (shadowed only when shading).
MANY_SELECTIONS = {
    "uniform": ["render.light_selection=uniform"],
    "power": ["render.light_selection=power"],
    "bvh": ["render.light_selection=bvh"],
    "restir": ["render.light_selection=restir", "render.restir.pairwise=true"],
    "restir-bvh": ["render.light_selection=restir", "render.restir.pairwise=true", 'render.restir.source="bvh"',
                   "render.restir.candidates=8"],
    # restir's first stage alone: each path's first vertex resamples 8 BVH candidates (RIS), no reuse passes.
    "ris-bvh": ["render.light_selection=restir", 'render.restir.source="bvh"', "render.restir.candidates=8",
                "render.restir.spatial_passes=0"],
    # restir and restir-bvh without visibility reuse: unshadowed targets in the reuse (no shadow rays there), one
    # shadow ray when shading; unbiased all the same (core/restir.h).
    "restir-unshadowed": ["render.light_selection=restir", "render.restir.pairwise=true",
                          "render.restir.visibility_reuse=false"],
    "restir-bvh-unshadowed": ["render.light_selection=restir", "render.restir.pairwise=true",
                              'render.restir.source="bvh"', "render.restir.candidates=8",
                              "render.restir.visibility_reuse=false"],
    "restir-temporal": ["render.light_selection=restir", "render.restir.pairwise=true", "render.restir.temporal=true"],
    "restir-biased": ["render.light_selection=restir", "render.restir.unbiased=false"],
}
# Methods whose renders are not independent samples (the slope check leaves them out) or not unbiased.
MANY_CORRELATED = {"restir-temporal"}
MANY_STRATEGIES = ["area", "solid-angle", "projected-solid-angle"]
MANY_SWEEP_SELECTIONS = ["power", "bvh", "ris-bvh", "restir", "restir-bvh-unshadowed"]
# restir's parameters (--only params, on many-spheres with and without GI at the headline's size): M candidates
# drawn by the light BVH, resampled without reuse (ris-bvh) and with unbiased pairwise reuse of unshadowed targets
# (restir-bvh-unshadowed, the headline's most efficient restir) over p spatial passes of k neighbours. Which is
# most efficient at equal time depends on what a candidate costs against a reuse pass on the machine; the headline
# keeps M = 8, p = 2, k = 3. name -> (M, p, k); power and bvh are run beside them as the baselines.
MANY_PARAMS = {**{f"ris-bvh-m{m}": (m, 0, 0) for m in (2, 4, 8)},
               **{f"restir-bvh-unshadowed-m{m}-p{p}-k{k}": (m, p, k) for m in (2, 4, 8)
                  for p, k in ((1, 3), (2, 3), (1, 5))}}
MANY_PARAM_SCENES = ("many-spheres", "many-spheres-direct")
MANY_COLORS = {"uniform": "#7f7f7f", "power": "#d62728", "bvh": "#1f77b4", "restir": "#2ca02c", "restir-bvh": "#17becf",
               "restir-temporal": "#bcbd22", "restir-biased": "#9467bd", "ris-bvh": "#ff7f0e",
               "restir-unshadowed": "#98df8a", "restir-bvh-unshadowed": "#9edae5"}


def many_param_sets(m, p, k):
    """The scene overrides of MANY_PARAMS' configuration (M, p, k)."""
    sets = ["render.light_selection=restir", 'render.restir.source="bvh"', f"render.restir.candidates={m}",
            f"render.restir.spatial_passes={p}"]
    if p:
        sets += ["render.restir.pairwise=true", "render.restir.visibility_reuse=false", f"render.restir.neighbors={k}"]
    return sets


def many_technique(strategy):
    return f"{strategy}+power"


def many_plan(args, cfg, out_dir):
    """(headline runs, {selection: sweep runs}): every selection method with every strategy on each many-light
    scene (sponza-lanterns optional: its model data lives in ../shared/scenes), and the lights-count sweep of
    many-spheres for each method of MANY_SWEEP_SELECTIONS."""
    head, sweeps = [], {}
    if args.only == "params":
        for key in MANY_PARAM_SCENES:
            if args.scene and key not in args.scene:
                continue
            scene, count_key, scene_sets = MANY_SCENES[key]
            sets = (f"{count_key}={cfg['lights']}",) + tuple(cfg.get("sets", ())) + scene_sets
            configs = {"power": MANY_SELECTIONS["power"], "bvh": MANY_SELECTIONS["bvh"],
                       **{name: many_param_sets(*v) for name, v in MANY_PARAMS.items()}}
            sweeps[f"params:{key}"] = [Run(f"params-{key}-{name}", scene, cfg["headline"], sets + tuple(extra),
                                           ("solid-angle",), ("power",), out_dir) for name, extra in configs.items()]
        return head, sweeps
    if args.only != "sweeps":
        for key, (scene, count_key, scene_sets) in MANY_SCENES.items():
            if args.scene and key not in args.scene:
                continue
            sets = (f"{count_key}={cfg['lights']}",) + tuple(cfg.get("sets", ())) if count_key else ()
            head += [Run(f"{key}-{sel}", scene, cfg["headline"], sets + scene_sets + tuple(extra),
                         tuple(MANY_STRATEGIES), ("power",), out_dir, None if count_key else scene)
                     for sel, extra in MANY_SELECTIONS.items() if not args.selection or sel in args.selection]
    if args.only != "headline" and (not args.scene or "many-spheres" in args.scene):
        for sel in MANY_SWEEP_SELECTIONS:
            sweeps[sel] = [Run(f"count-{n}-{sel}", "many-spheres", cfg["sweep"],
                               (f"defaults.lights={n}",) + tuple(cfg.get("sets", ())) + tuple(MANY_SELECTIONS[sel]),
                               ("solid-angle",), ("power",), out_dir) for n in cfg["counts"]]
    return head, sweeps


def many_group(plan_, head):
    """The headline's summaries as {scene key (MANY_SCENES): {selection: summary}}, in MANY_SELECTIONS' order: the
    runs that ran, for each scene with a power run (every efficiency is relative to it); the report names the
    selections missing."""
    keys = sorted(MANY_SCENES, key=len, reverse=True)  # many-spheres-direct-x before many-spheres-x
    where = {}
    for r in plan_[0]:
        key = next(k for k in keys if r.name.startswith(k + "-"))
        where[r.name] = (key, r.name[len(key) + 1:])
    out = {}
    for summary in head:
        scene, sel = where[summary["name"]]
        out.setdefault(scene, {})[sel] = summary
    return {scene: {sel: runs[sel] for sel in MANY_SELECTIONS if sel in runs} for scene, runs in out.items()
            if "power" in runs}


def many_bench(args, cfg, out_dir):
    """`penumbra bench` per lights count: ms per launch of each method, the light BVH's build and size (CLI only)."""
    if args.engine != "cli" or not os.path.exists(args.penumbra):
        return []
    out = []
    for n in cfg["counts"]:
        path = os.path.join(out_dir, "runs", f"bench-{n}.json")
        os.makedirs(os.path.dirname(path), exist_ok=True)
        cmd = [args.penumbra, "bench", "--backend", args.backend, "--scenes", "many-spheres", "--set",
               f"defaults.lights={n}", "--set", "render.restir.pairwise=true",  # restir as MANY_SELECTIONS runs it
               "--selections", ",".join(["uniform", "power", "bvh", "restir"]),
               "--strategies", "solid-angle", "--mis", "power", "--width", str(cfg["sweep"]["width"]), "--height",
               str(cfg["sweep"]["height"]), "--launches", "5" if args.preset == "smoke" else "20", "--json", path]
        if not args.report_only:
            log("study: " + " ".join(cmd))
            run_cmd(cmd, stdout=subprocess.DEVNULL)
        if os.path.exists(path):
            with open(path) as f:
                out.append(dict(lights=n, bench=json.load(f)))
    return out


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


def plot_many_sweep(counts, sweep, value, ylabel, title, path):
    fig, ax = plt.subplots(figsize=(5.8, 3.9))
    for sel, runs in sweep.items():
        ax.loglog(counts, [value(r) for r in runs], "o-", color=MANY_COLORS[sel], label=sel)
    ax.set_xlabel("lights")
    ax.set_ylabel(ylabel)
    ax.set_title(title)
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def many_report_name(head):
    """README.md for a study with many-spheres (the issue's numbers); <scene>.md for another scene run alone
    (sponza-lanterns at its own preset), so that the two reports sit side by side."""
    if not head:  # the lights-count sweep alone (--only sweeps)
        return "sweep.md", "many_lights_sweep.json"
    return ("README.md", "many_lights.json") if "many-spheres" in head else \
        (f"{'-'.join(head)}.md", f"many_lights_{'-'.join(head)}.json")


def write_many_report(args, cfg, head, sweep, bench, out_dir):
    fig_dir = os.path.join(out_dir, "figures")
    os.makedirs(fig_dir, exist_ok=True)
    env = next(iter(head.values()))["power"] if head else sweep["power"][0]
    h, sw = cfg["headline"], cfg["sweep"]
    lines = []
    w = lines.append
    w("# Many lights: light selection at equal time\n")
    w(generated_by(args, " --part many-lights", env))
    w("## What was measured\n")
    if not head:
        w("- The lights-count sweep and `penumbra bench` per count (below); time: GPU time (CUDA events) on the GPU, "
          "wall time on the CPU; efficiency = 1 / (MSE x time) at the largest spp relative to `power`, without the "
          "pixels that see a lamp directly.\n")
    else:
        counts = [f"{cfg['lights']} lights in many-spheres"] if "many-spheres" in head else []
        if "sponza-lanterns" in head:
            n = head["sponza-lanterns"]["power"].get("lights", {}).get("sphere")  # converge's count (older runs: none)
            counts.append(f"{n} sphere lights (lanterns) in sponza-lanterns" if n else "the lanterns of sponza-lanterns")
        if "many-spheres-direct" in head:
            counts.append("many-spheres-direct: many-spheres with direct lighting only, max depth 1, the setting of "
                          "the ReSTIR DI paper's numbers")
        w(f"- Scenes: {', '.join(head)} ({'; '.join(counts)}) at {h['width']}x{h['height']}, max depth "
          f"8 unless said otherwise, MIS power; ground truth {h['reference_spp']} spp selected by "
          f"{h.get('reference_selection', 'power')} (solid-angle); renders at 1, 2, ..., "
          f"{h['max_spp']} spp, {h['seeds']} seeds.")
        restir_env = next(iter(head.values())).get("restir", {})
        w("- Selection methods: " + ", ".join(f"`{s}`" for s in MANY_SELECTIONS) + ". `restir`: " +
          restir_env.get("light_selection", "?") + "; see the runs' summary.json for each method's settings. "
          "**`restir-biased` is the paper's biased combination: its error includes its bias.** "
          "**`restir-temporal`'s samples are correlated within a render** (each takes its pixel's last reservoir): "
          "its error is measured as it is, at each spp, over independent seeds; its slope is not -1/2.")
        w("- Time: GPU time (CUDA events) on the GPU, wall time on the CPU. **Efficiency** = 1 / (MSE x time) at the "
          "largest spp, relative to `power` with the same strategy (> 1: better at equal time); relMSE-efficiency the "
          "same with relMSE (pbrt's, (x - ref)^2 / (ref^2 + 0.01)). Both **without the pixels that see a lamp "
          "directly** (their pixel-coverage noise is the same for every method and far above the rest).\n")
    for scene, runs in head.items():
        w(f"## {scene}: efficiency relative to `power`\n")
        w("| selection | " + " | ".join(f"`{st}`" for st in MANY_STRATEGIES) + " | relMSE-efficiency (solid-angle) | ms/spp (solid-angle) |")
        w("| --- |" + " ---: |" * (len(MANY_STRATEGIES) + 2))
        sels = list(runs)  # the selections that ran (many_group)
        for sel in sels:
            rel = many_relmse_efficiency(runs[sel], "solid-angle") / many_relmse_efficiency(runs["power"], "solid-angle")
            ms = runs[sel]["strategies"][many_technique("solid-angle")]["ms_per_spp"]
            w(f"| `{sel}` | " + " | ".join(fmt(many_efficiency(runs, sel, st)) for st in MANY_STRATEGIES) +
              f" | {fmt(rel)} | {ms:.3f} |")
        missing = [sel for sel in MANY_SELECTIONS if sel not in runs]
        if missing:
            w("\nNot in this report (no run of it here): " + ", ".join(f"`{sel}`" for sel in missing) + ".")
        w("")
        st_sa = many_technique("solid-angle")
        if all("frame" in runs[sel]["strategies"][st_sa] for sel in sels):
            n = runs["power"]["strategies"][st_sa]["frame"]["spp"]
            w(f"**A single frame** (solid-angle): the error of sample {n} alone, after {n - 1} samples of the same "
              "render, as a real-time frame with that much history shows it (what temporal reuse is for; for the "
              "other methods, one sample's error), and its efficiency 1 / (frame MSE x ms per sample) relative to "
              "power's: the equal-time comparison of single frames that Bitterli et al. 2020 report.\n")
            w("| selection | frame RMSE | frame efficiency vs power |")
            w("| --- | ---: | ---: |")
            base = runs["power"]["strategies"][st_sa]["frame"]["efficiency_nolight"]
            for sel in sels:
                fr = runs[sel]["strategies"][st_sa]["frame"]
                w(f"| `{sel}` | {fr['rmse_nolight']:.4g} | {fmt(fr['efficiency_nolight'] / base)} |")
            w("")
        floor = runs["power"]["reference"].get("rmse_floor_nolight")
        if floor:
            best = min(mse_nolight(runs[sel]["strategies"][st_sa]["points"][-1]) for sel in sels
                       if sel != "restir-biased")
            w(f"The ground truth's own noise (RMSE {floor:.4g} without lamp pixels, from its variance) is "
              f"{100 * floor ** 2 / best:.1f}% of the smallest unbiased MSE at the largest spp, and adds to every "
              "method's error alike.\n")
        w("RMSE at the largest spp, slope of the log-log fit, and the image mean against the reference's (the "
          "bias, within the noise of both; solid-angle; pixels that see a lamp left out):\n")
        w("| selection | RMSE | slope | mean vs reference |")
        w("| --- | ---: | ---: | ---: |")
        for sel in sels:
            js = runs[sel]["strategies"][many_technique("solid-angle")]
            w(f"| `{sel}` | {js['points'][-1]['rmse_nolight']:.4g} | {js['fit_rmse_nolight']['slope']:.3f} | "
              f"{100 * many_mean_bias(runs[sel], 'solid-angle'):+.2f}% |")
        w("")
    if sweep:
        counts = cfg["counts"]
        w(f"## Lights-count sweep (many-spheres, solid-angle + power, {sw['width']}x{sw['height']})\n")
        plot_many_sweep(counts, sweep, lambda r: r["strategies"]["solid-angle+power"]["efficiency_nolight"],
                        "efficiency 1 / (MSE x ms)", "many-spheres: efficiency", os.path.join(fig_dir, "many_sweep_efficiency.png"))
        plot_many_sweep(counts, sweep, lambda r: r["strategies"]["solid-angle+power"]["ms_per_spp"], "ms per spp",
                        "many-spheres: cost", os.path.join(fig_dir, "many_sweep_cost.png"))
        w("![efficiency](figures/many_sweep_efficiency.png) ![cost](figures/many_sweep_cost.png)\n")
        w("| lights | " + " | ".join(f"`{s}` efficiency vs power | `{s}` ms/spp" for s in sweep) + " |")
        w("| ---: |" + " ---: | ---: |" * len(sweep))
        for i, n in enumerate(counts):
            cells = []
            for sel, runs in sweep.items():
                e = (runs[i]["strategies"]["solid-angle+power"]["efficiency_nolight"] /
                     sweep["power"][i]["strategies"]["solid-angle+power"]["efficiency_nolight"])
                cells += [fmt(e), f"{runs[i]['strategies']['solid-angle+power']['ms_per_spp']:.3f}"]
            w(f"| {n} | " + " | ".join(cells) + " |")
        w("")
    if bench:
        w("## Cost and memory per method (`penumbra bench`, many-spheres)\n")
        w("ms per launch of 1 spp (solid-angle + power; restir with pairwise MIS, as above); memory: the power CDF (4 bytes a light), the light BVH "
          "(nodes and trails, also uploaded to the GPU), restir's per-pixel buffers at this resolution.\n")
        w("| lights | uniform | power | bvh | restir | BVH build ms | BVH MiB | power CDF MiB | restir MiB |")
        w("| ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: |")
        for b in bench:
            j = b["bench"]
            ms = {r["light_selection"].split(" ")[0]: r["ms_per_launch"]["median"] for r in j["results"]}
            sb = j["scene_builds"][0]
            w(f"| {b['lights']} | " + " | ".join(f"{ms.get(s, float('nan')):.3f}" for s in ["uniform", "power", "bvh", "restir"]) +
              f" | {sb['light_bvh_build_ms']:.2f} | {sb['light_bvh_mib']:.3f} | {4 * (b['lights'] + 1) / 2**20:.3f} | "
              f"{sb.get('restir_frame_mib', float('nan')):.2f} |")
        w("")
    if os.path.exists(os.path.join(out_dir, "DISCUSSION.md")):
        w("## Discussion\n")
        w("[DISCUSSION.md](DISCUSSION.md).\n")
    report, data = many_report_name(head)
    write_text(os.path.join(out_dir, report), "\n".join(lines) + "\n")
    write_text(os.path.join(out_dir, data),
               json.dumps({"headline": head, "sweep": sweep, "bench": bench, "preset": cfg}, indent=1))


def plot_many_params(by, base, scene, path):
    """Efficiency relative to power against the candidates M, a line per reuse setting (p, k) and bvh's level."""
    st = many_technique("solid-angle")
    eff = lambda name: by[name]["strategies"][st]["efficiency_nolight"] / base["efficiency_nolight"]  # noqa: E731
    fig, ax = plt.subplots(figsize=(5.8, 3.9))
    reuse = sorted({(p, k) for (_, p, k) in MANY_PARAMS.values()})
    for p, k in reuse:
        names = sorted((m, n) for n, (m, pp, kk) in MANY_PARAMS.items() if (pp, kk) == (p, k) and n in by)
        label = "ris-bvh (no reuse)" if p == 0 else f"restir-bvh-unshadowed, {p} pass{'es' if p > 1 else ''} of {k}"
        ax.plot([m for m, _ in names], [eff(n) for _, n in names], "o-", label=label)
    ax.axhline(eff("bvh"), color=MANY_COLORS["bvh"], ls="--", lw=1, label="bvh")
    ax.axhline(1.0, color=MANY_COLORS["power"], ls=":", lw=1, label="power")
    ax.set_xscale("log", base=2)
    ax.set_xticks(sorted({m for (m, _, _) in MANY_PARAMS.values()}))
    ax.xaxis.set_major_formatter(matplotlib.ticker.ScalarFormatter())
    ax.xaxis.set_minor_formatter(matplotlib.ticker.NullFormatter())
    ax.set_xlabel("BVH candidates M")
    ax.set_ylabel("efficiency vs power")
    ax.set_title(f"{scene}: restir's parameters at equal time")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def write_many_params_report(args, cfg, params, out_dir):
    """params.md: restir's parameters at equal time, a table per scene (MANY_PARAMS)."""
    h = cfg["headline"]
    first = next(iter(params.values()))[0]
    st = many_technique("solid-angle")
    lines = []
    w = lines.append
    w("# Many lights: restir's parameters at equal time\n")
    w(generated_by(args, " --part many-lights --only params", first))
    w(f"many-spheres with {cfg['lights']} lights at {h['width']}x{h['height']}, solid-angle, MIS power; ground truth "
      f"{h['reference_spp']} spp selected by {h.get('reference_selection', 'power')}; renders at 1 to {h['max_spp']} "
      f"spp, {h['seeds']} seeds. M: candidates drawn by the light BVH; p: spatial passes; k: neighbours a pass "
      "(pairwise MIS, unshadowed targets, one shadow ray when shading: unbiased); p = 0 is ris-bvh (no reuse). "
      "Efficiency = 1 / (MSE x ms) at the largest spp relative to `power`; frame: the error of sample "
      f"{h.get('frame_spp', '?')} alone, as the headline's. Both without the pixels that see a lamp.\n")
    fig_dir = os.path.join(out_dir, "figures")
    os.makedirs(fig_dir, exist_ok=True)
    for key, runs in params.items():
        scene = key.split(":", 1)[1]
        by = {r["name"].split(f"params-{scene}-", 1)[1]: r for r in runs}
        base = by["power"]["strategies"][st]
        w(f"## {scene}\n")
        fig = f"params_{scene}.png"
        plot_many_params(by, base, scene, os.path.join(fig_dir, fig))
        w(f"![efficiency against M](figures/{fig})\n")
        w("| configuration | M | p | k | efficiency vs power | frame efficiency | ms/spp | RMSE |")
        w("| --- | ---: | ---: | ---: | ---: | ---: | ---: | ---: |")
        best = max((n for n in by if n in MANY_PARAMS), key=lambda n: by[n]["strategies"][st]["efficiency_nolight"])
        for name, r in by.items():
            js = r["strategies"][st]
            m, p, k = MANY_PARAMS.get(name, ("", "", ""))
            fr = js.get("frame", {}).get("efficiency_nolight")
            fr0 = base.get("frame", {}).get("efficiency_nolight")
            label = f"**`{name}`**" if name == best else f"`{name}`"
            w(f"| {label} | {m} | {p} | {k if p else ''} | {fmt(js['efficiency_nolight'] / base['efficiency_nolight'])} | "
              f"{fmt(fr / fr0) if fr and fr0 else 'n/a'} | {js['ms_per_spp']:.3f} | {js['points'][-1]['rmse_nolight']:.4g} |")
        w("")
    write_text(os.path.join(out_dir, "params.md"), "\n".join(lines) + "\n")
    write_text(os.path.join(out_dir, "many_lights_params.json"), json.dumps({"params": params, "preset": cfg}, indent=1))


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


def many_params_check(params, out_dir):
    """--only params --check: every configuration converges (the median seed's RMSE slope, as many_check), and more
    candidates lower ris-bvh's MSE at equal spp (fixed seeds: deterministic)."""
    failures = []
    st = many_technique("solid-angle")
    for key, runs in params.items():
        scene = key.split(":", 1)[1]
        for r in runs:
            slope = median_seed_slope(os.path.join(out_dir, "runs", r["name"], "measurements.csv"), st)
            if not -0.85 <= slope <= -0.15:
                failures.append(f"{r['name']}: slope {slope:.3f} (median of the seeds) outside [-0.85, -0.15]")
        rmse = {r["name"]: r["strategies"][st]["points"][-1]["rmse_nolight"] for r in runs}
        m2, m8 = rmse[f"params-{scene}-ris-bvh-m2"], rmse[f"params-{scene}-ris-bvh-m8"]
        if not m8 < m2:
            failures.append(f"{scene}: ris-bvh's RMSE with 8 candidates ({m8:.4g}) is not below 2's ({m2:.4g})")
    return checks_passed("MANY-LIGHTS PARAMS CHECK", failures)


def many_check(head, sweep, out_dir):
    """The CI smoke test's assertions: the unbiased methods converge (RMSE slopes near -1/2 against a reference
    selected by power), and the light BVH beats power selection per sample on many-spheres (MSE at equal spp, which
    the fixed seeds make deterministic; equal time is reported, not asserted: CI machines' timings are noisy)."""
    runs = head["many-spheres"]
    failures = [f"many-spheres: no {sel} run" for sel in MANY_SELECTIONS if sel not in runs]
    for sel in [s for s in MANY_SELECTIONS if s != "restir-biased" and s not in MANY_CORRELATED and s in runs]:
        for st in MANY_STRATEGIES:
            # A slope near 0 or above is what a method that does not converge gives (the 1/Z ReSTIR's fireflies:
            # +0.08 at 1080p). At the smoke preset's 24x16 pixels and 1-32 spp the fitted slope itself varies
            # with the random numbers: by about +-0.25 with 2 seeds (g++: -0.39 to -0.56; the same study built
            # by clang for the sanitizers: -0.23 to -0.56), less with the 4 it now has; hence the wide band. And
            # the light BVH's candidates have rare large samples (a lamp close to the point in a node whose centre
            # is far gets a small probability): one of them, in one seed of clang's build, put the mean's slope
            # of restir-bvh and ris-bvh with area sampling at -0.12; hence the median over the seeds.
            slope = median_seed_slope(os.path.join(out_dir, "runs", f"many-spheres-{sel}", "measurements.csv"),
                                      many_technique(st))
            if not -0.85 <= slope <= -0.15:
                failures.append(f"many-spheres {sel} {st}: slope {slope:.3f} (median of the seeds) outside "
                                "[-0.85, -0.15]")
    mse = {sel: mse_nolight(runs[sel]["strategies"][many_technique("solid-angle")]["points"][-1])
           for sel in ("power", "bvh") if sel in runs}
    if len(mse) == 2 and not mse["bvh"] < 0.6 * mse["power"]:
        failures.append(f"many-spheres: bvh's MSE at equal spp is not below 0.6x power's ({mse['bvh']:.4g} vs "
                        f"{mse['power']:.4g})")
    return checks_passed("MANY-LIGHTS CHECK", failures)


def finish_many_lights(args, cfg, out_dir, plan_, head, sweep):
    """The many-lights part's bench runs, report and (with --check) assertions. False: a check failed."""
    if args.only == "params":
        if sweep and not args.no_report:
            write_many_params_report(args, cfg, sweep, out_dir)
            log(f"study: wrote {os.path.join(out_dir, 'params.md')}")
        return not (args.check and not many_params_check(sweep, out_dir))
    head = many_group(plan_, head)
    bench = many_bench(args, cfg, out_dir) if args.only != "headline" else []
    if (head or sweep) and not args.no_report:
        write_many_report(args, cfg, head, sweep, bench, out_dir)
        log(f"study: wrote {os.path.join(out_dir, many_report_name(head)[0])}")
    return not (args.check and "many-spheres" in head and not many_check(head, sweep, out_dir))


# --- Denoising: does better sampling still pay after the denoiser? ----------------------
#
# For each scene and technique, progressive renders at 1, 2, 4, ... max_spp spp (a
# few seeds), each denoised by Intel Open Image Denoise (albedo and normal guides;
# its CPU device on the CPU backend, its CUDA device on the GPU), and the RMSE of
# the raw and the denoised image against `penumbra converge`'s ground truth of that
# scene and size (found in, or rendered into, its cache), over all pixels and over
# those that see no light (docs/metrics.md). Needs the Python module and OIDN
# (pip install pyoidn); elsewhere the part says it is skipped, in one line.
DENOISE_PRESETS = {
    "full": dict(width=1920, height=1080, reference_spp=16384, reference_chunk=4096, max_spp=64, seeds=4),
    "gpu": dict(width=640, height=360, reference_spp=4096, reference_chunk=4096, max_spp=64, seeds=2),
    "cpu": dict(width=160, height=90, reference_spp=4096, reference_chunk=1024, max_spp=64, seeds=2),
    "smoke": dict(width=32, height=32, reference_spp=1024, reference_chunk=512, max_spp=16, seeds=2),
}
DENOISE_TECHNIQUES = [("area", "none"), ("area", "power"), ("solid-angle", "none"), ("solid-angle", "power"),
                      ("projected-solid-angle", "none"), ("projected-solid-angle", "power"), ("bsdf", "none")]
# The thesis's scenes, a polygon light near a wall, glossy reflections of a sun, and many lights.
DENOISE_SCENES = HEADLINE + ["polygon-near", "glossy", "many-spheres"]
# On many-spheres also solid-angle + MIS power with each way of choosing a light: does restir's correlated noise
# (neighbours' samples reused) denoise worse than independent noise? SSIM beside RMSE shows blotches.
DENOISE_SELECTIONS = {"many-spheres": ["bvh", "restir"]}


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
        import penumbra  # noqa: F401
    except ImportError as e:
        return f"it needs the Python module penumbra ({e}): pip install ., or PYTHONPATH=build/python"
    import importlib.util
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
        ref, _ = denoise_reference(args, scene, cfg)
        # Pixels where a camera ray can see a light (a max-depth-0 render, as converge finds them): their
        # noise is the same for every strategy. rmse(img, keep) leaves them out.
        direct = penumbra.render(scene, max_depth=0, spp=16, backend=args.backend, gpus=args.gpus,
                                 width=cfg["width"], height=cfg["height"]).rgb
        keep = (direct.max(axis=2) <= 0)[..., None]
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


def denoise_ratios(table):
    """{scene: {spp: (area/solid-angle raw, area/solid-angle denoised)}}: RMSE ratios at equal spp."""
    out = {}
    for scene, ts in table.items():
        if "area" in ts and "solid-angle" in ts:
            out[scene] = {spp: (ts["area"][spp][0] / ts["solid-angle"][spp][0],
                                ts["area"][spp][1] / ts["solid-angle"][spp][1]) for spp in sorted(ts["area"])}
    return out


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
    summary = write_denoise_report(args, cfg, rows, out_dir, meta)
    log(f"study: wrote {os.path.join(out_dir, 'README.md')}")
    if args.check:  # the denoiser must lower the error of the pixels that see no light at 1 spp everywhere
        failures = [f"{sc} {t}: denoised RMSE {d:.4g} >= raw {a:.4g} at 1 spp (no-light pixels)"
                    for sc, ts in denoise_table(rows, "_nolight").items()
                    for t, pts in ts.items() for a, d in [pts[min(pts)]] if d >= a]
        return checks_passed("DENOISE CHECK", failures)
    return True


def main():
    here = os.path.dirname(os.path.abspath(__file__))
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--preset", choices=sorted(set(PRESETS) | set(DENOISE_PRESETS)), default="full",
                    help="full, gpu (about half an hour of one GPU), smoke (tiny, CPU, CI); cpu: the denoise part sized for a CPU")
    ap.add_argument("--allow-dirty", action="store_true",
                    help="run from a tree with uncommitted changes (refused otherwise); every report says so first")
    ap.add_argument("--out", default="docs/results", help="report folder")
    ap.add_argument("--penumbra", default=os.path.join(here, "..", "build", "penumbra"), help="the executable")
    ap.add_argument("--engine", choices=["cli", "python"], default="cli",
                    help="run each experiment with the executable (default) or the Python module penumbra "
                         "(importable: pip install ., or PYTHONPATH=build/python)")
    ap.add_argument("--backend", default="auto", choices=["auto", "cpu", "optix"])
    ap.add_argument("--gpus", default="all",
                    help="local executor: the GPUs that split each render (penumbra converge --gpus: all, N or 0,2)")
    ap.add_argument("--cache", help="ground-truth cache folder (default: penumbra's); the Ray executor also keeps "
                                    "its finished tasks there (study-results/), so that an interrupted study resumes")
    ap.add_argument("--executor", choices=["local", "ray"], default="local",
                    help="local (default): one experiment after the other on this machine; ray: the study as tasks "
                         "(ground-truth chunks, one per technique of each experiment) on a Ray cluster or a Ray "
                         "instance on this machine, through the Python module (docs/cluster.md)")
    ap.add_argument("--address", help="ray: the cluster to join (the head's HOST:6379, or 'auto'); default: start "
                                      "Ray on this machine")
    ap.add_argument("--task-gpus", type=float, default=1.0,
                    help="ray, GPU backend: GPUs per task (num_gpus; each task splits its renders across them)")
    ap.add_argument("--task-cpus", type=int, default=1,
                    help="ray: CPUs per task (num_cpus; with the CPU backend, its render threads)")
    ap.add_argument("--ray-cpus", type=int,
                    help="ray without --address: the CPUs the Ray instance on this machine may use (default: all)")
    ap.add_argument("--retries", type=int, default=3,
                    help="ray: how often a task whose worker or machine is lost runs again (Ray's max_retries)")
    ap.add_argument("--part", choices=["thesis", "lab", "many-lights", "denoise", "all"], default="all",
                    help="thesis: chapter 4 (area against solid-angle, docs/results/README.md); lab: every strategy and "
                         "MIS mode on the lab's scenes (docs/results/lab/README.md); many-lights: light selection "
                         "methods at equal time and the lights-count sweep (docs/results/many-lights/README.md); "
                         "denoise: raw and denoised RMSE per strategy, 1-64 spp, on the headline scenes (GPU only; "
                         "docs/results/denoise/README.md); all: the four")
    ap.add_argument("--only", choices=["headline", "sweeps", "params"],
                    help="run one part only; params (many-lights only, not part of a default run): restir's "
                         "candidates, spatial passes and neighbours at the headline's size (many-lights/params.md)")
    ap.add_argument("--scene", action="append", choices=sorted(set(HEADLINE + LAB_SCENES) | set(MANY_SCENES)),
                    help="run only this headline scene (repeatable): split a long study over several GPU calls, "
                         "then --report-only over the merged runs")
    ap.add_argument("--selection", action="append", choices=sorted(MANY_SELECTIONS),
                    help="many-lights: run only this selection method (repeatable); the report needs them all, so "
                         "merge the runs and use --report-only")
    ap.add_argument("--check", action="store_true", help="assert slopes and the near-light win (CI smoke test)")
    ap.add_argument("--keep-runs", action="store_true", help="keep the crops (.npy) the figures are drawn from")
    ap.add_argument("--report-only", action="store_true",
                    help="draw the report from the runs already in --out (e.g. made on a GPU machine without matplotlib)")
    ap.add_argument("--no-report", action="store_true", help="run the experiments only (implies --keep-runs)")
    ap.add_argument("--yes", action="store_true", help="run even when the estimate on the CPU is more than an hour")
    ap.add_argument("--force", action="store_true", help="overwrite a report folder that is committed to git")
    args = ap.parse_args()
    if args.no_report:
        args.keep_runs = True
    if args.only == "params":
        if args.part not in ("many-lights", "all"):
            sys.exit(f"study: --only params: restir's parameters are part of --part many-lights, not --part {args.part}")
        if args.selection:
            sys.exit("study: --only params runs its own configurations (MANY_PARAMS); --selection picks the "
                     "headline's methods")
        if args.scene and not set(args.scene) & set(MANY_PARAM_SCENES):
            sys.exit("study: --only params runs on " + " and ".join(MANY_PARAM_SCENES) + ", not on "
                     + ", ".join(args.scene))
    if (args.engine == "python" or args.executor == "ray") and not args.report_only:
        try:
            import penumbra  # noqa: F401
        except ImportError as e:
            sys.exit(f"study: --{'engine python' if args.engine == 'python' else 'executor ray'}: cannot import "
                     f"penumbra ({e}): pip install ., or PYTHONPATH=build/python")
    elif not args.report_only and not os.path.exists(args.penumbra):
        sys.exit(f"study: {args.penumbra}: no such executable (build first, or pass --penumbra)")
    if plt is None and not args.no_report:
        log("study: numpy and matplotlib are needed for the report (python3 -m pip install numpy matplotlib), "
            "or use --no-report")
        sys.exit(77)  # CTest's skip code: a machine without them (CI installs them) skips the smoke test
    check_out(args)
    args.source_commit, args.source_dirty = source_state()
    if args.source_dirty and not args.allow_dirty and not args.report_only:
        sys.exit("study: the checkout has uncommitted changes (git status): a report must come from a clean commit; "
                 "commit them, or pass --allow-dirty (each report then says so in its first line)")
    if args.preset not in PRESETS:  # the denoise part's own presets (cpu)
        if args.part != "denoise":
            sys.exit(f"study: --preset {args.preset} sizes the denoise part only: add --part denoise")
        ok = run_denoise(args, os.path.join(args.out, "denoise"))
        sys.exit(0 if ok else 1)
    preset, lab = PRESETS[args.preset], LAB_PRESETS[args.preset]
    lab_dir, many_dir = os.path.join(args.out, "lab"), os.path.join(args.out, "many-lights")
    many = MANY_PRESETS[args.preset]
    # Every run, planned and estimated before any starts.
    lab_runs = lab_plan(args, lab, lab_dir) if args.part in ("lab", "all") else ([], {})
    thesis_runs = thesis_plan(args, preset) if args.part in ("thesis", "all") else ([], {})
    many_runs = many_plan(args, many, many_dir) if args.part in ("many-lights", "all") else ([], {})
    args.ray_failed = {}
    if not args.report_only:
        every = [r for head, sweeps in (lab_runs, thesis_runs, many_runs) for r in head + sum(sweeps.values(), [])]
        planned = plan_on_ray(args, every) if args.executor == "ray" else [(r, None) for r in plan(args, every)]
        kept = {run_key(r) for r, _ in planned}
        lab_runs, thesis_runs, many_runs = keep(lab_runs, kept), keep(thesis_runs, kept), keep(many_runs, kept)
        if args.executor == "ray":
            os.makedirs(args.out, exist_ok=True)
            args.ray_failed = run_on_ray(args, planned)
    os.makedirs(args.out, exist_ok=True)
    ok = True
    if args.part in ("lab", "all"):
        os.makedirs(lab_dir, exist_ok=True)
        ok = finish_lab(args, lab, lab_dir, *run_all(args, lab_runs)) and ok
    if args.part in ("many-lights", "all"):
        os.makedirs(many_dir, exist_ok=True)
        ok = finish_many_lights(args, many, many_dir, many_runs, *run_all(args, many_runs)) and ok
    if args.part in ("thesis", "all"):
        head, sweeps = run_all(args, thesis_runs)
        radius_runs = sweeps.get("radius", [])
        if head and radius_runs and not args.no_report:
            write_report(args, preset, head, radius_runs, sweeps.get("distance", []), sweeps.get("occlusion", []),
                         preset["radii"], preset["near_k"], preset["slat_widths"])
            log(f"study: wrote {os.path.join(args.out, 'README.md')}")
        if args.check and head and not check(head):
            ok = False
    if args.part in ("denoise", "all"):
        ok = run_denoise(args, os.path.join(args.out, "denoise")) and ok
    if not ok:
        sys.exit(1)
    if not args.keep_runs:
        # Keep what the report needs to stay reproducible and small: CSV, JSON, PNG.
        for runs in (os.path.join(args.out, "runs"), os.path.join(lab_dir, "runs"), os.path.join(many_dir, "runs")):
            for root, _, files in os.walk(runs):
                for f in files:
                    if f.endswith(".npy"):
                        os.remove(os.path.join(root, f))

if __name__ == "__main__":
    try:
        main()
    except RunFailed as e:
        log(f"study: stopped: {e}")
        sys.exit(e.status)
    except KeyboardInterrupt:
        # Ctrl-C: one line, not a traceback. penumbra, in the same process group,
        # stopped too and said so; its outputs are written atomically.
        log("study: interrupted (Ctrl-C): stopped; runs already finished are complete")
        sys.exit(130)
