"""scripts/anchors/mitsuba_anchor.py's tile statistics: the t tail, which sets how many tiles may lie beyond 4
standard errors, against closed forms (one and two degrees of freedom) and the normal limit; tiles without noise
counted apart."""
import math
import os
import sys

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..", "scripts", "anchors"))
import numpy as np  # noqa: E402
from mitsuba_anchor import t_tail, tile_stats  # noqa: E402


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


def test_noise_free_tiles_are_counted_apart():
    # Three seeds of 16x16 images (four 8x8 tiles): three tiles with noise, one where every seed gives the same
    # value to float32's rounding (a lamp seen in every sample) and the two renderers differ in its last bits.
    rng = np.random.default_rng(7)
    pn = rng.normal(1.0, 0.1, (3, 16, 16, 3))
    mi = rng.normal(1.0, 0.1, (3, 16, 16, 3))
    pn[:, :8, :8, :] = 10.0
    mi[:, :8, :8, :] = 10.0 * (1 + 3e-8)
    mi[1, 0, 0, 0] = 10.0 * (1 + 6e-8)  # one rounding step in one seed: a variance of about 1e-17
    stats = tile_stats(pn, mi)
    assert stats["noise_free"] == 1
    assert 2e-8 < stats["noise_free_rel_diff"] < 5e-8
    assert stats["mean_z2"] < 20  # three noisy tiles: no z of millions from the quiet one


def test_a_noise_free_tile_that_differs_is_reported():
    pn = np.full((3, 8, 8, 3), 10.0)
    mi = np.full((3, 8, 8, 3), 10.05)
    stats = tile_stats(pn, mi)
    assert stats["noise_free"] == 1 and abs(stats["noise_free_rel_diff"] - 0.05 / 10.05) < 1e-9
