"""converge's "no light" metrics leave out the pixels that see a lamp. A pixel that a small lamp covers in part
must be found too: left in, it carries that lamp's pixel-coverage noise, the same for every technique and far above
the lighting's, and hides the differences the metrics are for (many-spheres' 10,000 lamps at 192x108: power
selection's no-lamp MSE doubled, the light BVH's advantage shrank from 0.52x to 0.71x its MSE)."""
import numpy as np

import penumbra

# many-spheres at 64x36: each of 10,000 lamps is a fraction of a pixel wide, so most lamp pixels are covered in part.
SCENE, W, H = "many-spheres", 64, 36
OVERRIDES = {"defaults.lights": 10000, "render.max_depth": 1}


def lamp_pixels(spp):
    """Pixels with emission seen by camera rays in a depth-0 render of `spp` samples."""
    img = penumbra.render(SCENE, backend="cpu", width=W, height=H, spp=spp, max_depth=0, overrides=OVERRIDES)
    return img.rgb.sum(axis=-1) > 0


def test_light_mask_finds_partly_covered_lamp_pixels(tmp_path):
    truth = lamp_pixels(8192)  # the pixels any lamp covers, but for coverages under about 1/8192
    few = lamp_pixels(16)
    assert few.sum() < 0.9 * truth.sum()  # 16 samples miss many: the scene can tell a weak mask from a good one
    res = penumbra.converge(SCENE, backend="cpu", width=W, height=H, reference_spp=16, max_spp=1, seeds=1,
                            strategies=["solid-angle"], mis=["power"], overrides=OVERRIDES, cache=str(tmp_path))
    # converge's mask: nearly every lamp pixel and its eight neighbours, and only those (its samples are a subset
    # of the 8192).
    grown = np.pad(truth, 1)
    grown = np.any([grown[1 + dy:1 + dy + H, 1 + dx:1 + dx + W] for dy in (-1, 0, 1) for dx in (-1, 0, 1)], axis=0)
    assert grown.sum() > truth.sum()
    assert 0.99 * grown.sum() <= res.summary["light_pixels"] <= grown.sum()
