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
# The study lives in the package scripts/study/ (study/__init__.py lists its
# modules); this file keeps `python3 scripts/study.py ...` working. Run as a
# script, this folder is first on sys.path, where the package study/ comes
# before this file.
from study.cli import entry

if __name__ == "__main__":
    entry()
