"""The study's plan: what each part runs (`penumbra converge` runs as Run
tuples), at which sizes (the presets), and how a plan loses the runs this
machine cannot make."""
from collections import namedtuple

STRATEGIES = ["area", "solid-angle"]
BOX = (5.56, 5.488, 5.592)  # the Cornell box's extent (x, y, z) in the built-in scenes
HEADLINE = ["cornell-sphere", "cornell-near", "occlusion"]

PRESETS = {
    # Headline scenes at the thesis's resolution and ground truth; sweeps smaller.
    "full": dict(headline=dict(width=1920, height=1080, reference_spp=65536, max_spp=1024, seeds=4, reference_chunk=4096),
                 sweep=dict(width=480, height=270, reference_spp=8192, max_spp=256, seeds=2, reference_chunk=4096),
                 radii=[0.02, 0.05, 0.1, 0.2, 0.4, 0.8], near_k=[1.1, 1.5, 2, 4, 8, 16],
                 slat_widths=[0.02, 0.08, 0.14, 0.2, 0.23]),
    # What a short spell of one GPU affords (about 10 minutes on the H100): the
    # headline scenes at full resolution with a smaller ground truth.
    "gpu": dict(headline=dict(width=1920, height=1080, reference_spp=8192, max_spp=512, seeds=4, reference_chunk=4096),
                sweep=dict(width=480, height=270, reference_spp=8192, max_spp=256, seeds=2, reference_chunk=4096),
                radii=[0.02, 0.05, 0.1, 0.2, 0.4, 0.8], near_k=[1.1, 1.5, 2, 4, 8, 16],
                slat_widths=[0.02, 0.08, 0.14, 0.2, 0.23]),
    # Two CPU cores: the gpu preset's sweeps at a fraction of the pixels and samples (with the other parts' cpu
    # presets, --part all takes well under an hour).
    "cpu": dict(headline=dict(width=160, height=90, reference_spp=8192, max_spp=256, seeds=4, reference_chunk=2048),
                sweep=dict(width=96, height=54, reference_spp=4096, max_spp=128, seeds=2, reference_chunk=2048),
                radii=[0.02, 0.05, 0.1, 0.2, 0.4, 0.8], near_k=[1.1, 1.5, 2, 4, 8, 16],
                slat_widths=[0.02, 0.08, 0.14, 0.2, 0.23]),
    # What fits in a CI run on two CPU cores: the same pipeline, tiny.
    "smoke": dict(headline=dict(width=32, height=32, reference_spp=4096, max_spp=256, seeds=4, reference_chunk=1024),
                  sweep=dict(width=24, height=24, reference_spp=1024, max_spp=64, seeds=2, reference_chunk=512),
                  radii=[0.05, 0.4], near_k=[2, 8], slat_widths=[0.08, 0.2]),
}
# The light-sampling lab (issue 10): every strategy x MIS mode on the lab's
# scenes, and its sweeps. Sizes per preset.
LAB_PRESETS = {
    "full": dict(headline=dict(width=960, height=540, reference_spp=16384, max_spp=256, seeds=2, reference_chunk=4096),
                 sweep=dict(width=480, height=270, reference_spp=4096, max_spp=128, seeds=2, reference_chunk=4096),
                 radii=[0.02, 0.05, 0.1, 0.2, 0.4, 0.8], near_k=[1.1, 1.5, 2, 4, 8, 16],
                 roughness=[0.02, 0.05, 0.1, 0.2, 0.4, 0.7, 1.0], panel_offsets=[0.0, 0.2, 0.5, 1.0, 2.0]),
    "gpu": dict(headline=dict(width=640, height=360, reference_spp=8192, max_spp=256, seeds=2, reference_chunk=4096),
                sweep=dict(width=320, height=180, reference_spp=4096, max_spp=128, seeds=2, reference_chunk=4096),
                radii=[0.02, 0.05, 0.1, 0.2, 0.4, 0.8], near_k=[1.1, 1.5, 2, 4, 8, 16],
                roughness=[0.02, 0.05, 0.1, 0.2, 0.4, 0.7, 1.0], panel_offsets=[0.0, 0.2, 0.5, 1.0, 2.0]),
    "cpu": dict(headline=dict(width=160, height=90, reference_spp=8192, max_spp=128, seeds=2, reference_chunk=2048),
                sweep=dict(width=80, height=45, reference_spp=4096, max_spp=128, seeds=2, reference_chunk=2048),
                radii=[0.02, 0.05, 0.1, 0.2, 0.4, 0.8], near_k=[1.1, 1.5, 2, 4, 8, 16],
                roughness=[0.02, 0.05, 0.1, 0.2, 0.4, 0.7, 1.0], panel_offsets=[0.0, 0.2, 0.5, 1.0, 2.0]),
    "smoke": dict(headline=dict(width=24, height=24, reference_spp=2048, max_spp=64, seeds=2, reference_chunk=1024),
                  sweep=dict(width=16, height=16, reference_spp=1024, max_spp=32, seeds=2, reference_chunk=512),
                  radii=[0.05, 0.4], near_k=[2, 8], roughness=[0.05, 0.6], panel_offsets=[0.0, 1.0]),
}
LAB_SCENES = ["cornell-sphere", "cornell-near", "occlusion", "cornell-quad", "polygon-near", "glossy"]
LAB_STRATEGIES = ["area", "solid-angle", "projected-solid-angle", "ltc", "bsdf"]
LAB_LIGHT_STRATEGIES = [st for st in LAB_STRATEGIES if st != "bsdf"]
MIS_MODES = ["none", "balance", "power"]
# Technique names as `penumbra converge` writes them: "area" (MIS none), "area+power".
LAB_TECHNIQUES = [st if m == "none" else f"{st}+{m}" for st in LAB_LIGHT_STRATEGIES for m in MIS_MODES] + ["bsdf"]
# The lab's scenes with quad or triangle lights: where ltc runs (with sphere lights alone it is projected-solid-angle).
LAB_POLYGON_SCENES = ["cornell-quad", "polygon-near"]


