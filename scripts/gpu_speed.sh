#!/usr/bin/env bash
# The GPU speed report (docs/results/gpu-speed): `penumbra bench` at 1920x1080, 1 spp a launch, depth 8, on the
# wavefront with each trace stage and on the megakernel, GPU time (CUDA events) beside wall time per launch, and
# the trace stage alone on random rays (`bench --probe`). Run on a GPU machine from a clean commit:
#
#   scripts/gpu_speed.sh [PENUMBRA] [OUT_DIR]      (defaults: build/penumbra, docs/results/gpu-speed)
#
# Scenes that need models from outside the repository (sponza) are left out where penumbra does not list them.
# The report (OUT_DIR/README.md) is written by scripts/gpu_speed_report.py from the JSON files beside it; where ncu
# is installed, scripts/gpu_profile.py adds the kernels' times (profile.md); where Mitsuba 3 and penumbra's Python
# module import, the Mitsuba anchor adds Mitsuba's time on the same GPU (anchor.md).
set -euo pipefail
penumbra=${1:-build/penumbra}
out=${2:-docs/results/gpu-speed}
here=$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)
mkdir -p "$out"
scenes=cornell-sphere
"$penumbra" scenes 2>/dev/null | grep -qw sponza && scenes+=,sponza
"$penumbra" scenes 2>/dev/null | grep -qw many-spheres && scenes+=,many-spheres
common=(--backend optix --scenes "$scenes" --strategies area,solid-angle --mis none --width 1920 --height 1080
        --spp-per-launch 1 --max-depth 8 --launches 50 --warmup 10)
for mode in wavefront-cuda wavefront-optix megakernel; do
  case $mode in
    wavefront-cuda) extra=(--wavefront --traversal cuda) ;;
    wavefront-optix) extra=(--wavefront --traversal optix) ;;
    megakernel) extra=(--megakernel) ;;
  esac
  echo "== bench $mode" >&2
  "$penumbra" bench "${common[@]}" "${extra[@]}" --json "$out/bench_$mode.json" >&2
done
echo "== probe" >&2
# Status 3: the trace stages disagree beyond the probe's bounds; the JSON says where, and the report shows it.
probe_status=0
"$penumbra" bench --backend optix --scenes "$scenes" --probe --json "$out/probe.json" >&2 || probe_status=$?
if [[ $probe_status != 0 && $probe_status != 3 ]]; then exit "$probe_status"; fi
# Mitsuba 3 on the same GPU, where its Python package and penumbra's module import here: the anchor
# (scripts/anchors/mitsuba_anchor.py) on cornell-sphere at 1920x1080, both renderers' images compared and their
# times a sample side by side (anchor.md, which the report shows). Its verdict does not stop the report.
rm -f "$out/anchor.md"
if python3 -c "import mitsuba, penumbra" >/dev/null 2>&1; then
  echo "== Mitsuba 3 (cuda_ad_rgb) and penumbra on cornell-sphere" >&2
  python3 "$here/anchors/mitsuba_anchor.py" cornell-sphere --variant cuda_ad_rgb --backend optix --width 1920 \
    --height 1080 --spp 64 --seeds 3 --out "$out" >&2 || echo "gpu_speed: the anchor's images disagree or it failed" >&2
fi
# Per kernel (Nsight Compute), where ncu is installed: profile.md, which the report links.
if command -v ncu >/dev/null 2>&1; then
  echo "== profile" >&2
  python3 "$here/gpu_profile.py" --penumbra "$penumbra" --out "$out" --scenes "${scenes%%,many-spheres}" >&2
fi
python3 "$here/gpu_speed_report.py" "$out"
