#!/usr/bin/env python3
"""Convert a Mitsuba 0.4 scene's serialized meshes to one OBJ + MTL.

    mitsuba_to_obj.py SCENE.xml OUT.obj [--mtl OUT.mtl] [--header TEXT] [--mtl-header TEXT]

Reads every <shape type="serialized"> of SCENE.xml (its file, shapeIndex,
toWorld matrix and bsdf reference) and the diffuse <bsdf>s it names, and writes:
  - OUT.obj: one `o` block per shape (named by the shape's id), `usemtl` = the
    bsdf id, positions and normals with toWorld applied (normals by its
    inverse transpose), `vt u (1-v)` (Mitsuba's v runs down the image, OBJ's up),
    faces `f v/vt/vn` (or `v/vt`, `v//vn`, `v` when a mesh lacks uvs or normals);
  - OUT.mtl: one `newmtl` per diffuse bsdf: `Kd r g b` for an rgb reflectance,
    `Kd 1 1 1` + `map_Kd FILE` for a bitmap texture reference.
Only what the Dabrovic Sponza uses is supported (diffuse bsdfs, serialized
meshes); anything else is reported and skipped. Python 3 standard library only.

The serialized format (Mitsuba 0.4, little-endian), per mesh:
  uint16 0x041C, uint16 version (3 or 4), then a zlib stream holding
  uint32 flags (0x1 normals, 0x2 uvs, 0x8 colours, 0x10 face normals,
  0x1000 float32, 0x2000 float64), the name (NUL-terminated, version 4 only),
  uint64 vertex count, uint64 triangle count, positions, normals, uvs,
  colours, then uint32 indices (uint64 above 2^32 vertices).
  The file ends with the meshes' offsets (uint64 each in version 4, uint32 in
  version 3) and a uint32 mesh count.
"""
import argparse
import os
import struct
import sys
import xml.etree.ElementTree as ET
import zlib

MAGIC = 0x041C
HAS_NORMALS, HAS_UVS, HAS_COLORS, FACE_NORMALS = 0x1, 0x2, 0x8, 0x10
SINGLE, DOUBLE = 0x1000, 0x2000


class ConvertError(Exception):
    pass


def mesh_offsets(data):
    """Byte offsets of the meshes in a serialized file (from its end table)."""
    if len(data) < 8:
        raise ConvertError("file too short")
    count = struct.unpack_from("<I", data, len(data) - 4)[0]
    magic, version = struct.unpack_from("<HH", data, 0)
    if magic != MAGIC:
        raise ConvertError("not a Mitsuba serialized file (magic 0x%04x)" % magic)
    if version >= 4:
        table = len(data) - 4 - 8 * count
        fmt = "<%dQ" % count
    else:
        table = len(data) - 4 - 4 * count
        fmt = "<%dI" % count
    if table < 0:
        raise ConvertError("bad offset table (%d meshes)" % count)
    return list(struct.unpack_from(fmt, data, table)), table


def read_mesh(data, offsets, table, index):
    """(name, positions, normals, uvs, triangles) of mesh `index`; flat lists."""
    if not 0 <= index < len(offsets):
        raise ConvertError("shapeIndex %d out of range (%d meshes)" % (index, len(offsets)))
    start = offsets[index]
    end = offsets[index + 1] if index + 1 < len(offsets) else table
    magic, version = struct.unpack_from("<HH", data, start)
    if magic != MAGIC:
        raise ConvertError("mesh %d: bad magic 0x%04x" % (index, magic))
    raw = zlib.decompress(data[start + 4:end])
    pos = 0
    flags = struct.unpack_from("<I", raw, pos)[0]
    pos += 4
    name = ""
    if version >= 4:
        nul = raw.index(b"\0", pos)
        name = raw[pos:nul].decode("utf-8", "replace")
        pos = nul + 1
    nv, nt = struct.unpack_from("<QQ", raw, pos)
    pos += 16
    if flags & DOUBLE:
        real, size = "d", 8
    else:
        real, size = "f", 4

    def reals(n):
        nonlocal pos
        out = struct.unpack_from("<%d%s" % (n, real), raw, pos)
        pos += n * size
        return out

    positions = reals(3 * nv)
    normals = reals(3 * nv) if flags & HAS_NORMALS else None
    uvs = reals(2 * nv) if flags & HAS_UVS else None
    if flags & HAS_COLORS:
        reals(3 * nv)
    ifmt = "Q" if nv > 0xFFFFFFFF else "I"
    tris = struct.unpack_from("<%d%s" % (3 * nt, ifmt), raw, pos)
    if flags & FACE_NORMALS:
        normals = None  # flat shading was asked for: let the renderer use face normals
    return name, positions, normals, uvs, tris