def lab_strategies(scene):
    return [st for st in LAB_STRATEGIES if st != "ltc" or scene in LAB_POLYGON_SCENES]


# The polygon roughness sweep (polygon-near's glossy floor): ltc, which samples by the GGX lobe, against the
# spherical-polygon samplers and BSDF sampling.
LAB_POLYGON_ROUGHNESS_STRATEGIES = ["solid-angle", "projected-solid-angle", "ltc", "bsdf"]

# Many lights (issue 14; many_lights.py says what is measured).
# The ground truths select lights by the light BVH: for the same time, its noise is a fifth of power selection's.
# A reference's own noise adds to every run's MSE alike, and so compresses the ratios between methods: with 4,096
# spp selected by power, it was 14% of bvh's MSE at 128 spp and 27-33% of the ReSTIR variants'.
MANY_PRESETS = {
    "full": dict(headline=dict(width=960, height=540, reference_spp=8192, max_spp=256, seeds=2, reference_chunk=4096,
                               frame_spp=32, reference_selection="bvh"),
                 lights=10000, counts=[10, 100, 1000, 10000, 100000],
                 sweep=dict(width=320, height=180, reference_spp=4096, max_spp=64, seeds=2, reference_chunk=4096,
                            reference_selection="bvh")),
    # The numbers: 10,000 lights at 1080p on the GPU.
    "gpu": dict(headline=dict(width=1920, height=1080, reference_spp=16384, max_spp=128, seeds=2, reference_chunk=4096,
                              frame_spp=32, reference_selection="bvh"),
                lights=10000, counts=[10, 100, 1000, 10000, 100000],
                sweep=dict(width=480, height=270, reference_spp=16384, max_spp=64, seeds=2, reference_chunk=4096,
                           reference_selection="bvh")),
    # Two CPU cores: the gpu preset's 10,000 lights, at 96x54 (sponza-lanterns' ten runs cost the most), and its
    # sweep up to 10,000.
    "cpu": dict(headline=dict(width=96, height=54, reference_spp=2048, max_spp=64, seeds=2, reference_chunk=2048,
                              frame_spp=16, reference_selection="bvh"),
                lights=10000, counts=[10, 100, 1000, 10000],
                sweep=dict(width=96, height=54, reference_spp=2048, max_spp=64, seeds=2, reference_chunk=2048,
                           reference_selection="bvh")),
    # At 24x16 every lamp is smaller than a pixel, and the pixels it covers in part escape the mask of lamp
    # pixels: the smoke runs look at the floor from below the lamps (none in view).
    # Four seeds: with two, one unbiased method's fitted slope fell to -0.12 in the sanitizer build (restir-bvh
    # with area sampling; -0.26 to -0.73 over pairs of seeds in the g++ build, -0.44 over twelve).
    "smoke": dict(headline=dict(width=24, height=16, reference_spp=1024, max_spp=32, seeds=4, reference_chunk=512,
                                frame_spp=16),
                  lights=500, counts=[10, 100, 1000],
                  sweep=dict(width=16, height=12, reference_spp=512, max_spp=16, seeds=2, reference_chunk=256),
                  sets=["camera.eye=[0,0.18,-3]", "camera.target=[0,0,-2.505]", "camera.fov=30"]),
}
# Report key -> (built-in scene, its lights-count key or None, extra settings). many-spheres-direct is the same
# scene with direct lighting only (one scattering vertex: x1's light sample and BSDF sample, MIS-weighted), the
# setting of Bitterli et al. 2020's ReSTIR DI numbers; with global illumination the indirect light's noise, which
# no light-selection method touches at x1, bounds what any of them can gain.
# many-spheres-glossy makes the glossy half of the floor (and its sphere) a metal of roughness 0.15: a lobe that
# sees few of the lamps, where sg-bvh's lobe-aware importance can gain over bvh's bound.
MANY_SCENES = {"many-spheres": ("many-spheres", "defaults.lights", ()),
               "many-spheres-direct": ("many-spheres", "defaults.lights", ("render.max_depth=1",)),
               "many-spheres-glossy": ("many-spheres", "defaults.lights", ("materials.glossy.metallic=1",)),
               "sponza-lanterns": ("sponza-lanterns", None, ())}
