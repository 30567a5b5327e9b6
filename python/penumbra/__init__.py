"""penumbra from Python: render, compare strategies and run convergence experiments.

    import penumbra
    img = penumbra.render("cornell-near", strategy="area", spp=16, width=320, height=180)
    img.rgb          # float32 numpy array (180, 320, 3), linear radiance
    img.variance     # the per-pixel variance of that mean
    img.stats        # backend, device, times, rays, ...

The same scenes, settings and seeds give the same images as ``penumbra render``
(bit for bit on the CPU backend). See docs/python.md.
"""
from __future__ import annotations

import inspect
import json
import os
from dataclasses import dataclass, field
from typing import Any, Callable, Dict, List, Mapping, NamedTuple, Optional, Sequence, Tuple, Union

from ._errors import BackendError, PenumbraError, SceneError

# The data of the built-in scenes (the glossy scene's sky) that a wheel carries.
_DATA = os.path.join(os.path.dirname(os.path.abspath(__file__)), "data")
if os.path.isdir(_DATA):
    os.environ.setdefault("PENUMBRA_DATA", _DATA)

from . import _penumbra  # noqa: E402  (after PENUMBRA_DATA)
from ._penumbra import Image  # noqa: E402

__all__ = [
    "BackendError", "ConvergeResult", "Image", "PenumbraError", "Renderer", "Scene", "SceneError", "build_info",
    "compare", "converge", "converge_plan", "gpu_tuning_keys", "load_scene", "read_exr", "ReferenceChunk", "render",
    "render_reference_chunk", "scenes", "store_reference",
]

ProgressFn = Callable[[int, int], None]
"""Called as ``progress(done, total)`` with samples (paths) done and to do, on the
calling thread, at most every 20 ms."""

SceneLike = Union[str, "os.PathLike[str]", Mapping[str, Any], "Scene"]
"""A built-in scene's name, a scene file, a scene document (a dict, as in a scene
file), or a Scene."""

_BACKENDS = ("auto", "cpu", "optix")
_DENOISERS = ("oidn", "optix")
_DENOISE_QUALITIES = ("fast", "balanced", "high")


def _oidn_library() -> str:
    """libOpenImageDenoise of the PyPI package pyoidn where it is installed, else "" (the system's)."""
    import importlib.util
    spec = importlib.util.find_spec("pyoidn")
    if spec is None or not spec.origin:
        return ""
    path = os.path.join(os.path.dirname(spec.origin), "oidn", "lib", "libOpenImageDenoise.so.2")
    return path if os.path.exists(path) else ""


def _check_denoiser(denoiser: str, quality: str) -> None:
    if denoiser not in _DENOISERS:
        raise ValueError(f"denoiser must be one of {', '.join(_DENOISERS)}, not {denoiser!r}")
    if quality not in _DENOISE_QUALITIES:
        raise ValueError(f"denoise_quality must be one of {', '.join(_DENOISE_QUALITIES)}, not {quality!r}")


def _jsonable(value: Any) -> Any:
    """numpy scalars and arrays, tuples and paths as JSON values."""
    if hasattr(value, "tolist"):  # numpy arrays and scalars
        return value.tolist()
    if isinstance(value, tuple):
        return [_jsonable(v) for v in value]
    if isinstance(value, os.PathLike):
        return os.fspath(value)
    raise TypeError(f"{type(value).__name__} is not a scene value")


def _override_list(overrides: Optional[Mapping[str, Any]]) -> List[str]:
    """{"light.radius": 0.05} -> ["light.radius=0.05"]: penumbra's --set syntax."""
    if overrides is None:
        return []
    if not isinstance(overrides, Mapping):
        raise TypeError(f"overrides must be a dict of 'key': value, not {type(overrides).__name__}")
    out = []
    for key, value in overrides.items():
        if not isinstance(key, str) or not key:
            raise TypeError(f"override keys are non-empty strings such as 'light.radius', not {key!r}")
        out.append(f"{key}={json.dumps(value, default=_jsonable)}")
    return out


def _frame_overrides(strategy: Optional[str] = None, spp: Optional[int] = None, width: Optional[int] = None,
                     height: Optional[int] = None, seed: Optional[int] = None, max_depth: Optional[int] = None,
                     mis: Optional[str] = None, light_selection: Optional[str] = None,
                     slc_cut: Optional[int] = None) -> Dict[str, Any]:
    """The keyword arguments of render() as scene overrides (validated by the scene parser)."""
    named = {"render.strategy": strategy, "render.spp": spp, "render.width": width, "render.height": height,
             "render.seed": seed, "render.max_depth": max_depth, "render.mis": mis,
             "render.light_selection": light_selection, "render.slc_cut": slc_cut}
    return {k: v for k, v in named.items() if v is not None}


