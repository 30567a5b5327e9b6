#!/usr/bin/env bash
# GPU test: the viewer's denoise toggle on the CUDA-OpenGL interop path (CTest gpu.viewer.denoise), headless (EGL
# on the NVIDIA GPU). On that path the image never goes through host memory (apps/viewer/images.cpp,
# show_denoised_on_device: the mean into a device image, Intel Open Image Denoise's CUDA device on it in place, a
# kernel's tone-map into the mapped GL buffer); with --display host the mean is copied out, denoised from host
# images and tone-mapped on the host. Checks:
#   a) the interop path says it denoises the image in GPU memory, the host path that it does not;
#   b) the two paths put the same pixels on the screen (window screenshots after the same frames: at most 0.1% of
#      the channels one 8-bit level apart, none further), and both differ from the raw frame;
#   c) the frame times of the four runs (raw and denoised, each path) are printed from the viewer's summary line.
#
#   tests/gpu/viewer_denoise.sh PENUMBRA OUT_DIR [WIDTH HEIGHT FRAMES]
# Skipped (77) where Intel Open Image Denoise is not found (pip install pyoidn).
source "$(dirname "${BASH_SOURCE[0]}")/lib.sh" viewer_denoise "$@"
w=${args[0]:-640}
h=${args[1]:-360}
frames=${args[2]:-30}
gpu_probe
if ! "$penumbra" render cornell-sphere --backend optix --width 8 --height 8 --spp 1 --denoise \
     -o "$out/oidn.exr" >"$out/oidn.log" 2>&1; then
  if grep -q "Open Image Denoise" "$out/oidn.log"; then
    echo "viewer_denoise: skipped: $(grep -m 1 "Open Image Denoise" "$out/oidn.log")"
    exit 77
  fi
  echo "viewer_denoise: FAIL: render --denoise on the GPU:"
  cat "$out/oidn.log"
  exit 1
fi

view_run() {  # view_run NAME DISPLAY DENOISE: a window screenshot after FRAMES frames, OUT/NAME.{png,log}
  local name=$1 display=$2 denoise=$3
  printf '[{"frame": 0, "denoise": %s}, {"frame": %d, "window_screenshot": "%s"}]\n' \
    "$denoise" "$frames" "$out/$name.png" >"$out/$name.json"
  "$penumbra" view cornell-sphere --backend optix --headless --hide-panel --width "$w" --height "$h" \
    --frames "$((frames + 1))" --display "$display" --camera-path "$out/$name.json" >"$out/$name.log" 2>&1
  local st=$?
  [[ $st == 0 ]] || tail -n 5 "$out/$name.log"
  grep -E "^view: [0-9]+ frames" "$out/$name.log" | sed "s/^/$name: /"
  return $st
}
view_run interop_raw interop false; record "interop path, raw" $?
view_run interop_denoised interop true; record "interop path, denoised" $?
view_run host_raw host false; record "host path, raw" $?
view_run host_denoised host true; record "host path, denoised" $?

grep -q "denoise: .*on the image in GPU memory" "$out/interop_denoised.log"
record "a) the interop path denoises the image in GPU memory" $?
grep -q "^view: denoise: " "$out/host_denoised.log" && ! grep -q "in GPU memory" "$out/host_denoised.log"
record "a) the host path denoises host images" $?

# b) PNG pixels (8-bit RGB or RGBA, no interlace): the five row filters undone.
python3 - "$out" <<'PY'
import struct, sys, zlib
import numpy as np

def pixels(path):
    d = open(path, "rb").read()
    pos, idat = 8, b""
    while pos < len(d):
        n, kind = struct.unpack(">I4s", d[pos:pos + 8])
        if kind == b"IHDR":
            w, h, depth, color = struct.unpack(">IIBB", d[pos + 8:pos + 18])
        elif kind == b"IDAT":
            idat += d[pos + 8:pos + 8 + n]
        pos += 12 + n
    bpp = {2: 3, 6: 4}[color]
    data, stride, prev, rows = zlib.decompress(idat), 1 + w * bpp, [0] * (w * bpp), []
    for y in range(h):
        f, row = data[y * stride], list(data[y * stride + 1:(y + 1) * stride])
        if f == 1:
            for i in range(bpp, len(row)): row[i] = (row[i] + row[i - bpp]) & 255
        elif f == 2:
            row = [(r + u) & 255 for r, u in zip(row, prev)]
        elif f == 3:
            for i in range(len(row)): row[i] = (row[i] + ((row[i - bpp] if i >= bpp else 0) + prev[i]) // 2) & 255
        elif f == 4:
            for i in range(len(row)):
                a, b, c = (row[i - bpp], prev[i], prev[i - bpp]) if i >= bpp else (0, prev[i], 0)
                pa, pb, pc = abs(b - c), abs(a - c), abs(a + b - 2 * c)
                row[i] = (row[i] + (a if pa <= pb and pa <= pc else (b if pb <= pc else c))) & 255
        rows.append(row)
        prev = row
    return np.array(rows, np.int32).reshape(h, w, bpp)[:, :, :3]

o = sys.argv[1]
dev, host = pixels(f"{o}/interop_denoised.png"), pixels(f"{o}/host_denoised.png")
raw = pixels(f"{o}/interop_raw.png")
diff = np.abs(dev - host)
off = int((diff > 0).sum())
print(f"interop vs host, denoised: {off} of {diff.size} channels differ, the largest by {int(diff.max())}; "
      f"raw vs denoised: mean |difference| {np.abs(raw - dev).mean():.2f} levels")
ok = diff.max() <= 1 and off <= diff.size // 1000 and np.abs(raw - dev).mean() > 0.5
sys.exit(0 if ok else 1)
PY
record "b) the interop and host paths show the same denoised pixels" $?
finish_checks "$title"