# name -> scene overrides. restir: the paper's defaults (32 candidates by power, 2 spatial passes of 3 neighbours)
# with pairwise MIS, unbiased (2k shadow rays a pass where the generalized balance heuristic, the renderer's default,
# needs k^2 + k: on the H200 at 10,000 lights and 1080p, 18.9 against 27.3 ms a sample, both unbiased);
# restir-bvh the same with 8 candidates drawn by the light BVH (each one a traversal: 32 of them cost 13 ms a
# sample there); restir-temporal adds temporal reuse (each sample also takes the pixel's last final reservoir, so a
# render's samples are correlated: its error at the largest spp is measured as it is, its slope is not -1/2);
# restir-biased is the paper's biased combination (shadowed only when shading).
MANY_SELECTIONS = {
    "uniform": ["render.light_selection=uniform"],
    "power": ["render.light_selection=power"],
    "bvh": ["render.light_selection=bvh"],
    # the light BVH weighed by the BSDF's lobes (spherical Gaussians; core/light_bvh.h)
    "sg-bvh": ['render.light_selection="sg-bvh"'],
    "restir": ["render.light_selection=restir", "render.restir.pairwise=true"],
    "restir-bvh": ["render.light_selection=restir", "render.restir.pairwise=true", 'render.restir.source="bvh"',
                   "render.restir.candidates=8"],
    # restir's first stage alone: each path's first vertex resamples 8 BVH candidates (RIS), no reuse passes.
    "ris-bvh": ["render.light_selection=restir", 'render.restir.source="bvh"', "render.restir.candidates=8",
                "render.restir.spatial_passes=0"],
    # restir and restir-bvh without visibility reuse: unshadowed targets in the reuse (no shadow rays there), one
    # shadow ray when shading; unbiased all the same (core/restir.h).
    "restir-unshadowed": ["render.light_selection=restir", "render.restir.pairwise=true",
                          "render.restir.visibility_reuse=false"],
    "restir-bvh-unshadowed": ["render.light_selection=restir", "render.restir.pairwise=true",
                              'render.restir.source="bvh"', "render.restir.candidates=8",
                              "render.restir.visibility_reuse=false"],
    "restir-temporal": ["render.light_selection=restir", "render.restir.pairwise=true", "render.restir.temporal=true"],
    "restir-biased": ["render.light_selection=restir", "render.restir.unbiased=false"],
    # stochastic lightcuts (core/light_bvh.h): a cut of at most N nodes of the light BVH, a light sample and shadow
    # ray in each; slc-1 is the light BVH's one sample (the same image as bvh, through slc's code).
    **{f"slc-{n}": ['render.light_selection="slc"', f"render.slc_cut={n}"] for n in (1, 8, 32)},
}
# Methods whose renders are not independent samples (the slope check leaves them out) or not unbiased.
MANY_CORRELATED = {"restir-temporal"}
MANY_STRATEGIES = ["area", "solid-angle", "projected-solid-angle"]
# Methods run with fewer strategies: slc-32 takes about 90 ms a 1080p sample on the H200 (a light sample and shadow
# ray for each of up to 32 nodes; 4 minutes a run with all three), so it runs with solid-angle alone, the strategy
# every table's other columns compare.
MANY_SELECTION_STRATEGIES = {"slc-32": ("solid-angle",)}
MANY_SWEEP_SELECTIONS = ["power", "bvh", "sg-bvh", "slc-1", "slc-8", "slc-32", "ris-bvh", "restir",
                         "restir-bvh-unshadowed"]