def _check_backend(backend: str) -> str:
    if backend not in _BACKENDS:
        raise ValueError(f"backend must be one of {', '.join(_BACKENDS)}, not {backend!r}")
    return backend


GpusLike = Union[str, int, Sequence[int]]
"""Which GPUs render: "all", a number of GPUs (the first N) or a list of CUDA
device indices such as [0, 2] (or "0,2"), as ``penumbra render --gpus``."""


def _gpus(gpus: GpusLike) -> str:
    """gpus as --gpus's text (its syntax is checked by the library)."""
    if isinstance(gpus, bool):
        raise TypeError("gpus must be 'all', a number of GPUs or a list of GPU indices, not a bool")
    if isinstance(gpus, int):
        return str(gpus)
    if isinstance(gpus, str):
        return gpus
    if isinstance(gpus, Sequence) and all(isinstance(g, int) and not isinstance(g, bool) for g in gpus):
        if not gpus:
            raise ValueError("gpus: an empty list of GPUs")
        return ",".join(str(g) for g in gpus) + ("," if len(gpus) == 1 else "")  # "1,": GPU 1, not one GPU
    raise TypeError(f"gpus must be 'all', a number of GPUs or a list of GPU indices, not {gpus!r}")


GpuTuningLike = Union[None, str, Mapping[str, Any], Sequence[str]]
"""The GPU's tuning knobs, as ``penumbra render --tune``: a dict of key -> value
({"cuda_occ": 0, "shadow_order": "queue"}), "KEY=VALUE" strings (a list, or one
string, comma-separated), or None for the defaults. ``gpu_tuning_keys()`` lists the
keys (docs/guide.md has the table); the CPU backend ignores them."""


def _gpu_tuning(gpu_tuning: GpuTuningLike) -> List[str]:
    """gpu_tuning as --tune's KEY=VALUE strings (the keys and values are checked by the library)."""
    if gpu_tuning is None:
        return []
    if isinstance(gpu_tuning, str):
        return [a for a in gpu_tuning.split(",") if a]
    if isinstance(gpu_tuning, Mapping):
        def text(v: Any) -> str:
            return ("true" if v else "false") if isinstance(v, bool) else str(v)
        return [f"{k}={text(v)}" for k, v in gpu_tuning.items()]
    if isinstance(gpu_tuning, Sequence) and all(isinstance(a, str) for a in gpu_tuning):
        return list(gpu_tuning)
    raise TypeError(f"gpu_tuning must be a dict of key -> value or KEY=VALUE strings, not {gpu_tuning!r}")


def gpu_tuning_keys() -> List[Dict[str, str]]:
    """The GPU's tuning keys (``gpu_tuning=`` of render, Renderer and converge; ``penumbra
    render --tune``): each a dict with ``key``, ``values`` (the accepted ones), ``default``
    and ``help``."""
    return [dict(zip(("key", "values", "default", "help"), k)) for k in _penumbra.gpu_tuning_keys()]


def _threads(threads: Optional[int]) -> int:
    if threads is None:
        return 0
    if isinstance(threads, bool) or not isinstance(threads, int) or threads < 0:
        raise ValueError(f"threads must be a non-negative integer (0: all cores), not {threads!r}")
    return threads


def scenes() -> List[str]:
    """The names of the built-in scenes (``penumbra scenes``)."""
    return [name for name, _ in _penumbra.scenes()]


def build_info() -> Dict[str, Any]:
    """What this module was built with: ``optix`` (the GPU backend is in it),
    ``gpu_available`` and, if not, ``gpu_unavailable_reason``, ``gpus`` (how
    many this process sees), ``strategies``, ``git_commit``."""
    return _penumbra.build_info()


