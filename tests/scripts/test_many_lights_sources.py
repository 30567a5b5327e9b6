"""The many-lights report's line naming the binaries and devices behind its runs (scripts/study/many_lights.py),
on run summaries and bench files written here. CTest runs this file (many_lights_sources)."""
import os
import sys

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), os.pardir, os.pardir, "scripts"))
from study import many_lights  # noqa: E402


def run(commit, gpu=None, device="2 CPU threads (Embree 3.13.5)"):
    """The fields of a converge summary (or bench json) that name what made it."""
    return dict(git_commit=commit, device=device, device_info={"gpu": gpu} if gpu else {})


def test_one_binary_on_one_device_says_nothing():
    head = {"many-spheres": {"power": run("aaa", "H200"), "bvh": run("aaa", "H200")}}
    sweep = {"power": [run("aaa", "H200"), run("aaa", "H200")]}
    bench = [dict(lights=10, bench=run("aaa", "H200"))]
    assert many_lights.sources_line(head, sweep, bench) is None


def test_one_binary_on_two_devices_names_each_and_says_the_ratios_are_alike():
    head = {"many-spheres": {"power": run("aaa", "H200"), "bvh": run("aaa", "H200")},
            "many-spheres-glossy": {"power": run("aaa", "H100"), "bvh": run("aaa", "H100")}}
    bench = [dict(lights=10, bench=run("aaa", "H200")), dict(lights=100000, bench=run("aaa", "H100"))]
    line = many_lights.sources_line(head, {}, bench)
    assert line.startswith("**The runs come from 1 binary on 2 devices**")
    assert "every ratio compares like with like" in line
    assert ("`aaa` on H200: many-spheres (power, bvh), `penumbra bench` at 10 lights; "
            "`aaa` on H100: many-spheres-glossy (power, bvh), `penumbra bench` at 100000 lights.") in line


def test_a_scene_of_two_binaries_is_not_called_alike():
    head = {"sponza-lanterns": {"power": run("aaa"), "bvh": run("bbb")}}
    line = many_lights.sources_line(head, {}, [])
    assert line.startswith("**The runs come from 2 binaries on 1 device**")
    assert "compare runs of different binaries or devices" in line
    assert "`aaa` on 2 CPU threads (Embree 3.13.5): sponza-lanterns (power)" in line


def test_a_sweep_across_devices_is_not_called_alike():
    head = {"many-spheres": {"power": run("aaa", "H200")}}
    sweep = {"power": [run("aaa", "H200"), run("aaa", "H100")]}
    line = many_lights.sources_line(head, sweep, [])
    assert "compare runs of different binaries or devices" in line
    assert "`aaa` on H100: the lights-count sweep (power)" in line


def summary(width, height, reference_spp, spps):
    """A converge summary's fields that say at which settings it ran."""
    return dict(width=width, height=height, reference=dict(spp=reference_spp),
                strategies={"solid-angle+power": dict(points=[dict(spp=n) for n in spps]),
                            "area+power": dict(points=[dict(spp=n) for n in spps[:-1]])})


def test_a_run_at_another_presets_settings_is_told_apart():
    gpu = dict(width=1920, height=1080, reference_spp=16384, max_spp=128, seeds=2)
    same = summary(1920, 1080, 16384, [1, 2, 4, 128])
    assert many_lights.run_settings(same) == many_lights.preset_settings(gpu)
    cpu = summary(96, 54, 2048, [1, 2, 64])
    assert many_lights.run_settings(cpu) == dict(width=96, height=54, reference_spp=2048, max_spp=64)
    assert many_lights.run_settings(cpu) != many_lights.preset_settings(gpu)
    fewer = summary(1920, 1080, 16384, [1, 2, 64])  # a run stopped short of the preset's largest spp
    assert many_lights.run_settings(fewer) != many_lights.preset_settings(gpu)
