"""Intel Open Image Denoise on the CPU backend (penumbra.render(..., denoise=True)): it cuts the error of a
noisy render against a converged one, on the pixels that see no light directly (docs/metrics.md's no-light set;
at a lamp's edge, radiance 32 beside 0.5, any denoiser blurs, and all-pixel RMSE grows). Skipped without the PyPI
package pyoidn."""
import importlib.util

import numpy as np
import pytest

import penumbra

pytestmark = pytest.mark.skipif(importlib.util.find_spec("pyoidn") is None,
                                reason="Intel Open Image Denoise not installed (pip install pyoidn)")

SIZE = dict(width=320, height=180)


def no_light_rmse(image, ref, mask):
    return float(np.sqrt(np.mean(((image - ref) ** 2)[mask])))


def test_oidn_on_the_cpu_cuts_the_error_of_a_noisy_render():
    ref = penumbra.render("cornell-sphere", spp=1024, seed=1, backend="cpu", **SIZE).rgb
    # The pixels that see no emitter: a render of camera rays alone is 0 there.
    mask = penumbra.render("cornell-sphere", spp=64, seed=3, max_depth=0, backend="cpu", **SIZE).rgb.sum(axis=2) == 0
    assert 0.98 < mask.mean() < 1.0  # the lamp covers a little of the image
    # Measured (2 cores): 4 spp 3.6x, 16 spp 2.45x; the reference's own noise (1024 spp) is a third of the
    # denoised 16-spp image's error.
    for spp, factor in ((4, 3.0), (16, 2.0)):
        img = penumbra.render("cornell-sphere", spp=spp, seed=2, backend="cpu", denoise=True, **SIZE)
        assert img.denoised.shape == img.rgb.shape and np.isfinite(img.denoised).all()
        assert "Intel Open Image Denoise, CPU device" in img.stats["denoiser"]
        raw, den = no_light_rmse(img.rgb, ref, mask), no_light_rmse(img.denoised, ref, mask)
        assert den * factor < raw, (spp, raw, den)


def test_renderer_denoises_with_the_chosen_quality():
    r = penumbra.Renderer("cornell-sphere", backend="cpu", width=64, height=36)
    r.render(4)
    fast = r.image(denoise=True, denoise_quality="fast")
    assert "quality fast" in fast.stats["denoiser"] and fast.stats["denoise_repaired"] == 0
    high = r.image(denoise=True)
    assert "quality high" in high.stats["denoiser"]
    assert not np.array_equal(fast.denoised, high.denoised)  # two different networks
    assert np.array_equal(fast.rgb, high.rgb)  # the same samples
    # DLPack: the denoised mean as an array-API object on the host, the same values, no copy.
    d = np.from_dlpack(high.denoised_dlpack())
    assert d.shape == (36, 64, 3) and np.array_equal(d, high.denoised) and np.shares_memory(d, high.denoised)
    assert r.render(1).denoised_dlpack() is None