class Scene:
    """A parsed, validated scene: load one with :func:`load_scene`.

    Scenes are immutable; :meth:`with_overrides` makes a changed copy."""

    __slots__ = ("_state",)

    def __init__(self, state: "_penumbra.Scene"):
        self._state = state

    @property
    def source(self) -> str:
        """Where the scene came from: ``builtin:<name>``, a file path, or ``<dict>``."""
        return self._state.source

    def to_dict(self) -> Dict[str, Any]:
        """The scene document after overrides, as a dict (save it with json.dump and
        render the file, or pass it to load_scene)."""
        return self._state.to_py()

    def with_overrides(self, overrides: Mapping[str, Any]) -> "Scene":
        """A copy with more overrides, e.g. ``{"light.radius": 0.05}`` (see load_scene)."""
        return Scene(self._state.with_overrides(_override_list(overrides)))

    def counts(self) -> Dict[str, int]:
        """Triangles, spheres, lights, materials, meshes, instances and textures."""
        return self._state.counts()

    def __repr__(self) -> str:
        c = self.counts()
        return f"<penumbra.Scene {self.source}: {c['triangles']} triangles, {c['spheres']} spheres, {c['lights']} lights>"


def load_scene(scene: SceneLike, overrides: Optional[Mapping[str, Any]] = None) -> Scene:
    """Loads and validates a scene.

    Args:
        scene: a built-in scene's name (see :func:`scenes`), a scene file (JSON,
            docs/scene-format.md), a scene document as a dict (relative file paths
            in it are relative to the current directory), or a Scene.
        overrides: scene values to change, as ``penumbra render --set`` does:
            ``{"light.radius": 0.05, "camera.fov": 30, "render.strategy": "area"}``
            ("light." is short for "lights.0."; array elements by index).

    Raises:
        SceneError: with ``file`` and ``field``, for anything invalid.
    """
    ov = _override_list(overrides)
    if isinstance(scene, Scene):
        return scene.with_overrides(overrides or {})
    if isinstance(scene, Mapping):
        try:
            text = json.dumps(scene, default=_jsonable, allow_nan=False)
        except (TypeError, ValueError) as e:
            raise SceneError(f"<dict>: not a JSON document: {e}", "<dict>", None) from None
        return Scene(_penumbra.load_scene_json(text, "<dict>", os.getcwd(), ov))
    if isinstance(scene, (str, os.PathLike)):
        return Scene(_penumbra.load_scene_name(os.fspath(scene), ov))
    raise TypeError(f"scene must be a name, a path, a dict or a Scene, not {type(scene).__name__}")


def render(scene: SceneLike, *, strategy: Optional[str] = None, spp: Optional[int] = None,
           width: Optional[int] = None, height: Optional[int] = None, seed: Optional[int] = 0,
           max_depth: Optional[int] = None, backend: str = "auto", mis: Optional[str] = None,
           light_selection: Optional[str] = None, slc_cut: Optional[int] = None,
           denoise: bool = False, denoiser: str = "oidn", denoise_quality: str = "high",
           overrides: Optional[Mapping[str, Any]] = None, threads: Optional[int] = None,
           gpus: GpusLike = "all", gpu_tuning: GpuTuningLike = None,
           progress: Optional[ProgressFn] = None) -> Image:
    """Renders a scene and returns the image.

    Every setting left at None keeps the scene's own value, as on the command
    line: ``render("cornell-sphere", spp=64, seed=3, backend="cpu")`` gives the
    image of ``penumbra render cornell-sphere --spp 64 --seed 3 --backend cpu``.

    Args:
        scene: a built-in scene's name, a scene file, a dict or a Scene (see load_scene).
        strategy: "area", "solid-angle", "projected-solid-angle", "ltc" or "bsdf".
        spp: samples per pixel.
        width, height: the image size in pixels.
        seed: the random seed: the image is a pure function of scene, settings and seed
            (None: the scene's own, as on the command line).
        max_depth: the maximum number of bounces.
        backend: "cpu", "optix" (the GPU) or "auto" (the GPU where it works, else the CPU;
            ``image.stats["note"]`` says which and why).
        mis: multiple importance sampling ("none", "balance" or "power"), passed as the
            scene value render.mis where this penumbra's scenes have it.
        light_selection: which light a sample goes to: "uniform", "power", "bvh", "sg-bvh", "slc"
            or "restir" (render.light_selection; restir's own settings through overrides).
        slc_cut: light_selection "slc": the most nodes of a cut, a light sample each (render.slc_cut).
        denoise: also denoise the image: ``image.denoised`` is the denoised mean and
            ``image.albedo``, ``image.normal`` the denoiser's guides, float32 (H, W, 3) numpy
            arrays (None without denoise); ``image.stats["denoiser"]`` says which ran.
        denoiser: "oidn" (Intel Open Image Denoise, every backend: the PyPI package pyoidn's
            library, else the system's) or "optix" (the OptiX AI denoiser, GPU backend only).
        denoise_quality: OIDN's "fast", "balanced" or "high".
        overrides: other scene values to change (see load_scene).
        threads: CPU threads (default: all cores).
        gpus: the GPUs of the "optix" backend: "all" (default), a number N (the first N)
            or a list of device indices; several split the samples of every pixel
            (the same image; ``image.stats["devices"]`` has each one's share and time).
        gpu_tuning: the GPU's tuning knobs (GpuTuningLike: a dict such as {"cuda_occ": 0}, as
            ``penumbra render --tune cuda_occ=0``); a bad key or value raises ValueError naming it.
        progress: called as progress(done, total) while rendering.

    Raises:
        SceneError: a bad scene or setting (names the field).
        BackendError: the backend cannot run here, or failed; the denoiser cannot run (OIDN's
            library not found, or denoiser="optix" on the CPU backend), before any rendering.
        KeyboardInterrupt: Ctrl-C stops the render.
    """
    _check_denoiser(denoiser, denoise_quality)
    if denoise and denoiser == "optix" and _check_backend(backend) == "cpu":
        raise BackendError("denoise=True: the OptiX AI denoiser needs the GPU backend: backend='cpu' renders on the "
                           "CPU (denoiser='oidn' denoises on any backend)")
    s = load_scene(scene, overrides)
    r = Renderer(s, backend=backend, strategy=strategy, spp=spp, width=width, height=height, seed=seed,
                 max_depth=max_depth, mis=mis, light_selection=light_selection, slc_cut=slc_cut, threads=threads,
                 gpus=gpus,
                 gpu_tuning=gpu_tuning)
    if denoise:  # the denoiser's checks (its library, its backend) before rendering
        r._check_denoise(denoiser, denoise_quality)
    img = r.render(r.settings["spp"], progress=progress)
    return r.image(denoise=True, denoiser=denoiser, denoise_quality=denoise_quality) if denoise else img


