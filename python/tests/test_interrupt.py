"""Ctrl-C stops a render with KeyboardInterrupt, and the renderer stays usable;
other threads keep running while it renders (the GIL is released)."""
import os
import subprocess
import sys
import textwrap
import threading
import time

import penumbra

CHILD = textwrap.dedent("""
    import os, signal, sys, threading, time
    import penumbra
    r = penumbra.Renderer("cornell-sphere", backend="cpu", width=320, height=180)
    r.render(1)
    # About 20 s of work on two cores; SIGINT (what Ctrl-C sends) after 0.5 s.
    threading.Timer(0.5, lambda: os.kill(os.getpid(), signal.SIGINT)).start()
    t0 = time.time()
    try:
        r.render(256)
        print("NOT INTERRUPTED")
    except KeyboardInterrupt:
        print(f"interrupted after {time.time() - t0:.2f} s")
    print("spp", r.spp)
    img = r.render(1)
    print("then spp", img.spp, "mean", float(img.rgb.mean()))
""")


def test_ctrl_c_interrupts_a_render():
    env = dict(os.environ, PYTHONUNBUFFERED="1")
    t0 = time.time()
    p = subprocess.run([sys.executable, "-c", CHILD], capture_output=True, text=True, timeout=120, env=env)
    assert p.returncode == 0, p.stderr
    lines = p.stdout.splitlines()
    assert lines[0].startswith("interrupted after"), p.stdout
    assert float(lines[0].split()[2]) < 5.0, p.stdout
    assert lines[1] == "spp 1", p.stdout  # the interrupted call added nothing
    assert lines[2].startswith("then spp 2 "), p.stdout
    assert time.time() - t0 < 60


def test_other_threads_run_while_rendering():
    ticks = []
    stop = threading.Event()

    def tick():
        while not stop.is_set():
            ticks.append(time.time())
            time.sleep(0.005)

    t = threading.Thread(target=tick)
    t.start()
    try:
        t0 = time.time()
        penumbra.render("cornell-sphere", spp=64, backend="cpu", width=160, height=90)
        t1 = time.time()
    finally:
        stop.set()
        t.join()
    during = [x for x in ticks if t0 < x < t1]
    # The render takes about a second; a thread blocked by the GIL would tick
    # at most a few times (at progress callbacks).
    assert t1 - t0 > 0.2
    assert len(during) > 0.5 * (t1 - t0) / 0.01, (len(during), t1 - t0)


def test_progress_callback():
    calls = []
    penumbra.render("cornell-sphere", spp=8, backend="cpu", width=64, height=36,
                    progress=lambda done, total: calls.append((done, total)))
    assert calls and calls[-1] == (64 * 36 * 8, 64 * 36 * 8)
    assert all(a <= b for (a, _), (b, _) in zip(calls, calls[1:]))
