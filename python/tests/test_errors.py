"""Bad input raises Python exceptions that name the file and the field; nothing
crashes the interpreter."""
import json

import numpy as np
import pytest

import penumbra
from conftest import SMALL


def test_unknown_scene_names_the_file():
    with pytest.raises(penumbra.SceneError) as e:
        penumbra.load_scene("no-such-scene")
    assert e.value.file == "no-such-scene" and e.value.field is None
    assert "cannot open scene file" in str(e.value) and "cornell-sphere" in str(e.value)


@pytest.mark.parametrize("kwargs,field", [
    (dict(width=0), "render.width"),
    (dict(height=-3), "render.height"),
    (dict(spp=0), "render.spp"),
    (dict(strategy="nope"), "render.strategy"),
    (dict(max_depth=-1), "render.max_depth"),
    (dict(seed=-1), "render.seed"),
    (dict(overrides={"light.radius": -0.5}), "lights[0].radius"),
    (dict(overrides={"light.radius": float("nan")}), "lights[0].radius"),
    (dict(overrides={"camera.fov": "wide"}), "camera.fov"),
    (dict(overrides={"light.nope.x": 1}), "light.nope.x"),
])
def test_bad_settings_raise_scene_error_naming_the_field(kwargs, field):
    with pytest.raises(penumbra.SceneError) as e:
        penumbra.render("cornell-sphere", backend="cpu", **{**SMALL, **kwargs})
    assert e.value.file == "builtin:cornell-sphere"
    assert e.value.field == field
    assert "\n" not in str(e.value)
    assert isinstance(e.value, ValueError)  # SceneError is a ValueError


def test_bad_scene_file_names_file_and_field(tmp_path):
    doc = penumbra.load_scene("cornell-sphere").to_dict()
    doc["lights"][0]["radius"] = "big"
    path = tmp_path / "bad.json"
    path.write_text(json.dumps(doc))
    with pytest.raises(penumbra.SceneError) as e:
        penumbra.load_scene(path)
    assert (e.value.file, e.value.field) == (str(path), "lights[0].radius")
    path.write_text("{ not json")
    with pytest.raises(penumbra.SceneError, match="invalid JSON") as e:
        penumbra.load_scene(str(path))
    assert e.value.file == str(path)


def test_bad_dict_scene():
    with pytest.raises(penumbra.SceneError) as e:
        penumbra.load_scene({"camera": {"eye": [0, 0, 0]}})
    assert e.value.file == "<dict>"
    with pytest.raises(penumbra.SceneError):
        penumbra.load_scene({"render": {"spp": object()}})
    with pytest.raises(penumbra.SceneError) as e:
        penumbra.load_scene({"shapes": [], "camera": {"eye": [0, 0, 1], "target": [0, 0, 0]}})
    assert "no shapes" in str(e.value)


def test_bad_arguments_raise_type_and_value_errors():
    with pytest.raises(ValueError, match="backend"):
        penumbra.render("cornell-sphere", backend="vulkan", **SMALL)
    with pytest.raises(TypeError):
        penumbra.load_scene(42)
    with pytest.raises(TypeError):
        penumbra.load_scene("cornell-sphere", overrides=["light.radius=1"])
    r = penumbra.Renderer("cornell-sphere", backend="cpu", **SMALL)
    for bad in (0, -1, 1.5, "4", 1 << 25):
        with pytest.raises(ValueError):
            r.render(bad)
    with pytest.raises(ValueError):
        penumbra.compare((np.zeros(3, np.float32),) * 2, (np.zeros(4, np.float32),) * 2)
    with pytest.raises(OSError):
        penumbra.read_exr("/no/such/file.exr")


def test_optix_without_a_gpu_is_a_backend_error():
    info = penumbra.build_info()
    if info["gpu_available"]:
        pytest.skip("a GPU is usable here")
    with pytest.raises(penumbra.BackendError) as e:
        penumbra.render("cornell-sphere", spp=1, backend="optix", **SMALL)
    assert "\n" not in str(e.value)
    # "auto" falls back to the CPU and says why.
    img = penumbra.render("cornell-sphere", spp=1, backend="auto", **SMALL)
    assert img.stats["backend"] == "cpu" and "chosen by --backend auto" in img.stats["note"]


def test_converge_errors():
    with pytest.raises(penumbra.SceneError):
        penumbra.converge("cornell-sphere", strategies=["nope"], backend="cpu", width=8, height=8, max_spp=1,
                          reference_spp=1, seeds=1)
    with pytest.raises(ValueError, match="max-spp"):
        penumbra.converge("cornell-sphere", backend="cpu", width=8, height=8, max_spp=0, reference_spp=1, seeds=1)
    with pytest.raises(TypeError):
        penumbra.converge({"camera": {}})