class Renderer:
    """Progressive rendering of one scene on one backend.

        r = penumbra.Renderer("cornell-sphere", backend="cpu", width=320, height=180)
        for _ in range(8):
            img = r.render(4)            # adds 4 samples per pixel; img has them all
        r.set(strategy="area")           # frame settings: no rebuild, the image starts over
        r.set(overrides={"light.radius": 0.1})  # the light: the backend is rebuilt

    Changes of strategy, depth, seed, size, camera and mis reuse the backend (its
    acceleration structures and device data); other scene changes rebuild it
    (``builds`` counts how often). Any change starts the accumulation over.
    ``gpus`` as in render(): with one GPU the image stays on it (DLPack); several
    split every render() call and the image is accumulated on the host. ``gpu_tuning``
    as in render().
    """

    def __init__(self, scene: SceneLike, *, backend: str = "auto", strategy: Optional[str] = None,
                 spp: Optional[int] = None, width: Optional[int] = None, height: Optional[int] = None,
                 seed: Optional[int] = 0, max_depth: Optional[int] = None, mis: Optional[str] = None,
                 light_selection: Optional[str] = None, slc_cut: Optional[int] = None,
                 overrides: Optional[Mapping[str, Any]] = None, threads: Optional[int] = None,
                 gpus: GpusLike = "all", gpu_tuning: GpuTuningLike = None):
        tuning = _gpu_tuning(gpu_tuning)
        s = scene if isinstance(scene, Scene) else load_scene(scene)
        frame = _frame_overrides(strategy, spp, width, height, seed, max_depth, mis, light_selection, slc_cut)
        frame.update(overrides or {})
        self._r = _penumbra.Renderer(s._state, _check_backend(backend), _threads(threads), _gpus(gpus),
                                     _override_list(frame), tuning)

    def render(self, spp: int = 1, *, progress: Optional[ProgressFn] = None) -> Image:
        """Adds ``spp`` samples per pixel and returns the image of all samples so far.

        Ctrl-C stops it with KeyboardInterrupt; the samples of earlier calls stay."""
        if isinstance(spp, bool) or not isinstance(spp, int) or not 1 <= spp <= (1 << 24):
            raise ValueError(f"spp must be an integer in [1, {1 << 24}], not {spp!r}")
        self._r.render(spp, progress)
        return self._r.image()

    def image(self, *, denoise: bool = False, denoiser: str = "oidn", denoise_quality: str = "high") -> Image:
        """The image of all samples so far (a snapshot: later samples do not change it).

        With ``denoise``, also ``image.denoised`` and its guides ``image.albedo``,
        ``image.normal`` (see render() for the denoiser's choices; BackendError where it
        cannot run); the guides are rendered once per frame and kept until the image
        starts over."""
        _check_denoiser(denoiser, denoise_quality)
        return self._r.image(denoise, denoiser, denoise_quality, _oidn_library() if denoiser == "oidn" else "")

    def _check_denoise(self, denoiser: str, denoise_quality: str) -> None:
        """BackendError where the denoiser cannot run on this renderer (before any samples)."""
        if denoiser == "optix" and self.backend != "optix":
            raise BackendError("denoise=True: the OptiX AI denoiser needs the GPU backend: the image is rendered on "
                               f"the {self.backend} backend ({self.note}) (denoiser='oidn' denoises on any backend)")
        if denoiser == "oidn":
            self._r.check_oidn(_oidn_library())

    def reset(self) -> None:
        """Drops the samples: the next render() starts a new image."""
        self._r.reset()

    def set(self, *, strategy: Optional[str] = None, width: Optional[int] = None, height: Optional[int] = None,
            seed: Optional[int] = None, max_depth: Optional[int] = None, mis: Optional[str] = None,
            light_selection: Optional[str] = None, slc_cut: Optional[int] = None,
            overrides: Optional[Mapping[str, Any]] = None) -> None:
        """Changes settings or scene values (see the class) and starts the image over.

        Raises SceneError, leaving everything as it was, if a value is invalid."""
        frame = _frame_overrides(strategy, None, width, height, seed, max_depth, mis, light_selection, slc_cut)
        frame.update(overrides or {})
        self._r.update(_override_list(frame))

    @property
    def spp(self) -> int:
        """Samples per pixel accumulated so far."""
        return self._r.samples

    @property
    def backend(self) -> str:
        """"cpu" or "optix"."""
        return self._r.backend

    @property
    def device(self) -> str:
        """The device, e.g. "2 CPU threads (Embree 3.13.5)" or the GPU, driver and OptiX."""
        return self._r.device

    @property
    def note(self) -> str:
        """Which backend was chosen and why (as ``penumbra render`` prints it)."""
        return self._r.note

    @property
    def builds(self) -> int:
        """How many times the backend was built for this renderer (1 + rebuilds)."""
        return self._r.builds

    @property
    def scene(self) -> Scene:
        """The scene with every change made so far."""
        return Scene(self._r.scene)

    @property
    def settings(self) -> Dict[str, Any]:
        """width, height, spp (the scene's), strategy, max_depth, rr_depth, seed."""
        return self._r.settings

    def __repr__(self) -> str:
        return f"<penumbra.Renderer {self._r.scene.source} on {self.backend}: {self.spp} spp>"