def parse_matrix(text):
    vals = [float(x) for x in text.replace(",", " ").split()]
    if len(vals) != 16:
        raise ConvertError("toWorld matrix with %d values" % len(vals))
    return [vals[0:4], vals[4:8], vals[8:12], vals[12:16]]


def normal_matrix(m):
    """Inverse transpose of the upper-left 3x3 of m."""
    a = [row[:3] for row in m[:3]]
    det = (a[0][0] * (a[1][1] * a[2][2] - a[1][2] * a[2][1]) - a[0][1] * (a[1][0] * a[2][2] - a[1][2] * a[2][0]) +
           a[0][2] * (a[1][0] * a[2][1] - a[1][1] * a[2][0]))
    if det == 0:
        raise ConvertError("singular toWorld matrix")
    cof = [[0.0] * 3 for _ in range(3)]
    for i in range(3):
        for j in range(3):
            r = [k for k in range(3) if k != i]
            c = [k for k in range(3) if k != j]
            minor = a[r[0]][c[0]] * a[r[1]][c[1]] - a[r[0]][c[1]] * a[r[1]][c[0]]
            cof[i][j] = (-1) ** (i + j) * minor / det
    return cof  # inverse transpose = cofactor matrix / det


def parse_scene(xml_path):
    root = ET.parse(xml_path).getroot()
    textures = {}
    for t in root.iter("texture"):
        if t.get("type") == "bitmap" and t.get("id"):
            for s in t.findall("string"):
                if s.get("name") == "filename":
                    textures[t.get("id")] = s.get("value")
    bsdfs = []  # (id, kd tuple or None, texture file or None), in file order
    for b in root.findall("bsdf"):
        bid = b.get("id")
        if not bid:
            continue
        if b.get("type") != "diffuse":
            print("mitsuba_to_obj: bsdf %s: type %s not supported, written as grey" % (bid, b.get("type")),
                  file=sys.stderr)
            bsdfs.append((bid, "0.5 0.5 0.5", None))
            continue
        kd, tex = "0.5 0.5 0.5", None
        for child in b:
            if child.get("name") != "reflectance":
                continue
            if child.tag == "rgb":
                kd = " ".join(child.get("value").replace(",", " ").split())
            elif child.tag == "ref":
                tex = textures.get(child.get("id"))
                kd = "1 1 1"
                if tex is None:
                    raise ConvertError("bsdf %s: texture %s not defined" % (bid, child.get("id")))
        bsdfs.append((bid, kd, tex))
    shapes = []  # (id, file, shapeIndex, matrix, bsdf id)
    for sh in root.findall("shape"):
        if sh.get("type") != "serialized":
            continue
        filename, index, matrix, bsdf = None, 0, None, None
        for child in sh:
            if child.tag == "string" and child.get("name") == "filename":
                filename = child.get("value")
            elif child.tag == "integer" and child.get("name") == "shapeIndex":
                index = int(child.get("value"))
            elif child.tag == "transform" and child.get("name") == "toWorld":
                for m in child.findall("matrix"):
                    matrix = parse_matrix(m.get("value"))
                if len(child) and matrix is None:
                    raise ConvertError("shape %s: only <matrix> transforms are supported" % sh.get("id"))
            elif child.tag == "ref" and child.get("name", "bsdf") == "bsdf":
                bsdf = child.get("id")
            elif child.tag == "bsdf":
                bsdf = child.get("id")
        if filename is None:
            raise ConvertError("shape %s has no filename" % sh.get("id"))
        shapes.append((sh.get("id") or "shape%d" % len(shapes), filename, index, matrix, bsdf))
    return bsdfs, shapes


