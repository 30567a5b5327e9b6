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
    # A process started with SIGINT ignored (a shell's background job without job control: `cmd &` in a script)
    # passes that on, and Python then installs no KeyboardInterrupt handler: install it, as an interactive
    # interpreter has it.
    signal.signal(signal.SIGINT, signal.default_int_handler)
    backend, width, height, spp = sys.argv[1], int(sys.argv[2]), int(sys.argv[3]), int(sys.argv[4])
    r = penumbra.Renderer("cornell-sphere", backend=backend, width=width, height=height)
    r.render(1)
    # Much more work than 0.5 s; SIGINT (what Ctrl-C sends) after 0.5 s.
    threading.Timer(0.5, lambda: os.kill(os.getpid(), signal.SIGINT)).start()
    t0 = time.time()
    try:
        r.render(spp)
        print("NOT INTERRUPTED")
    except KeyboardInterrupt:
        print(f"interrupted after {time.time() - t0:.2f} s")
    print("spp", r.spp)
    n = r.spp
    img = r.render(1)
    print("then", img.spp - n, "more, mean", float(img.rgb.mean()))
""")


def interrupted_render(backend, width, height, spp):
    """Sends SIGINT to a child process 0.5 s into a long render; returns its
    seconds to KeyboardInterrupt and its spp before and after."""
    env = dict(os.environ, PYTHONUNBUFFERED="1")
    p = subprocess.run([sys.executable, "-c", CHILD, backend, str(width), str(height), str(spp)],
                       capture_output=True, text=True, timeout=120, env=env)
    assert p.returncode == 0, p.stderr
    lines = p.stdout.splitlines()
    assert lines[0].startswith("interrupted after"), p.stdout
    assert lines[2].startswith("then 1 more, mean"), p.stdout  # the renderer goes on
    return float(lines[0].split()[2]), int(lines[1].split()[1])


def test_ctrl_c_interrupts_a_render():
    # About 5 s of work on two cores, in tiles of 16x16 pixels x 256 samples.
    seconds, spp = interrupted_render("cpu", 320, 180, 256)
    assert seconds < 5.0
    assert spp == 1  # the interrupted call added nothing; the first call's sample stays


def test_other_threads_run_while_rendering():
    ticks = []
    stop = threading.Event()

    def tick():
        while not stop.is_set():
            ticks.append(time.time())
            time.sleep(0.005)

    # One render of about a second on this machine, whatever its core count:
    # its spp from calibration renders long enough that the scene's fixed cost
    # (loading, the BVH) does not dominate (on 16 cores one of 4 spp did, and
    # the render took 0.09 s).
    spp, seconds = 4, 0.0
    while spp < 65536:
        c0 = time.time()
        penumbra.render("cornell-sphere", spp=spp, backend="cpu", width=160, height=90)
        seconds = time.time() - c0
        if seconds > 0.25:
            break
        spp *= 4
    spp = max(4, min(262144, int(spp * 1.0 / max(seconds, 1e-3))))
    t = threading.Thread(target=tick)
    t.start()
    try:
        t0 = time.time()
        penumbra.render("cornell-sphere", spp=spp, backend="cpu", width=160, height=90)
        t1 = time.time()
    finally:
        stop.set()
        t.join()
    during = [x for x in ticks if t0 < x < t1]
    # A thread blocked by the GIL would not tick at all during the render (the
    # progress hook's acquire is then a no-op), a free one every 5 ms or so,
    # less what the busy render threads leave it.
    assert t1 - t0 > 0.2, f"the render took {t1 - t0:.3f} s with {spp} spp"
    assert len(during) > 0.2 * (t1 - t0) / 0.01, (len(during), t1 - t0)


def test_progress_callback():
    calls = []
    penumbra.render("cornell-sphere", spp=8, backend="cpu", width=64, height=36,
                    progress=lambda done, total: calls.append((done, total)))
    assert calls and calls[-1] == (64 * 36 * 8, 64 * 36 * 8)
    assert all(a <= b for (a, _), (b, _) in zip(calls, calls[1:]))
