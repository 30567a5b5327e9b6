#!/usr/bin/env bash
# The study on every GPU of one machine (issue 15): a 1080p ground truth on one
# GPU and on N, its speed-up and its image. Needs a machine with several NVIDIA
# GPUs, so it cannot run in CI (tests/render/test_multi_backend.cpp checks the split on
# CPU "devices" there).
#
#   scripts/multi_gpu_check.sh [BUILD_DIR]
#
# Without BUILD_DIR it configures and builds build-multi-gpu (Release,
# CMAKE_CUDA_ARCHITECTURES=90, OptiX_ROOT from the environment or .optix/).
# Then, for cornell-sphere at 1920x1080:
#   1. `penumbra converge` renders the ground truth (MULTI_GPU_SPP samples per
#      pixel, default 65536, in chunks of 4096; --max-spp 1 --seeds 1: the rest
#      is negligible) into a fresh cache with --gpus 1, then with --gpus N (all
#      GPUs, or MULTI_GPU_N); the times are summary.json's reference.seconds;
#   2. speed-up = time on 1 / time on N, which should be at least 0.9 x N;
#   3. the two cached ground truths (mean and variance EXRs): byte for byte
#      (the paths are the same whatever the split; only the order of double
#      additions differs); where they are not, `penumbra compare` says whether
#      they are the same image statistically, and the check fails;
#   4. `penumbra render --gpus N --stats`: the per-GPU sample ranges and times.
# Prints PASS/FAIL per step, the numbers, and a summary; exits 0 only if all passed.
#
# Environment: MULTI_GPU_SPP, MULTI_GPU_N, MULTI_GPU_SCENE (default cornell-sphere),
# MULTI_GPU_OUT (default BUILD_DIR/multi_gpu_check), OptiX_ROOT.
set -uo pipefail

root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
build=${1:-}
spp=${MULTI_GPU_SPP:-65536}
scene=${MULTI_GPU_SCENE:-cornell-sphere}

source "$root/scripts/check_record.sh"  # record NAME STATUS, finish_checks TITLE, gpu_build DIR TITLE

if [[ -z $build ]]; then
  build=$root/build-multi-gpu
  gpu_build "$build" multi_gpu_check penumbra
fi
build=$(cd "$build" && pwd)
penumbra=$build/penumbra
out=${MULTI_GPU_OUT:-$build/multi_gpu_check}
rm -rf "$out"
mkdir -p "$out"
[[ -x $penumbra ]] || { echo "multi_gpu_check: FAIL: no executable $penumbra"; exit 1; }

gpus=$(nvidia-smi --query-gpu=name --format=csv,noheader 2>/dev/null | wc -l)
n=${MULTI_GPU_N:-$gpus}
echo "== $gpus GPUs: $(nvidia-smi --query-gpu=name,driver_version --format=csv,noheader 2>/dev/null | sort | uniq -c | tr '\n' ' ')"
if [[ $n -lt 2 ]]; then
  echo "multi_gpu_check: FAIL: this needs a machine with at least 2 GPUs ($gpus found)"
  exit 1
fi

# 1. The ground truth on 1 GPU and on N.
ground_truth() {  # ground_truth GPUS NAME
  "$penumbra" converge "$scene" --backend optix --gpus "$1" --width 1920 --height 1080 --reference-spp "$spp" \
    --reference-chunk 4096 --max-spp 1 --seeds 1 --strategies solid-angle --cache "$out/cache-$2" \
    --out "$out/converge-$2" >"$out/converge-$2.log" 2>&1
}
seconds() {  # the ground truth's time from summary.json
  python3 -c "import json,sys; print(json.load(open(sys.argv[1]))['reference']['seconds'])" "$out/converge-$1/summary.json"
}
echo "== ground truth of $scene, 1920x1080, $spp spp on 1 GPU"
ground_truth 1 one; st=$?
[[ $st -eq 0 ]] || tail -n 5 "$out/converge-one.log"
record "ground truth on 1 GPU" $st
echo "== the same on $n GPUs"
ground_truth "$n" many; st=$?
[[ $st -eq 0 ]] || tail -n 5 "$out/converge-many.log"
record "ground truth on $n GPUs" $st

# 2. Speed-up.
if [[ -f $out/converge-one/summary.json && -f $out/converge-many/summary.json ]]; then
  t1=$(seconds one)
  tn=$(seconds many)
  speedup=$(python3 -c "print(f'{$t1 / $tn:.2f}')")
  echo "ground truth: $t1 s on 1 GPU, $tn s on $n GPUs: speed-up ${speedup}x (target >= $(python3 -c "print(0.9 * $n)"))"
  python3 -c "import sys; sys.exit(0 if $t1 / $tn >= 0.9 * $n else 1)"
  record "speed-up ${speedup}x >= 0.9 x $n" $?

  # 3. The same image.
  same=0
  for f in "$out"/cache-one/ref-*.exr; do
    name=$(basename "$f")
    cmp -s "$f" "$out/cache-many/$name"
    st=$?
    [[ $st -eq 0 ]] || same=1
    record "ground truth $name: the same bytes on 1 and $n GPUs" $st
  done
  if [[ $same -ne 0 ]]; then
    mean=$(ls "$out"/cache-one/ref-*.exr | grep -v _var)
    name=$(basename "$mean" .exr)
    "$penumbra" compare "$mean" "$out/cache-one/${name}_var.exr" "$out/cache-many/$name.exr" \
      "$out/cache-many/${name}_var.exr"
  fi
fi

# 4. Per-GPU statistics of one render.
echo "== penumbra render --gpus $n --stats"
"$penumbra" render "$scene" --backend optix --gpus "$n" --width 1920 --height 1080 --spp 1024 --stats \
  -o "$out/render.exr" 2>&1 | tee "$out/render.log" | grep -E "^backend|^stats|^wrote"
record "render --gpus $n --stats" "${PIPESTATUS[0]}"

finish_checks "multi_gpu_check"
