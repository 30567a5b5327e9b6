"""The GPU backend from Python: DLPack without a host copy, and the same image
as the CPU. Runs only where a GPU is usable (scripts/python_gpu_check.sh runs it
on the GPU machine); skipped elsewhere."""
import numpy as np
import pytest

import penumbra
from conftest import gpu_reason
from test_interrupt import interrupted_render

pytestmark = pytest.mark.skipif(gpu_reason() is not None, reason=str(gpu_reason()))

SIZE = dict(width=96, height=54)


def consumers():
    out = []
    try:
        import torch
        if torch.cuda.is_available():
            out.append(("torch", lambda x: torch.from_dlpack(x), lambda t: t.cpu().numpy(),
                        lambda t: (t.is_cuda, t.data_ptr())))
    except ImportError:
        pass
    try:
        import cupy
        out.append(("cupy", lambda x: cupy.from_dlpack(x), lambda t: cupy.asnumpy(t),
                    lambda t: (True, t.data.ptr)))
    except ImportError:
        pass
    return out


def test_gpu_image_stays_on_the_gpu_and_matches_its_host_copy():
    kinds = consumers()
    if not kinds:
        pytest.skip("neither torch nor cupy with CUDA is installed")
    img = penumbra.render("cornell-sphere", spp=16, backend="optix", **SIZE)
    assert img.on_gpu and img.stats["backend"] == "optix"
    assert img.__dlpack_device__()[0] == 2  # kDLCUDA
    for name, take, to_host, where in kinds:
        t = take(img.rgb_dlpack())
        on_cuda, ptr = where(t)
        assert on_cuda, name
        assert tuple(t.shape) == (54, 96, 3), name
        t2 = take(img)  # __dlpack__
        assert where(t2)[1] == ptr, name  # the same device buffer: no copy
        v = take(img.variance_dlpack())
        assert np.array_equal(to_host(t), img.rgb), name
        assert np.array_equal(to_host(v), img.variance), name


def test_gpu_render_agrees_with_the_cpu():
    for strategy in ("area", "solid-angle"):
        gpu = penumbra.render("cornell-near", strategy=strategy, spp=1024, seed=1, backend="optix", **SIZE)
        cpu = penumbra.render("cornell-near", strategy=strategy, spp=1024, seed=2, backend="cpu", **SIZE)
        r = penumbra.compare(gpu, cpu)
        # The statistical test decides, as in scripts/gpu_check.sh: at 96x54 pixels the image mean of area
        # sampling has a standard error near 0.5%, too close to the default 1% bound on the means; the verdict
        # this test always had (compare used to widen the bound to 4 standard errors).
        assert r["statistical_pass"], r["report"]


def test_gpu_progressive_renderer():
    r = penumbra.Renderer("cornell-sphere", backend="optix", seed=3, **SIZE)
    assert r.backend == "optix"
    a = r.render(4)
    b = r.render(4)
    assert (a.spp, b.spp, r.spp) == (4, 8, 8)
    once = penumbra.render("cornell-sphere", spp=8, seed=3, backend="optix", **SIZE)
    np.testing.assert_allclose(b.rgb, once.rgb, rtol=1e-5, atol=1e-7)
    r.set(strategy="area")
    assert r.builds == 1 and r.spp == 0
    assert r.render(2).stats["strategy"] == "area"
    assert b.stats["rays"] > 0 and b.stats["gpu_ms"] > 0


def test_gpu_same_seed_same_image_as_the_cli(cli, tmp_path):
    import subprocess
    out = tmp_path / "gpu.exr"
    subprocess.run([cli, "render", "cornell-sphere", "--backend", "optix", "--spp", "8", "--seed", "3",
                    "--width", "96", "--height", "54", "-o", str(out)], check=True, capture_output=True)
    img = penumbra.render("cornell-sphere", spp=8, seed=3, backend="optix", **SIZE)
    # Same launches, same device sums, the host's arithmetic on the device.
    assert np.array_equal(penumbra.read_exr(out), img.rgb)


def test_ctrl_c_interrupts_a_gpu_render():
    # 1 spp per launch at 1920x1080: 100000 spp would take minutes.
    seconds, spp = interrupted_render("optix", 1920, 1080, 100000)
    assert seconds < 5.0
    assert spp >= 1  # launches that started before the interrupt completed, and count


def test_gpus_selects_gpus_and_splits_the_samples():
    n = penumbra.build_info()["gpus"]
    # 512 spp at 96x54: launches of 202 spp, so that two GPUs get 404 and 108.
    one = penumbra.render("cornell-sphere", spp=512, backend="optix", gpus=1, **SIZE)
    first = penumbra.render("cornell-sphere", spp=512, backend="optix", gpus=[0], **SIZE)
    assert np.array_equal(one.rgb, first.rgb) and "devices" not in one.stats
    with pytest.raises(ValueError, match="gpus"):
        penumbra.render("cornell-sphere", spp=1, backend="optix", gpus=n + 1, **SIZE)
    if n < 2:
        pytest.skip("one GPU: the split across GPUs needs two (tests/render/test_multi_backend.cpp checks it on the CPU)")
    two = penumbra.render("cornell-sphere", spp=512, backend="optix", gpus=2, **SIZE)
    assert not two.on_gpu  # accumulated on the host
    assert two.rgb.tobytes() == one.rgb.tobytes() and two.variance.tobytes() == one.variance.tobytes()
    assert [(d["first_sample"], d["count"]) for d in two.stats["devices"]] == [(0, 404), (404, 108)]
    # Progressive: the launches of one GPU's progressive renders, on two.
    r1 = penumbra.Renderer("cornell-sphere", backend="optix", gpus=1, **SIZE)
    r2 = penumbra.Renderer("cornell-sphere", backend="optix", gpus=2, **SIZE)
    for spp in (300, 700):
        a, b = r1.render(spp), r2.render(spp)
    assert b.spp == 1000 and b.rgb.tobytes() == a.rgb.tobytes()


def test_gpu_denoise_lowers_the_error_and_keeps_the_guides_in_range():
    ref = penumbra.render("cornell-sphere", spp=4096, seed=7, backend="optix", **SIZE).rgb
    img = penumbra.render("cornell-sphere", spp=4, seed=1, backend="optix", denoise=True, **SIZE)
    assert img.denoised.shape == img.rgb.shape == img.albedo.shape == img.normal.shape == (54, 96, 3)
    assert img.denoised.dtype == np.float32 and np.isfinite(img.denoised).all()
    assert img.albedo.min() >= 0.0 and img.albedo.max() <= 1.0
    lengths = np.linalg.norm(img.normal, axis=2)
    surface = lengths > 0  # 0: every ray of the pixel escaped
    np.testing.assert_allclose(lengths[surface], 1.0, atol=1e-4)
    assert surface.mean() > 0.9
    rmse = lambda a: float(np.sqrt(np.mean((a - ref) ** 2)))  # noqa: E731
    assert rmse(img.denoised) < 0.7 * rmse(img.rgb), (rmse(img.denoised), rmse(img.rgb))
    # the raw image is the one render() without denoise gives
    plain = penumbra.render("cornell-sphere", spp=4, seed=1, backend="optix", **SIZE)
    assert np.array_equal(plain.rgb, img.rgb)
