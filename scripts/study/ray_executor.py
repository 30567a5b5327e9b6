"""The Ray executor of scripts/study.py (--executor ray): the study as tasks on a
Ray cluster (or a Ray instance on this machine), through the Python module.

Two kinds of task, each declaring its resources (with the GPU backend
num_gpus=--task-gpus, else num_cpus=--task-cpus):

- a ground-truth chunk: penumbra.render_reference_chunk(), the float64 sums of
  one chunk of samples of an experiment's ground truth;
- a converge point: one technique of one experiment (a headline scene, or a
  sweep point: a scene with the sweep's overrides), measured against the
  experiment's ground truth by penumbra.converge().

This process (the driver) adds each ground truth's chunks in chunk order, which
are then to the bit the sums `penumbra converge` accumulates itself, stores it
in its ground-truth cache and hands its files to the experiment's points; it
writes each experiment's points into the files `penumbra converge` writes
(measurements.csv in technique order, summary.json, crops, images), so that the
study reads and reports them as the local executor's.

Ray retries a task whose worker or node is lost (max_retries); an error of
penumbra itself (a bad scene, a failed backend) fails the experiment as it would
locally. Every finished task is kept in <cache>/study-results/, keyed by the
ground truth's cache key and the task's settings: a study interrupted midway
resumes from the tasks it finished when the same command runs again.

PENUMBRA_STUDY_FAULT=<folder> is for the tests: the first chunk and the first
point to get halfway through their samples kill their own worker (once each,
leaving chunk.killed and point.killed in the folder), as a lost machine would.
"""
import hashlib
import json
import logging
import os
import shutil
import signal
import sys
import tempfile
import time


def log(msg):
    print(msg, file=sys.stderr, flush=True)


# --- Tasks (run in Ray's worker processes) -----------------------------------------

def _fault_hook(fault, kind):
    """The progress hook of PENUMBRA_STUDY_FAULT (see the module's text), or None."""
    if not fault:
        return None
    marker = os.path.join(fault, kind + ".killed")

    def hook(done, total):
        if 2 * done < total or os.path.exists(marker):
            return
        try:
            os.close(os.open(marker, os.O_CREAT | os.O_EXCL | os.O_WRONLY))
        except FileExistsError:
            return  # another task got there first
        os.kill(os.getpid(), signal.SIGKILL)
    return hook


def chunk_task(scene, options, index, fault):
    """A ground-truth chunk: (sum, sum_sq, samples, seconds)."""
    import penumbra
    t0 = time.perf_counter()
    c = penumbra.render_reference_chunk(scene, index, progress=_fault_hook(fault, "chunk"), **options)
    return c.sum, c.sum_sq, c.samples, time.perf_counter() - t0


def point_task(scene, options, technique, reference, fault):
    """One technique of an experiment, with its ground truth (`reference`: the
    files' bytes, written into this worker's cache unless they are there):
    {"summary": summary.json, "files": {name: bytes}} of `penumbra converge`."""
    import penumbra
    plan = penumbra.converge_plan(scene, **options)["reference"]
    for path, data in ((plan["var_path"], reference["var"]), (plan["path"], reference["mean"])):
        if not os.path.exists(path):
            os.makedirs(os.path.dirname(path), exist_ok=True)
            tmp = f"{path}.{os.getpid()}.tmp"
            with open(tmp, "wb") as f:
                f.write(data)
            os.replace(tmp, path)
    with tempfile.TemporaryDirectory(prefix="penumbra-point-") as out:
        one = dict(options, strategies=[technique["strategy"]], mis=[technique["mis"]])
        res = penumbra.converge(scene, out=out, progress=_fault_hook(fault, "point"), **one)
        files = {}
        for name in os.listdir(out):
            with open(os.path.join(out, name), "rb") as f:
                files[name] = f.read()
    return {"summary": res.summary, "files": files}


# --- The results cache -----------------------------------------------------------------

class Results:
    """Finished tasks under <cache>/study-results/: chunks as .npz, points as
    folders of their files; each written under a temporary name and renamed, so
    that an interrupted write leaves nothing."""

    def __init__(self, folder):
        self.folder = folder
        os.makedirs(folder, exist_ok=True)

    def chunk_path(self, key, chunk_spp, index):
        return os.path.join(self.folder, f"chunk-{key}-{chunk_spp}-{index}.npz")

    def save_chunk(self, path, s, s2, n, seconds):
        import numpy as np
        tmp = f"{path}.{os.getpid()}.tmp.npz"
        np.savez(tmp, sum=s, sum_sq=s2, samples=n, seconds=seconds)
        os.replace(tmp, path)

    def point_path(self, key):
        return os.path.join(self.folder, f"point-{key}")

    def save_point(self, path, result):
        tmp = f"{path}.{os.getpid()}.tmp"
        shutil.rmtree(tmp, ignore_errors=True)
        os.makedirs(os.path.join(tmp, "files"))
        for name, data in result["files"].items():
            with open(os.path.join(tmp, "files", name), "wb") as f:
                f.write(data)
        with open(os.path.join(tmp, "summary.json"), "w") as f:
            json.dump(result["summary"], f)
        shutil.rmtree(path, ignore_errors=True)
        os.rename(tmp, path)

    @staticmethod
    def load_point(path):
        with open(os.path.join(path, "summary.json")) as f:
            summary = json.load(f)
        files = {}
        for name in os.listdir(os.path.join(path, "files")):
            with open(os.path.join(path, "files", name), "rb") as f:
                files[name] = f.read()
        return {"summary": summary, "files": files}


