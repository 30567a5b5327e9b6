"""scripts/study.py --resume: an interrupted local study continues where it stopped.

Usage: study_resume_check.py PENUMBRA WORK_DIR. One tiny run (the smoke preset's thesis headline on cornell-sphere,
CPU) is made, then the same command again with --resume keeps it (its files untouched, no penumbra converge run);
a changed summary.json, or another penumbra (a copy of the executable: a new file), makes it run again."""
import os
import shutil
import subprocess
import sys

HERE = os.path.dirname(os.path.abspath(__file__))
STUDY = os.path.join(HERE, os.pardir, os.pardir, "scripts", "study.py")


def study(penumbra, work, resume=True):
    cmd = [sys.executable, STUDY, "--preset", "smoke", "--part", "thesis", "--only", "headline", "--scene",
           "cornell-sphere", "--backend", "cpu", "--allow-dirty", "--no-report", "--penumbra", penumbra,
           "--out", os.path.join(work, "out"), "--cache", os.path.join(work, "cache")] + (["--resume"] if resume else [])
    p = subprocess.run(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
    if p.returncode:
        sys.exit(f"study exited with {p.returncode}:\n{p.stderr}")
    ran = sum(" converge cornell-sphere " in line for line in p.stderr.splitlines() if line.startswith("study: "))
    kept = sum(line.startswith("study: kept (--resume): ") for line in p.stderr.splitlines())
    return ran, kept


def main():
    penumbra, work = os.path.abspath(sys.argv[1]), os.path.abspath(sys.argv[2])
    shutil.rmtree(work, ignore_errors=True)
    os.makedirs(work)
    summary = os.path.join(work, "out", "thesis", "runs", "cornell-sphere", "summary.json")

    assert study(penumbra, work, resume=False) == (1, 0), "the first study did not run its one run"
    with open(summary, "rb") as f:
        first = f.read()
    mtime = os.stat(summary).st_mtime_ns
    assert study(penumbra, work) == (0, 1), "--resume ran a run that was finished with the same command"
    with open(summary, "rb") as f:
        assert f.read() == first and os.stat(summary).st_mtime_ns == mtime, "--resume rewrote a kept run"

    with open(summary, "ab") as f:  # another file than the run left
        f.write(b"\n")
    assert study(penumbra, work) == (1, 0), "--resume kept a run whose summary.json changed since"
    assert study(penumbra, work) == (0, 1), "--resume did not keep the run made again"

    other = os.path.join(work, "penumbra-copy")
    shutil.copy(penumbra, other)  # the same program, another file: another penumbra as far as --resume knows
    assert study(other, work) == (1, 0), "--resume kept a run of another penumbra"
    print("study --resume: keeps a finished run; runs it again after a change to its output or to penumbra")


if __name__ == "__main__":
    main()
