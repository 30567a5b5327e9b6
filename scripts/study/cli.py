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
import importlib
import os
import subprocess
import sys

from .common import RunFailed, log
from .denoise import run_denoise
from .executors import Ledger, plan, plan_on_ray, run_all, run_on_ray
from .external import run_anchors, run_gpu_speed
from .lab import finish_lab
from .many_lights import finish_many_lights
from .planner import (DENOISE_PRESETS, HEADLINE, LAB_PRESETS, LAB_SCENES, MANY_PARAM_SCENES, MANY_PRESETS,
                      MANY_SCENES, MANY_SELECTIONS, PRESETS, keep, lab_plan, many_plan, run_key, thesis_plan)
from .report import plt, source_state
from .thesis import finish_thesis


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


def main(prog=None):
    here = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))  # scripts/
    ap = argparse.ArgumentParser(prog=prog, description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--preset", choices=sorted(set(PRESETS) | set(DENOISE_PRESETS)), default="full",
                    help="full, gpu (about half an hour of one GPU), cpu (every part sized for two CPU cores: well "
                         "under an hour), smoke (tiny, CPU, CI)")
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
    ap.add_argument("--ray-gpus", type=int,
                    help="ray without --address: the GPUs the Ray instance on this machine may use (default: all; "
                         "the first N of CUDA_VISIBLE_DEVICES); scripts/scale_out_study.py varies it")
    ap.add_argument("--retries", type=int, default=3,
                    help="ray: how often a task whose worker or machine is lost runs again (Ray's max_retries)")
    ap.add_argument("--part", choices=["thesis", "lab", "many-lights", "denoise", "gpu-speed", "anchors", "all"],
                    default="all",
                    help="thesis: chapter 4 (area against solid-angle, docs/results/thesis/README.md); lab: every strategy and "
                         "MIS mode on the lab's scenes (docs/results/lab/README.md); many-lights: light selection "
                         "methods at equal time and the lights-count sweep (docs/results/many-lights/README.md); "
                         "denoise: raw and denoised RMSE per strategy, 1-64 spp, on the headline scenes, on any backend ("
                         "docs/results/denoise/README.md); gpu-speed: scripts/gpu_speed.sh (on a GPU; "
                         "docs/results/gpu-speed/README.md); anchors: scripts/anchors/run.sh (penumbra against Mitsuba "
                         "3; docs/results/anchors/README.md); all: the six, each skipped in one line where it cannot "
                         "run")
    ap.add_argument("--only", choices=["headline", "sweeps", "params"],
                    help="run one part only; params (many-lights only, not part of a default run): restir's "
                         "candidates, spatial passes and neighbours at the headline's size (many-lights/params.md)")
    ap.add_argument("--scene", action="append", choices=sorted(set(HEADLINE + LAB_SCENES) | set(MANY_SCENES)),
                    help="run only this headline scene (repeatable): split a long study over several GPU calls, "
                         "then --report-only over the merged runs")
    ap.add_argument("--selection", action="append", choices=sorted(MANY_SELECTIONS),
                    help="many-lights: run only this selection method, in the headline and the sweep (repeatable); "
                         "the report needs them all, so merge the runs and use --report-only")
    ap.add_argument("--check", action="store_true", help="assert slopes and the near-light win (CI smoke test)")
    ap.add_argument("--keep-runs", action="store_true", help="keep the crops (.npy) the figures are drawn from")
    ap.add_argument("--report-only", action="store_true",
                    help="draw the report from the runs already in --out (e.g. made on a GPU machine without matplotlib)")
    ap.add_argument("--no-report", action="store_true", help="run the experiments only (implies --keep-runs)")
    ap.add_argument("--yes", action="store_true", help="run even when the estimate on the CPU is more than an hour")
    ap.add_argument("--no-estimate", action="store_true",
                    help="local executor: start without estimating every run first (a penumbra process and a "
                         "measurement each; no total is printed); each run prints its own estimate and, on the CPU, "
                         "stops past an hour without --yes")
    ap.add_argument("--resume", action="store_true",
                    help="local executor, the thesis, lab and many-lights parts: keep the runs an earlier study "
                         "finished with the same command and the same penumbra (their files unchanged since; "
                         "recorded in <cache>/study-local/) and run the rest: an interrupted study continues where it "
                         "stopped (the Ray executor always does)")
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
    for name in ("ray_cpus", "ray_gpus"):
        value, flag = getattr(args, name), "--" + name.replace("_", "-")
        if value is not None and value < (1 if name == "ray_cpus" else 0):
            sys.exit(f"study: {flag} {value}: at least {1 if name == 'ray_cpus' else 0}")
        if value is not None and args.address:
            sys.exit(f"study: {flag} sizes the Ray instance this command starts; a cluster joined with --address "
                     "has the resources its nodes declared (ray start --num-gpus)")
    if (args.engine == "python" or args.executor == "ray") and not args.report_only:
        try:
            importlib.import_module("penumbra")
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
    thesis_dir = os.path.join(args.out, "thesis")
    many = MANY_PRESETS[args.preset]
    # Every run, planned and estimated before any starts.
    lab_runs = lab_plan(args, lab, lab_dir) if args.part in ("lab", "all") else ([], {})
    thesis_runs = thesis_plan(args, preset, thesis_dir) if args.part in ("thesis", "all") else ([], {})
    many_runs = many_plan(args, many, many_dir) if args.part in ("many-lights", "all") else ([], {})
    args.ray_failed = {}
    # Every run the local executor finishes is recorded, so that a later --resume can keep it.
    args.ledger = Ledger(args) if args.executor == "local" and not args.report_only else None
    every = [r for head, sweeps in (lab_runs, thesis_runs, many_runs) for r in head + sum(sweeps.values(), [])]
    if not args.report_only and every:
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
        os.makedirs(thesis_dir, exist_ok=True)
        ok = finish_thesis(args, preset, thesis_dir, *run_all(args, thesis_runs)) and ok
    if args.part in ("denoise", "all"):
        ok = run_denoise(args, os.path.join(args.out, "denoise")) and ok
    if args.part in ("gpu-speed", "all"):
        ok = run_gpu_speed(args, os.path.join(args.out, "gpu-speed")) and ok
    if args.part in ("anchors", "all"):
        ok = run_anchors(args, os.path.join(args.out, "anchors")) and ok
    if not ok:
        sys.exit(1)
    if not args.keep_runs:
        # Keep what the report needs to stay reproducible and small: CSV, JSON, PNG.
        for runs in (os.path.join(thesis_dir, "runs"), os.path.join(lab_dir, "runs"), os.path.join(many_dir, "runs")):
            for root, _, files in os.walk(runs):
                for f in files:
                    if f.endswith(".npy"):
                        os.remove(os.path.join(root, f))


def entry(prog=None):
    """main() with the study's own words for a failed run and for Ctrl-C (no traceback)."""
    try:
        main(prog)
    except RunFailed as e:
        log(f"study: stopped: {e}")
        sys.exit(e.status)
    except KeyboardInterrupt:
        # Ctrl-C: one line, not a traceback. penumbra, in the same process group,
        # stopped too and said so; its outputs are written atomically.
        log("study: interrupted (Ctrl-C): stopped; runs already finished are complete")
        sys.exit(130)
