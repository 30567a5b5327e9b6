"""How the study's runs run: the local executor (`penumbra converge` one run
after the other, or penumbra.converge() with --engine python) with its estimate,
and the entry to the Ray executor (ray_executor.py)."""
import hashlib
import json
import os
import subprocess
from collections import namedtuple

from .common import RunFailed, format_seconds, log, write_atomic

CONFIRM_SECONDS = 3600  # past this estimate on the CPU, --yes is needed (as `penumbra converge` asks)


def parse_set(assignment):
    """"key=value" (penumbra's --set) as a key and a value (JSON where it parses, else a string)."""
    key, _, text = assignment.partition("=")
    try:
        return key, json.loads(text)
    except ValueError:
        return key, text


def run_dir(args, r):
    return os.path.join(r.out_dir or args.out, "runs", r.name)


def converge_cmd(args, r):
    cmd = [args.penumbra, "converge", r.scene, "--out", run_dir(args, r), "--backend", args.backend,
           "--gpus", args.gpus, "--width", str(r.cfg["width"]), "--height", str(r.cfg["height"]),
           "--reference-spp", str(r.cfg["reference_spp"]), "--reference-chunk", str(r.cfg["reference_chunk"]),
           "--max-spp", str(r.cfg["max_spp"]), "--seeds", str(r.cfg["seeds"]),
           "--strategies", ",".join(r.strategies), "--mis", ",".join(r.mis)]
    if r.cfg.get("frame_spp"):
        cmd += ["--frame-spp", str(r.cfg["frame_spp"])]
    if r.cfg.get("reference_selection"):
        cmd += ["--reference-selection", r.cfg["reference_selection"]]
    if args.cache:
        cmd += ["--cache", args.cache]
    for s in r.sets:
        cmd += ["--set", s]
    return cmd


def run_cmd(cmd, **kw):
    """A penumbra command; RunFailed with its exit status when it fails (its message is on stderr)."""
    p = subprocess.run(cmd, **kw)
    if p.returncode == 130:
        raise KeyboardInterrupt
    if p.returncode not in (0, 4):  # 4: outputs written, some samples dropped (penumbra said where)
        raise RunFailed(f"`{' '.join(cmd[:3])} ...` exited with status {p.returncode}", p.returncode)
    return p


def converge_options(args, r):
    """A run as penumbra.converge()'s keyword arguments (the CLI's options of the same names)."""
    return dict(backend=args.backend, gpus=args.gpus, width=r.cfg["width"], height=r.cfg["height"],
                reference_spp=r.cfg["reference_spp"], reference_chunk=r.cfg["reference_chunk"],
                max_spp=r.cfg["max_spp"], seeds=r.cfg["seeds"], strategies=list(r.strategies), mis=list(r.mis),
                frame_spp=r.cfg.get("frame_spp", 0), reference_selection=r.cfg.get("reference_selection", "power"),
                cache=args.cache, overrides=dict(parse_set(s) for s in r.sets))


def python_converge(args, r, **kw):
    """The same experiment in this process: penumbra.converge() is the CLI's code."""
    import penumbra
    try:
        return penumbra.converge(r.scene, **converge_options(args, r), **kw)
    except (penumbra.PenumbraError, ValueError) as e:
        raise RunFailed(str(e)) from e


# --- Resuming (--resume) ---------------------------------------------------------------

def default_cache():
    """penumbra's own ground-truth cache folder (`penumbra converge` without --cache; docs/guide.md)."""
    if os.environ.get("XDG_CACHE_HOME"):
        return os.path.join(os.environ["XDG_CACHE_HOME"], "penumbra")
    if os.environ.get("HOME"):
        return os.path.join(os.environ["HOME"], ".cache", "penumbra")
    return ".penumbra-cache"


def sha256_file(path):
    h = hashlib.sha256()
    with open(path, "rb") as f:
        for block in iter(lambda: f.read(1 << 20), b""):
            h.update(block)
    return h.hexdigest()


