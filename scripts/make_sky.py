#!/usr/bin/env python3
"""Writes the procedural HDR sky of the `glossy` scene: data/sky.hdr.

An equirectangular (latitude-longitude) Radiance RGBE image in penumbra's
environment convention (core/environment.h): the top row looks straight up,
the centre column looks down -z, u grows with the azimuth atan2(x, -z). A blue
gradient from the zenith to a pale horizon, a dim brownish ground, and a sun disc
(angular radius 1.5 degrees, 35 degrees above the horizon) with a soft glow
around it. Scanlines are run-length encoded (Radiance's "new" RLE, channel by
channel), which keeps a 2048x1024 map of smooth rows small. numpy only.

    python3 scripts/make_sky.py [--out data/sky.hdr] [--width 2048]
"""
import argparse
import sys

import numpy as np


def sky(width, height):
    y, x = np.mgrid[0:height, 0:width].astype(np.float64)
    theta = (y + 0.5) / height * np.pi
    phi = ((x + 0.5) / width - 0.5) * 2.0 * np.pi
    d = np.stack([np.sin(theta) * np.sin(phi), np.cos(theta), -np.sin(theta) * np.cos(phi)], axis=-1)
    up = d[..., 1]

    zenith = np.array([0.10, 0.25, 0.75])
    horizon = np.array([0.75, 0.85, 1.00])
    ground = np.array([0.12, 0.10, 0.08])
    t = np.clip(up, 0.0, 1.0)[..., None] ** 0.5
    img = horizon * (1.0 - t) + zenith * t
    below = (up < 0.0)[..., None]
    fade = np.clip(-up * 8.0, 0.0, 1.0)[..., None]  # a short blend into the ground
    img = np.where(below, horizon * (1.0 - fade) + ground * fade, img)

    elev, azim = np.radians(35.0), np.radians(-40.0)
    sun = np.array([np.cos(elev) * np.sin(azim), np.sin(elev), -np.cos(elev) * np.cos(azim)])
    cos_sun = np.clip(d @ sun, -1.0, 1.0)
    angle = np.arccos(cos_sun)
    radius = np.radians(1.5)
    glow = 6.0 * np.exp(-angle / np.radians(6.0))
    img = img + (glow * (up > -0.05))[..., None] * np.array([1.0, 0.85, 0.6])
    img = np.where((angle < radius)[..., None], np.array([2000.0, 1800.0, 1500.0]), img)
    return img.astype(np.float32)


def to_rgbe(img):
    m = img.max(axis=-1)
    mant, expo = np.frexp(m)
    scale = np.where(m > 1e-32, mant * 256.0 / np.maximum(m, 1e-32), 0.0)
    rgbe = np.zeros(img.shape[:2] + (4,), dtype=np.uint8)
    rgbe[..., :3] = np.clip(img * scale[..., None], 0, 255).astype(np.uint8)
    rgbe[..., 3] = np.where(m > 1e-32, expo + 128, 0).astype(np.uint8)
    return rgbe


def rle_channel(row):
    """One channel of one scanline: runs (count > 128) and literals (count <= 128)."""
    out = bytearray()
    i, n = 0, len(row)
    while i < n:
        j = i
        while j < n and j - i < 127 and row[j] == row[i]:
            j += 1
        if j - i >= 4:  # a run
            out += bytes([128 + (j - i), row[i]])
            i = j
            continue
        # A literal up to the next run of 4 (or 128 bytes).
        j = i
        while j < n and j - i < 128:
            if j + 3 < n and row[j] == row[j + 1] == row[j + 2] == row[j + 3]:
                break
            j += 1
        out += bytes([j - i]) + bytes(row[i:j])
        i = j
    return out


def rle_scanline(rgbe_row):
    w = rgbe_row.shape[0]
    out = bytearray([2, 2, w >> 8, w & 255])
    for c in range(4):
        out += rle_channel(rgbe_row[:, c].tolist())
    return bytes(out)


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", default="data/sky.hdr")
    ap.add_argument("--width", type=int, default=2048)
    a = ap.parse_args()
    w, h = a.width, a.width // 2
    if not 8 <= w <= 32767:
        sys.exit("make_sky.py: --width must be in [8, 32767] (Radiance RLE)")
    rgbe = to_rgbe(sky(w, h))
    with open(a.out, "wb") as f:
        f.write(b"#?RADIANCE\n# penumbra scripts/make_sky.py: procedural sky, sun 35 deg up\n")
        f.write(b"FORMAT=32-bit_rle_rgbe\n\n")
        f.write(f"-Y {h} +X {w}\n".encode())
        for row in rgbe:
            f.write(rle_scanline(row))
    print(f"wrote {a.out}: {w}x{h}")


if __name__ == "__main__":
    main()
