#!/usr/bin/env python3
"""The viewer's window end to end (CTest: viewer_xvfb, viewer_headless, viewer_no_display).

--case xvfb: under `xvfb-run -a` (Mesa's software OpenGL) with the CPU backend at
160x90: screenshots are not blank, are exactly what `penumbra render` makes for
the same camera, strategy and spp, and change after a scripted camera move and a
strategy switch; the split screen and equal time run; a display without
OpenGL 3.3 fails in one line. Exits 77 (CTest SKIP_RETURN_CODE) without xvfb-run.

--case headless: the same checks with `--headless` and no display server at all
(no DISPLAY, no Xvfb: an EGL context on Mesa's surfaceless platform), plus a
screenshot of the offscreen framebuffer with the panel drawn; `--headless`
without an end fails in one line. Exits 77 where this machine has no EGL
display (Debian: libegl1 and libegl-mesa0, which scripts/install-deps.sh
installs).

--case no-display: with no DISPLAY, `penumbra view` fails at once with one line
that points to `penumbra render`.

Python standard library only (PNGs are decoded with zlib).
"""
import argparse
import json
import os
import shutil
import struct
import subprocess
import sys
import zlib

SKIP = 77
SIZE = ["--width", "160", "--height", "90"]


def fail(msg):
    print("FAIL: " + msg, file=sys.stderr)
    sys.exit(1)


