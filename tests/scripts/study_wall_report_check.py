"""The study's reports show the wall time of the render calls beside the GPU time where the runs measured both.

Usage: study_wall_report_check.py STUDY_OUT WORK_DIR (STUDY_OUT: study_smoke's output, with its runs; CTest runs
this after study_smoke). On the CPU a render's time is its wall time, so the smoke study's reports have no wall
column. A copy of its runs made to look like GPU runs (backend optix, each technique's wall ms per spp 1.25 times
its ms per spp) is drawn again with --report-only: the thesis's table 4.2, the lab's cost tables and the many-lights
tables then show the wall times, and they are the runs' numbers."""
import glob
import json
import os
import re
import shutil
import subprocess
import sys

PARTS = ("thesis", "lab", "many-lights")
WALL = 1.25


def table_rows(text, header_start):
    """The rows (lists of cells) of the first table whose header line starts with header_start."""
    lines = text.splitlines()
    start = next(i for i, line in enumerate(lines) if line.startswith(header_start))
    rows = []
    for line in lines[start + 2:]:
        if not line.startswith("|"):
            break
        rows.append([c.strip() for c in line.strip("|").split("|")])
    return lines[start], rows


def main():
    smoke, work = sys.argv[1], sys.argv[2]
    if not all(os.path.isfile(os.path.join(smoke, part, "README.md")) for part in PARTS):
        print(f"skipped: no smoke study in {smoke} (study_smoke skipped or failed)")
        sys.exit(77)
    for part in PARTS:
        with open(os.path.join(smoke, part, "README.md")) as f:
            text = f.read()
        if "wall ms/spp" in text or ", wall (ms)" in text or "wall time of the same render calls" in text:
            sys.exit(f"{part}: the CPU study's report shows wall times beside its times, which are wall times")
    shutil.rmtree(work, ignore_errors=True)
    for part in PARTS:
        shutil.copytree(os.path.join(smoke, part, "runs"), os.path.join(work, part, "runs"))
    ms = {}  # (part, run, technique) -> ms per spp
    for path in glob.glob(os.path.join(work, "*", "runs", "*", "summary.json")):
        with open(path) as f:
            s = json.load(f)
        s["backend"] = "optix"
        for name, js in s["strategies"].items():
            js["wall_ms_per_spp"] = WALL * js["ms_per_spp"]
            run_dir = os.path.dirname(path)
            ms[(os.path.basename(os.path.dirname(os.path.dirname(run_dir))), os.path.basename(run_dir), name)] = \
                js["ms_per_spp"]
        with open(path, "w") as f:
            json.dump(s, f)
    script = os.path.join(os.path.dirname(os.path.abspath(__file__)), os.pardir, os.pardir, "scripts", "study.py")
    for part in PARTS:
        rc = subprocess.run([sys.executable, script, "--preset", "smoke", "--part", part, "--out", work,
                             "--report-only", "--allow-dirty", "--force"], stdout=subprocess.DEVNULL).returncode
        if rc:
            sys.exit(rc)  # 77 where the study skips (no matplotlib)

    def near(cell, value):
        return abs(float(cell) - value) <= 0.0005 + 1e-9 * value

    with open(os.path.join(work, "thesis", "README.md")) as f:
        header, rows = table_rows(f.read(), "| scene | area (ms) |")
    assert header.endswith("| area, wall (ms) | solid-angle, wall (ms) |"), header
    assert rows, "thesis: table 4.2 is empty"
    scenes = len(rows)
    for r in rows:
        assert near(r[4], WALL * ms[("thesis", r[0], "area")]), r
        assert near(r[5], WALL * ms[("thesis", r[0], "solid-angle")]), r

    with open(os.path.join(work, "lab", "README.md")) as f:
        lab = f.read()
    cost = lab[lab.index("## Cost: ms per spp"):lab.index("## Per scene")]
    tables = re.findall(r"(\| scene \|.*\n\| ---.*\n(?:\|.*\n)+)", cost)
    assert len(tables) == 2, f"lab: {len(tables)} cost tables, not the GPU time's and the wall time's"
    cols = [c.strip() for c in tables[1].splitlines()[0].strip("|").split("|")][1:]
    for line in tables[1].splitlines()[2:]:
        cells = [c.strip() for c in line.strip("|").split("|")]
        for col, cell in zip(cols, cells[1:]):
            if re.fullmatch(r"[0-9.]+", cell):
                assert near(cell, WALL * ms[("lab", cells[0], col.strip("`"))]), (cells[0], col, cell)

    with open(os.path.join(work, "many-lights", "README.md")) as f:
        header, rows = table_rows(f.read(), "| selection |")
    cols = [c.strip() for c in header.strip("|").split("|")]
    i, j = cols.index("ms/spp (solid-angle)"), cols.index("wall ms/spp (solid-angle)")
    assert rows
    for r in rows:  # both cells rounded to 3 decimals
        assert abs(float(r[j]) - WALL * float(r[i])) <= 0.0005 * (1 + WALL) + 1e-9, r
    print(f"wall times in the reports: thesis ({scenes} scenes), lab, many-lights ({len(rows)} selections)")


if __name__ == "__main__":
    main()
