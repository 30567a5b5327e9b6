#!/usr/bin/env python3
"""Where a GPU sample's time goes, kernel by kernel: Nsight Compute (`ncu`) over `penumbra bench` at 1920 x 1080,
1 spp a launch, depth 8, and one table per scene of the kernels' time a sample with what limits each (the GPU
speed report's profile; the GPU issue's "measured reason why not").

    python3 scripts/gpu_profile.py [--penumbra build/penumbra] [--out docs/results/gpu-speed]
                                   [--scenes cornell-sphere,sponza] [--ncu ncu] [--launches 4]

Writes OUT/profile_SCENE.csv (ncu's raw page, as it printed it) and OUT/profile.md. Clocks are left as the GPU
runs them (`--clock-control none`), so that kernel times are those of a render, not of base clocks. Every kernel
of the bench's launches is profiled, replayed once per metric pass; the scene's set-up kernels (OptiX's
acceleration-structure builds) are listed under the table, outside a sample's total.
Needs ncu on the GPU machine (CUDA's nsight-compute); `--summarize CSV...` only draws the tables from CSV files
already made (no GPU).
"""
import argparse
import csv
import io
import os
import re
import subprocess
import sys

# (metric, column title, how a kernel's launches combine: "sum" or "time" (their mean weighted by time))
METRICS = [
    ("gpu__time_duration.sum", "ms a sample", "sum"),
    ("sm__throughput.avg.pct_of_peak_sustained_elapsed", "SM %", "time"),
    ("gpu__compute_memory_throughput.avg.pct_of_peak_sustained_elapsed", "memory %", "time"),
    ("sm__warps_active.avg.pct_of_peak_sustained_active", "occupancy %", "time"),
    ("launch__registers_per_thread", "registers", "time"),
    ("smsp__average_warps_issue_stalled_long_scoreboard_per_issue_active.ratio", "stall: memory", "time"),
    ("smsp__average_warps_issue_stalled_no_instruction_per_issue_active.ratio", "stall: no instruction", "time"),
    ("smsp__average_warps_issue_stalled_wait_per_issue_active.ratio", "stall: fixed latency", "time"),
]


def number(text):
    """A value of ncu's CSV ("1,234.5", "12", "n/a") as a float; None where it is none."""
    t = text.replace(",", "").strip()
    try:
        return float(t)
    except ValueError:
        return None


def short_name(kernel):
    """A kernel's name without its parameter list and namespaces, its template arguments kept: the rows differ by
    them (the shading kernels' level, strategy and MIS class)."""
    k = re.sub(r"^void\s+", "", kernel.strip()).replace("(anonymous namespace)::", "")
    depth, cut = 0, len(k)
    for i, c in enumerate(k):  # the parameter list: the first '(' outside template brackets
        if c == "<":
            depth += 1
        elif c == ">":
            depth -= 1
        elif c == "(" and depth == 0:
            cut = i
            break
    k = k[:cut]
    return re.sub(r"\b[A-Za-z_]\w*::", "", k)


def parse_raw_csv(text):
    """ncu's `--csv --page raw` output (a header row, a units row, a row per profiled kernel launch; lines that are
    not CSV, such as ncu's ==PROF== notes, skipped) as a list of {column: text}."""
    lines = [l for l in text.splitlines() if l.startswith('"')]
    rows = list(csv.reader(io.StringIO("\n".join(lines))))
    if len(rows) < 2:
        return []
    header = rows[0]
    body = rows[1:]
    if body and not body[0][header.index("ID")].strip():  # the units row
        body = body[1:]
    return [dict(zip(header, r)) for r in body if len(r) == len(header)]


def summarize(launch_rows, launches):
    """Rows of one scene's profile -> [(kernel, {column title: value}, launches of it)], slowest first; times in ms a
    sample (the bench's launches each render one)."""
    kernels = {}
    for r in launch_rows:
        kernels.setdefault(short_name(r["Kernel Name"]), []).append(r)
    out = []
    for name, rs in kernels.items():
        times = [number(r.get("gpu__time_duration.sum", "")) or 0.0 for r in rs]  # ns
        total = sum(times)
        row = {}
        for metric, title, how in METRICS:
            vals = [(number(r.get(metric, "")), t) for r, t in zip(rs, times)]
            vals = [(v, t) for v, t in vals if v is not None]
            if not vals:
                row[title] = None
            elif how == "sum":
                row[title] = sum(v for v, _ in vals) / 1e6 / launches
            else:
                w = sum(t for _, t in vals)
                row[title] = sum(v * t for v, t in vals) / w if w > 0 else sum(v for v, _ in vals) / len(vals)
        out.append((name, row, len(rs)))
    out.sort(key=lambda x: -(x[1]["ms a sample"] or 0.0))
    return out


