"""Strategies estimate the same image: penumbra compare's z-test from Python."""
import numpy as np
import pytest

import penumbra

SIZE = dict(width=32, height=18)


def render(strategy, seed, spp=256, **kw):
    return penumbra.render("cornell-near", strategy=strategy, spp=spp, seed=seed, backend="cpu", **SIZE, **kw)


@pytest.fixture(scope="module")
def solid_angle():
    return render("solid-angle", seed=1)


@pytest.mark.parametrize("strategy,seed", [("area", 2), ("solid-angle", 4)])
def test_strategies_agree(solid_angle, strategy, seed):
    r = penumbra.compare(render(strategy, seed), solid_angle)
    assert r["pass"], r["summary"]
    assert 0.8 < r["mean_z2"] < 1.25, r["summary"]


def test_bsdf_sampling_agrees_at_image_level():
    # As tests/backends/test_render.cpp: BSDF sampling alone finds the light too rarely
    # for per-pixel variance estimates to hold; the image means must agree.
    def sphere(strategy, spp, seed):
        return penumbra.render("cornell-sphere", strategy=strategy, spp=spp, seed=seed, backend="cpu", width=24,
                               height=24)
    r = penumbra.compare(sphere("bsdf", 1024, 3), sphere("solid-angle", 64, 1), max_mean_rel_diff=0.05,
                         max_outlier_fraction=0.01)
    assert abs(r["image_z"]) < 4.0, r["summary"]


def test_the_z_test_sees_a_different_image(solid_angle):
    # The negative control: a light 30% brighter must fail.
    brighter = render("area", seed=2, overrides={"light.power": [78.9 * 1.3, 66.9 * 1.3, 34.3 * 1.3]})
    r = penumbra.compare(brighter, solid_angle)
    assert not r["statistical_pass"], r["report"]  # the z-test itself, not only the bound on the means
    assert not r["pass"], r["report"]


def test_compare_is_the_z_test_it_describes(solid_angle):
    area = render("area", seed=5)
    r = penumbra.compare(area, solid_angle)
    a, va, b, vb = area.rgb, area.variance, solid_angle.rgb, solid_angle.variance
    v = va.astype(np.float64) + vb
    z = (a.astype(np.float64) - b)[v > 0] / np.sqrt(v[v > 0])
    assert r["mean_z2"] == pytest.approx(np.mean(z * z), rel=1e-4)
    assert r["max_abs_z"] == pytest.approx(np.abs(z).max(), rel=1e-4)
    # The bound on the means is a test of its own, as given: never widened by their noise.
    ma, mb = a.astype(np.float64).mean(), b.astype(np.float64).mean()
    # Its standard error bounds a pixel's channels as fully correlated: (sd_r + sd_g + sd_b)^2 a pixel.
    sd_a = np.sqrt(va.astype(np.float64)).reshape(-1, 3).sum(axis=1)
    sd_b = np.sqrt(vb.astype(np.float64)).reshape(-1, 3).sum(axis=1)
    se = np.sqrt((sd_a**2).sum() + (sd_b**2).sum()) / a.size / abs(mb)
    assert r["mean_rel_diff"] == pytest.approx(abs(ma - mb) / abs(mb), rel=1e-4)
    assert r["mean_rel_se"] == pytest.approx(se, rel=1e-4)
    assert r["bound_pass"] == (r["mean_rel_diff"] <= 0.01)
    assert r["statistical_pass"] == (abs(r["image_z"]) < 4 and r["outliers"] <= 0.002 * r["channels"]
                                     and r["zero_var_mismatches"] == 0)
    assert r["pass"] == (r["statistical_pass"] and r["bound_pass"])
    tight = penumbra.compare(area, solid_angle, max_mean_rel_diff=r["mean_rel_diff"] / 2)
    assert not tight["bound_pass"] and not tight["pass"], tight["report"]
    assert tight["statistical_pass"] == r["statistical_pass"]
    assert tight["report"].split("\n")[2].startswith("bound on the means"), tight["report"]
    # Arrays work as well as images.
    assert penumbra.compare((a, va), (b, vb))["mean_z2"] == pytest.approx(r["mean_z2"])
