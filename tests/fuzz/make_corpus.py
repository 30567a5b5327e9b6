#!/usr/bin/env python3
"""Writes the seed corpora of the fuzz targets (tests/fuzz/corpus/<target>/):
small valid inputs of every kind each loader reads, so that libFuzzer starts
from the formats' structure. Needs a built penumbra (for the built-in scenes
and an EXR it writes) and Pillow (for PNG, JPEG, BMP and TGA seeds).

    python3 tests/fuzz/make_corpus.py --penumbra build/penumbra
"""
import argparse
import io
import os
import shutil
import struct
import subprocess
import tempfile

HERE = os.path.dirname(os.path.abspath(__file__))
DATA = os.path.join(HERE, "..", "data")


def put(target, name, data):
    folder = os.path.join(HERE, "corpus", target)
    os.makedirs(folder, exist_ok=True)
    with open(os.path.join(folder, name), "wb") as f:
        f.write(data if isinstance(data, bytes) else data.encode())


def read(name):
    with open(os.path.join(DATA, name), "rb") as f:
        return f.read()


def scenes(penumbra):
    for name in ["cornell-sphere", "cornell-near", "occlusion"]:
        text = subprocess.run([penumbra, "scenes", "--dump", name], capture_output=True, check=True).stdout
        put("scene", name + ".json", text)
    dump = subprocess.run([penumbra, "scenes", "--dump", "cornell-sphere"], capture_output=True, check=True).stdout
    put("scene", "overrides.json", dump + b"\0light.radius=0.05\nrender.spp=3\ncamera.fov=30\nlight.power=[1,2,3]")
    for f in ["mesh_scene.json", "bad_index_scene.json", "nan_env_scene.json", "overflow_env_scene.json",
              "gltf_two_parents_scene.json", "no_light.json", "no_render_block.json", "closed_box.json",
              "missing_mesh.json", "truncated.json"]:
        put("scene", f, read(f))
    # Materials with textures, models and every shape type, in one file.
    put("scene", "everything.json", """{
 "camera": {"eye": [0, 1, 4], "target": [0, 0.5, 0], "up": [0, 1, 0], "fov": 45},
 "render": {"width": 8, "height": 6, "spp": 1, "max_depth": 3, "rr_depth": 2, "strategy": "area", "seed": 7},
 "background": [0.1, 0.1, 0.1],
 "materials": {
  "lambert": {"albedo": [0.8, 0.5, 0.2]},
  "metal": {"base_color": [0.9, 0.9, 0.9], "metallic": 1, "roughness": 0.3, "specular": 0.5},
  "tex": {"base_color_texture": "checker.bmp", "normal_texture": "checker.bmp", "normal_scale": 0.5,
          "metallic_roughness_texture": "checker.bmp", "alpha_cutoff": 0.5, "alpha": 1},
  "glow": {"albedo": 0.1, "emission": [2, 2, 2], "emission_texture": "checker.bmp"}},
 "meshes": {"tet": {"type": "mesh", "file": "tetra.obj"}, "q": {"type": "quad", "corner": [0, 0, 0],
            "edge1": [1, 0, 0], "edge2": [0, 1, 0]}},
 "shapes": [
  {"type": "sphere", "center": [0, 0.5, 0], "radius": 0.5, "material": "metal"},
  {"type": "box", "center": [1, 0.5, 0], "size": [0.5, 1, 0.5], "rotate_y": 30, "material": "lambert"},
  {"type": "instance", "mesh": "tet", "material": "tex",
   "transform": {"translate": [-1, 0, 0], "rotate": [0, 1, 0, 45], "scale": [1, 2, 1]}},
  {"type": "instance", "mesh": "q", "material": "glow"},
  {"type": "mesh", "positions": [[0, 0, 0], [1, 0, 0], [0, 1, 0]], "indices": [[0, 1, 2]], "material": "lambert"}],
 "models": [{"file": "tiny.gltf", "transforms": [{}, {"translate": [0, 0, -2]}]},
            {"file": "tiny_textured.obj", "material": "lambert"}],
 "lights": [{"type": "sphere", "center": [0, 3, 0], "radius": 0.2, "power": 50},
            {"type": "quad", "corner": [2, 2, 0], "edge1": [0, 0, 1], "edge2": [0, -1, 0], "radiance": [1, 2, 3]}],
 "environment": {"file": "nan_env.exr", "rotation": 90, "intensity": [1, 0.5, 0.25]}
}
""")


