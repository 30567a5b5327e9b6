#!/usr/bin/env python3
"""The executable on bad input and bad luck (issue 12), one CTest per class:

  outputs   every output is checked before any work: a missing folder, a folder
            given as a file, two outputs that are one file (render, bench, converge, study)
  atomic    a write that fails (file-size limit, as on a full disk) exits 1 with one line
            and leaves the previous file byte for byte; no temporary file stays
  nonfinite a render whose samples overflow writes its image, says how many samples and
            where, and exits 4 (documented in --help)
  memory    a film or an environment map larger than the memory allowed (ulimit -v): one
            line with the need and what is available, at once
  options   render options on a scene file without a "render" block; NaN and infinity
            rejected by every floating-point option; a scene without light warns
  long      converge prints its estimate and wants --yes past an hour on the CPU;
            --estimate-only; Ctrl-C stops converge and study.py with one line, exit 130;
            study.py refuses a committed report folder without --force

Python standard library only.
"""
import argparse
import json
import os
import resource
import shutil
import signal
import subprocess
import sys
import time

ARGS = None


def fail(msg):
    print("FAIL: " + msg, file=sys.stderr)
    sys.exit(1)


def run(cmd, timeout=120, limits=(), ignore_xfsz=False, expect=None):
    """Runs cmd; limits: (resource, value) pairs set in the child. Returns (rc, stdout, stderr)."""
    def child():
        for res, value in limits:
            resource.setrlimit(res, (value, value))
        if ignore_xfsz:
            signal.signal(signal.SIGXFSZ, signal.SIG_IGN)  # then write() fails with EFBIG, as on a full disk
    try:
        p = subprocess.run(cmd, capture_output=True, text=True, timeout=timeout, preexec_fn=child)
    except subprocess.TimeoutExpired:
        fail(f"still running after {timeout} s (the check did not come before the work?): {' '.join(cmd)}")
    if expect is not None and p.returncode != expect:
        fail(f"expected exit status {expect}, got {p.returncode}: {' '.join(cmd)}\n{p.stderr}")
    return p.returncode, p.stdout, p.stderr


def one_line_error(cmd, words, rc=1, **kw):
    """The command fails with exit status rc, and its error is one line (the last on
    stderr, after any progress lines) holding every word."""
    code, _, err = run(cmd, expect=rc, **kw)
    lines = [l for l in err.strip().split("\n") if l]
    errors = [l for l in lines if "error:" in l]
    if len(errors) != 1 or errors[0] != lines[-1] or "Traceback" in err:
        fail(f"expected one error line, the last on stderr: {' '.join(cmd)}\n{err}")
    for w in words:
        if w not in errors[0]:
            fail(f"the error does not mention '{w}': {errors[0]}")
    return errors[0]


def penumbra(*args):
    return [ARGS.penumbra] + list(args)


def data(name):
    return os.path.join(ARGS.data, name)


def work(name):
    return os.path.join(ARGS.work, name)


def leftovers(folder):
    return [f for f in os.listdir(folder) if ".tmp-" in f]


# A render that takes minutes on two cores: a check that fails at once proves it came first.
LONG = ["--backend", "cpu", "--width", "1920", "--height", "1080", "--spp", "4096"]


