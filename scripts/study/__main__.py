"""python3 -m study (from scripts/): the same as python3 scripts/study.py."""
from study.cli import entry

entry(prog="python3 -m study")
