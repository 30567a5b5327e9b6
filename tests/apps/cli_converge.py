#!/usr/bin/env python3
"""`penumbra converge`, what it says about its results (issue 32):

  - a time to the RMSE threshold is read off the fitted line, never measured: summary.json's fit_rmse and
    fit_rmse_nolight say whether it is extrapolated beyond the spp the line was fitted to ("extrapolated",
    "fit_spp"), and the text line of each technique says the same;
  - a --max-spp below --crop-spp (or a --crop-spp that is not one of the spp levels) writes no crops: one
    warning line on stderr says so; with a --crop-spp among the levels, there is none and the crops are written;
  - the ground truth's cache key leaves out what the reference does not render with: a run with another light
    selection and slc cut finds the reference of the runs before it.

Tiny runs on the CPU (16x16 pixels, a 64-spp ground truth). Python standard library only.
"""
import argparse
import json
import math
import os
import shutil
import subprocess
import sys


def fail(msg):
    print("FAIL: " + msg, file=sys.stderr)
    sys.exit(1)


def converge(args, out, *extra):
    cmd = [args.penumbra, "converge", "cornell-sphere", "--backend", "cpu", "--width", "16", "--height", "16",
           "--reference-spp", "64", "--reference-chunk", "64", "--max-spp", "8", "--seeds", "1", "--fit-min-spp", "2",
           "--cache", os.path.join(args.work, "cache"), "--out", os.path.join(args.work, out), *extra]
    p = subprocess.run(cmd, capture_output=True, text=True, timeout=300)
    if p.returncode != 0:
        fail(f"exit status {p.returncode}: {' '.join(cmd)}\n{p.stderr}")
    with open(os.path.join(args.work, out, "summary.json")) as f:
        return json.load(f), p.stderr


def technique_lines(summary, err):
    """The text line of each technique (its name first)."""
    lines = {}
    for name in summary["strategies"]:
        mine = [l for l in err.splitlines() if l.split(" ")[0] == name and " slope " in l]
        if len(mine) != 1:
            fail(f"expected one line for {name}:\n{err}")
        lines[name] = mine[0]
    return lines


def check_labels(summary, err):
    """Every fit's label agrees with its numbers, and the text with the JSON."""
    labels = []
    lines = technique_lines(summary, err)
    for name, s in summary["strategies"].items():
        for key in ("fit_rmse", "fit_rmse_nolight"):
            fit = s[key]
            lo, hi = fit["fit_spp"]
            if (lo, hi) != (2, 8):
                fail(f"{name} {key}: fitted to {lo}..{hi} spp, not 2..8 (--fit-min-spp 2, --max-spp 8)")
            n = fit["spp_to_threshold"]
            outside = n is None or not (lo <= n <= hi)  # None: infinite (the line never reaches it)
            if fit["extrapolated"] != outside:
                fail(f"{name} {key}: spp_to_threshold {n} with fit_spp {lo}..{hi}, but extrapolated is "
                     f"{fit['extrapolated']}")
        word = "extrapolated beyond the 2..8 spp fitted" if s["fit_rmse"]["extrapolated"] else \
            "interpolated within the 2..8 spp fitted"
        if word not in lines[name] or " reached " in lines[name]:
            fail(f"{name}: the text does not say '{word}' (fit_rmse.extrapolated is "
                 f"{s['fit_rmse']['extrapolated']}): {lines[name]}")
        labels.append(s["fit_rmse"]["extrapolated"])
    return labels


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--penumbra", required=True)
    ap.add_argument("--work", required=True)
    args = ap.parse_args()
    shutil.rmtree(args.work, ignore_errors=True)
    os.makedirs(args.work)

    # A threshold far below what 8 spp reach: extrapolated, for every technique. And --max-spp 8 below the
    # default --crop-spp 32: one warning, no crops.
    summary, err = converge(args, "far", "--threshold", "0.0001")
    if check_labels(summary, err) != [True] * len(summary["strategies"]):
        fail(f"a threshold of 0.0001 was not extrapolated:\n{err}")
    warnings = [l for l in err.splitlines() if l.startswith("warning:")]
    if warnings != ["warning: --max-spp 8 is below --crop-spp 32: no crops are written (crop_*.npy, "
                    "image_*spp.png)"]:
        fail(f"expected one warning about --crop-spp:\n{err}")
    if any(f.startswith("crop_area") or f.startswith("image_") for f in os.listdir(os.path.join(args.work, "far"))):
        fail("crops were written, though the warning says none are")

    # The threshold the area line reaches at 4 spp: interpolated, about 4 spp. The same renders (seeded) and
    # ground truth (cached): the same line.
    area = summary["strategies"]["area"]["fit_rmse"]
    threshold = math.exp(area["intercept"] + area["slope"] * math.log(4))
    summary, err = converge(args, "near", "--threshold", repr(threshold), "--crop-spp", "4")
    check_labels(summary, err)
    area = summary["strategies"]["area"]["fit_rmse"]
    if area["extrapolated"] or not 3.99 < area["spp_to_threshold"] < 4.01:
        fail(f"area at its own 4-spp RMSE {threshold}: {area}")
    # --crop-spp 4 is one of the levels: no warning, and the crops are there.
    if "warning:" in err or not os.path.exists(os.path.join(args.work, "near", "crop_area.npy")):
        fail(f"--crop-spp 4 with --max-spp 8: a warning, or no crop:\n{err}")

    # A --crop-spp between the levels writes no crops either: said so.
    _, err = converge(args, "between", "--crop-spp", "3")
    if [l for l in err.splitlines() if l.startswith("warning:")] != [
            "warning: --crop-spp 3 is not one of the spp levels (1, 2, 4, ..., 8): no crops are written "
            "(crop_*.npy, image_*spp.png)"]:
        fail(f"--crop-spp 3: expected one warning:\n{err}")
    # slc with a cut of 3: the reference still selects by power, so it is the one already cached.
    summary, _ = converge(args, "slc", "--set", 'render.light_selection="slc"', "--set", "render.slc_cut=3")
    if not summary["reference"]["cached"]:
        fail("a run with render.slc_cut=3 rendered its power-selected reference again instead of the cached one")
    print("cli_converge: PASS")


if __name__ == "__main__":
    main()