def case_outputs():
    t0 = time.time()
    one_line_error(penumbra("render", "cornell-sphere", *LONG, "-o", work("nosuch/x.png")),
                   ["-o", "nosuch", "does not exist"], timeout=30)
    one_line_error(penumbra("render", "cornell-sphere", *LONG, "-o", work("a.exr"), "--variance",
                            "./" + os.path.relpath(work("a.exr"))), ["same file"], timeout=30)
    os.makedirs(work("folder.png"), exist_ok=True)
    one_line_error(penumbra("render", "cornell-sphere", *LONG, "-o", work("folder.png")), ["is a folder"], timeout=30)
    one_line_error(penumbra("render", "cornell-sphere", *LONG, "-o", work("a.png"), "--variance",
                            work("nosuch/v.exr")), ["--variance", "does not exist"], timeout=30)
    one_line_error(penumbra("bench", "--backend", "cpu", "--launches", "100000", "--json", work("nosuch/b.json")),
                   ["--json", "does not exist"], timeout=30)
    with open(work("a_file"), "w") as f:
        f.write("x")
    one_line_error(penumbra("converge", "cornell-sphere", "--backend", "cpu", "--out", work("a_file/runs")),
                   ["--out", "a_file"], timeout=30)
    one_line_error(penumbra("converge", "cornell-sphere", "--backend", "cpu", "--out", work("cv"), "--cache",
                            work("a_file")), ["--cache", "not a folder"], timeout=30)
    if time.time() - t0 > 20:
        fail(f"the output checks took {time.time() - t0:.1f} s: they did not come before the work")
    rc, _, err = run([sys.executable, ARGS.study, "--preset", "smoke", "--backend", "cpu", "--penumbra",
                      ARGS.penumbra, "--out", work("a_file/report"), "--no-report"], timeout=30)
    if rc == 0 or "a_file" not in err or "Traceback" in err:
        fail(f"study.py accepted an --out under a file ({rc}):\n{err}")


def case_atomic():
    out = work("keep.png")
    run(penumbra("render", "cornell-sphere", "--backend", "cpu", "--width", "64", "--height", "48", "--spp", "2",
                 "-o", out), expect=0)
    before = open(out, "rb").read()
    # A second, different render into the same file, allowed 2 KB a file: the PNG
    # (about 6 KB) cannot be written. Before: "wrote" and a truncated PNG.
    line = one_line_error(penumbra("render", "cornell-sphere", "--backend", "cpu", "--width", "64", "--height", "48",
                                   "--spp", "2", "--seed", "5", "-o", out),
                          ["keep.png", "cannot write"], limits=[(resource.RLIMIT_FSIZE, 2048)], ignore_xfsz=True)
    if "wrote" in line:
        fail("a failed write was reported as written")
    if open(out, "rb").read() != before:
        fail("the previous image was changed by a failed write")
    if leftovers(ARGS.work):
        fail(f"temporary files left behind: {leftovers(ARGS.work)}")
    # The same for EXR and the variance image.
    run(penumbra("render", "cornell-sphere", "--backend", "cpu", "--width", "64", "--height", "48", "--spp", "2",
                 "-o", work("keep.exr")), expect=0)
    before = open(work("keep.exr"), "rb").read()
    one_line_error(penumbra("render", "cornell-sphere", "--backend", "cpu", "--width", "64", "--height", "48",
                            "--spp", "2", "--seed", "5", "-o", work("keep.exr")), ["keep.exr", "cannot write"],
                   limits=[(resource.RLIMIT_FSIZE, 4096)], ignore_xfsz=True)
    if open(work("keep.exr"), "rb").read() != before or leftovers(ARGS.work):
        fail("a failed EXR write changed the previous file or left a temporary file")


def case_nonfinite():
    out = work("overflow.png")
    if os.path.exists(out):
        os.remove(out)
    rc, _, err = run(penumbra("render", data("overflow_env_scene.json"), "--backend", "cpu", "-o", out,
                              "--variance", work("overflow_var.exr")))
    if rc != 4:
        fail(f"expected exit status 4 (written, samples dropped), got {rc}:\n{err}")
    with open(out, "rb") as f:
        if f.read(8) != b"\x89PNG\r\n\x1a\n":
            fail("the image was not written")
    if not os.path.exists(work("overflow_var.exr")):
        fail("the variance image was not written")
    warn = [l for l in err.split("\n") if "NaN or infinite" in l]
    if len(warn) != 1 or "(0, 0)" not in warn[0] or "samples" not in warn[0] or "overflow.png" not in warn[0]:
        fail(f"expected one warning with the count and the first pixels:\n{err}")
    _, help_text, _ = run(penumbra("render", "--help"), expect=0)
    if "4 the outputs were written but" not in " ".join(help_text.split()):
        fail("render --help does not document exit status 4")