def objs():
    for f in ["tetra.obj", "bad_index.obj", "truncated.obj"]:
        put("obj", f, read(f))
    obj = read("tiny_textured.obj").replace(b"tiny_textured.mtl", b"m.mtl")
    put("obj", "textured.obj", obj + b"\0" + read("tiny_textured.mtl"))
    put("obj", "everything.obj", b"""mtllib m.mtl
o quad
v 0 0 0
v 1 0 0
v 1 1 0
v 0 1 0
vt 0 0
vt 1 0
vt 1 1
vt 0 1
vn 0 0 1
g front
usemtl a
f 1/1/1 2/2/1 3/3/1 4/4/1
usemtl b
f -4//1 -2//1 -1//1
s 1
f 1 2 3
\0newmtl a
Kd 0.8 0.2 0.1
Ks 0.04 0.04 0.04
Ns 100
Ke 0 0 0
d 0.5
map_Kd m.obj
newmtl b
Kd 1 1 1
Ke 2 2 2
map_Ke m.mtl
map_d m.obj
norm -bm 0.5 m.obj
illum 2
""")


def gltfs():
    for f in ["tiny.gltf", "tiny.glb", "gltf_two_parents.gltf", "gltf_many_nodes.gltf"]:
        put("gltf", f, read(f))


def images(penumbra):
    from PIL import Image
    img = Image.new("RGBA", (8, 8))
    for y in range(8):
        for x in range(8):
            img.putpixel((x, y), (x * 32, y * 32, (x ^ y) * 32, 255 - x * 8))
    for fmt, name, mode in [("PNG", "rgba.png", "RGBA"), ("PNG", "grey.png", "L"), ("JPEG", "rgb.jpg", "RGB"),
                            ("BMP", "rgb.bmp", "RGB"), ("TGA", "rgba.tga", "RGBA"), ("PNG", "palette.png", "P")]:
        b = io.BytesIO()
        img.convert(mode).save(b, fmt)
        put("image", name, b.getvalue())
    put("image", "checker.bmp", read("checker.bmp"))
    for f in ["nan_env.exr", "overflow_env.exr"]:
        put("image", f, read(f))
    # Radiance HDR, flat and run-length encoded scanlines.
    flat = b"#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y 2 +X 4\n" + bytes([128, 64, 32, 129] * 8)
    put("image", "flat.hdr", flat)
    w = 8
    rle = b"#?RADIANCE\nFORMAT=32-bit_rle_rgbe\nEXPOSURE=1.0\n\n-Y 2 +X 8\n"
    for _ in range(2):
        rle += bytes([2, 2, 0, w])
        for c in range(4):
            rle += bytes([128 + w, 100 + c])  # a run of w equal values
    put("image", "rle.hdr", rle)
    # EXR as penumbra writes it: ZIP-compressed float (32x16 is past tinyexr's "no compression" size).
    tmp = tempfile.mkdtemp()
    try:
        scene = os.path.join(tmp, "s.json")
        with open(scene, "w") as f:
            f.write(subprocess.run([penumbra, "scenes", "--dump", "cornell-sphere"], capture_output=True,
                                   check=True).stdout.decode())
        subprocess.run([penumbra, "render", scene, "--backend", "cpu", "--width", "32", "--height", "16", "--spp",
                        "1", "-o", os.path.join(tmp, "zip.exr")], check=True, capture_output=True)
        put("image", "zip.exr", open(os.path.join(tmp, "zip.exr"), "rb").read())
    finally:
        shutil.rmtree(tmp)


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--penumbra", required=True)
    args = ap.parse_args()
    shutil.rmtree(os.path.join(HERE, "corpus"), ignore_errors=True)
    scenes(args.penumbra)
    objs()
    gltfs()
    images(args.penumbra)


if __name__ == "__main__":
    main()
