#!/usr/bin/env python3
"""A peer renderer as an anchor: a built-in scene exported to Mitsuba 3 (PyPI `mitsuba`) and rendered there and
in penumbra, with the same samples per pixel and several independent seeds each; the image means compared within
their standard errors (from the seeds' spread), tile by tile and over the whole image, and the time per sample
side by side.

    python3 scripts/anchors/mitsuba_anchor.py cornell-sphere --spp 256 --width 160 --height 90 [--variant scalar_rgb]

Exported: quads, boxes (rotate_y) and spheres with Lambertian materials (`albedo`), shared quad and box meshes
placed by translations (instances), sphere and quad lights
(`radiance` or `power`), the camera (vertical field of view) and the box pixel filter, and max_depth (penumbra
counts bounces, Mitsuba path vertices: +1). A scene with anything else (meshes from files, textures, glossy
materials, an environment, scattered lights) is refused in one line naming the field. Mitsuba's BSDFs are one-sided,
penumbra's Lambertian two-sided: every material is wrapped in `twosided`. Variants: scalar_rgb or llvm_ad_rgb on the
CPU, cuda_ad_rgb on a GPU. Exit status 0 when the images agree (the image means within 4 standard errors, at most 1%
of 8x8-pixel tiles beyond 4, or three times the share a t of the seeds' degrees of freedom puts there where that is
more: 4.8% at 3 seeds), 1 when they do not, 2 for bad input, 77 without Mitsuba or penumbra's module.
"""
import argparse
import math
import os
import sys
import time

import numpy as np

here = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.join(here, "..", "..", "build", "python"))


def t_tail(t, nu):
    """P(|T| > t) for Student's t with nu degrees of freedom (Simpson's rule on its density over [0, t])."""
    c = math.exp(math.lgamma((nu + 1) / 2) - math.lgamma(nu / 2)) / math.sqrt(nu * math.pi)
    n = 4000
    h = t / n
    f = [c * (1 + (i * h) ** 2 / nu) ** (-(nu + 1) / 2) for i in range(n + 1)]
    inside = h / 3 * (f[0] + f[-1] + 4 * sum(f[1:-1:2]) + 2 * sum(f[2:-1:2]))
    return max(0.0, 1 - 2 * inside)


def fail(msg):
    print(f"anchors/mitsuba: {msg}", file=sys.stderr)
    sys.exit(2)


def radiance(light):
    if "radiance" in light:
        return [float(v) for v in light["radiance"]]
    if light["type"] == "sphere":
        area = 4.0 * math.pi * light["radius"] ** 2
    else:
        e1, e2 = np.array(light["edge1"], float), np.array(light["edge2"], float)
        area = float(np.linalg.norm(np.cross(e1, e2)))
    return [float(p) / (math.pi * area) for p in light["power"]]