def case_memory():
    limit = [(resource.RLIMIT_AS, 3 << 30)]  # 3 GiB of address space
    t0 = time.time()
    one_line_error(penumbra("render", data("huge_film.json"), "--backend", "cpu", "-o", work("huge.png")),
                   ["huge_film.json", "16384x16384", "needs about", "film", "available", "ulimit -v"], limits=limit)
    one_line_error(penumbra("render", data("huge_env_scene.json"), "--backend", "cpu", "-o", work("huge.png")),
                   ["huge_env.hdr", "8192x8192", "needs about", "available"], limits=limit)
    one_line_error(penumbra("render", "cornell-sphere", "--backend", "cpu", "--width", "16384", "--height", "16384",
                            "-o", work("huge.png")), ["needs about", "available"], limits=limit)
    if time.time() - t0 > 20:
        fail(f"the memory checks took {time.time() - t0:.1f} s")


def case_options():
    run(penumbra("render", data("no_render_block.json"), "--backend", "cpu", "--spp", "2", "--width", "8",
                 "--height", "6", "--strategy", "area", "-o", work("norender.png")), expect=0)
    for opt in ["nan", "inf", "-inf", "NaN"]:
        one_line_error(penumbra("render", "cornell-sphere", "--backend", "cpu", "--exposure", opt, "-o",
                                work("x.png")), ["--exposure"], rc=2)
        one_line_error(penumbra("converge", "cornell-sphere", "--backend", "cpu", "--threshold", opt, "--out",
                                work("cv")), ["--threshold"], rc=2)
        one_line_error(penumbra("compare", data("nan_env.exr"), data("nan_env.exr"), data("nan_env.exr"),
                                data("nan_env.exr"), "--max-rel-diff", opt), ["--max-rel-diff"], rc=2)
        one_line_error(penumbra("view", "cornell-sphere", "--scale", opt), ["--scale"], rc=2)
    _, _, err = run(penumbra("render", data("no_light.json"), "--backend", "cpu", "-o", work("dark.png")), expect=0)
    if "no light" not in err or "no_light.json" not in err:
        fail(f"a scene without light did not warn:\n{err}")
    # --tune (the GPU's tuning, every command that makes a backend): a bad key or value is a usage error whose one
    # line names the key and what it takes, before any work; the cpu backend renders the same image with it.
    for cmd in (["render", "cornell-sphere", *LONG, "-o", work("x.png")],
                ["bench", "--backend", "cpu", "--scenes", "cornell-sphere"],
                ["converge", "cornell-sphere", "--backend", "cpu", "--out", work("cv")],
                ["view", "cornell-sphere"]):
        one_line_error(penumbra(*cmd, "--tune", "cuda_occ=11"), ["--tune", "cuda_occ", "0, 10 or 12", "'11'"], rc=2)
        one_line_error(penumbra(*cmd, "--tune", "shadow_order=sometimes"),
                       ["shadow_order", "auto, direction or queue"], rc=2)
        one_line_error(penumbra(*cmd, "--tune", "cuda_ooc=0"), ["--tune", "unknown key 'cuda_ooc'", "cuda_occ"], rc=2)
        one_line_error(penumbra(*cmd, "--tune", "wavefront_paths"), ["--tune", "'wavefront_paths' is not KEY=VALUE"],
                       rc=2)
        one_line_error(penumbra(*cmd, "--tune", "cuda_leaf=4", "--tune", "cuda_block=64"),
                       ["cuda_block=64 needs cuda_occ=0"], rc=2)
    small = ["--backend", "cpu", "--spp", "2", "--width", "8", "--height", "6"]
    run(penumbra("render", "cornell-sphere", *small, "-o", work("untuned.exr")), expect=0)
    run(penumbra("render", "cornell-sphere", *small, "--tune", "cuda_occ=0,cuda_block=64", "--tune",
                 "wavefront_paths=4096", "-o", work("tuned.exr")), expect=0)
    with open(work("untuned.exr"), "rb") as a, open(work("tuned.exr"), "rb") as b:
        if a.read() != b.read():
            fail("--tune changed the cpu backend's image")