@dataclass
class ConvergeResult:
    """What ``penumbra converge`` writes: ``measurements`` (the rows of
    measurements.csv, one dict per render: scene, strategy, spp, seed, time_ms
    (GPU time on the GPU, wall time on the CPU), wall_ms (the render call's wall
    time, the read-back included), rmse, rmse_nolight, relmse, relmse_nolight)
    and ``summary`` (summary.json: settings, reference, per-strategy points,
    fits, efficiency)."""

    measurements: List[Dict[str, Any]] = field(default_factory=list)
    summary: Dict[str, Any] = field(default_factory=dict)

    @property
    def fits(self) -> Dict[str, Dict[str, Any]]:
        """Per strategy: the log-log fits of RMSE against spp (fit_rmse,
        fit_rmse_nolight: slope, intercept, spp_to_threshold, ms_to_threshold,
        read off the fitted line; fit_spp, the spp it was fitted to; extrapolated,
        whether spp_to_threshold lies beyond them), ms_per_spp, wall_ms_per_spp,
        efficiency and efficiency_nolight."""
        return {name: {k: v for k, v in s.items() if k != "points"}
                for name, s in self.summary.get("strategies", {}).items()}


def converge(scene: Union[str, "os.PathLike[str]"], *, strategies: Sequence[str] = ("area", "solid-angle"),
             mis: Sequence[str] = ("none",), max_spp: int = 1024, seeds: int = 4, reference_spp: int = 65536,
             reference_strategy: str = "solid-angle", reference_mis: str = "power", reference_selection: str = "power",
             reference_chunk: int = 4096, width: Optional[int] = None, height: Optional[int] = None,
             overrides: Optional[Mapping[str, Any]] = None, backend: str = "auto", gpus: GpusLike = "all",
             gpu_tuning: GpuTuningLike = None, threads: Optional[int] = None, cache: Optional[str] = None,
             out: Optional[str] = None,
             threshold: float = 0.05, crop_spp: int = 32, crop: Optional[Sequence[int]] = None, fit_min_spp: int = 4,
             frame_spp: int = 0, verbose: bool = False, yes: bool = False, estimate_only: bool = False,
             progress: Optional[ProgressFn] = None) -> ConvergeResult:
    """One convergence experiment, as ``penumbra converge`` runs it: a ground truth
    (cached under ``cache``, default $XDG_CACHE_HOME/penumbra, else ~/.cache/penumbra; rendered in chunks of
    ``reference_chunk`` spp added in order), then 1, 2, 4, ... max_spp
    spp for each technique (every strategy with every ``mis`` mode; named
    "area" for MIS none, "area+power" otherwise) with ``seeds`` seeds, errors
    against the ground truth, fits. With ``out``, also writes the CLI's files there (measurements.csv,
    summary.json, crops, images).

    ``scene`` is a built-in scene's name or a scene file; ``overrides`` as in
    load_scene; ``gpus`` and ``gpu_tuning`` as in render(). The other arguments are the CLI's options of the same
    names.

    Before rendering, the run time is estimated from a measured render; on the
    CPU, an estimate over an hour raises ValueError unless ``yes``. With
    ``estimate_only``, nothing is rendered or written: ``summary`` holds
    ``estimated_seconds``, ``backend``, ``device`` and ``reference_cached``.
    """
    options = {k: v for k, v in locals().items() if k not in ("scene", "progress")}
    rows, summary = _penumbra.converge(_converge_options(scene, options), progress)
    return ConvergeResult(rows, summary)


