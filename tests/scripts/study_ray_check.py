#!/usr/bin/env python3
"""CTest study_ray: the smoke study's thesis part through `study.py --executor ray`
(a Ray instance on this machine with two CPU workers) gives exactly the numbers
of the local executor (study_smoke's runs): every error, fit, ground truth and
crop, to the bit; only times, the device line and the cache's bookkeeping
differ. On the way, the first ground-truth chunk task and the first converge
point task kill their own worker halfway (PENUMBRA_STUDY_FAULT) and Ray runs
them again, and the study is interrupted (Ctrl-C) after a few tasks and resumed
by the same command from the tasks it had finished.

    PYTHONPATH=build/python python3 tests/scripts/study_ray_check.py --local build/tests/study-smoke --work /tmp/study-ray

Exit status 77 (CTest's skip) where Ray is not installed.
"""
import argparse
import os
import re
import shutil
import signal
import subprocess
import sys

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..", "scripts"))
from study.compare import compare_runs  # noqa: E402


def main():
    here = os.path.dirname(os.path.abspath(__file__))
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--local", required=True, help="the local executor's smoke study (study_smoke's --out)")
    ap.add_argument("--work", required=True, help="a folder for this test (emptied first)")
    ap.add_argument("--study", default=os.path.join(here, "..", "..", "scripts", "study.py"))
    ap.add_argument("--interrupt-after", type=int, default=8, help="Ctrl-C after this many finished tasks")
    args = ap.parse_args()
    try:
        import ray  # noqa: F401
    except ImportError:
        print("study_ray: ray is not installed (python3 -m pip install ray): skipped", file=sys.stderr)
        return 77
    local = os.path.join(args.local, "thesis")  # the thesis part's report and runs
    if not os.path.isdir(os.path.join(local, "runs")):
        print(f"study_ray: {local}/runs: no local smoke study to compare with (run study_smoke)", file=sys.stderr)
        return 1
    shutil.rmtree(args.work, ignore_errors=True)
    fault = os.path.join(args.work, "fault")
    os.makedirs(fault)
    out, cache = os.path.join(args.work, "out"), os.path.join(args.work, "cache")
    cmd = [sys.executable, args.study, "--preset", "smoke", "--backend", "cpu", "--allow-dirty", "--part", "thesis", "--check",
           "--keep-runs", "--executor", "ray", "--ray-cpus", "2", "--out", out, "--cache", cache]
    env = dict(os.environ, PENUMBRA_STUDY_FAULT=fault)

    # 1. Interrupted after a few tasks, as a person with Ctrl-C would.
    print("study_ray: " + " ".join(cmd), file=sys.stderr, flush=True)
    p = subprocess.Popen(cmd, env=env, stderr=subprocess.PIPE, text=True)
    done, tasks = 0, None
    plan = re.compile(r"study: ray: \d+ experiments, (\d+) tasks, (\d+) of them done before")
    for line in p.stderr:
        sys.stderr.write(line)
        if plan.match(line):
            tasks = int(plan.match(line).group(1))
        if re.match(r"study: ray: \[\d+/\d+\]", line):
            done += 1
            if done == args.interrupt_after:
                p.send_signal(signal.SIGINT)
    rc = p.wait()
    if rc != 130 or done < args.interrupt_after:
        print(f"study_ray: FAILED: the first run was not interrupted midway (exit status {rc}, {done} tasks)",
              file=sys.stderr)
        return 1

    # 2. The same command again: it resumes from the finished tasks.
    run2 = subprocess.run(cmd, env=env, stderr=subprocess.PIPE, text=True)
    sys.stderr.write(run2.stderr)
    if run2.returncode != 0:
        print(f"study_ray: FAILED: the resumed study exited with {run2.returncode}", file=sys.stderr)
        return 1
    # Tasks it ran: at most those the first run left (chunks merged into a ground
    # truth are no longer tasks: the ground truth is in the cache).
    m = plan.search(run2.stderr)
    problems = []
    if not m or tasks is None or int(m.group(1)) - int(m.group(2)) > tasks - args.interrupt_after:
        problems.append(f"the resumed study did not start from the {args.interrupt_after} tasks the first of "
                        f"{tasks} finished ({m.group(0) if m else 'no count'})")
    for kind in ("chunk", "point"):
        if not os.path.exists(os.path.join(fault, kind + ".killed")):
            problems.append(f"no {kind} task was killed (PENUMBRA_STUDY_FAULT)")
    problems += compare_runs(local, os.path.join(out, "thesis"))
    if not os.path.exists(os.path.join(out, "thesis", "README.md")):
        problems.append("no report (README.md)")
    for line in problems:
        print("study_ray: FAILED: " + line, file=sys.stderr)
    if problems:
        return 1
    print(f"study_ray: the Ray study equals the local one ({len(os.listdir(os.path.join(out, 'thesis', 'runs')))} runs), "
          "with two killed tasks retried and one interruption resumed", file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main())