def point_key(options, reference_key, technique, commit):
    """A point's results depend on its ground truth, its technique, its settings
    and the penumbra that measured it."""
    settings = {k: v for k, v in options.items() if k not in ("cache", "threads", "gpus", "strategies", "mis")}
    text = json.dumps([reference_key, technique["name"], settings, commit], sort_keys=True)
    return hashlib.sha256(text.encode()).hexdigest()[:20]


# --- An experiment's files from its points -------------------------------------------------

def write_run(run, plan, points, reference, write_atomic):
    """Writes run.out as `penumbra converge` would: the points' files, their
    measurements in technique order, and one summary.json with every technique,
    each through write_atomic(path, write) (common.py's: never a half-written
    file). `reference`: cached (before this study), seconds (of its chunks), file."""
    def write(path, data):
        mode = "wb" if isinstance(data, bytes) else "w"

        def to(tmp):
            with open(tmp, mode) as f:
                f.write(data)
        write_atomic(path, to)

    os.makedirs(run.out, exist_ok=True)
    rows, header = [], None
    for p in points:
        for name, data in p["files"].items():
            if name not in ("measurements.csv", "summary.json"):
                write(os.path.join(run.out, name), data)
        lines = p["files"]["measurements.csv"].decode().splitlines(keepends=True)
        header = header or lines[0]
        rows += lines[1:]
    write(os.path.join(run.out, "measurements.csv"), header + "".join(rows))
    summary = json.loads(json.dumps(points[0]["summary"]))
    summary["strategies"] = {}
    for p in points:
        summary["strategies"].update(p["summary"]["strategies"])
    summary["seconds"] = sum(p["summary"]["seconds"] for p in points)
    summary["reference"].update(reference)
    summary["overrides"] = list(run.sets)  # as the study wrote them (the tasks pass them as values)
    summary["executor"] = "ray"
    write(os.path.join(run.out, "summary.json"), json.dumps(summary, indent=2, sort_keys=True) + "\n")


# --- The driver ---------------------------------------------------------------------------