def _converge_options(scene: Union[str, "os.PathLike[str]"], options: Mapping[str, Any]) -> Any:
    """converge()'s keyword arguments (any subset; the rest take converge()'s
    defaults) as the library's ConvergeOptions. TypeError for an unknown name."""
    if not isinstance(scene, (str, os.PathLike)):
        raise TypeError("converge() takes a built-in scene's name or a scene file (save a dict with json.dump)")
    params = inspect.signature(converge).parameters
    unknown = [k for k in options if k not in params or k in ("scene", "progress")]
    if unknown:
        raise TypeError(f"unknown converge option(s): {', '.join(unknown)}")
    a = {k: p.default for k, p in params.items() if k not in ("scene", "progress")}
    a.update(options)
    o = _penumbra.ConvergeOptions()
    o.scene = os.fspath(scene)
    o.sets = _override_list(a["overrides"])
    o.out = os.fspath(a["out"]) if a["out"] else ""
    o.cache = os.fspath(a["cache"]) if a["cache"] else _penumbra.default_cache_dir()
    o.backend = _check_backend(a["backend"])
    o.gpus = _gpus(a["gpus"])
    o.set_gpu_tuning(_gpu_tuning(a["gpu_tuning"]))
    o.strategies = [a["strategies"]] if isinstance(a["strategies"], str) else list(a["strategies"])
    o.mis = [a["mis"]] if isinstance(a["mis"], str) else list(a["mis"])
    o.reference_strategy = a["reference_strategy"]
    o.reference_mis = a["reference_mis"]
    o.reference_selection = a["reference_selection"]
    o.width = a["width"] or 0
    o.height = a["height"] or 0
    for k in ("max_spp", "seeds", "reference_spp", "reference_chunk", "crop_spp", "fit_min_spp", "frame_spp"):
        setattr(o, k, a[k])
    o.threads = _threads(a["threads"])
    o.threshold = float(a["threshold"])
    o.crop = list(a["crop"] or [])
    o.verbose = bool(a["verbose"])
    o.yes = bool(a["yes"])
    o.estimate_only = bool(a["estimate_only"])
    return o


