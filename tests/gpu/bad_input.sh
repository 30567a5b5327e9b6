#!/usr/bin/env bash
# GPU test: bad input on the GPU (issue 12), on the files of tests/data (CTest gpu.bad_input; what
# scripts/gpu_check.sh's step 5 was).
#
#   tests/gpu/bad_input.sh PENUMBRA OUT_DIR
#
#   a) a camera inside a closed box sees exactly 0 with every strategy, on the wavefront with both trace stages
#      and on the megakernel (watertight triangles, hit points off the edges, in each traversal);
#   b) an overflowing sky: the image is written, the dropped samples counted and located, exit status 4 (each
#      GPU mode);
#   c) the device-memory estimate checked before building is not below what the scenes take.
source "$(dirname "${BASH_SOURCE[0]}")/lib.sh" bad_input "$@"
data=$gpu_tests_root/tests/data

# a) Written as PNG at +20 stops, so that anything above 1e-6 is a non-zero byte; the first non-zero pixel in scan
#    order has zero neighbours, so a PNG row filter cannot hide it: all-zero filtered bytes mean an all-zero image.
all_black_png() {
  python3 - "$1" <<'PY'
import struct, sys, zlib
d = open(sys.argv[1], "rb").read()
pos, idat, w = 8, b"", 0
while pos < len(d):
    n, kind = struct.unpack(">I4s", d[pos:pos + 8])
    if kind == b"IHDR":
        w = struct.unpack(">I", d[pos + 8:pos + 12])[0]
    elif kind == b"IDAT":
        idat += d[pos + 8:pos + 8 + n]
    pos += 12 + n
raw = zlib.decompress(idat)
stride = 1 + 3 * w
lit = sum(1 for i, b in enumerate(raw) if i % stride != 0 and b != 0)
print(f"{sys.argv[1]}: {lit} non-zero bytes")
sys.exit(1 if lit else 0)
PY
}
for mode in wf_cuda wf_optix mega; do
  gpu_args $mode
  for strategy in area solid-angle bsdf; do
    n=closed_box_${strategy}_$mode
    "$penumbra" render "$data/closed_box.json" "${garg[@]}" --strategy "$strategy" --exposure 20 -o "$out/$n.png" \
      >"$out/$n.log" 2>&1 && all_black_png "$out/$n.png"
    record "closed box, $strategy, $mode: the GPU sees exactly 0" $?
  done
done

# b) An overflowing sky.
for mode in wf_cuda wf_optix mega; do
  gpu_args $mode
  n=overflow_$mode
  rm -f "$out/$n.png"
  "$penumbra" render "$data/overflow_env_scene.json" "${garg[@]}" -o "$out/$n.png" >"$out/$n.log" 2>&1
  st=$?
  grep "NaN or infinite" "$out/$n.log" || true
  [[ $st -eq 4 && -s $out/$n.png ]] && grep -q "at pixels (0, 0)" "$out/$n.log"
  record "non-finite samples, $mode: image written, exit 4" $?
done

# c) bench's JSON: estimated_mib against accel + buffers + textures, on cornell-sphere and the real scenes listed.
scenes=cornell-sphere
for s in glossy sponza; do listed "$s" && scenes+=",$s"; done
"$penumbra" bench --backend optix --scenes "$scenes" --launches 2 --warmup 0 --json "$out/estimate.json" \
  >"$out/estimate.log" 2>&1
st=$?
if [[ $st -eq 0 ]]; then
  python3 - "$out/estimate.json" <<'PY'
import json, sys
bad = 0
for b in json.load(open(sys.argv[1]))["scene_builds"]:
    ok = b["estimated_mib"] >= b["scene_total_mib"]
    bad += not ok
    print(f"  {b['scene']}: estimated {b['estimated_mib']:.1f} MiB, took {b['scene_total_mib']:.1f} MiB "
          f"(device-wide {b['device_used_delta_mib']:.1f} MiB) {'ok' if ok else 'UNDER-ESTIMATED'}")
sys.exit(1 if bad else 0)
PY
  st=$?
else
  tail -n 3 "$out/estimate.log"
fi
record "GPU memory estimate >= what the scene takes ($scenes)" $st

finish_checks "$title"