# restir's parameters (--only params, on many-spheres with and without GI at the headline's size): M candidates
# drawn by the light BVH, resampled without reuse (ris-bvh) and with unbiased pairwise reuse of unshadowed targets
# (restir-bvh-unshadowed, the headline's most efficient restir) over p spatial passes of k neighbours. Which is
# most efficient at equal time depends on what a candidate costs against a reuse pass on the machine; the headline
# keeps M = 8, p = 2, k = 3. name -> (M, p, k); power and bvh are run beside them as the baselines.
MANY_PARAMS = {**{f"ris-bvh-m{m}": (m, 0, 0) for m in (2, 4, 8)},
               **{f"restir-bvh-unshadowed-m{m}-p{p}-k{k}": (m, p, k) for m in (2, 4, 8)
                  for p, k in ((1, 3), (2, 3), (1, 5))}}
MANY_PARAM_SCENES = ("many-spheres", "many-spheres-direct")

# Denoising (denoise.py says what is measured).
DENOISE_PRESETS = {
    "full": dict(width=1920, height=1080, reference_spp=16384, reference_chunk=4096, max_spp=64, seeds=4),
    "gpu": dict(width=640, height=360, reference_spp=4096, reference_chunk=4096, max_spp=64, seeds=2),
    "cpu": dict(width=160, height=90, reference_spp=4096, reference_chunk=1024, max_spp=64, seeds=2),
    "smoke": dict(width=32, height=32, reference_spp=1024, reference_chunk=512, max_spp=16, seeds=2),
}
DENOISE_TECHNIQUES = [("area", "none"), ("area", "power"), ("solid-angle", "none"), ("solid-angle", "power"),
                      ("projected-solid-angle", "none"), ("projected-solid-angle", "power"), ("bsdf", "none")]
