#!/usr/bin/env python3
"""The study on every GPU count of one machine (the scale-out report): the same
study through `study.py --executor ray` with one task per GPU (--task-gpus 1),
Ray started here with 1, 2, 4 and 8 of the machine's GPUs (--ray-gpus, those
the machine has), in interleaved rounds; each run renders its ground truths and
its points from an empty cache. It reports the wall time of each run, the
speed-up over one GPU (the target: at least 0.8 x N) and whether every run's
numbers equal one GPU's to the bit (errors, fits, ground truths and crops: only
times may differ; scripts/study/compare.py).

    python3 scripts/scale_out_study.py --out /tmp/scale-out
        # the lab (--preset gpu --part lab: 51 experiments) on every GPU count
    python3 scripts/scale_out_study.py --out /tmp/scale-out --counts 1,2 -- --preset gpu --part thesis
        # another study after `--`
    python3 scripts/scale_out_study.py --backend cpu --counts 1,2 --out /tmp/so -- --preset smoke --part thesis
        # CPU workers instead of GPUs (--ray-cpus N --task-cpus 1): the pipeline on a machine without GPUs

It needs Ray and penumbra's Python module with the GPU backend (PYTHONPATH=build/python). Writes OUT/times.tsv
(round, count, seconds) and OUT/speedups.md; prints PASS or FAIL per check; exits 0 only if all passed, 2 on a
usage error (fewer than two counts on this machine), 77 without Ray. What it costs: the lab's renders at the gpu
preset took 66 s of one H200 in its last run (the sum of its summaries' seconds: 640 x 360 and 320 x 180 images),
to which each task adds its set-up (a Ray worker, the scene, the GPU backend): a round on 1, 2, 4 and 8 GPUs,
a few minutes.
"""
import argparse
import os
import platform
import shutil
import statistics
import subprocess
import sys
import time

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)
from study.compare import compare_runs  # noqa: E402

DEFAULT_STUDY = {"optix": ["--preset", "gpu", "--part", "lab"],
                 "cpu": ["--preset", "smoke", "--part", "thesis"]}


def machine_gpus():
    """The GPUs this machine shows (CUDA_VISIBLE_DEVICES applies), by nvidia-smi; 0 without it."""
    try:
        r = subprocess.run(["nvidia-smi", "-L"], capture_output=True, text=True, timeout=60)
    except (OSError, subprocess.TimeoutExpired):
        return 0, ""
    lines = [line for line in r.stdout.splitlines() if line.startswith("GPU ")] if r.returncode == 0 else []
    visible = os.environ.get("CUDA_VISIBLE_DEVICES")
    count = len(lines) if visible is None else min(len(lines), len([v for v in visible.split(",") if v.strip()]))
    name = lines[0].split(":", 1)[1].split("(")[0].strip() if lines else ""
    return count, name


def penumbra_commit():
    """The Python module's commit (what the Ray tasks run), or '' where it cannot be imported."""
    r = subprocess.run([sys.executable, "-c", "import penumbra; print(penumbra.build_info()['git_commit'])"],
                       capture_output=True, text=True)
    return r.stdout.strip() if r.returncode == 0 else ""


