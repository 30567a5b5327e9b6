#!/usr/bin/env python3
"""Check that two OBJ files describe the same geometry and materials.

    compare_obj.py A.obj B.obj [--tol 1e-5]

Same objects (`o`), materials (`usemtl`, and the MTL files' lines), faces
(`f`, exactly), and positions, uvs and normals equal within --tol. Prints the
counts and the largest differences; exit status 1 when they differ.
"""
import argparse
import os
import sys


def load(path):
    d = {"v": [], "vt": [], "vn": [], "f": [], "o": [], "usemtl": [], "mtllib": []}
    with open(path) as f:
        for line in f:
            parts = line.split()
            if parts and parts[0] in d:
                d[parts[0]].append(parts[1:])
    return d


def mtl_lines(obj, d):
    if not d["mtllib"]:
        return []
    with open(os.path.join(os.path.dirname(obj), d["mtllib"][0][0])) as f:
        return [l.split() for l in f if l.strip() and not l.startswith("#")]


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("a")
    ap.add_argument("b")
    ap.add_argument("--tol", type=float, default=1e-5)
    args = ap.parse_args()
    a, b = load(args.a), load(args.b)
    ok = True
    for key in ("o", "usemtl", "f"):
        same = a[key] == b[key]
        print("%-6s %d vs %d: %s" % (key, len(a[key]), len(b[key]), "same" if same else "DIFFERENT"))
        ok &= same
    for key in ("v", "vt", "vn"):
        if len(a[key]) != len(b[key]):
            print("%-6s %d vs %d: DIFFERENT counts" % (key, len(a[key]), len(b[key])))
            ok = False
            continue
        worst = 0.0
        for x, y in zip(a[key], b[key]):
            worst = max([worst] + [abs(float(p) - float(q)) for p, q in zip(x, y)])
        print("%-6s %d vs %d: max |difference| %.3g" % (key, len(a[key]), len(b[key]), worst))
        ok &= worst <= args.tol
    same = mtl_lines(args.a, a) == mtl_lines(args.b, b)
    print("mtl    %s" % ("same" if same else "DIFFERENT"))
    ok &= same
    print("OK" if ok else "DIFFERENT")
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
