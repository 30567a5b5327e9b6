"""converge(frame_spp=N): the error of sample N alone after N - 1 samples of the same render (a real-time frame
with N - 1 frames of history), computed here from two renders and the ground truth, must be converge's own."""
import numpy as np
import pytest

import penumbra


def rmse(img, ref, keep):
    d = (np.asarray(img, dtype=np.float64) - np.asarray(ref, dtype=np.float64)) ** 2
    return float(np.sqrt(d[keep].mean()))


def grow(lamps):
    """Light pixels and their eight neighbours (docs/metrics.md)."""
    p = np.pad(lamps, 1)
    h, w = lamps.shape
    return np.any([p[1 + dy:1 + dy + h, 1 + dx:1 + dx + w] for dy in (-1, 0, 1) for dx in (-1, 0, 1)], axis=0)


@pytest.mark.parametrize("scene,overrides", [
    ("cornell-sphere", {}),
    # restir with temporal reuse: sample N takes sample N - 1's final reservoirs, so it is not a render of
    # sample N alone; the difference of the two renders is.
    ("many-spheres", {"defaults.lights": 60, "render.light_selection": "restir", "render.restir.temporal": True}),
])
def test_frame_error_is_sample_n_alone(tmp_path, scene, overrides):
    n, w, h = 8, 24, 16
    res = penumbra.converge(scene, backend="cpu", width=w, height=h, reference_spp=64, max_spp=n, seeds=1,
                            frame_spp=n, strategies=["solid-angle"], mis=["power"], overrides=overrides,
                            cache=str(tmp_path))
    frame = res.summary["strategies"]["solid-angle+power"]["frame"]
    assert frame["spp"] == n and res.summary["frame_spp"] == n
    ref = penumbra.read_exr(res.summary["reference"]["file"])
    # converge's mask: pixels with any emission seen by camera rays at max depth 0 (1,024 spp, the scene's seed),
    # grown by their eight neighbours.
    lamps = grow(penumbra.render(scene, backend="cpu", width=w, height=h, spp=1024, max_depth=0,
                                 overrides=overrides).rgb.sum(axis=-1) > 0)
    keep = np.repeat(~lamps[..., None], 3, axis=-1)
    kw = dict(backend="cpu", width=w, height=h, strategy="solid-angle", mis="power", seed=1, overrides=overrides)
    a = penumbra.render(scene, spp=n, **kw).rgb.astype(np.float64)
    b = penumbra.render(scene, spp=n - 1, **kw).rgb.astype(np.float64)
    last = n * a - (n - 1) * b
    assert frame["rmse_nolight"] == pytest.approx(rmse(last, ref, keep), rel=1e-4)
    assert frame["rmse"] == pytest.approx(rmse(last, ref, np.ones_like(keep)), rel=1e-4)
    # Not the accumulated image's error, nor the first sample's.
    points = res.summary["strategies"]["solid-angle+power"]["points"]
    assert frame["rmse_nolight"] != pytest.approx(points[-1]["rmse_nolight"], rel=1e-3)
    assert frame["rmse_nolight"] != pytest.approx(points[0]["rmse_nolight"], rel=1e-3)


def test_frame_spp_must_be_a_level(tmp_path):
    with pytest.raises(ValueError, match="frame-spp"):
        penumbra.converge("cornell-sphere", backend="cpu", width=8, height=8, reference_spp=16, max_spp=8,
                          frame_spp=3, cache=str(tmp_path))