def is_setup(kernel):
    """A scene's set-up kernel, run once a render and not a sample's: OptiX's acceleration-structure builds."""
    return kernel.startswith("optixAccel")


def table(scene, summary, launches):
    setup = [(name, r, n) for name, r, n in summary if is_setup(name)]
    summary = [(name, r, n) for name, r, n in summary if not is_setup(name)]
    total = sum(r["ms a sample"] or 0.0 for _, r, _ in summary)
    titles = [t for _, t, _ in METRICS]
    lines = [f"## {scene}: {total:.3f} ms of kernel time a sample ({launches} launches profiled)\n",
             "| kernel | launches a sample | share | " + " | ".join(titles) + " |",
             "| --- | ---: | ---: |" + " ---: |" * len(titles)]
    tail = []
    if setup:
        tail = ["", "The scene's set-up, once a render and not in the total: " + ", ".join(
            f"`{name}` x {n} ({(r['ms a sample'] or 0.0) * launches:.3f} ms)" for name, r, n in setup) + "."]
    for name, r, n in summary:
        cells = []
        for t in titles:
            v = r[t]
            cells.append("" if v is None else f"{v:.3f}" if t == "ms a sample" else f"{v:.2f}" if "stall" in t
                         else f"{v:.0f}")
        share = 100 * (r["ms a sample"] or 0.0) / total if total > 0 else 0.0
        lines.append(f"| `{name}` | {n / launches:.1f} | {share:.1f}% | " + " | ".join(cells) + " |")
    return "\n".join(lines + tail) + "\n"


def profile(args, scene):
    cmd = [args.ncu, "--clock-control", "none", "--csv", "--page", "raw", "--print-kernel-base", "demangled",
           "--metrics", ",".join(m for m, _, _ in METRICS),
           args.penumbra, "bench", "--backend", "optix", "--scenes", scene, "--strategies", "solid-angle", "--mis",
           "none", "--width", "1920", "--height", "1080", "--spp-per-launch", "1", "--max-depth", "8",
           "--launches", str(args.launches), "--warmup", "0"]
    print("gpu_profile: " + " ".join(cmd), file=sys.stderr)
    p = subprocess.run(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    if p.returncode != 0:
        sys.exit(f"gpu_profile: ncu exited with status {p.returncode} on {scene}:\n{p.stderr[-2000:]}")
    path = os.path.join(args.out, f"profile_{scene}.csv")
    with open(path, "w") as f:
        f.write(p.stdout)
    return path


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--penumbra", default="build/penumbra")
    ap.add_argument("--out", default="docs/results/gpu-speed")
    ap.add_argument("--scenes", default="cornell-sphere,sponza")
    ap.add_argument("--ncu", default="ncu")
    ap.add_argument("--launches", type=int, default=4, help="bench launches profiled (1 spp each)")
    ap.add_argument("--summarize", nargs="+", metavar="CSV", help="draw the tables from these profile_SCENE.csv")
    args = ap.parse_args()
    if args.launches < 1:
        sys.exit("gpu_profile: --launches must be at least 1")
    os.makedirs(args.out, exist_ok=True)
    paths = args.summarize or [profile(args, s) for s in args.scenes.split(",") if s]
    parts = ["# Where a sample's GPU time goes, kernel by kernel\n",
             "Nsight Compute over `penumbra bench` (solid-angle, MIS none, 1920 x 1080, 1 spp a launch, depth 8; "
             "`--clock-control none`), by `python3 scripts/gpu_profile.py`. ms a sample: the kernel's GPU time over "
             "the launches profiled; SM % and memory %: throughput against the GPU's peak; occupancy: warps active "
             "of the most an SM holds; stalls: cycles a warp waits per instruction issued, on memory (long "
             "scoreboard), for instructions to fetch, and on fixed-latency results.\n"]
    for path in paths:
        scene = re.sub(r"^profile_|\.csv$", "", os.path.basename(path))
        with open(path) as f:
            rows = parse_raw_csv(f.read())
        if not rows:
            sys.exit(f"gpu_profile: {path}: no kernel rows (not ncu's --csv --page raw output)")
        parts.append(table(scene, summarize(rows, args.launches), args.launches))
    with open(os.path.join(args.out, "profile.md"), "w") as f:
        f.write("\n".join(parts))
    print(f"gpu_profile: wrote {os.path.join(args.out, 'profile.md')}", file=sys.stderr)


if __name__ == "__main__":
    main()
