"""converge's ground truth may select lights by another unbiased method than power (reference_selection): the light
BVH's reference has less noise for the same time, which matters when the methods compared are far better than power.
It is a different reference (its own cache key), the same expected image, and restir is refused."""
import math

import pytest

import penumbra

OPTIONS = dict(backend="cpu", width=24, height=16, reference_spp=192, reference_chunk=64, max_spp=2, seeds=1,
               strategies=["solid-angle"], mis=["power"], threads=2,
               overrides={"defaults.lights": 200, "camera.eye": [0, 0.18, -3], "camera.target": [0, 0, -2.505],
                          "camera.fov": 30})


def test_the_key_names_the_selection_and_power_is_the_default(tmp_path):
    plan = lambda **kw: penumbra.converge_plan("many-spheres", cache=str(tmp_path), **dict(OPTIONS, **kw))["reference"]
    assert plan()["key"] == plan(reference_selection="power")["key"]  # caches made before the option stay valid
    assert plan(reference_selection="bvh")["key"] != plan()["key"]
    assert plan(reference_selection="uniform")["key"] not in (plan()["key"], plan(reference_selection="bvh")["key"])
    with pytest.raises(ValueError, match="--reference-selection must be uniform, power or bvh"):
        plan(reference_selection="restir")
    with pytest.raises(ValueError, match="--reference-selection"):
        plan(reference_selection="nearest")


def test_power_and_bvh_references_have_the_same_mean(tmp_path):
    """Both are unbiased: their image means (over all pixels and channels) differ by noise alone. The variance of
    each mean is at most rmse_floor^2 / pixels (rmse_floor: the root of the mean per-value variance of the reference;
    a pixel's three channels are at most fully correlated)."""
    summaries = {sel: penumbra.converge("many-spheres", cache=str(tmp_path), reference_selection=sel,
                                        **OPTIONS).summary["reference"] for sel in ("power", "bvh")}
    assert summaries["bvh"]["light_selection"] == "bvh" and summaries["power"]["light_selection"] == "power"
    values = OPTIONS["width"] * OPTIONS["height"]  # a pixel's channels are correlated: count pixels (conservative)
    p, b = summaries["power"], summaries["bvh"]
    assert p["mean"] > 0 and b["rmse_floor"] > 0
    z = (p["mean"] - b["mean"]) / math.sqrt((p["rmse_floor"] ** 2 + b["rmse_floor"] ** 2) / values)
    assert abs(z) < 4, (p["mean"], b["mean"], z)
    # What the option is for: the light BVH's reference is the less noisy one at the same spp.
    assert b["rmse_floor"] < p["rmse_floor"]
