"""Two study outputs' runs compared number for number: every error, fit,
ground truth and crop must be equal to the bit; measured times, the device line
and the cache's bookkeeping may differ (they do between two runs by design).
The Ray executor's test (tests/scripts/study_ray_check.py) and the scale-out
measurement (scripts/scale_out_study.py) compare with it."""
import csv
import json
import os

# Values that are measured times (or derived from them), and the bookkeeping
# that differs between two runs by design.
TIMES = {"time_ms", "wall_ms", "ms_per_spp", "wall_ms_per_spp", "ms_to_threshold", "efficiency",
         "efficiency_nolight", "seconds", "estimated_seconds"}
BOOKKEEPING = {"device", "executor"}
REFERENCE_BOOKKEEPING = {"cached", "seconds", "file"}


def without_times(x):
    if isinstance(x, dict):
        return {k: without_times(v) for k, v in x.items() if k not in TIMES}
    if isinstance(x, list):
        return [without_times(v) for v in x]
    return x


def summary_numbers(path):
    with open(path) as f:
        s = json.load(f)
    for k in BOOKKEEPING:
        s.pop(k, None)
    s["reference"]["key"] = os.path.basename(s["reference"]["file"])  # the cache key; the folder differs
    for k in REFERENCE_BOOKKEEPING:
        s["reference"].pop(k)
    return without_times(s)


def csv_numbers(path):
    with open(path) as f:
        return [{k: v for k, v in row.items() if k not in TIMES} for row in csv.DictReader(f)]


def compare_runs(a_part, b_part):
    """Differences between two outputs of one part (each a folder holding runs/), as lines; none if equal."""
    problems = []
    b_runs = os.path.join(b_part, "runs")
    names = sorted(os.listdir(b_runs)) if os.path.isdir(b_runs) else []
    if not names:
        return [f"{b_part}: no runs"]
    for name in names:
        a, b = os.path.join(a_part, "runs", name), os.path.join(b_runs, name)
        if not os.path.isdir(a):
            problems.append(f"{name}: not in {a_part}")
            continue
        if sorted(os.listdir(a)) != sorted(os.listdir(b)):
            problems.append(f"{name}: files {sorted(os.listdir(a))} != {sorted(os.listdir(b))}")
            continue
        sa, sb = summary_numbers(os.path.join(a, "summary.json")), summary_numbers(os.path.join(b, "summary.json"))
        for k in sorted(set(sa) | set(sb)):
            if sa.get(k) != sb.get(k):
                problems.append(f"{name}: summary.json {k}: {str(sa.get(k))[:120]} != {str(sb.get(k))[:120]}")
        if csv_numbers(os.path.join(a, "measurements.csv")) != csv_numbers(os.path.join(b, "measurements.csv")):
            problems.append(f"{name}: measurements.csv differs")
        for f in os.listdir(a):  # crops (float32 images), PNGs: byte for byte
            if f.endswith((".npy", ".png")):
                with open(os.path.join(a, f), "rb") as x, open(os.path.join(b, f), "rb") as y:
                    if x.read() != y.read():
                        problems.append(f"{name}: {f} differs")
    a_names = sorted(os.listdir(os.path.join(a_part, "runs")))
    if a_names != names:
        problems.append(f"runs: {a_names} != {names}")
    return problems