def penumbra_identity(args):
    """What made a run: the executable's version line (its commit), size and modification time, or the Python
    module's build; measured once."""
    if getattr(args, "identity", None) is None:
        if args.engine == "python":
            import penumbra
            args.identity = {"module": penumbra.build_info()}
        else:
            p = subprocess.run([args.penumbra, "--version"], stdout=subprocess.PIPE, stderr=subprocess.DEVNULL,
                               text=True)
            st = os.stat(args.penumbra)
            args.identity = {"version": p.stdout.strip(), "size": st.st_size, "mtime_ns": st.st_mtime_ns}
    return args.identity


class Ledger:
    """The local executor's finished runs, for --resume: one file per run under <cache>/study-local/, named by a
    hash of the run's command and the penumbra that ran it, holding the hash of the output it left (summary.json,
    or bench's JSON). A run is done when its entry exists and its output is still that file: the same command
    with another penumbra, or an output another run has since overwritten, runs again."""

    def __init__(self, args):
        self.folder = os.path.join(args.cache or default_cache(), "study-local")
        self.args = args

    def entry(self, command):
        text = json.dumps({"command": command, "penumbra": penumbra_identity(self.args)}, sort_keys=True)
        return os.path.join(self.folder, "run-" + hashlib.sha256(text.encode()).hexdigest()[:24] + ".json")

    def done(self, command, output):
        try:
            with open(self.entry(command)) as f:
                kept = json.load(f)
            return os.path.abspath(output) == kept["output"] and sha256_file(output) == kept["sha256"]
        except (OSError, ValueError, KeyError):
            return False

    def mark(self, command, output):
        os.makedirs(self.folder, exist_ok=True)
        record = {"command": command, "output": os.path.abspath(output), "sha256": sha256_file(output)}

        def w(tmp):
            with open(tmp, "w") as f:
                json.dump(record, f)
        write_atomic(self.entry(command), w)


def run_command(args, r):
    """What identifies a run for --resume: its `penumbra converge` command (without --yes), or penumbra.converge()'s
    arguments with --engine python."""
    if args.engine == "python":
        return ["penumbra.converge", r.scene, run_dir(args, r), converge_options(args, r)]
    return converge_cmd(args, r)


def resumed(args, r):
    """--resume: whether an earlier study finished this run with the same command and penumbra (its files kept)."""
    return args.resume and args.executor == "local" and \
        args.ledger.done(run_command(args, r), os.path.join(run_dir(args, r), "summary.json"))


def estimate(args, r):
    """penumbra's estimate of one run (it measures the backend): (seconds, backend name)."""
    if args.engine == "python":
        e = python_converge(args, r, estimate_only=True).summary
    else:
        p = subprocess.run(converge_cmd(args, r) + ["--estimate-only"], stdout=subprocess.PIPE,
                           stderr=subprocess.PIPE, text=True)
        if p.returncode == 130:
            raise KeyboardInterrupt
        if p.returncode != 0:
            raise RunFailed(p.stderr.strip().splitlines()[-1] if p.stderr.strip() else
                            f"penumbra converge exited with status {p.returncode}", p.returncode)
        e = json.loads(p.stdout.strip().splitlines()[-1])
    return e["estimated_seconds"], e["backend"]


def plan(args, runs):
    """Estimates every run before any starts; leaves out the optional groups that
    cannot run here; stops when the CPU would take over an hour without --yes.
    With --no-estimate only the first run of each optional group is tried (its
    estimate loads the scene); each run still prints its own estimate, and on
    the CPU refuses to run past an hour without --yes."""
    args.estimated = not args.no_estimate
    if args.resume:
        done = [r for r in runs if resumed(args, r)]
        if done:
            log(f"study: --resume: {len(done)} of {len(runs)} runs finished earlier with the same command and penumbra "
                "are kept")
        runs_left = [r for r in runs if r not in done]
    else:
        runs_left = runs
    if not args.estimated:
        groups = sorted({r.group for r in runs if r.group is not None})
        log(f"study: {len(runs)} runs, not estimated beforehand (--no-estimate); each prints its own estimate"
            + (f"; trying the optional {', '.join(groups)} first" if groups else ""))
    else:
        log(f"study: estimating {len(runs_left)} runs on --backend {args.backend} ...")
    total, backend, dropped, tried = 0.0, args.backend, set(), set()
    for r in runs_left:
        if r.group in dropped:
            continue
        if not args.estimated:
            if r.group is None or r.group in tried:
                continue
            tried.add(r.group)
        try:
            seconds, backend = estimate(args, r)
        except RunFailed as e:
            if r.group is None:
                raise
            log(f"study: leaving {r.group} out: {e}")
            dropped.add(r.group)
            continue
        total += seconds
    if not args.estimated:
        return [r for r in runs if r.group not in dropped]
    # Groups dropped midway contributed to the total; a slight overestimate is harmless.
    log(f"study: estimated run time {format_seconds(total)} on the {backend} backend")
    if backend == "cpu" and total > CONFIRM_SECONDS and not args.yes:
        raise RunFailed(f"the estimated run time, {format_seconds(total)} on the CPU, is more than an hour: "
                        "pass --yes to run it (or a smaller --preset)", 2)
    return [r for r in runs if r.group not in dropped]