def execute(args, runs, converge_options, write_atomic):
    """Runs `runs` ([(study.Run, penumbra.converge_plan())]) as Ray tasks and writes
    each run's files into run.out. Returns {run.out: error} for the runs that failed."""
    import numpy as np
    import penumbra

    fault = os.environ.get("PENUMBRA_STUDY_FAULT") or None
    commit = penumbra.build_info()["git_commit"]
    caches = {os.path.dirname(plan["reference"]["path"]) for _, plan in runs}
    results = {c: Results(os.path.join(c, "study-results")) for c in caches}
    failed = {}
    ray = None
    backend, resources, threads = args.backend, {}, 0

    def start_ray():
        nonlocal ray, backend, resources, threads
        if ray is not None:
            return
        import ray as ray_module
        ray = ray_module
        kw = dict(include_dashboard=False, logging_level=logging.WARNING, configure_logging=True)
        if args.address:
            ray.init(address=args.address, **kw)
        else:
            ray.init(num_cpus=args.ray_cpus, num_gpus=args.ray_gpus, **kw)
        ray.cloudpickle.register_pickle_by_value(sys.modules[__name__])  # workers need not find this file
        gpus = ray.cluster_resources().get("GPU", 0)
        if backend == "auto":
            backend = "optix" if gpus > 0 else "cpu"
        if backend == "optix":
            if gpus == 0:  # tasks asking for a GPU would wait forever
                ray.shutdown()
                raise SystemExit("study: ray: --backend optix, but the Ray cluster has no GPUs (ray status)")
            resources, threads = dict(num_gpus=args.task_gpus, num_cpus=1), 0
        else:
            resources, threads = dict(num_cpus=args.task_cpus), args.task_cpus
        log(f"study: ray: {ray.cluster_resources().get('CPU', 0):g} CPUs, {gpus:g} GPUs; tasks on the {backend} "
            f"backend with {resources}")

    def task_options(run):
        o = converge_options(args, run)
        o.update(backend=backend, threads=threads, gpus="all")
        return o

    # What each run needs: its ground-truth chunks (unless the ground truth is
    # cached), then its points (unless they are in the results cache).
    state = []
    cached_tasks = 0
    for run, plan in runs:
        ref = plan["reference"]
        res = results[os.path.dirname(ref["path"])]
        st = dict(run=run, plan=plan, res=res, chunks={}, chunk_seconds=0.0, points={}, cached=ref["cached"],
                  ref_files=None)
        if ref["cached"]:  # chunks an interrupted merge left behind
            for k in range(ref["chunks"]):
                path = res.chunk_path(ref["key"], ref["chunk_spp"], k)
                if os.path.exists(path):
                    os.remove(path)
        else:
            for k in range(ref["chunks"]):
                path = res.chunk_path(ref["key"], ref["chunk_spp"], k)
                if os.path.exists(path):
                    st["chunks"][k] = path
                    cached_tasks += 1
        for t in plan["techniques"]:
            # Keyed without the backend's choice of auto: the backend is in the settings as given.
            path = res.point_path(point_key(converge_options(args, run), ref["key"], t, commit))
            if os.path.exists(path):
                st["points"][t["name"]] = Results.load_point(path)
                cached_tasks += 1
        state.append(st)
    total = sum((0 if st["cached"] else st["plan"]["reference"]["chunks"]) + len(st["plan"]["techniques"])
                for st in state)
    log(f"study: ray: {len(runs)} experiments, {total} tasks, {cached_tasks} of them done before "
        f"(in the results cache)")

    pending = {}  # ObjectRef -> (state, kind, chunk index or technique)
    finished = cached_tasks

    def reference_ready(st):
        """Merges the chunks in order into the ground truth (unless cached) and
        submits the points still to do."""
        ref = st["plan"]["reference"]
        run = st["run"]
        if not st["cached"]:
            s = np.zeros((ref["height"], ref["width"], 3))
            s2 = np.zeros_like(s)
            for k in range(ref["chunks"]):  # in chunk order: converge's own additions
                with np.load(st["chunks"][k]) as d:
                    s += d["sum"]
                    s2 += d["sum_sq"]
                    st["chunk_seconds"] += float(d["seconds"])
            penumbra.store_reference(run.scene, s, s2, **converge_options(args, run))
            for k in range(ref["chunks"]):
                os.remove(st["chunks"][k])
        todo = [t for t in st["plan"]["techniques"] if t["name"] not in st["points"]]
        if not todo:
            return
        start_ray()
        files = {}
        for name, path in (("mean", ref["path"]), ("var", ref["var_path"])):
            with open(path, "rb") as f:
                files[name] = f.read()
        st["ref_files"] = ray.put(files)
        point = ray.remote(max_retries=args.retries, retry_exceptions=False)(point_task).options(**resources)
        for t in todo:
            pending[point.remote(run.scene, task_options(run), t, st["ref_files"], fault)] = (st, "point", t)

    t0 = time.time()
    try:
        for st in state:
            ref = st["plan"]["reference"]
            missing = [] if st["cached"] else [k for k in range(ref["chunks"]) if k not in st["chunks"]]
            if missing:
                start_ray()
                chunk = ray.remote(max_retries=args.retries, retry_exceptions=False)(chunk_task).options(**resources)
                for k in missing:
                    pending[chunk.remote(st["run"].scene, task_options(st["run"]), k, fault)] = (st, "chunk", k)
            else:
                reference_ready(st)
        while pending:
            done, _ = ray.wait(list(pending), num_returns=1)
            st, kind, what = pending.pop(done[0])
            run, ref = st["run"], st["plan"]["reference"]
            try:
                value = ray.get(done[0])
            except Exception as e:  # penumbra's error in the task, or retries exhausted
                if run.out not in failed:
                    failed[run.out] = f"{run.name}: {kind} task failed: {str(e).strip().splitlines()[-1]}"
                    log(f"study: ray: {failed[run.out]}")
                continue
            finished += 1
            if kind == "chunk":  # kept even when the experiment failed: a rerun needs it
                path = st["res"].chunk_path(ref["key"], ref["chunk_spp"], what)
                st["res"].save_chunk(path, *value)
                st["chunks"][what] = path
                log(f"study: ray: [{finished}/{total}] {run.name}: ground-truth chunk {what + 1}/{ref['chunks']} "
                    f"({value[3]:.1f} s)")
                if len(st["chunks"]) == ref["chunks"] and run.out not in failed:
                    reference_ready(st)
            else:
                key = point_key(converge_options(args, run), ref["key"], what, commit)
                st["res"].save_point(st["res"].point_path(key), value)
                st["points"][what["name"]] = value
                log(f"study: ray: [{finished}/{total}] {run.name}: {what['name']} "
                    f"({value['summary']['seconds']:.1f} s)")
    except KeyboardInterrupt:
        log(f"study: ray: interrupted; {finished} of {total} tasks are done and kept in the results cache: the same "
            "command resumes from them")
        raise SystemExit(130)
    finally:
        if ray is not None:
            ray.shutdown()
    if total > cached_tasks:
        log(f"study: ray: {finished - cached_tasks} tasks in {time.time() - t0:.1f} s")

    for st in state:
        run = st["run"]
        if run.out in failed:
            continue
        points = [st["points"][t["name"]] for t in st["plan"]["techniques"]]
        write_run(run, st["plan"], points, {"cached": st["cached"], "seconds": st["chunk_seconds"],
                                            "file": st["plan"]["reference"]["path"]}, write_atomic)
    return failed
