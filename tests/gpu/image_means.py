#!/usr/bin/env python3
"""The image-mean test of the GPU tests: are two renders' image means equal, with an error that is honest?

    image_means.py A.exr B.exr [--tile N] [--z 4] [--bias 0.01]

A and B are two renders of one scene with independent seeds (penumbra render -o). Prints one line and exits 0
(PASS) or 3 (FAIL), as `penumbra compare` does; 1 on an unreadable file. Python's standard library only (the
GPU machine has no numpy): EXR as penumbra writes it (tinyexr: float32 B, G, R, uncompressed or ZIP).

Why not `penumbra compare`'s image z. Its standard error of the image mean adds the per-channel variances of
the mean, as if a pixel's R, G and B were independent. They are not: a white light on a grey or metal surface
moves all three together, and then Var((R + G + B) / 3) is up to 3 times the sum the test assumes. On glossy
(white sun and sphere light, grey, white and metal materials) eight CPU seeds at 128x72 and 1024 spp spread
their image means by 0.147% (standard deviation), where the sum of channel variances says 0.089% and the sum
that takes each pixel's channels as fully correlated says 0.145%: the image z of two independent renders is
1.65 times too large there, so seeds 0 and 1 "differ" at z 2.8-4.1 (0.36-0.40%) in every technique and
selection, which gpu_check.sh used to excuse when the CPU's own seeds 0 and 1 failed alike. That control
could not tell noise from a real difference (a GPU that differs by as much as two CPU seeds do passed), so it
is gone; this test has the right size instead, and its power is stated and required.

The test. Sum each image over tiles of N x N pixels and their channels: A_t and B_t (N = 1 by default; larger
where nearby pixels are correlated, as restir's spatial reuse makes them: the GPU tests use 8). The relative
difference of the image means is r = sum(A) / sum(B) - 1, and its variance is estimated from the tiles
themselves, as for a ratio estimator: Var(r) = sum_t e_t^2 / sum(B)^2 with the residuals e_t = A_t - (1 + r) B_t
(times T / (T - 1) for T tiles). Tiles are independent, so this holds whatever a pixel's channels do, however a
pixel's samples are correlated (restir's temporal reuse, where the film's per-pixel variance is too small) and
whatever the shape of their distribution: a single extreme tile raises the error with the difference. The
residuals are noise alone under a bias that scales the image (a light's power, a pdf's constant factor), so such
a bias does not hide itself by inflating the error. z = r / SE, |z| < 4 passes (`penumbra compare`'s bound on its
image z), normal for many tiles. The test sees a bias of (4 + 1.645) SE with 95% power, and it FAILs where that
is above --bias (1%): a check that cannot catch a 1% bias does not pass for want of power.

Measured (CPU, 128x72, seeds 0 and 1, which are the GPU's paths with the GPU's seed), the standard error of r and
the bias each check sees: glossy, solid-angle with MIS power, 1024 spp: 0.20% (1.12%), 2048 spp: 0.133% (0.75%);
BSDF sampling alone at 0.6 roughness, 1024 spp: 1.11% (6.3%); many-spheres (2000 lights), restir with temporal
reuse, 1024 spp: 0.42% (2.3%).
"""
import argparse
import math
import struct
import sys
import zlib


