# Where is many-spheres' direct-lighting error? Per-sample MSE of each selection, overall and by region
# (left/right image half = diffuse/glossy floor half: the camera sits in the x = 0 plane), with and without the
# occluders (pillars, wall, sphere). Usage, with the Python module on PYTHONPATH:
#   python3 ceiling.py BACKEND W H SPP SEEDS REF_SPP OUT.json
# Here: python3 ceiling.py optix 1920 1080 16 2 4096 ceiling_1080p.json (one H200, built from 9d3feab's tree).
# ceiling_1080p_old_bvh.* is an earlier version of this script (one reference floor for every region; its "all"
# was the 1024-spp mask grown by one pixel) built from 1f76795, before the light BVH's change of dd52b7b.
import json, sys, time
import numpy as np
import penumbra

backend, W, H, spp, seeds, ref_spp, out = sys.argv[1], *map(int, sys.argv[2:7]), sys.argv[7]
base = penumbra.load_scene("many-spheres", {"defaults.lights": 10000, "render.max_depth": 1}).to_dict()
open_doc = json.loads(json.dumps(base))
open_doc["shapes"] = [s for s in open_doc["shapes"] if s.get("type") == "quad"]  # the floor only
METHODS = {
    "power": {"render.light_selection": "power"},
    "bvh": {"render.light_selection": "bvh"},
    "ris32": {"render.light_selection": "restir", "render.restir.spatial_passes": 0},
    "ris1024": {"render.light_selection": "restir", "render.restir.spatial_passes": 0, "render.restir.candidates": 1024},
    "restir": {"render.light_selection": "restir", "render.restir.pairwise": True},
}
kw = dict(width=W, height=H, backend=backend, strategy="solid-angle", mis="power")
res = {}
for name, doc in (("occluders", base), ("open", open_doc)):
    mask16 = penumbra.render(doc, spp=16, max_depth=0, **kw).rgb.sum(axis=2) == 0  # converge's mask: no lamp in 16 spp
    lamp = penumbra.render(doc, spp=1024, max_depth=0, **kw).rgb.sum(axis=2) > 0  # any lamp in 1024 spp
    near = lamp.copy()  # and the pixels next to those
    near[1:] |= lamp[:-1]; near[:-1] |= lamp[1:]; near[:, 1:] |= lamp[:, :-1]; near[:, :-1] |= lamp[:, 1:]
    mask = ~lamp  # converge's mask since session 21
    print(name, "lamp pixels: 16 spp", int((~mask16).sum()), "1024 spp", int(lamp.sum()), "dilated", int(near.sum()), flush=True)
    t = time.time()
    ref = penumbra.render(doc, spp=ref_spp, seed=1000, **kw)
    print(name, "reference", round(time.time() - t, 1), "s", flush=True)
    ref_rgb = ref.rgb.astype(np.float64)
    ref_var = ref.variance.astype(np.float64).mean(axis=2)
    floor = float(ref_var[mask].mean())  # the reference's own expected squared error (1024-spp mask)
    left = np.zeros((H, W), bool); left[:, : W // 2] = True
    regions = {"16-spp mask": mask16, "1024-spp mask": mask, "1024 + 1 px": ~near, "left (diffuse)": mask & left,
               "right (glossy)": mask & ~left}
    res[name] = {"reference_floor_mse": floor, "methods": {}}
    for m, ov in METHODS.items():
        acc = {k: 0.0 for k in regions}
        top = 0.0; ms = 0.0
        for s in range(seeds):
            img = penumbra.render(doc, spp=spp, seed=s, overrides=ov, **kw)
            e = ((img.rgb.astype(np.float64) - ref_rgb) ** 2).mean(axis=2)
            for k, r in regions.items():
                acc[k] += (e[r].mean() - ref_var[r].mean()) / seeds  # less the reference's own squared error
            v = np.sort(e[mask])[::-1]
            top += v[: max(1, v.size // 100)].sum() / v.sum() / seeds  # share of the MSE in the worst 1% of pixels
            ms += img.stats.get("gpu_ms", img.stats["render_seconds"] * 1e3) / spp / seeds
        res[name]["methods"][m] = {"mse_1spp": {k: v * spp for k, v in acc.items()}, "top1pct_share": top, "ms_per_spp": ms}
        print(name, m, {k: round(v * spp, 5) for k, v in acc.items()}, "top1%", round(top, 3), "ms", round(ms, 2), flush=True)
    p = res[name]["methods"]["power"]["mse_1spp"]
    for m, r in res[name]["methods"].items():
        print(name, m.ljust(8), "MSE vs power:", {k: round(r["mse_1spp"][k] / p[k], 3) for k in p}, flush=True)
json.dump(res, open(out, "w"), indent=1)