def converge_plan(scene: Union[str, "os.PathLike[str]"], **options: Any) -> Dict[str, Any]:
    """What converge(scene, **options) will do, without rendering: a dict with
    ``reference`` (``key``: the ground-truth cache's key, ``path`` and ``var_path``:
    its files, ``width``, ``height``, ``spp``, ``chunk_spp``, ``chunks``, ``cached``)
    and ``techniques`` (in the order of measurements.csv: ``name``, ``strategy``, ``mis``).
    ``options`` are converge()'s keyword arguments. Raises SceneError as converge() does."""
    return _penumbra.converge_plan(_converge_options(scene, options))


class ReferenceChunk(NamedTuple):
    """One chunk of a ground truth (render_reference_chunk)."""

    sum: Any      # float64 (H, W, 3): the per-pixel sums of the samples' radiance
    sum_sq: Any   # float64 (H, W, 3): ... and of its squares
    samples: int  # samples per pixel in the chunk
    nonfinite: int  # samples that were NaN or infinite (left out of the sums)


def render_reference_chunk(scene: Union[str, "os.PathLike[str]"], index: int, *,
                           progress: Optional[ProgressFn] = None, **options: Any) -> ReferenceChunk:
    """Chunk ``index`` of the ground truth that converge(scene, **options) uses
    (samples [index * chunk_spp, ...) of every pixel, see converge_plan()): a
    ReferenceChunk of the per-pixel sums of the samples' radiance and of its
    squares (float64 arrays (H, W, 3)), the samples per pixel and how many
    samples were NaN or infinite.

    Chunks may be rendered anywhere (e.g. as tasks on a cluster); their sums
    added in chunk order (``sum = s0 + s1 + ...`` in float64, as numpy adds them)
    are, to the bit, the sums converge() accumulates: store_reference() turns
    them into its cached ground truth."""
    s, s2, n, bad = _penumbra.render_reference_chunk(_converge_options(scene, options), int(index), progress)
    return ReferenceChunk(s, s2, int(n), int(bad))


def store_reference(scene: Union[str, "os.PathLike[str]"], sums: Any, sums_sq: Any, **options: Any) -> str:
    """Writes the ground truth of converge(scene, **options) into its cache from
    the sums of all its samples (every chunk of render_reference_chunk(), added
    in chunk order), as converge() writes it; converge() then finds it there.
    Returns the mean's path. Raises ValueError when the sums do not have the
    plan's size."""
    import numpy as np

    o = _converge_options(scene, options)
    plan = _penumbra.converge_plan(o)["reference"]
    s = np.ascontiguousarray(sums, dtype=np.float64)
    s2 = np.ascontiguousarray(sums_sq, dtype=np.float64)
    _penumbra.store_reference(o, s, s2, plan["spp"])
    return plan["path"]


def _mean_and_variance(x: Any) -> Tuple[Any, Any]:
    import numpy as np

    if isinstance(x, Image):
        return x.rgb, x.variance
    mean, var = x
    return np.ascontiguousarray(mean, dtype=np.float32), np.ascontiguousarray(var, dtype=np.float32)


def compare(a: Union[Image, Tuple[Any, Any]], b: Union[Image, Tuple[Any, Any]], *, max_mean_rel_diff: float = 0.01,
            max_image_z: float = 4.0, outlier_z: float = 5.0, max_outlier_fraction: float = 0.002) -> Dict[str, Any]:
    """Are two renders the same image? ``penumbra compare``'s two tests
    (src/render/compare.h): the statistical test (per-pixel z = (a - b) /
    sqrt(var_a + var_b), the image means within ``max_image_z`` standard errors)
    and the bound on the image means' relative difference (``max_mean_rel_diff``,
    never widened by their noise). ``a`` and ``b`` are Images or (mean, variance)
    array pairs. Returns a dict with ``pass`` (both), ``statistical_pass``,
    ``bound_pass``, ``mean_rel_diff``, ``mean_rel_se``, ``mean_z2``, ``image_z``,
    ``max_abs_z``, ``outliers``, ``summary`` (one line), ``report`` (the summary and
    each test's line), ..."""
    am, av = _mean_and_variance(a)
    bm, bv = _mean_and_variance(b)
    return _penumbra.compare(am, av, bm, bv, max_mean_rel_diff, max_image_z, outlier_z, max_outlier_fraction)


def read_exr(path: Union[str, "os.PathLike[str]"]) -> Any:
    """An EXR image (as ``penumbra render -o x.exr`` writes) as a float32 array (H, W, 3)."""
    return _penumbra.read_exr(os.fspath(path))
