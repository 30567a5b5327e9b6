#!/usr/bin/env bash
# GPU test: `penumbra converge`'s two times on each GPU path (CTest gpu.converge.times). A render's time_ms is the
# GPU time of its launches (CUDA events), its wall_ms the host's clock around the whole render call, the film's
# read-back included (docs/metrics.md): every row of measurements.csv must have 0 < time_ms <= wall_ms, every
# point and technique of summary.json the same order (time_ms and wall_ms, ms_per_spp and wall_ms_per_spp), and
# the run must have taken the GPU path asked for. cornell-sphere at 256x144, 1..16 spp x 2 seeds, area and solid-angle.
#
#   tests/gpu/converge_times.sh PENUMBRA OUT_DIR
source "$(dirname "${BASH_SOURCE[0]}")/lib.sh" converge_times "$@"
gpu_probe

for mode in wf_cuda wf_optix mega; do
  gpu_args $mode
  run=$out/$mode
  "$penumbra" converge cornell-sphere "${garg[@]}" --width 256 --height 144 --reference-spp 256 --max-spp 16 \
    --seeds 2 --strategies area,solid-angle --cache "$out/cache" --out "$run" >"$out/$mode.log" 2>&1
  st=$?
  [[ $st == 0 ]] || tail -n 3 "$out/$mode.log"
  record "converge on $mode runs" $st
  [[ $st == 0 ]] || continue
  case $mode in
    wf_cuda) path="wavefront (cuda traversal)" ;;
    wf_optix) path="wavefront (optix traversal)" ;;
    mega) path=megakernel ;;
  esac
  python3 - "$run" "$path" <<'EOF'
import csv, json, sys
run, path = sys.argv[1], sys.argv[2]
bad = []
with open(f"{run}/measurements.csv") as f:
    rows = list(csv.DictReader(f))
if len(rows) != 2 * 5 * 2:  # techniques x spp 1, 2, 4, 8, 16 x seeds
    bad.append(f"{len(rows)} rows, not 20")
for r in rows:
    t, w = float(r["time_ms"]), float(r["wall_ms"])
    if not 0 < t <= w:
        bad.append(f"{r['strategy']} {r['spp']} spp seed {r['seed']}: time_ms {t} wall_ms {w}")
with open(f"{run}/summary.json") as f:
    s = json.load(f)
took = s["device_info"].get("path_tracer", "?")
if (path == "megakernel") != (took == "megakernel") or (took == "wavefront" and path not in s["device"]):
    bad.append(f"the run took {took} on {s['device']!r}, not the {path}")
for name, js in s["strategies"].items():
    if not 0 < js["ms_per_spp"] <= js["wall_ms_per_spp"]:
        bad.append(f"{name}: ms_per_spp {js['ms_per_spp']} wall_ms_per_spp {js['wall_ms_per_spp']}")
    for p in js["points"]:
        if not 0 < p["time_ms"] <= p["wall_ms"]:
            bad.append(f"{name} {p['spp']} spp: time_ms {p['time_ms']} wall_ms {p['wall_ms']}")
last = {n: js["points"][-1] for n, js in s["strategies"].items()}
print("  " + path + ": " + ", ".join(f"{n} {p['time_ms']:.2f} ms GPU / {p['wall_ms']:.2f} ms wall at {p['spp']} spp"
                                     for n, p in last.items()))
for b in bad[:10]:
    print("  " + b)
sys.exit(1 if bad else 0)
EOF
  record "converge on $mode: GPU time <= wall time in every row, point and technique, the path named" $?
done

finish_checks "$title"