def fmt(x):
    s = "%.6f" % x
    return s


def convert(xml_path, obj_path, mtl_path, header, mtl_header):
    bsdfs, shapes = parse_scene(xml_path)
    base = os.path.dirname(os.path.abspath(xml_path))
    files = {}
    out = ["# " + header, "mtllib " + os.path.basename(mtl_path)]
    nv_total, nt_total = 0, 0
    for sid, filename, index, matrix, bsdf in shapes:
        if filename not in files:
            with open(os.path.join(base, filename), "rb") as f:
                data = f.read()
            files[filename] = (data,) + tuple(mesh_offsets(data))
        data, offsets, table = files[filename]
        _, p, n, uv, tris = read_mesh(data, offsets, table, index)
        nv = len(p) // 3
        m = matrix or [[1, 0, 0, 0], [0, 1, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1]]
        nm = normal_matrix(m)
        out.append("o " + sid)
        if bsdf:
            out.append("usemtl " + bsdf)
        for i in range(nv):
            x, y, z = p[3 * i:3 * i + 3]
            out.append("v %s %s %s" % tuple(fmt(r[0] * x + r[1] * y + r[2] * z + r[3]) for r in m[:3]))
        if uv:
            for i in range(nv):
                out.append("vt %s %s" % (fmt(uv[2 * i]), fmt(1.0 - uv[2 * i + 1])))
        if n:
            for i in range(nv):
                x, y, z = n[3 * i:3 * i + 3]
                w = [r[0] * x + r[1] * y + r[2] * z for r in nm]
                length = (w[0] * w[0] + w[1] * w[1] + w[2] * w[2]) ** 0.5 or 1.0
                out.append("vn %s %s %s" % tuple(fmt(c / length) for c in w))
        if uv and n:
            pat = "{0}/{0}/{0}"
        elif uv:
            pat = "{0}/{0}"
        elif n:
            pat = "{0}//{0}"
        else:
            pat = "{0}"
        for t in range(len(tris) // 3):
            out.append("f " + " ".join(pat.format(nv_total + tris[3 * t + k] + 1) for k in range(3)))
        nv_total += nv
        nt_total += len(tris) // 3
    with open(obj_path, "w", newline="\n") as f:
        f.write("\n".join(out) + "\n")
    used = {s[4] for s in shapes}
    mtl = ["# " + mtl_header, ""]
    for bid, kd, tex in bsdfs:
        if bid not in used:
            continue
        mtl.append("newmtl " + bid)
        mtl.append("Kd " + kd)
        if tex:
            mtl.append("map_Kd " + tex)
        mtl += ["Ka 0 0 0", "Ks 0 0 0", "illum 1", ""]
    with open(mtl_path, "w", newline="\n") as f:
        f.write("\n".join(mtl))
    return len(shapes), nv_total, nt_total


def main():
    ap = argparse.ArgumentParser(description="Mitsuba 0.4 serialized meshes (+ diffuse bsdfs) to OBJ + MTL")
    ap.add_argument("xml", help="the Mitsuba scene (its serialized files are read relative to it)")
    ap.add_argument("obj", help="the OBJ to write")
    ap.add_argument("--mtl", help="the MTL to write (default: OBJ with .mtl)")
    ap.add_argument("--header", default="converted from a Mitsuba serialized scene by mitsuba_to_obj.py")
    ap.add_argument("--mtl-header", default="materials (diffuse only) from a Mitsuba scene")
    a = ap.parse_args()
    mtl = a.mtl or os.path.splitext(a.obj)[0] + ".mtl"
    try:
        shapes, nv, nt = convert(a.xml, a.obj, mtl, a.header, a.mtl_header)
    except (ConvertError, OSError, ET.ParseError, struct.error, zlib.error) as e:
        print("mitsuba_to_obj: error: %s" % e, file=sys.stderr)
        return 1
    print("mitsuba_to_obj: %s: %d shapes, %d vertices, %d triangles" % (a.obj, shapes, nv, nt))
    return 0


if __name__ == "__main__":
    sys.exit(main())
