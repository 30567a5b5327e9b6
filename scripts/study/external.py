"""The topics that their own scripts make, run as parts of the study so that `--part all` regenerates every
generated topic of docs/results: gpu-speed (scripts/gpu_speed.sh: `penumbra bench` on the GPU, the trace stage
alone, Nsight Compute and the Mitsuba anchor where they are installed) and anchors (scripts/anchors/run.sh:
penumbra against Mitsuba 3 on the CPU). Each says in one line why it is skipped where it cannot run."""
import os
import subprocess
import sys

from .common import log

HERE = os.path.dirname(os.path.abspath(__file__))
SCRIPTS = os.path.dirname(HERE)

# The anchors' options per preset (mitsuba_anchor.py's); None: run.sh's own (the published report's).
ANCHOR_OPTIONS = {"smoke": ["--spp", "32", "--width", "64", "--height", "36", "--seeds", "6"]}


def filtered(args):
    """The study's run filters (--only, --scene, --selection) pick runs of the converge parts, which these
    topics do not have: with any of them the topics are not run."""
    return args.only or args.scene or args.selection


def imports(modules):
    """Why `python3 -c "import <modules>"` fails here (its last line), or None."""
    p = subprocess.run([sys.executable, "-c", "import " + ", ".join(modules)], capture_output=True, text=True)
    if p.returncode == 0:
        return None
    lines = p.stderr.strip().splitlines()
    return lines[-1] if lines else f"exit status {p.returncode}"


def gpu_unavailable(args):
    """Why `penumbra bench` cannot run on a GPU here (one line), or None."""
    if args.backend == "cpu":
        return "it measures the GPU (--backend cpu)"
    if not os.path.exists(args.penumbra):
        return f"{args.penumbra}: no such executable"
    p = subprocess.run([args.penumbra, "bench", "--backend", "optix", "--scenes", "cornell-sphere", "--width", "16",
                        "--height", "16", "--launches", "1", "--warmup", "0"], capture_output=True, text=True)
    if p.returncode != 0:
        lines = p.stderr.strip().splitlines()
        return "penumbra has no GPU backend here: " + (lines[-1] if lines else f"exit status {p.returncode}")
    return None


def run_gpu_speed(args, out_dir):
    """The gpu-speed topic: scripts/gpu_speed.sh into out_dir (with --report-only, its report drawn again from the
    JSON there). Returns False when the script fails."""
    if filtered(args):
        log("study: gpu-speed part skipped: --only, --scene and --selection pick runs of the converge parts")
        return True
    report = [sys.executable, os.path.join(SCRIPTS, "gpu_speed_report.py"), out_dir]
    if args.report_only:
        if not os.path.exists(os.path.join(out_dir, "bench_wavefront-cuda.json")):
            log(f"study: gpu-speed part skipped: no bench JSON in {out_dir} (run it on a GPU first)")
            return True
        return subprocess.run(report).returncode == 0
    why = gpu_unavailable(args)
    if why:
        log(f"study: gpu-speed part skipped: {why}")
        return True
    log(f"study: bash scripts/gpu_speed.sh {args.penumbra} {out_dir}")
    return subprocess.run(["bash", os.path.join(SCRIPTS, "gpu_speed.sh"), args.penumbra, out_dir]).returncode == 0


def run_anchors(args, out_dir):
    """The anchors topic: scripts/anchors/run.sh into out_dir, with the preset's options. Returns False when an
    anchor disagrees or fails."""
    if filtered(args):
        log("study: anchors part skipped: --only, --scene and --selection pick runs of the converge parts")
        return True
    if args.report_only:
        log("study: anchors part: its report is written with its renders (scripts/anchors/run.sh), nothing to redraw")
        return True
    if args.source_dirty:
        log("study: anchors part skipped: scripts/anchors/run.sh reports from a clean commit only")
        return True
    why = imports(["mitsuba", "penumbra"])
    if why:
        log(f"study: anchors part skipped: it needs Mitsuba 3 (pip install mitsuba) and penumbra's Python module "
            f"(pip install ., or PYTHONPATH=build/python): {why}")
        return True
    cmd = ["bash", os.path.join(SCRIPTS, "anchors", "run.sh"), os.path.abspath(out_dir)]
    cmd += ANCHOR_OPTIONS.get(args.preset) or []
    log("study: " + " ".join(cmd))
    return subprocess.run(cmd).returncode == 0