def plan_on_ray(args, runs):
    """The Ray executor's plan: every run's ground truth and techniques
    (penumbra.converge_plan(), which loads the scene here); the optional groups
    whose scene cannot be loaded are left out. No run time is estimated: the
    tasks run on the cluster's machines, not this one."""
    import penumbra
    kept, dropped = [], set()
    for r in runs:
        if r.group in dropped:
            continue
        try:
            kept.append((r, penumbra.converge_plan(r.scene, **converge_options(args, r))))
        except (penumbra.PenumbraError, ValueError) as e:
            if r.group is None:
                raise RunFailed(str(e)) from e
            log(f"study: leaving {r.group} out: {e}")
            dropped.add(r.group)
    return [(r, p) for r, p in kept if r.group not in dropped]


# What the Ray executor needs of a run: its files' folder, and the Run for its options.
RayRun = namedtuple("RayRun", "name scene sets out run")


def run_on_ray(args, planned):
    """Runs the planned runs as Ray tasks (ray_executor.py), which leave each
    run's files in its folder as `penumbra converge` would. {run folder: error}
    for the runs that failed."""
    from . import ray_executor
    runs = [(RayRun(r.name, r.scene, r.sets, run_dir(args, r), r), p) for r, p in planned]
    return ray_executor.execute(args, runs, lambda a, ray_run: converge_options(a, ray_run.run), write_atomic)


def confirmed(args):
    """Whether a run may take over an hour on the CPU without asking: the study's own estimate of every run was
    accepted, or --yes was given."""
    return args.yes or getattr(args, "estimated", False)


def converge(args, r):
    """Runs one experiment (unless --report-only, or done by the Ray executor) and returns its summary."""
    out = run_dir(args, r)
    if out in args.ray_failed:
        raise RunFailed(args.ray_failed[out])
    if not args.report_only and args.executor == "local":
        if resumed(args, r):
            log(f"study: kept (--resume): {out}")
        else:
            if args.engine == "python":
                log(f"study: penumbra.converge({r.scene!r}, out={out!r}, {r.cfg}, overrides={list(r.sets)})")
                python_converge(args, r, out=out, verbose=True, yes=confirmed(args))
            else:
                cmd = converge_cmd(args, r) + (["--yes"] if confirmed(args) else [])
                log("study: " + " ".join(cmd))
                run_cmd(cmd)
            args.ledger.mark(run_command(args, r), os.path.join(out, "summary.json"))
    return load_summary(out, r.name)


def load_summary(out, name):
    with open(os.path.join(out, "summary.json")) as f:
        summary = json.load(f)
    summary["run_dir"] = out
    summary["name"] = name
    return summary


def run_all(args, plan_):
    """Runs a plan (or, with --report-only, loads what an earlier run left: a missing run is left out)."""
    head, sweeps = plan_
    if args.report_only:
        have = lambda r: os.path.exists(os.path.join(run_dir(args, r), "summary.json"))  # noqa: E731
        return ([converge(args, r) for r in head if have(r)],
                {k: [converge(args, r) for r in v] for k, v in sweeps.items() if all(have(r) for r in v)})
    return [converge(args, r) for r in head], {k: [converge(args, r) for r in v] for k, v in sweeps.items()}