def read_png(path):
    """8-bit RGB/RGBA non-interlaced PNG (what stb_image_write writes) -> (w, h, channels, rows of bytes)."""
    data = open(path, "rb").read()
    if data[:8] != b"\x89PNG\r\n\x1a\n":
        fail(f"{path}: not a PNG")
    pos, idat, w = 8, b"", None
    while pos < len(data):
        length, kind = struct.unpack(">I4s", data[pos:pos + 8])
        body = data[pos + 8:pos + 8 + length]
        if kind == b"IHDR":
            w, h, depth, color, _, _, interlace = struct.unpack(">IIBBBBB", body)
            if depth != 8 or color not in (2, 6) or interlace:
                fail(f"{path}: unexpected PNG format (depth {depth}, colour type {color})")
            ch = 3 if color == 2 else 4
        elif kind == b"IDAT":
            idat += body
        pos += 12 + length
    raw = zlib.decompress(idat)
    stride = w * ch
    rows, prev = [], bytearray(stride)
    for y in range(h):
        f = raw[y * (stride + 1)]
        line = bytearray(raw[y * (stride + 1) + 1:(y + 1) * (stride + 1)])
        for i in range(stride):
            a = line[i - ch] if i >= ch else 0
            b = prev[i]
            c = prev[i - ch] if i >= ch else 0
            if f == 1:
                line[i] = (line[i] + a) & 255
            elif f == 2:
                line[i] = (line[i] + b) & 255
            elif f == 3:
                line[i] = (line[i] + (a + b) // 2) & 255
            elif f == 4:
                p = a + b - c
                pa, pb, pc = abs(p - a), abs(p - b), abs(p - c)
                line[i] = (line[i] + (a if pa <= pb and pa <= pc else b if pb <= pc else c)) & 255
        rows.append(bytes(line))
        prev = line
    return w, h, ch, rows


def pixels(path):
    w, h, ch, rows = read_png(path)
    return w, h, [rows[y][x * ch + c] for y in range(h) for x in range(w) for c in range(3)]


def check_not_blank(path, w=160, h=90):
    pw, ph, px = pixels(path)
    if (pw, ph) != (w, h):
        fail(f"{path}: {pw}x{ph}, expected {w}x{h}")
    mean = sum(px) / len(px)
    lit = sum(1 for v in px if v > 16) / len(px)
    if mean < 8 or lit < 0.2 or max(px) - min(px) < 64:
        fail(f"{path}: looks blank (mean {mean:.1f}, {lit:.0%} lit, range {min(px)}..{max(px)})")
    return px


def check_differ(a, b, why):
    pa, pb = pixels(a)[2], pixels(b)[2]
    diff = sum(abs(x - y) for x, y in zip(pa, pb)) / len(pa)
    if diff < 2.0:
        fail(f"{a} and {b} should differ ({why}) but the mean difference is {diff:.2f}/255")
    return diff


def same_bytes(a, b, why):
    if open(a, "rb").read() != open(b, "rb").read():
        fail(f"{a} and {b} differ: {why}")


def run(cmd, env=None, expect_ok=True, timeout=240):
    p = subprocess.run(cmd, env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, timeout=timeout)
    if expect_ok and p.returncode != 0:
        fail(f"exit {p.returncode}: {' '.join(cmd)}\n{p.stdout}\n{p.stderr}")
    return p


def check_one_line_error(p, must_contain, what):
    lines = p.stderr.strip().splitlines()
    if p.returncode == 0:
        fail(f"{what}: exit status 0")
    if len(lines) != 1 or not lines[0].startswith("penumbra: error: ") or any(s not in lines[0] for s in must_contain):
        fail(f"{what}: expected one line 'penumbra: error: ...' mentioning {must_contain}, got:\n{p.stderr}")
    print(f"ok: {what}: {lines[0]}")


def case_no_display(penumbra, work):
    env = {k: v for k, v in os.environ.items() if k not in ("DISPLAY", "WAYLAND_DISPLAY")}
    p = run([penumbra, "view", "cornell-sphere", "--backend", "cpu", "--frames", "1"] + SIZE, env=env,
            expect_ok=False, timeout=60)
    check_one_line_error(p, ["penumbra render"], "no display")


def fresh_work_dir(work):
    os.makedirs(work, exist_ok=True)
    os.chdir(work)
    for f in os.listdir("."):
        os.remove(f)


def frames_path_and_split(view, penumbra, env, how):
    """Checks 1-3, the same for a window and headless: `view` is the command up to the scene."""
    # 1. --frames N --screenshot: not blank, and the frame rate on stderr.
    p = run(view + ["cornell-sphere", "--frames", "6", "--screenshot", "frames.png"], env=env)
    check_not_blank("frames.png")
    if "fps as displayed" not in p.stderr or "6 frames of 160x90" not in p.stderr:
        fail("no frame-rate line on stderr:\n" + p.stderr)
    if "display: host upload, cpu backend" not in p.stderr:
        fail("the frame-rate line does not name the display path (host upload with the CPU backend):\n" + p.stderr)
    if ("headless)" in p.stderr) != (how == "headless"):
        fail(f"the frame-rate line should say 'headless' exactly when headless ({how}):\n" + p.stderr)
    print(f"ok: {how}: --frames/--screenshot: " + [l for l in p.stderr.splitlines() if "fps" in l][0])

    # 2. A scripted camera move and strategy switch. Each screenshot must be
    # exactly `penumbra render` of the same camera (saved by the path), strategy
    # and spp: proof that the move and the switch took effect and that the
    # progressive frames add up to the renderer's image.
    path = [
        {"frame": 4, "screenshot": "start.png"},
        {"frame": 4, "orbit": [25, 8], "dolly": 0.8, "save_camera": "moved.json"},
        {"frame": 8, "screenshot": "moved.png"},
        {"frame": 8, "key": "1"},  # the window's key 1: the first strategy, area
        {"frame": 12, "screenshot": "area.png"},
        {"frame": 12, "window_screenshot": "window.png"},
        {"frame": 12, "quit": True},
    ]
    with open("path.json", "w") as f:
        json.dump(path, f)
    p = run(view + ["cornell-sphere", "--camera-path", "path.json"], env=env)
    for f in ("start.png", "moved.png", "area.png"):
        check_not_blank(f)
    d1 = check_differ("start.png", "moved.png", "camera move")
    d2 = check_differ("moved.png", "area.png", "strategy switch")
    render = [penumbra, "render", "--backend", "cpu", "--spp", "4"] + SIZE
    run(render + ["cornell-sphere", "-o", "start_render.png"])
    run(render + ["moved.json", "-o", "moved_render.png"])
    run(render + ["moved.json", "--strategy", "area", "-o", "area_render.png"])
    same_bytes("start.png", "start_render.png", "the viewer's 4 frames of 1 spp are not `render --spp 4`")
    same_bytes("moved.png", "moved_render.png", "after the camera move the viewer does not show the saved camera")
    same_bytes("area.png", "area_render.png", "after key 1 the viewer does not show `--strategy area`")
    # The window as shown: the image with the panel over it, so not the image alone.
    check_not_blank("window.png")
    check_differ("window.png", "area.png", "the panel is drawn over the image")
    print(f"ok: {how}: camera move (mean difference {d1:.1f}/255) and key 1's strategy switch ({d2:.1f}/255), "
          "each identical to `penumbra render`; the window's screenshot shows the panel")

    # 2b. The light panel's radius drag: the scene and the backend change in place (nothing is loaded again, no
    # backend made again), and the image is `penumbra render` of the camera file the viewer saves then, which
    # holds the edited light.
    path = [
        {"frame": 2, "light_radius": 0.5},
        {"frame": 3, "light_radius": 0.6, "save_camera": "lit.json"},
        {"frame": 7, "screenshot": "lit.png"},
        {"frame": 7, "quit": True},
    ]
    with open("light_path.json", "w") as f:
        json.dump(path, f)
    p = run(view + ["cornell-sphere", "--camera-path", "light_path.json"], env=env)
    if p.stderr.count("(cpu backend updated in place)") != 2:
        fail("two radius steps should each update the cpu backend in place:\n" + p.stderr)
    if "the scene was loaded 1 time, a backend made 1 time" not in p.stderr:
        fail("a light edit loaded the scene or made a backend again:\n" + p.stderr)
    run(render + ["lit.json", "-o", "lit_render.png"])
    same_bytes("lit.png", "lit_render.png", "after the radius drag the viewer does not show the saved scene's light")
    check_differ("start.png", "lit.png", "radius drag")
    step = [l for l in p.stderr.splitlines() if "light changed in" in l][-1]
    print(f"ok: {how}: radius drag in place ({step.split('view: ')[-1]}), identical to `penumbra render`")

    # 3. Split screen at equal spp and at equal time; EXR screenshot.
    p = run(view + ["cornell-sphere", "--split", "area,solid-angle", "--frames", "4", "--screenshot", "split.png"],
            env=env)
    check_not_blank("split.png")
    if "area 4 spp | solid-angle 4 spp" not in p.stderr:
        fail("split screen at equal spp: expected 4 spp on each side:\n" + p.stderr)
    p = run(view + ["cornell-sphere", "--split", "solid-angle,bsdf", "--equal-time", "--spp-per-frame", "2",
                    "--frames", "6", "--screenshot", "equal_time.exr"], env=env)
    if not os.path.getsize("equal_time.exr"):
        fail("no EXR screenshot")
    print(f"ok: {how}: split screen: " + [l for l in p.stderr.splitlines() if "fps" in l][0])


def case_xvfb(penumbra, work):
    xvfb = shutil.which("xvfb-run")
    if not xvfb:
        print("xvfb-run not found (Debian: xvfb): skipping the viewer's window test")
        sys.exit(SKIP)
    fresh_work_dir(work)
    # A 24-bit screen: xvfb-run's default 8-bit one has no OpenGL visual. Mesa's
    # software rasteriser, whatever GPU the machine has.
    env = dict(os.environ, LIBGL_ALWAYS_SOFTWARE="1")
    # Our own X authority file: with xvfb-run's own, it removes a temporary
    # folder on exit, and that removal once failed a finished run in CI
    # ("problem while cleaning up temporary directory", exit 5).
    auth = os.path.join(work, "Xauthority")
    open(auth, "w").close()
    X = [xvfb, "-a", "-f", auth, "-s", "-screen 0 1280x720x24"]
    view = X + [penumbra, "view", "--backend", "cpu"] + SIZE
    frames_path_and_split(view, penumbra, env, "window")

    # 4. A display without OpenGL 3.3: one line, no hang.
    p = run(view + ["cornell-sphere", "--frames", "2"], env=dict(env, MESA_GL_VERSION_OVERRIDE="3.0"),
            expect_ok=False, timeout=60)
    check_one_line_error(p, ["OpenGL 3.3", "penumbra render"], "no OpenGL 3.3")

    # 5. --display interop where there is none (the CPU backend renders in host memory): one line, no hang.
    p = run(view + ["cornell-sphere", "--frames", "2", "--display", "interop"], env=env, expect_ok=False, timeout=60)
    check_one_line_error(p, ["--display interop", "penumbra render"], "--display interop without interop")


def case_headless(penumbra, work):
    fresh_work_dir(work)
    # No display server of any kind; Mesa's software rasteriser even where a GPU is.
    env = {k: v for k, v in os.environ.items() if k not in ("DISPLAY", "WAYLAND_DISPLAY")}
    env["LIBGL_ALWAYS_SOFTWARE"] = "1"
    view = [penumbra, "view", "--backend", "cpu", "--headless"] + SIZE
    p = run(view + ["cornell-sphere", "--frames", "1"], env=env, expect_ok=False, timeout=120)
    if p.returncode != 0 and ("no display without a display server" in p.stderr or "libEGL.so.1" in p.stderr):
        print("no EGL display here (Debian: libegl1, libegl-mesa0): skipping the headless viewer test\n" + p.stderr)
        sys.exit(SKIP)
    if p.returncode != 0:
        fail(f"--headless --frames 1: exit {p.returncode}\n{p.stderr}")
    frames_path_and_split(view, penumbra, env, "headless")

    # 4. Nothing would end it: one line, at once.
    p = run(view + ["cornell-sphere"], env=env, expect_ok=False, timeout=60)
    check_one_line_error(p, ["--headless", "--frames"], "--headless without --frames")


def main():
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--penumbra", required=True)
    ap.add_argument("--work", required=True)
    ap.add_argument("--case", choices=["xvfb", "headless", "no-display"], required=True)
    a = ap.parse_args()
    penumbra = os.path.abspath(a.penumbra)
    cases = {"xvfb": case_xvfb, "headless": case_headless, "no-display": case_no_display}
    cases[a.case](penumbra, os.path.abspath(a.work))


if __name__ == "__main__":
    main()