def parts_of(out):
    """The study's part folders (those holding runs/) in an output folder."""
    return sorted(d for d in os.listdir(out) if os.path.isdir(os.path.join(out, d, "runs")))


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--out", required=True, help="where times.tsv, speedups.md and each run's output go")
    ap.add_argument("--backend", choices=["optix", "cpu"], default="optix",
                    help="optix: N GPUs (--ray-gpus N --task-gpus 1); cpu: N CPU workers (--ray-cpus N --task-cpus 1)")
    ap.add_argument("--counts", default="1,2,4,8", help="GPU (or CPU worker) counts; those above the machine's "
                                                        "are left out, 1 always comes first")
    ap.add_argument("--rounds", type=int, default=1, help="interleaved rounds (every count in each round)")
    ap.add_argument("--target", type=float, default=0.8, help="the speed-up to reach on N: at least TARGET x N")
    ap.add_argument("--keep", action="store_true", help="keep each run's output and cache (else only the first "
                                                        "round's runs are kept until compared)")
    ap.add_argument("study", nargs=argparse.REMAINDER,
                    help="after --: the study's own arguments (default: " + " ".join(DEFAULT_STUDY["optix"]) +
                         "; with --backend cpu: " + " ".join(DEFAULT_STUDY["cpu"]) + ")")
    args = ap.parse_args()
    study_args = [a for a in args.study if a != "--"] or DEFAULT_STUDY[args.backend]
    for bad in ("--executor", "--out", "--cache", "--ray-gpus", "--ray-cpus", "--task-gpus", "--task-cpus",
                "--backend", "--address"):
        if bad in study_args:
            sys.exit(f"scale_out_study: {bad} after --: this script sets it for each run")
    try:
        counts = sorted({int(c) for c in args.counts.split(",") if c.strip()})
    except ValueError:
        print(f"scale_out_study: --counts {args.counts}: a comma-separated list of whole numbers", file=sys.stderr)
        return 2
    if args.rounds < 1 or not counts or counts[0] < 1:
        print("scale_out_study: --rounds and every count must be at least 1", file=sys.stderr)
        return 2
    if args.backend == "optix":
        have, device = machine_gpus()
        unit = "GPU"
    else:
        have, device = os.cpu_count() or 1, platform.processor() or platform.machine()
        unit = "CPU worker"
    counts = sorted({1} | {c for c in counts if c <= have})
    if len(counts) < 2:
        print(f"scale_out_study: --counts {args.counts}: no count above 1 within this machine's {have} {unit}(s) "
              "(it needs several GPUs; --backend cpu checks the pipeline on CPU workers)", file=sys.stderr)
        return 2
    try:
        import ray  # noqa: F401
    except ImportError:
        print("scale_out_study: ray is not installed (python3 -m pip install ray): skipped", file=sys.stderr)
        return 77  # CTest's skip
    commit = penumbra_commit()
    if not commit:
        print("scale_out_study: cannot import penumbra (PYTHONPATH=build/python, or pip install .)", file=sys.stderr)
        return 2

    os.makedirs(args.out, exist_ok=True)
    study = os.path.join(HERE, "study.py")
    times = {c: [] for c in counts}
    problems = []
    first = {}  # count -> the first round's output folder
    tsv = open(os.path.join(args.out, "times.tsv"), "w")
    tsv.write("round\tcount\tseconds\n")
    for r in range(args.rounds):
        for c in counts:
            run = os.path.join(args.out, f"round{r + 1}-{c}")
            shutil.rmtree(run, ignore_errors=True)
            sizing = ["--ray-gpus", str(c), "--task-gpus", "1"] if args.backend == "optix" else \
                     ["--ray-cpus", str(c), "--task-cpus", "1"]
            cmd = [sys.executable, study, "--executor", "ray", "--backend", args.backend, "--no-report",
                   "--allow-dirty", "--out", os.path.join(run, "out"), "--cache", os.path.join(run, "cache"),
                   *sizing, *study_args]
            print(f"scale_out_study: round {r + 1}, {c} {unit}(s): " + " ".join(cmd), file=sys.stderr, flush=True)
            t0 = time.monotonic()
            p = subprocess.run(cmd)
            seconds = time.monotonic() - t0
            if p.returncode != 0:
                print(f"scale_out_study: FAIL: round {r + 1}, {c} {unit}(s): the study exited with {p.returncode}",
                      file=sys.stderr)
                return 1
            times[c].append(seconds)
            tsv.write(f"{r + 1}\t{c}\t{seconds:.2f}\n")
            tsv.flush()
            print(f"scale_out_study: round {r + 1}, {c} {unit}(s): {seconds:.1f} s", file=sys.stderr, flush=True)
            shutil.rmtree(os.path.join(run, "cache"), ignore_errors=True)  # ground truths: in each run's summaries
            if r == 0:
                first[c] = os.path.join(run, "out")
            elif not args.keep:
                shutil.rmtree(run, ignore_errors=True)
    tsv.close()

    # The numbers on N against one: to the bit.
    base = first[1]
    parts = parts_of(base)
    if not parts:
        problems.append(f"{base}: the study wrote no runs")
    identical = True
    for c in counts[1:]:
        diffs = [f"{part}: {d}" for part in parts for d in compare_runs(os.path.join(base, part),
                                                                         os.path.join(first[c], part))]
        identical = identical and not diffs
        problems += [f"{c} {unit}(s) against 1: {d}" for d in diffs[:10]]
        if diffs:
            print(f"scale_out_study: FAIL: {c} {unit}(s): {len(diffs)} differences from one {unit}'s numbers",
                  file=sys.stderr)
        else:
            print(f"scale_out_study: PASS: {c} {unit}(s): the numbers of {', '.join(parts)} equal one {unit}'s to "
                  "the bit", file=sys.stderr)
    # Speed-ups over the rounds' medians.
    t1 = statistics.median(times[1])
    rows = []
    for c in counts:
        tc = statistics.median(times[c])
        speedup = t1 / tc
        ok = c == 1 or speedup >= args.target * c
        rows.append((c, tc, speedup, ok))
        if c > 1:
            print(f"scale_out_study: {'PASS' if ok else 'FAIL'}: {c} {unit}s: {speedup:.2f}x one (target "
                  f"{args.target * c:.2f}x)", file=sys.stderr)
            if not ok:
                problems.append(f"{c} {unit}s: speed-up {speedup:.2f}x under {args.target * c:.2f}x")
    with open(os.path.join(args.out, "speedups.md"), "w") as f:
        f.write(f"Made by `python3 scripts/scale_out_study.py --backend {args.backend} --counts "
                f"{','.join(map(str, counts))} --rounds {args.rounds} -- {' '.join(study_args)}` with penumbra "
                f"`{commit}` on {device or 'this machine'} ({have} {unit}s); each run through `study.py --executor "
                f"ray`, one task a {unit}, from an empty cache.\n\n")
        f.write(f"| {unit}s | wall s (median of {args.rounds}) | speed-up | target |\n| ---: | ---: | ---: | ---: |\n")
        for c, tc, speedup, ok in rows:
            f.write(f"| {c} | {tc:.1f} | {speedup:.2f}x | {'' if c == 1 else f'{args.target * c:.2f}x'}"
                    f"{'' if ok else ' (missed)'} |\n")
        f.write("\nNumbers on every count against one: " + ("equal to the bit (" + ", ".join(parts) + ")" if identical
                                                           else "DIFFERENT (the check's output says where)") + ".\n")
    if not args.keep:
        for c in counts:
            shutil.rmtree(os.path.join(args.out, f"round1-{c}"), ignore_errors=True)
    for line in problems:
        print("scale_out_study: FAIL: " + line, file=sys.stderr)
    print(f"scale_out_study: {'all passed' if not problems else f'{len(problems)} failed'}; "
          f"{os.path.join(args.out, 'speedups.md')}", file=sys.stderr)
    return 0 if not problems else 1


if __name__ == "__main__":
    sys.exit(main())
