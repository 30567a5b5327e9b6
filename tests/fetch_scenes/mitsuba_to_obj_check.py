#!/usr/bin/env python3
"""scripts/scenes/mitsuba_to_obj.py on a tiny Mitsuba scene written here (CTest mitsuba_to_obj):
two serialized meshes (float32 with normals and uvs, translated and rotated by toWorld; float64
positions only, version 3 offsets), a textured and an rgb diffuse bsdf, and a bsdf no shape uses."""
import math
import os
import struct
import subprocess
import sys
import tempfile
import zlib

HERE = os.path.dirname(os.path.abspath(__file__))
CONVERTER = os.path.join(HERE, "..", "..", "scripts", "scenes", "mitsuba_to_obj.py")


def mesh(version, flags, name, positions, normals, uvs, tris):
    real = "d" if flags & 0x2000 else "f"
    body = struct.pack("<I", flags)
    if version >= 4:
        body += name.encode() + b"\0"
    body += struct.pack("<QQ", len(positions) // 3, len(tris) // 3)
    for arr in (positions, normals, uvs):
        if arr:
            body += struct.pack("<%d%s" % (len(arr), real), *arr)
    body += struct.pack("<%dI" % len(tris), *tris)
    return struct.pack("<HH", 0x041C, version) + zlib.compress(body)


def serialized(version, meshes):
    data, offsets = b"", []
    for m in meshes:
        offsets.append(len(data))
        data += m
    data += struct.pack("<%d%s" % (len(offsets), "Q" if version >= 4 else "I"), *offsets)
    return data + struct.pack("<I", len(offsets))


XML = """<?xml version='1.0' encoding='utf-8'?>
<scene version="0.4.0">
  <texture type="bitmap" id="tex"><string name="filename" value="textures/a.JPG"/></texture>
  <bsdf type="diffuse" id="unused"><rgb name="reflectance" value="0.1 0.1 0.1"/></bsdf>
  <bsdf type="diffuse" id="textured"><ref name="reflectance" id="tex"/></bsdf>
  <!-- <bsdf type="phong" id="commented"/> -->
  <bsdf type="diffuse" id="grey"><rgb name="reflectance" value="0.25 0.5 0.75"/></bsdf>
  <shape type="sphere"><float name="radius" value="1"/></shape>
  <shape type="serialized" id="quad">
    <string name="filename" value="m.serialized"/>
    <integer name="shapeIndex" value="0"/>
    <transform name="toWorld"><matrix value="0 -1 0 10  1 0 0 20  0 0 1 30  0 0 0 1"/></transform>
    <ref name="bsdf" id="textured"/>
  </shape>
  <shape type="serialized" id="tri">
    <string name="filename" value="m.serialized"/>
    <integer name="shapeIndex" value="1"/>
    <ref name="bsdf" id="grey"/>
  </shape>
</scene>
"""


def main():
    failures = []

    def check(what, ok):
        print(("ok: " if ok else "FAIL: ") + what)
        if not ok:
            failures.append(what)

    for version in (3, 4):
        with tempfile.TemporaryDirectory() as d:
            quad = mesh(version, 0x1 | 0x2 | 0x1000, "quad", [0, 0, 0, 1, 0, 0, 1, 1, 0, 0, 1, 0], [1, 0, 0] * 4,
                        [0, 0, 1, 0, 1, 0.25, 0, 1], [0, 1, 2, 0, 2, 3])
            tri = mesh(version, 0x2000, "tri", [0.5, 0, 0, 0, 0.5, 0, 0, 0, 0.5], None, None, [0, 1, 2])
            with open(os.path.join(d, "m.serialized"), "wb") as f:
                f.write(serialized(version, [quad, tri]))
            with open(os.path.join(d, "s.xml"), "w") as f:
                f.write(XML)
            r = subprocess.run([sys.executable, CONVERTER, os.path.join(d, "s.xml"), os.path.join(d, "out.obj")],
                               capture_output=True, text=True)
            check("v%d: exit 0 (%s)" % (version, r.stderr.strip()), r.returncode == 0)
            check("v%d: summary line" % version, "2 shapes, 7 vertices, 3 triangles" in r.stdout)
            if r.returncode:
                continue
            obj = open(os.path.join(d, "out.obj")).read().split("\n")
            mtl = open(os.path.join(d, "out.mtl")).read().split("\n")
            rows = lambda key: [l.split()[1:] for l in obj if l.startswith(key + " ")]
            check("v%d: mtllib" % version, "mtllib out.mtl" in obj)
            check("v%d: objects and materials" % version,
                  rows("o") == [["quad"], ["tri"]] and rows("usemtl") == [["textured"], ["grey"]])
            v = [[float(x) for x in r] for r in rows("v")]
            # toWorld: (x, y, z) -> (10 - y, 20 + x, 30 + z)
            want = [[10, 20, 30], [10, 21, 30], [9, 21, 30], [9, 20, 30], [0.5, 0, 0], [0, 0.5, 0], [0, 0, 0.5]]
            check("v%d: positions transformed" % version,
                  len(v) == 7 and all(math.isclose(a, b, abs_tol=1e-6) for p, q in zip(v, want) for a, b in zip(p, q)))
            vt = [[float(x) for x in r] for r in rows("vt")]
            check("v%d: vt u (1-v)" % version, vt == [[0, 1], [1, 1], [1, 0.75], [0, 0]])
            vn = [[float(x) for x in r] for r in rows("vn")]
            check("v%d: normals rotated" % version, vn == [[0, 1, 0]] * 4)
            check("v%d: faces" % version, rows("f") == [["1/1/1", "2/2/2", "3/3/3"], ["1/1/1", "3/3/3", "4/4/4"],
                                                        ["5", "6", "7"]])
            check("v%d: mtl" % version, [l for l in mtl if l.startswith(("newmtl", "Kd", "map_Kd"))] ==
                  ["newmtl textured", "Kd 1 1 1", "map_Kd textures/a.JPG", "newmtl grey", "Kd 0.25 0.5 0.75"])
    with tempfile.TemporaryDirectory() as d:
        with open(os.path.join(d, "m.serialized"), "wb") as f:
            f.write(b"\x00\x00\x00\x00garbage!")
        with open(os.path.join(d, "s.xml"), "w") as f:
            f.write(XML)
        r = subprocess.run([sys.executable, CONVERTER, os.path.join(d, "s.xml"), os.path.join(d, "out.obj")],
                           capture_output=True, text=True)
        check("not a serialized file: exit 1, one line (%s)" % r.stderr.strip(),
              r.returncode == 1 and r.stderr.count("\n") == 1 and "mitsuba_to_obj: error: " in r.stderr)
    print("mitsuba_to_obj: %s" % ("%d checks failed" % len(failures) if failures else "all checks passed"))
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())