# The thesis's scenes, a polygon light near a wall, glossy reflections of a sun, and many lights.
DENOISE_SCENES = HEADLINE + ["polygon-near", "glossy", "many-spheres"]
# On many-spheres also solid-angle + MIS power with each way of choosing a light: does restir's correlated noise
# (neighbours' samples reused) denoise worse than independent noise? SSIM beside RMSE shows blotches.
DENOISE_SELECTIONS = {"many-spheres": ["bvh", "restir"]}


# One `penumbra converge` run of the study. `group`: where set, the run is
# optional and the whole group is left out when one of its runs cannot be
# made on this machine (the glossy scene needs ../shared/scenes).
Run = namedtuple("Run", "name scene cfg sets strategies mis out_dir group",
                 defaults=((), tuple(STRATEGIES), ("none",), None, None))


def run_key(r):
    return (r.out_dir, r.name)


def keep(plan_, kept):
    """A (headline, sweeps) plan less the runs `plan()` left out; a sweep loses all or nothing."""
    head, sweeps = plan_
    return ([r for r in head if run_key(r) in kept],
            {k: v for k, v in sweeps.items() if all(run_key(r) in kept for r in v)})


def thesis_plan(args, preset, out_dir):
    """Chapter 4's runs (in out_dir/runs): (headline runs, {sweep: runs})."""
    scenes = HEADLINE if args.report_only or not args.scene else [s for s in args.scene if s in HEADLINE]
    head = [Run(s, s, preset["headline"], out_dir=out_dir) for s in scenes] \
        if args.only not in ("sweeps", "params") else []
    sweeps = {}
    if args.only not in ("headline", "params"):
        sw = preset["sweep"]
        sweeps["radius"] = [Run(f"radius-{r}", "cornell-sphere", sw, (f"light.radius={r}",), out_dir=out_dir)
                            for r in preset["radii"]]
        sweeps["distance"] = [Run(f"near-{k}", "cornell-near", sw, (f"light.center=[1.6,3.2,{BOX[2] - k * 0.15:.4f}]",),
                                  out_dir=out_dir) for k in preset["near_k"]]
        sweeps["occlusion"] = [Run(f"slats-{wd}", "occlusion", sw, (f"meshes.slat-x.size=[{wd},0.04,{BOX[2]}]",
                                                                    f"meshes.slat-z.size=[{BOX[0]},0.04,{wd}]"),
                                   out_dir=out_dir) for wd in preset["slat_widths"]]
    return head, sweeps


def lab_plan(args, lab, out_dir):
    """Every technique on every lab scene, then the sweeps: (headline runs, {sweep: runs}).
    The glossy scene and its sweep are optional (their model data lives in ../shared/scenes)."""
    h, sw = lab["headline"], lab["sweep"]
    scenes = LAB_SCENES if not args.scene else [s for s in LAB_SCENES if s in args.scene]
    head = [Run(sc, sc, h, (), lab_strategies(sc), MIS_MODES, out_dir, "glossy" if sc == "glossy" else None)
            for sc in scenes] if args.only not in ("sweeps", "params") else []
    sweeps = {}
    if args.only not in ("sweeps", "params"):
        # Direct lighting alone (one scattering vertex: what a light sampler changes), beside the headline's global
        # illumination, on the same scenes and sizes.
        sweeps["direct"] = [Run(f"{sc}-direct", sc, h, ("render.max_depth=1",), lab_strategies(sc), MIS_MODES, out_dir,
                                "glossy" if sc == "glossy" else None) for sc in scenes]
        # glossy's sky sampled by its MIS-compensated distribution (Karlik et al. 2019), beside the headline's.
        if "glossy" in scenes:
            sweeps["compensation"] = [Run("glossy-compensated", "glossy", h, ("render.mis_compensation=true",),
                                          ("solid-angle", "projected-solid-angle"), ("balance", "power"), out_dir,
                                          "glossy")]
    if args.only not in ("headline", "params"):
        three = ["area", "solid-angle", "projected-solid-angle"]
        sweeps["radius"] = [Run(f"radius-{r}", "cornell-sphere", sw, (f"light.radius={r}",), three, out_dir=out_dir)
                            for r in lab["radii"]]
        sweeps["distance"] = [Run(f"near-{k}", "cornell-near", sw, (f"light.center=[1.6,3.2,{BOX[2] - k * 0.15:.4f}]",),
                                  three, out_dir=out_dir) for k in lab["near_k"]]
        sweeps["panel"] = [Run(f"panel-{o}", "polygon-near", sw, (f"defaults.panel_z={-o}",), three, out_dir=out_dir)
                           for o in lab["panel_offsets"]]
        sweeps["roughness"] = [Run(f"roughness-{r}", "glossy", sw, (f"defaults.roughness={r}",), ("solid-angle", "bsdf"),
                                   MIS_MODES, out_dir, "the roughness sweep") for r in lab["roughness"]]
        for key, name, sets in (("roughness_polygon", "polygon-roughness", ()),
                                ("roughness_polygon_metal", "polygon-metal-roughness", ("materials.floor.metallic=1",))):
            sweeps[key] = [Run(f"{name}-{r}", "polygon-near", sw, (f"defaults.roughness={r}",) + sets,
                               LAB_POLYGON_ROUGHNESS_STRATEGIES, ("none", "power"), out_dir) for r in lab["roughness"]]
    return head, sweeps


