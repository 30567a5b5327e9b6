#!/usr/bin/env python3
"""The study (`python3 scripts/study.py --help`): the thesis's chapter 4, the light-sampling lab, many lights and
denoising, each a `penumbra converge` plan and a report. The code is the package scripts/study/ (study/cli.py's
docstring has the usual commands)."""
# The study lives in the package scripts/study/ (study/__init__.py lists its
# modules); this file keeps `python3 scripts/study.py ...` working. Run as a
# script, this folder is first on sys.path, where the package study/ comes
# before this file.
from study.cli import entry

if __name__ == "__main__":
    entry()