def read_exr(path):
    """(width, height, [R, G, B] lists of floats, row-major) of a scanline float32 EXR."""
    with open(path, "rb") as f:
        data = f.read()
    if data[:4] != b"\x76\x2f\x31\x01":
        raise ValueError(f"{path}: not an EXR file")
    if data[5] & 0x02:
        raise ValueError(f"{path}: tiled EXR (penumbra writes scanlines)")
    pos = 8
    channels, compression, window = [], None, None

    def cstr(p):
        end = data.index(b"\0", p)
        return data[p:end].decode("latin-1"), end + 1

    while data[pos] != 0:
        name, pos = cstr(pos)
        _, pos = cstr(pos)  # the attribute's type
        size = struct.unpack_from("<i", data, pos)[0]
        pos += 4
        value = data[pos:pos + size]
        pos += size
        if name == "channels":
            p = 0
            while value[p] != 0:
                end = value.index(b"\0", p)
                cname = value[p:end].decode("latin-1")
                ptype = struct.unpack_from("<i", value, end + 1)[0]
                channels.append((cname, ptype))
                p = end + 1 + 16
        elif name == "compression":
            compression = value[0]
        elif name == "dataWindow":
            window = struct.unpack("<4i", value)
    pos += 1
    if window is None or compression is None or not channels:
        raise ValueError(f"{path}: EXR header without channels, compression or dataWindow")
    if any(t != 2 for _, t in channels):
        raise ValueError(f"{path}: not float32 channels")
    lines_per_block = {0: 1, 2: 1, 3: 16}.get(compression)
    if lines_per_block is None:
        raise ValueError(f"{path}: EXR compression {compression} (penumbra writes none or ZIP)")
    x0, y0, x1, y1 = window
    width, height = x1 - x0 + 1, y1 - y0 + 1
    blocks = (height + lines_per_block - 1) // lines_per_block
    offsets = struct.unpack_from(f"<{blocks}Q", data, pos)
    planes = {name: [0.0] * (width * height) for name, _ in channels}
    for off in offsets:
        y, size = struct.unpack_from("<ii", data, off)
        raw = data[off + 8:off + 8 + size]
        lines = min(lines_per_block, y1 + 1 - y)
        expect = lines * width * 4 * len(channels)
        if compression != 0 and size < expect:
            t = bytearray(zlib.decompress(raw))
            for i in range(1, len(t)):  # undo the predictor
                t[i] = (t[i - 1] + t[i] - 128) & 0xFF
            half = (len(t) + 1) // 2
            raw = bytearray(len(t))  # undo the interleaving of the two halves
            raw[0::2] = t[:half]
            raw[1::2] = t[half:]
        if len(raw) != expect:
            raise ValueError(f"{path}: a block of {len(raw)} bytes, expected {expect}")
        values = struct.unpack(f"<{expect // 4}f", raw)
        k = 0
        for line in range(lines):
            row = (y - y0 + line) * width
            for name, _ in channels:  # each line: every channel's row, in the header's order
                planes[name][row:row + width] = values[k:k + width]
                k += width
    try:
        return width, height, [planes["R"], planes["G"], planes["B"]]
    except KeyError:
        raise ValueError(f"{path}: no R, G and B channels") from None


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("a")
    ap.add_argument("b")
    ap.add_argument("--tile", type=int, default=1, help="tile size in pixels (default 1)")
    ap.add_argument("--z", type=float, default=4.0, help="|z| at and above which the means differ (default 4)")
    ap.add_argument("--bias", type=float, default=0.01,
                    help="the relative bias the test must catch with 95%% power (default 0.01; 0: only reported)")
    args = ap.parse_args()
    try:
        wa, ha, a = read_exr(args.a)
        wb, hb, b = read_exr(args.b)
    except (OSError, ValueError, struct.error, zlib.error) as e:
        print(f"image_means: {e}")
        return 1
    if (wa, ha) != (wb, hb):
        print(f"image_means: {args.a} is {wa}x{ha}, {args.b} is {wb}x{hb}")
        return 1
    w, h, t = wa, ha, max(1, args.tile)
    tiles_x = (w + t - 1) // t
    sums_a, sums_b = {}, {}
    for c in range(3):
        ac, bc = a[c], b[c]
        for y in range(h):
            row, ty = y * w, (y // t) * tiles_x
            for x in range(w):
                k = ty + x // t
                sums_a[k] = sums_a.get(k, 0.0) + ac[row + x]
                sums_b[k] = sums_b.get(k, 0.0) + bc[row + x]
    sum_a, sum_b = math.fsum(sums_a.values()), math.fsum(sums_b.values())
    n, count = 3 * w * h, len(sums_a)
    mean_a, mean_b = sum_a / n, sum_b / n
    r = sum_a / sum_b - 1 if sum_b else (0.0 if sum_a == 0 else math.inf)
    # The residuals of A = (1 + r) B over tiles: noise alone under the same estimator, and noise alone under a
    # bias that scales the image too (a light's power, a pdf's constant), which therefore does not inflate them.
    ss = math.fsum((sums_a[k] - (1 + r) * sums_b[k]) ** 2 for k in sums_a) * count / max(count - 1, 1)
    se = math.sqrt(ss) / abs(sum_b) if sum_b and not math.isnan(ss) else math.inf
    z = r / se if se > 0 and math.isfinite(r) else (0.0 if r == 0 else math.copysign(math.inf, r))
    rel = abs(r)
    detects = (args.z + 1.645) * se
    ok_z = abs(z) < args.z
    ok_power = args.bias <= 0 or detects <= args.bias
    verdict = "PASS" if ok_z and ok_power else "FAIL"
    why = "" if ok_power else f" (too noisy to catch a {100 * args.bias:g}% bias: more samples)"
    print(f"{verdict}: means {mean_a:.6g} vs {mean_b:.6g} (rel. diff {100 * rel:.3f}%), z {z:.2f} over "
          f"{count} tiles of {t}x{t} px (SE {100 * se:.3f}%; catches a bias of {100 * detects:.2f}% or more)"
          f"{why}")
    return 0 if verdict == "PASS" else 3


if __name__ == "__main__":
    sys.exit(main())
