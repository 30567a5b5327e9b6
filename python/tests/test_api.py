"""The Python API: what it returns, and that it is the renderer's own image."""
import json

import numpy as np
import pytest

import penumbra
from conftest import SMALL


def test_scenes_lists_the_builtin_scenes():
    names = penumbra.scenes()
    assert {"cornell-sphere", "cornell-near", "occlusion"} <= set(names)
    assert all(isinstance(n, str) for n in names)


def test_render_returns_float32_arrays_of_the_image_size():
    img = penumbra.render("cornell-sphere", spp=4, backend="cpu", **SMALL)
    assert isinstance(img, penumbra.Image)
    for a in (img.rgb, img.variance):
        assert isinstance(a, np.ndarray)
        assert a.shape == (27, 48, 3)
        assert a.dtype == np.float32
        assert a.flags.c_contiguous
        assert not a.flags.writeable  # a view of the image's own buffer
    assert (img.width, img.height, img.spp) == (48, 27, 4)
    assert np.isfinite(img.rgb).all() and (img.rgb >= 0).all()
    assert img.rgb.mean() > 0.01  # the box is lit
    assert (img.variance >= 0).all() and img.variance.max() > 0


def test_arrays_are_views_without_copies():
    img = penumbra.render("cornell-sphere", spp=2, backend="cpu", **SMALL)
    a, b = img.rgb, img.rgb
    assert a.__array_interface__["data"][0] == b.__array_interface__["data"][0]
    assert np.shares_memory(a, b)


def test_stats_describe_the_render():
    img = penumbra.render("cornell-near", strategy="area", spp=3, seed=5, max_depth=2, backend="cpu", **SMALL)
    s = img.stats
    assert s["backend"] == "cpu" and "Embree" in s["device"]
    assert s["scene"] == "builtin:cornell-near"
    assert (s["strategy"], s["spp"], s["seed"], s["max_depth"]) == ("area", 3, 5, 2)
    assert (s["width"], s["height"]) == (48, 27)
    assert s["render_seconds"] > 0 and s["samples_per_second"] > 0
    assert s["note"].startswith("backend: cpu")


def test_defaults_are_the_scenes_own():
    scene = penumbra.load_scene("cornell-sphere", {"render.spp": 2, "render.width": 40, "render.height": 20,
                                                   "render.strategy": "area"})
    img = penumbra.render(scene, backend="cpu")
    assert (img.width, img.height, img.spp, img.stats["strategy"]) == (40, 20, 2, "area")


def test_scene_to_dict_round_trips_through_a_file(tmp_path):
    scene = penumbra.load_scene("cornell-near", {"light.radius": 0.07, "camera.fov": 35})
    d = scene.to_dict()
    assert d["lights"][0]["radius"] == 0.07 and d["camera"]["fov"] == 35
    path = tmp_path / "near.json"
    path.write_text(json.dumps(d))
    from_file = penumbra.load_scene(path)
    from_dict = penumbra.load_scene(d)
    assert from_file.to_dict() == d == from_dict.to_dict()
    assert from_file.source == str(path) and from_dict.source == "<dict>"
    a = penumbra.render(from_file, spp=2, backend="cpu", **SMALL)
    b = penumbra.render(from_dict, spp=2, backend="cpu", **SMALL)
    c = penumbra.render(scene, spp=2, backend="cpu", **SMALL)
    assert np.array_equal(a.rgb, b.rgb) and np.array_equal(a.rgb, c.rgb)


def test_overrides_change_the_image():
    small = penumbra.render("cornell-sphere", spp=8, backend="cpu", overrides={"light.power": 10}, **SMALL)
    large = penumbra.render("cornell-sphere", spp=8, backend="cpu", overrides={"light.power": 20}, **SMALL)
    # Twice the power, twice the radiance: the same paths (same seed), scaled.
    np.testing.assert_allclose(large.rgb, 2 * small.rgb, rtol=1e-5, atol=1e-7)