def export(doc, spp, seed, mi):
    """The Mitsuba scene dict of a penumbra scene document (Scene.to_dict())."""
    T = mi.ScalarTransform4f
    allowed_top = {"background", "camera", "lights", "materials", "meshes", "render", "shapes"}
    for k in doc:
        if k not in allowed_top:
            fail(f"field '{k}': not exported (quads, boxes, spheres, sphere and quad lights only)")
    if any(float(v) != 0 for v in doc.get("background", [0, 0, 0])):
        fail("field 'background': a non-black background is not exported")
    mats = {}
    for name, m in doc.get("materials", {}).items():
        for k in m:
            if k != "albedo":
                fail(f"materials.{name}.{k}: only Lambertian 'albedo' is exported")
        mats[name] = {"type": "twosided", "bsdf": {"type": "diffuse", "reflectance": {
            "type": "rgb", "value": [float(v) for v in m["albedo"]]}}}
    black = {"type": "twosided", "bsdf": {"type": "diffuse", "reflectance": {"type": "rgb", "value": [0.0, 0.0, 0.0]}}}

    def quad_transform(corner, e1, e2):
        corner, e1, e2 = (np.array(v, float) for v in (corner, e1, e2))
        n = np.cross(e1, e2)
        n /= np.linalg.norm(n)
        c = corner + 0.5 * (e1 + e2)
        m = np.eye(4)
        m[:3, 0], m[:3, 1], m[:3, 2], m[:3, 3] = 0.5 * e1, 0.5 * e2, n, c
        return T(m.tolist())

    r = doc["render"]
    cam = doc["camera"]
    out = {"type": "scene",
           "integrator": {"type": "path", "max_depth": int(r["max_depth"]) + 1, "rr_depth": int(r.get("rr_depth", 5)) + 1},
           "sensor": {"type": "perspective", "fov": float(cam["fov"]), "fov_axis": "y",
                      "to_world": T().look_at(origin=cam["eye"], target=cam["target"], up=cam["up"]),
                      "sampler": {"type": "independent", "sample_count": spp, "seed": seed},
                      "film": {"type": "hdrfilm", "width": int(r["width"]), "height": int(r["height"]),
                               "rfilter": {"type": "box"}, "pixel_format": "rgb"}}}
    meshes = doc.get("meshes", {})
    for name, m in meshes.items():
        if m["type"] not in ("quad", "box"):
            fail(f"meshes.{name}.type '{m['type']}': not exported (quad, box)")
    shapes = []
    for i, s in enumerate(doc.get("shapes", [])):
        if s["type"] == "instance":  # a shared quad or box moved by a translation
            t = s.get("transform", {})
            if set(t) - {"translate"}:
                fail(f"shapes[{i}].transform: only 'translate' is exported")
            d = np.array(t.get("translate", [0, 0, 0]), float)
            m = dict(meshes[s["mesh"]], material=s.get("material"))
            if m["type"] == "quad":
                m["corner"] = (np.array(m["corner"], float) + d).tolist()
            else:
                m["center"] = (np.array(m["center"], float) + d).tolist()
            shapes.append(m)
        else:
            shapes.append(s)
    for i, s in enumerate(shapes):
        t = s["type"]
        bsdf = mats[s["material"]] if s.get("material") else black
        if t == "quad":
            out[f"shape{i}"] = {"type": "rectangle", "to_world": quad_transform(s["corner"], s["edge1"], s["edge2"]),
                                "bsdf": bsdf}
        elif t == "box":
            size = [float(v) for v in s["size"]]
            out[f"shape{i}"] = {"type": "cube", "bsdf": bsdf,
                                "to_world": T().translate(s["center"]).rotate([0, 1, 0], float(s.get("rotate_y", 0)))
                                .scale([0.5 * v for v in size])}
        elif t == "sphere":
            out[f"shape{i}"] = {"type": "sphere", "center": [float(v) for v in s["center"]],
                                "radius": float(s["radius"]), "bsdf": bsdf}
        else:
            fail(f"shapes[{i}].type '{t}': not exported (quad, box, sphere)")
    for i, l in enumerate(doc.get("lights", [])):
        emitter = {"type": "area", "radiance": {"type": "rgb", "value": radiance(l)}}
        bsdf = mats[l["material"]] if "material" in l else black
        if l["type"] == "sphere":
            out[f"light{i}"] = {"type": "sphere", "center": [float(v) for v in l["center"]],
                                "radius": float(l["radius"]), "emitter": emitter, "bsdf": bsdf}
        elif l["type"] == "quad":
            out[f"light{i}"] = {"type": "rectangle", "to_world": quad_transform(l["corner"], l["edge1"], l["edge2"]),
                                "emitter": emitter, "bsdf": bsdf}
        else:
            fail(f"lights[{i}].type '{l['type']}': not exported (sphere, quad)")
    return out


