"""A ground truth rendered in chunks apart and merged (what scripts/study.py
--executor ray does on a cluster) is converge()'s own, to the bit; and gpus=."""
import os

import numpy as np
import pytest

import penumbra
from conftest import SMALL

# 3 chunks of 96 spp, the last one short (288 = 96 + 96 + 96, 250: 96 + 96 + 58).
OPTIONS = dict(backend="cpu", width=20, height=14, reference_spp=250, reference_chunk=96, max_spp=8, seeds=2,
               strategies=["area", "solid-angle"], mis=["none", "power"], threads=1)


def test_plan_names_the_cache_key_chunks_and_techniques(tmp_path):
    plan = penumbra.converge_plan("cornell-near", cache=str(tmp_path), **OPTIONS)
    ref = plan["reference"]
    assert (ref["width"], ref["height"], ref["spp"], ref["chunk_spp"], ref["chunks"]) == (20, 14, 250, 96, 3)
    assert ref["path"] == os.path.join(str(tmp_path), f"ref-{ref['key']}.exr") and not ref["cached"]
    assert [t["name"] for t in plan["techniques"]] == ["area", "area+power", "solid-angle", "solid-angle+power"]
    assert plan["techniques"][1] == {"name": "area+power", "strategy": "area", "mis": "power"}
    # The key is the ground truth's: the techniques, spp and chunking of the runs do not change it.
    other = penumbra.converge_plan("cornell-near", cache=str(tmp_path), **dict(OPTIONS, max_spp=2, reference_chunk=7,
                                                                               strategies=["bsdf"]))
    assert other["reference"]["key"] == ref["key"] and other["reference"]["chunks"] == 36
    moved = penumbra.converge_plan("cornell-near", cache=str(tmp_path), overrides={"light.radius": 0.3}, **OPTIONS)
    assert moved["reference"]["key"] != ref["key"]


def test_chunks_merged_in_order_are_converges_ground_truth(tmp_path):
    apart, whole = str(tmp_path / "apart"), str(tmp_path / "whole")
    plan = penumbra.converge_plan("cornell-near", cache=apart, **OPTIONS)["reference"]
    chunks = [penumbra.render_reference_chunk("cornell-near", k, cache=apart, **OPTIONS) for k in (2, 0, 1)]
    chunks = [chunks[1], chunks[2], chunks[0]]  # rendered in any order, added in chunk order
    assert [c.samples for c in chunks] == [96, 96, 58] and [c.nonfinite for c in chunks] == [0, 0, 0]
    assert chunks[0].sum.shape == (14, 20, 3) and chunks[0].sum.dtype == np.float64
    s, s2 = np.zeros((14, 20, 3)), np.zeros((14, 20, 3))
    for c in chunks:
        s += c.sum
        s2 += c.sum_sq
    assert penumbra.store_reference("cornell-near", s, s2, cache=apart, **OPTIONS) == plan["path"]
    assert penumbra.converge_plan("cornell-near", cache=apart, **OPTIONS)["reference"]["cached"]

    fresh = penumbra.converge("cornell-near", cache=whole, **OPTIONS)  # renders its own ground truth
    assert not fresh.summary["reference"]["cached"]
    for name in (f"ref-{plan['key']}.exr", f"ref-{plan['key']}_var.exr"):
        with open(os.path.join(apart, name), "rb") as a, open(os.path.join(whole, name), "rb") as b:
            assert a.read() == b.read(), name
    found = penumbra.converge("cornell-near", cache=apart, **OPTIONS)
    assert found.summary["reference"]["cached"]
    key = ("strategy", "spp", "seed", "rmse", "rmse_nolight", "relmse", "relmse_nolight")
    assert [tuple(m[k] for k in key) for m in found.measurements] == \
        [tuple(m[k] for k in key) for m in fresh.measurements]

    # Sums of another size, or a chunk that does not exist, are refused.
    with pytest.raises(ValueError, match="20x14"):
        penumbra.store_reference("cornell-near", s[:5], s2[:5], cache=apart, **OPTIONS)
    with pytest.raises(ValueError, match="chunk 3"):
        penumbra.render_reference_chunk("cornell-near", 3, cache=apart, **OPTIONS)
    with pytest.raises(TypeError, match="colour"):
        penumbra.converge_plan("cornell-near", colour="red")


def test_gpus_is_checked_and_the_cpu_ignores_it():
    a = penumbra.render("cornell-sphere", spp=2, backend="cpu", gpus=3, **SMALL)
    b = penumbra.render("cornell-sphere", spp=2, backend="cpu", gpus=[0, 1], **SMALL)
    c = penumbra.render("cornell-sphere", spp=2, backend="cpu", gpus=[0], **SMALL)  # GPU 0, not "0 GPUs"
    assert np.array_equal(a.rgb, b.rgb) and np.array_equal(a.rgb, c.rgb)
    for bad in ("x", 0, "1,1", [], "-1"):
        with pytest.raises(ValueError, match="gpus"):
            penumbra.render("cornell-sphere", spp=1, backend="cpu", gpus=bad, **SMALL)
    for bad in (True, 1.5, ["0"]):
        with pytest.raises(TypeError):
            penumbra.render("cornell-sphere", spp=1, backend="cpu", gpus=bad, **SMALL)
    with pytest.raises(ValueError, match="gpus"):
        penumbra.converge("cornell-sphere", backend="cpu", gpus="zero", width=8, height=8, max_spp=1,
                          reference_spp=1, seeds=1)