def case_long():
    # A 1080p study on two cores: refused at once, nothing created.
    out = work("long")
    shutil.rmtree(out, ignore_errors=True)
    t0 = time.time()
    line = one_line_error(penumbra("converge", "cornell-sphere", "--backend", "cpu", "--width", "1920", "--height",
                                   "1080", "--reference-spp", "65536", "--out", out, "--cache", work("cache")),
                          ["estimated run time", "--yes"], timeout=120)
    if time.time() - t0 > 90 or os.path.exists(out):
        fail(f"converge did not stop before the work ({time.time() - t0:.1f} s): {line}")
    rc, stdout, err = run(penumbra("converge", "cornell-sphere", "--backend", "cpu", "--width", "32", "--height",
                                   "32", "--reference-spp", "64", "--max-spp", "4", "--seeds", "1", "--out", out,
                                   "--estimate-only"), expect=0)
    e = json.loads(stdout.strip().split("\n")[-1])
    if not (e["estimated_seconds"] > 0 and e["backend"] == "cpu") or os.path.exists(out):
        fail(f"--estimate-only: {stdout} {err}")
    # Ctrl-C during the reference: one line, status 130, no partial file.
    for f in os.listdir(work("cache")) if os.path.isdir(work("cache")) else []:
        os.remove(os.path.join(work("cache"), f))
    p = subprocess.Popen(penumbra("converge", "cornell-sphere", "--backend", "cpu", "--width", "320", "--height",
                                  "180", "--reference-spp", "100000", "--yes", "--out", out, "--cache", work("cache")),
                         stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    time.sleep(8)
    p.send_signal(signal.SIGINT)
    _, err = p.communicate(timeout=30)
    lines = [l for l in err.strip().split("\n") if l]
    if p.returncode != 130 or "interrupted" not in lines[-1] or "Traceback" in err:
        fail(f"converge on Ctrl-C: status {p.returncode}:\n{err}")
    # (A slow start, as under the sanitizers, may be interrupted before the cache folder exists: nothing left.)
    cached = os.listdir(work("cache")) if os.path.isdir(work("cache")) else []
    if any(f.startswith("ref-") or ".tmp-" in f for f in cached):
        fail(f"an interrupted reference left files: {cached}")
    # study.py: Ctrl-C (to the whole process group, as a terminal sends it).
    p = subprocess.Popen([sys.executable, ARGS.study, "--preset", "smoke", "--backend", "cpu", "--penumbra",
                          ARGS.penumbra, "--out", work("study"), "--cache", work("study-cache"), "--no-report",
                          "--allow-dirty"],
                         stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, start_new_session=True)
    time.sleep(6)
    os.killpg(p.pid, signal.SIGINT)
    _, err = p.communicate(timeout=60)
    lines = [l for l in err.strip().split("\n") if l]
    if p.returncode != 130 or "study: interrupted" not in lines[-1] or "Traceback" in err:
        fail(f"study.py on Ctrl-C: status {p.returncode}:\n{err}")
    # study.py and a committed report folder: refused before any work without --force.
    results = os.path.join(ARGS.source, "docs", "results")
    tracked = subprocess.run(["git", "-C", ARGS.source, "ls-files", "--", "docs/results"], capture_output=True,
                             text=True)
    if tracked.returncode == 0 and tracked.stdout.strip():
        rc, _, err = run([sys.executable, ARGS.study, "--preset", "smoke", "--backend", "cpu", "--penumbra",
                          ARGS.penumbra, "--out", results], timeout=30)
        if rc == 0 or "committed" not in err or "--force" not in err:
            fail(f"study.py overwrote a committed report folder without --force ({rc}):\n{err}")
    else:
        print("note: not a git checkout; the committed-folder check was not run")


def main():
    global ARGS
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--case", required=True, choices=["outputs", "atomic", "nonfinite", "memory", "options", "long"])
    ap.add_argument("--penumbra", required=True)
    ap.add_argument("--data", required=True)
    ap.add_argument("--source", required=True)
    ap.add_argument("--work", required=True)
    ARGS = ap.parse_args()
    ARGS.study = os.path.join(ARGS.source, "scripts", "study.py")
    ARGS.work = os.path.join(ARGS.work, ARGS.case)
    shutil.rmtree(ARGS.work, ignore_errors=True)
    os.makedirs(ARGS.work)
    globals()["case_" + ARGS.case]()
    print(f"cli_robustness {ARGS.case}: PASS")


if __name__ == "__main__":
    main()