def many_param_sets(m, p, k):
    """The scene overrides of MANY_PARAMS' configuration (M, p, k)."""
    sets = ["render.light_selection=restir", 'render.restir.source="bvh"', f"render.restir.candidates={m}",
            f"render.restir.spatial_passes={p}"]
    if p:
        sets += ["render.restir.pairwise=true", "render.restir.visibility_reuse=false", f"render.restir.neighbors={k}"]
    return sets


def many_plan(args, cfg, out_dir):
    """(headline runs, {selection: sweep runs}): every selection method with every strategy on each many-light
    scene (sponza-lanterns optional: its model data lives in ../shared/scenes), and the lights-count sweep of
    many-spheres for each method of MANY_SWEEP_SELECTIONS."""
    head, sweeps = [], {}
    if args.only == "params":
        for key in MANY_PARAM_SCENES:
            if args.scene and key not in args.scene:
                continue
            scene, count_key, scene_sets = MANY_SCENES[key]
            sets = (f"{count_key}={cfg['lights']}",) + tuple(cfg.get("sets", ())) + scene_sets
            configs = {"power": MANY_SELECTIONS["power"], "bvh": MANY_SELECTIONS["bvh"],
                       **{name: many_param_sets(*v) for name, v in MANY_PARAMS.items()}}
            sweeps[f"params:{key}"] = [Run(f"params-{key}-{name}", scene, cfg["headline"], sets + tuple(extra),
                                           ("solid-angle",), ("power",), out_dir) for name, extra in configs.items()]
        return head, sweeps
    if args.only != "sweeps":
        for key, (scene, count_key, scene_sets) in MANY_SCENES.items():
            if args.scene and key not in args.scene:
                continue
            sets = (f"{count_key}={cfg['lights']}",) + tuple(cfg.get("sets", ())) if count_key else ()
            head += [Run(f"{key}-{sel}", scene, cfg["headline"], sets + scene_sets + tuple(extra),
                         tuple(MANY_SELECTION_STRATEGIES.get(sel, MANY_STRATEGIES)), ("power",), out_dir,
                         None if count_key else scene)
                     for sel, extra in MANY_SELECTIONS.items() if not args.selection or sel in args.selection]
    if args.only != "headline" and (not args.scene or "many-spheres" in args.scene):
        for sel in MANY_SWEEP_SELECTIONS:
            if args.selection and sel not in args.selection:
                continue
            sweeps[sel] = [Run(f"count-{n}-{sel}", "many-spheres", cfg["sweep"],
                               (f"defaults.lights={n}",) + tuple(cfg.get("sets", ())) + tuple(MANY_SELECTIONS[sel]),
                               ("solid-angle",), ("power",), out_dir) for n in cfg["counts"]]
    return head, sweeps