def tile_means(img, k=8):
    h, w = img.shape[0] // k * k, img.shape[1] // k * k
    return img[:h, :w].mean(axis=2).reshape(h // k, k, w // k, k).mean(axis=(1, 3))


# A tile whose mean is the same in every seed of both renderers to float32's precision (every sample of every
# pixel sees the lamp) has no noise to judge a difference by: its z would be the difference over rounding (1e13 at
# 1080p). Such tiles are counted apart, and their relative difference is held to this tolerance.
NOISE_FREE_REL = 1e-6
NOISE_FREE_TOLERANCE = 1e-3


def tile_stats(pn_imgs, mi_imgs, k=8):
    """8x8-pixel tiles of two stacks of seeds' images (seeds, height, width, channels): the mean z^2 and the share
    beyond 4 of each tile's mean difference over the seeds' standard errors, among tiles with noise; the number
    of noise-free tiles and their largest relative difference."""
    tp = np.stack([tile_means(i, k) for i in pn_imgs])
    tm = np.stack([tile_means(i, k) for i in mi_imgs])
    var = tp.var(axis=0, ddof=1) / len(tp) + tm.var(axis=0, ddof=1) / len(tm)
    mean_p, mean_m = tp.mean(0), tm.mean(0)
    diff = mean_p - mean_m
    scale = np.maximum(np.abs(mean_p), np.abs(mean_m))
    noisy = var > (NOISE_FREE_REL * scale) ** 2
    tz = diff[noisy] / np.sqrt(var[noisy])
    quiet = ~noisy & (scale > 0)
    rel = np.abs(diff[quiet]) / scale[quiet]
    return {"mean_z2": float(np.mean(tz ** 2)) if tz.size else 0.0,
            "beyond4": float(np.mean(np.abs(tz) > 4)) if tz.size else 0.0,
            "noise_free": int(quiet.sum()), "noise_free_rel_diff": float(rel.max()) if rel.size else 0.0}


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("scene")
    ap.add_argument("--spp", type=int, default=256, help="samples per pixel of each seed's image")
    ap.add_argument("--seeds", type=int, default=8, help="independent images per renderer")
    ap.add_argument("--width", type=int, default=160)
    ap.add_argument("--height", type=int, default=90)
    ap.add_argument("--max-depth", type=int, help="default: the scene's")
    ap.add_argument("--variant", default="scalar_rgb", help="Mitsuba variant: scalar_rgb, llvm_ad_rgb, cuda_ad_rgb")
    ap.add_argument("--backend", default="cpu", help="penumbra's backend: cpu, optix or auto")
    ap.add_argument("--out", help="folder whose anchor.md gets the result line (appended)")
    ap.add_argument("--save-images", action="store_true", help="also write both renderers' mean images to --out (.npy)")
    a = ap.parse_args()
    if a.spp < 1 or a.seeds < 3 or a.width < 8 or a.height < 8:
        fail("--spp >= 1, --seeds >= 3, --width and --height >= 8")
    try:
        import mitsuba as mi
    except ImportError as e:
        print(f"anchors/mitsuba: skipped: needs Mitsuba 3 ({e}): pip install mitsuba", file=sys.stderr)
        sys.exit(77)
    try:
        mi.set_variant(a.variant)
    except Exception as e:  # noqa: BLE001 (Mitsuba raises several kinds)
        fail(f"--variant {a.variant}: {e}")
    try:
        import penumbra
    except ImportError as e:
        print(f"anchors/mitsuba: skipped: needs penumbra's Python module ({e}): pip install ., or "
              "PYTHONPATH=build/python", file=sys.stderr)
        sys.exit(77)

    overrides = {"render.width": a.width, "render.height": a.height}
    if a.max_depth is not None:
        overrides["render.max_depth"] = a.max_depth
    doc = penumbra.load_scene(a.scene, overrides).to_dict()

    # Each renderer's scene is built before its clock starts (penumbra's acceleration structures and device data,
    # Mitsuba's load_dict); the clock covers the render call and the image's copy into numpy. Mitsuba's first call
    # also compiles its kernels (cuda_ad_rgb, llvm_ad_rgb), penumbra's first OptiX call its pipeline (cached on
    # disk): the median over seeds leaves those out.
    renderer = penumbra.Renderer(a.scene, backend=a.backend, overrides=overrides)
    pn_imgs, mi_imgs, pn_ms, mi_ms = [], [], [], []
    for seed in range(a.seeds):
        renderer.set(seed=seed + 1)  # the image starts over
        t0 = time.perf_counter()
        pn_imgs.append(np.array(renderer.render(a.spp).rgb, np.float64))
        pn_ms.append((time.perf_counter() - t0) * 1e3)
        scene = mi.load_dict(export(doc, a.spp, seed + 1, mi))
        t0 = time.perf_counter()
        m = np.array(mi.render(scene, spp=a.spp, seed=seed + 1), np.float64)
        mi_ms.append((time.perf_counter() - t0) * 1e3)
        mi_imgs.append(m)
    pn_imgs, mi_imgs = np.stack(pn_imgs), np.stack(mi_imgs)
    # Image means, each with the standard error of the mean over seeds.
    def mean_se(stack):
        per = stack.mean(axis=(1, 2, 3))
        return per.mean(), per.std(ddof=1) / math.sqrt(len(per))
    (mp, sp), (mm, sm) = mean_se(pn_imgs), mean_se(mi_imgs)
    z = (mp - mm) / math.hypot(sp, sm)
    tiles = tile_stats(pn_imgs, mi_imgs)
    tz2, beyond = tiles["mean_z2"], tiles["beyond4"]
    samples = a.width * a.height * a.spp
    # With variances estimated from the seeds (about 2 (seeds - 1) degrees of freedom for the pair), a tile's z^2
    # has mean nu / (nu - 2), not 1.
    nu = 2 * (a.seeds - 1)
    expected = nu / (nu - 2)
    pn_med, mi_med = float(np.median(pn_ms)), float(np.median(mi_ms))
    noise_free = ""
    if tiles["noise_free"]:
        noise_free = (f"; {tiles['noise_free']} noise-free tiles (a lamp seen in every sample) differ by at most "
                      f"{tiles['noise_free_rel_diff']:.2g} relative")
    line = (f"{a.scene} {a.width}x{a.height}, {a.spp} spp x {a.seeds} seeds, max depth {doc['render']['max_depth']}: "
            f"image mean penumbra {mp:.6g} +- {sp:.2g}, Mitsuba {mm:.6g} +- {sm:.2g} (rel. diff {(mp - mm) / mm:+.3%}, "
            f"z {z:+.2f}); 8x8 tiles: mean z^2 {tz2:.2f} (variances from {a.seeds} seeds a renderer: about "
            f"{expected:.2f} expected), {beyond:.1%} beyond 4{noise_free}; ms per image (wall, the median over seeds, "
            f"the scene built before): penumbra {pn_med:.1f} ({renderer.device}), "
            f"Mitsuba {mi_med:.1f} ({a.variant}); ns per sample {pn_med * 1e6 / samples:.1f} vs {mi_med * 1e6 / samples:.1f}")
    print(line)
    if a.out:
        os.makedirs(a.out, exist_ok=True)
        if a.save_images:
            np.save(os.path.join(a.out, f"{a.scene}_penumbra.npy"), pn_imgs.mean(0).astype(np.float32))
            np.save(os.path.join(a.out, f"{a.scene}_mitsuba.npy"), mi_imgs.mean(0).astype(np.float32))
        with open(os.path.join(a.out, "anchor.md"), "a") as f:
            f.write(f"- {line}\n")
    # The seeds' variances are rough (and heavy-tailed at a lamp's edge): the tiles' verdict is their tail, as
    # penumbra compare's is. A tile's z is then a t of nu = 2 (seeds - 1) degrees of freedom, beyond 4 for 0.13% of
    # tiles at 8 seeds but 1.6% at 3: the bound is 1% or three times that tail, whichever is larger.
    allowed = max(0.01, 3 * t_tail(4.0, nu))
    agree = abs(z) < 4 and beyond <= allowed and tiles["noise_free_rel_diff"] <= NOISE_FREE_TOLERANCE
    print("anchors/mitsuba: " + ("AGREE" if agree else "DISAGREE"))
    sys.exit(0 if agree else 1)


if __name__ == "__main__":
    main()