def test_seed_makes_the_image_a_pure_function():
    a = penumbra.render("cornell-sphere", spp=2, seed=11, backend="cpu", **SMALL)
    b = penumbra.render("cornell-sphere", spp=2, seed=11, backend="cpu", threads=1, **SMALL)
    c = penumbra.render("cornell-sphere", spp=2, seed=12, backend="cpu", **SMALL)
    assert np.array_equal(a.rgb, b.rgb)
    assert not np.array_equal(a.rgb, c.rgb)


def test_progressive_renderer_adds_samples():
    r = penumbra.Renderer("cornell-sphere", backend="cpu", seed=4, **SMALL)
    assert r.spp == 0 and r.backend == "cpu" and r.builds == 1
    first = r.render(2)
    assert first.spp == 2 and r.spp == 2
    second = r.render(3)
    assert second.spp == 5 and r.spp == 5
    # The snapshot taken before is unchanged by the samples added since.
    assert first.spp == 2
    # Samples are identified by their index: 2 + 3 samples are the paths of one
    # 5-sample render (the sums differ only by the order of additions).
    once = penumbra.render("cornell-sphere", spp=5, seed=4, backend="cpu", **SMALL)
    np.testing.assert_allclose(second.rgb, once.rgb, rtol=1e-5, atol=1e-7)
    np.testing.assert_allclose(second.variance, once.variance, rtol=1e-3, atol=1e-9)
    # The first call alone is exactly the one-shot render of its samples.
    two = penumbra.render("cornell-sphere", spp=2, seed=4, backend="cpu", **SMALL)
    assert np.array_equal(first.rgb, two.rgb)
    r.reset()
    assert r.spp == 0 and r.image().spp == 0
    assert np.array_equal(r.render(2).rgb, two.rgb)


def test_frame_changes_keep_the_backend_and_scene_changes_rebuild_it():
    r = penumbra.Renderer("cornell-near", backend="cpu", strategy="area", **SMALL)
    a = r.render(4)
    r.set(strategy="solid-angle", seed=9, max_depth=3)
    assert r.builds == 1 and r.spp == 0
    assert r.settings["strategy"] == "solid-angle" and r.settings["max_depth"] == 3 and r.settings["seed"] == 9
    b = r.render(4)
    assert b.stats["strategy"] == "solid-angle" and b.stats["max_depth"] == 3
    expected = penumbra.render("cornell-near", strategy="solid-angle", seed=9, max_depth=3, spp=4, backend="cpu",
                               **SMALL)
    assert np.array_equal(b.rgb, expected.rgb)
    r.set(width=32, height=18, overrides={"camera.fov": 30})
    assert r.builds == 1 and r.render(1).rgb.shape == (18, 32, 3)
    # The light is in the acceleration structure: a rebuild, and a brighter image.
    r.set(width=48, height=27, overrides={"light.power": 400})
    assert r.builds == 2
    c = r.render(4)
    assert c.rgb.mean() > 1.5 * b.rgb.mean()
    assert r.scene.to_dict()["lights"][0]["power"] == 400
    assert a.stats["strategy"] == "area"


def test_bad_change_leaves_the_renderer_as_it_was():
    r = penumbra.Renderer("cornell-sphere", backend="cpu", **SMALL)
    r.render(1)
    with pytest.raises(penumbra.SceneError) as e:
        r.set(overrides={"light.radius": -1})
    assert e.value.field == "lights[0].radius"
    assert r.spp == 1 and r.builds == 1
    assert r.render(1).spp == 2


