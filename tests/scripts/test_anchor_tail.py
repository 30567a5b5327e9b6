"""scripts/anchors/mitsuba_anchor.py's t tail, which sets how many tiles may lie beyond 4 standard errors: against
closed forms (one and two degrees of freedom) and the normal limit."""
import math
import os
import sys

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..", "scripts", "anchors"))
from mitsuba_anchor import t_tail  # noqa: E402


def test_one_degree_of_freedom_is_cauchy():
    assert abs(t_tail(4.0, 1) - (1 - 2 / math.pi * math.atan(4.0))) < 1e-6


def test_two_degrees_of_freedom():
    # P(|T| > t) = 1 - t / sqrt(2 + t^2) for nu = 2
    assert abs(t_tail(4.0, 2) - (1 - 4.0 / math.sqrt(18.0))) < 1e-6


def test_many_degrees_of_freedom_approach_the_normal():
    assert abs(t_tail(4.0, 100000) - math.erfc(4.0 / math.sqrt(2))) < 2e-6


def test_three_seeds_allow_more_tiles_than_eight():
    assert 0.015 < t_tail(4.0, 4) < 0.017  # 3 seeds a renderer: nu = 4
    assert t_tail(4.0, 14) < 0.0014        # 8 seeds: nu = 14
