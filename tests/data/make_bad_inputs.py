#!/usr/bin/env python3
"""Writes the bad-input files of tests/data that are binary or repetitive (the
tests read the committed files; this script says how they were made):

  nan_env.exr         16x8 environment of radiance 1 with a NaN, an +Inf and a negative texel
  overflow_env.exr    4x2 environment of radiance 1e35 (x intensity 1e6 = 1e41: beyond float)
  huge_env.hdr        a Radiance header claiming 8192x8192 texels (1 GiB as floats), no pixels
  gltf_two_parents.gltf  node 2 is the child of nodes 0 and 1 (the hierarchy is not a tree)
  gltf_explode.gltf   32 levels of two nodes, each the parent of both nodes below it: 2^32 paths
                      from 3 KB (a renderer that instanced every path would place 4 billion meshes)
  gltf_many_nodes.gltf   one root with 1025 mesh nodes (placed 1024 times by many_instances.json)

    python3 tests/data/make_bad_inputs.py
"""
import base64
import json
import os
import struct

HERE = os.path.dirname(os.path.abspath(__file__))


def exr(path, width, height, rgb):
    """A scanline OpenEXR file, float32 B, G, R channels, no compression.
    rgb(x, y) -> (r, g, b)."""
    def attr(name, kind, data):
        return name.encode() + b"\0" + kind.encode() + b"\0" + struct.pack("<i", len(data)) + data
    chlist = b"".join(c.encode() + b"\0" + struct.pack("<iB3xii", 2, 0, 1, 1) for c in "BGR") + b"\0"
    box = struct.pack("<iiii", 0, 0, width - 1, height - 1)
    header = (b"\x76\x2f\x31\x01" + struct.pack("<i", 2) +
              attr("channels", "chlist", chlist) + attr("compression", "compression", b"\0") +
              attr("dataWindow", "box2i", box) + attr("displayWindow", "box2i", box) +
              attr("lineOrder", "lineOrder", b"\0") + attr("pixelAspectRatio", "float", struct.pack("<f", 1)) +
              attr("screenWindowCenter", "v2f", struct.pack("<ff", 0, 0)) +
              attr("screenWindowWidth", "float", struct.pack("<f", 1)) + b"\0")
    blocks = []
    for y in range(height):
        px = [rgb(x, y) for x in range(width)]
        data = b"".join(struct.pack("<%df" % width, *[p[c] for p in px]) for c in (2, 1, 0))  # B, G, R
        blocks.append(struct.pack("<ii", y, len(data)) + data)
    offset = len(header) + 8 * height
    table = b""
    for b in blocks:
        table += struct.pack("<Q", offset)
        offset += len(b)
    with open(path, "wb") as f:
        f.write(header + table + b"".join(blocks))


def gltf(path, nodes, roots):
    """tiny.gltf's quad mesh and material with another node hierarchy, compact."""
    with open(os.path.join(HERE, "tiny.gltf")) as f:
        g = json.load(f)
    g.pop("cameras", None)
    g["asset"]["generator"] = "penumbra tests/data/make_bad_inputs.py"
    g["nodes"] = nodes
    g["scenes"] = [{"nodes": roots}]
    with open(path, "w") as f:
        json.dump(g, f, separators=(",", ":"))
        f.write("\n")


def main():
    nan, inf = float("nan"), float("inf")
    bad = {(3, 2): (nan, 1, 1), (9, 5): (1, inf, 1), (12, 6): (1, 1, -5)}
    exr(os.path.join(HERE, "nan_env.exr"), 16, 8, lambda x, y: bad.get((x, y), (1, 1, 1)))
    exr(os.path.join(HERE, "overflow_env.exr"), 4, 2, lambda x, y: (1e35, 1e35, 1e35))
    with open(os.path.join(HERE, "huge_env.hdr"), "wb") as f:
        f.write(b"#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y 8192 +X 8192\n" + b"\x02\x02\x40\x00" + b"\x80" * 16)
    gltf(os.path.join(HERE, "gltf_two_parents.gltf"),
         [{"children": [2]}, {"translation": [2, 0, 0], "children": [2]}, {"mesh": 0}], [0, 1])
    levels = 32
    nodes = []
    for k in range(levels):
        below = [2 * k + 2, 2 * k + 3] if k + 1 < levels else []
        for _ in range(2):
            nodes.append({"children": below} if below else {"mesh": 0})
    gltf(os.path.join(HERE, "gltf_explode.gltf"), nodes, [0, 1])
    gltf(os.path.join(HERE, "gltf_many_nodes.gltf"),
         [{"children": list(range(1, 1026))}] + [{"mesh": 0}] * 1025, [0])


if __name__ == "__main__":
    main()