def test_image_save_writes_what_the_cli_writes(tmp_path):
    img = penumbra.render("cornell-sphere", spp=2, backend="cpu", **SMALL)
    img.save(tmp_path / "a.exr", variance_path=str(tmp_path / "a_var.exr"))
    img.save(str(tmp_path / "a.png"))
    assert np.array_equal(penumbra.read_exr(tmp_path / "a.exr"), img.rgb)
    assert np.array_equal(penumbra.read_exr(tmp_path / "a_var.exr"), img.variance)
    assert (tmp_path / "a.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    with pytest.raises(OSError):
        img.save(str(tmp_path / "no-such-dir" / "a.exr"))


def test_dlpack_on_the_cpu_is_the_host_array():
    img = penumbra.render("cornell-sphere", spp=2, backend="cpu", **SMALL)
    assert img.__dlpack_device__() == (1, 0)  # kDLCPU
    a = np.from_dlpack(img.rgb_dlpack())
    assert a.shape == (27, 48, 3) and a.dtype == np.float32
    assert np.array_equal(a, img.rgb) and np.shares_memory(a, img.rgb)
    assert np.array_equal(np.from_dlpack(img), img.rgb)
    assert np.array_equal(np.from_dlpack(img.variance_dlpack()), img.variance)


def test_the_optix_denoiser_needs_the_gpu_backend_and_says_so_before_rendering():
    calls = []
    with pytest.raises(penumbra.BackendError, match="the OptiX AI denoiser needs the GPU backend"):
        penumbra.render("cornell-sphere", spp=4, denoise=True, denoiser="optix", backend="cpu",
                        progress=lambda done, total: calls.append(done), **SMALL)
    assert calls == []  # refused before any sample was traced
    r = penumbra.Renderer("cornell-sphere", backend="cpu", **SMALL)
    img = r.render(2)
    assert img.denoised is None and img.albedo is None and img.normal is None
    with pytest.raises(penumbra.BackendError, match="the OptiX AI denoiser needs the GPU backend"):
        r.image(denoise=True, denoiser="optix")
    with pytest.raises(ValueError, match="denoiser must be one of oidn, optix"):
        r.image(denoise=True, denoiser="nlm")
    with pytest.raises(ValueError, match="denoise_quality must be one of"):
        penumbra.render("cornell-sphere", spp=1, denoise=True, denoise_quality="best", backend="cpu", **SMALL)
    if penumbra.build_info()["gpu_available"]:
        return
    # auto falls back to the CPU here: the same error, naming why
    calls.clear()
    with pytest.raises(penumbra.BackendError, match="rendered on the cpu backend"):
        penumbra.render("cornell-sphere", spp=4, denoise=True, denoiser="optix", backend="auto",
                        progress=lambda done, total: calls.append(done), **SMALL)
    assert calls == []


def test_mis_is_passed_to_the_scene_as_render_mis():
    # render.mis is a scene value ("none", "balance", "power"): the thesis's
    # scenes say none, others default to power; a bad name is a SceneError.
    img = penumbra.render("cornell-sphere", spp=1, mis="balance", backend="cpu", **SMALL)
    assert img.stats["mis"] == "balance"
    assert penumbra.render("cornell-sphere", spp=1, backend="cpu", **SMALL).stats["mis"] == "none"
    assert penumbra.render("cornell-quad", spp=1, backend="cpu", **SMALL).stats["mis"] == "power"
    with pytest.raises(penumbra.SceneError) as e:
        penumbra.render("cornell-sphere", spp=1, mis="sometimes", backend="cpu", **SMALL)
    assert e.value.field == "render.mis" and "power" in str(e.value)


def test_light_selection_and_the_lobe_aware_techniques():
    # light_selection is render.light_selection; ltc and sg-bvh render a glossy polygon scene and a many-light one,
    # and each image's mean is the default technique's within a few standard errors (both unbiased).
    stats = penumbra.render("many-spheres", spp=1, light_selection="sg-bvh", backend="cpu", **SMALL).stats
    assert stats["light_selection"] == "sg-bvh"
    for options in ({"strategy": "ltc", "mis": "power"}, {"light_selection": "sg-bvh"}):
        a = penumbra.render("polygon-near", spp=64, backend="cpu", seed=1, **SMALL, **options)
        b = penumbra.render("polygon-near", spp=64, backend="cpu", seed=2, **SMALL)
        r = penumbra.compare(a, b)
        assert abs(r["image_z"]) < 4, (options, r["summary"])
    with pytest.raises(penumbra.SceneError) as e:
        penumbra.render("cornell-sphere", spp=1, light_selection="nearest", backend="cpu", **SMALL)
    assert e.value.field == "render.light_selection" and "sg-bvh" in str(e.value)


def test_stochastic_lightcuts():
    # slc_cut is render.slc_cut: a cut of one node renders the light BVH's very image; a larger one an image with the
    # same mean; a cut out of 1..64 is an error naming the field.
    one = penumbra.render("many-spheres", spp=2, light_selection="slc", slc_cut=1, backend="cpu", **SMALL)
    bvh = penumbra.render("many-spheres", spp=2, light_selection="bvh", backend="cpu", **SMALL)
    assert one.stats["slc_cut"] == 1 and one.stats["light_selection"] == "slc"
    assert np.array_equal(one.rgb, bvh.rgb)
    a = penumbra.render("many-spheres", spp=32, light_selection="slc", slc_cut=16, backend="cpu", seed=1, **SMALL)
    b = penumbra.render("many-spheres", spp=32, light_selection="bvh", backend="cpu", seed=2, **SMALL)
    r = penumbra.compare(a, b)
    assert abs(r["image_z"]) < 4, r["summary"]
    r = penumbra.Renderer("many-spheres", backend="cpu", light_selection="slc", **SMALL)
    r.set(slc_cut=4)
    assert r.settings["slc_cut"] == 4
    with pytest.raises(penumbra.SceneError) as e:
        penumbra.render("many-spheres", spp=1, light_selection="slc", slc_cut=65, backend="cpu", **SMALL)
    assert e.value.field == "render.slc_cut"


def test_build_info():
    info = penumbra.build_info()
    assert isinstance(info["optix"], bool) and isinstance(info["gpu_available"], bool)
    assert info["strategies"][:2] == ["area", "solid-angle"]
    if not info["gpu_available"]:
        assert info["gpu_unavailable_reason"]


def test_gpu_tuning_reaches_the_library_and_leaves_the_cpu_image_alone():
    keys = penumbra.gpu_tuning_keys()
    assert [k["key"] for k in keys][:2] == ["cuda_occ", "cuda_block"]
    assert {"key", "values", "default", "help"} <= set(keys[0]) and keys[0]["default"] == "10"
    plain = penumbra.render("cornell-sphere", spp=2, backend="cpu", **SMALL)
    for tuning in ({"cuda_occ": 0, "cuda_block": 64, "wavefront_fuse": False}, "shadow_order=queue,cuda_leaf=4",
                   ["ray_order=cells"]):
        tuned = penumbra.render("cornell-sphere", spp=2, backend="cpu", gpu_tuning=tuning, **SMALL)
        assert np.array_equal(tuned.rgb, plain.rgb)  # the cpu backend ignores the GPU's knobs
    r = penumbra.Renderer("cornell-sphere", backend="cpu", gpu_tuning={"wavefront_paths": 4096}, **SMALL)
    assert np.array_equal(r.render(2).rgb, plain.rgb)


@pytest.mark.parametrize("tuning,words", [
    ({"cuda_occ": 11}, ["cuda_occ", "0, 10 or 12", "'11'"]),
    ({"shadow_reverse": "yes"}, ["shadow_reverse", "true, false, 1 or 0"]),
    ("cuda_ooc=0", ["unknown key 'cuda_ooc'", "cuda_occ"]),
    (["cuda_block=64"], ["cuda_block=64 needs cuda_occ=0"]),
])
def test_bad_gpu_tuning_is_a_value_error_naming_the_key(tuning, words):
    for call in (lambda: penumbra.render("cornell-sphere", spp=1, backend="cpu", gpu_tuning=tuning, **SMALL),
                 lambda: penumbra.Renderer("cornell-sphere", backend="cpu", gpu_tuning=tuning, **SMALL),
                 lambda: penumbra.converge_plan("cornell-sphere", backend="cpu", gpu_tuning=tuning)):
        with pytest.raises(ValueError) as e:
            call()
        for w in words:
            assert w in str(e.value)
    with pytest.raises(TypeError):
        penumbra.render("cornell-sphere", spp=1, backend="cpu", gpu_tuning=3, **SMALL)
