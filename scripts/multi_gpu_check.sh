#!/usr/bin/env bash
# The ground truths on every GPU count of one machine (the scale-out report): 1920x1080 ground truths of each
# scene on 1, 2, 4 and 8 GPUs (those the machine has), on the wavefront with each trace stage, in interleaved
# rounds; the wall time of each, the speed-up over one GPU, and the images byte for byte across GPU counts. Needs
# a machine with several NVIDIA GPUs, so it cannot run in CI (tests/render/test_multi_backend.cpp checks the split
# on CPU "devices" there, and on two parts of one GPU where there is one: gpu.unit.multi_backend).
#
#   scripts/multi_gpu_check.sh [BUILD_DIR]
#
# Without BUILD_DIR it configures and builds build-multi-gpu (Release, CMAKE_CUDA_ARCHITECTURES=90, OptiX_ROOT
# from the environment or .optix/). Then, for every scene, trace stage and round:
#   1. `penumbra converge --gpus N` renders the ground truth (MULTI_GPU_SPP samples per pixel, default 65536, in
#      chunks of 4096; --max-spp 1 --seeds 1: the rest is negligible) into a cache of its own, for N = 1 and every
#      other count up to the machine's GPUs, one count after the other within a round (interleaved, so that a
#      drift of the machine falls on every count alike); the time is summary.json's reference.seconds (the wall
#      clock of the ground truth's rendering), the process's wall time beside it;
#   2. speed-up = median time on 1 GPU / median time on N over the rounds, which should be at least 0.9 x N;
#   3. the first round's ground truths (mean and variance EXRs) on N GPUs against 1: byte for byte (the paths
#      are the same whatever the split; only the order of double additions differs); where they are not,
#      `penumbra compare` says whether they are the same image statistically, and the check fails;
#   4. `penumbra render --gpus N --stats` on the first scene: the per-GPU sample ranges and times.
# Prints PASS/FAIL per check, a table of the times (also OUT/times.tsv) and a summary; exits 0 only if all passed.
# What it costs: a ground truth of 65,536 spp takes about 2 minutes of one H200 on cornell-sphere (1.84 ms a
# sample) and 10 on Sponza (9.2 ms) with the cuda traversal, twice that with OptiX's trace stage; three rounds on
# 1 and 2 GPUs of both scenes and stages take about 2.5 hours. Lower MULTI_GPU_SPP, MULTI_GPU_ROUNDS or the lists
# to fit a machine's time.
#
# Environment: MULTI_GPU_SPP (65536), MULTI_GPU_SCENES ("cornell-sphere sponza"; a scene whose models are not on
# the machine is left out with a line), MULTI_GPU_TRAVERSALS ("cuda optix"), MULTI_GPU_COUNTS ("1 2 4 8", those
# up to the machine's GPUs), MULTI_GPU_ROUNDS (3), MULTI_GPU_OUT (default BUILD_DIR/multi_gpu_check), OptiX_ROOT.
set -uo pipefail

root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
build=${1:-}
spp=${MULTI_GPU_SPP:-65536}
rounds=${MULTI_GPU_ROUNDS:-3}
read -r -a want_scenes <<<"${MULTI_GPU_SCENES:-cornell-sphere sponza}"
read -r -a traversals <<<"${MULTI_GPU_TRAVERSALS:-cuda optix}"
read -r -a want_counts <<<"${MULTI_GPU_COUNTS:-1 2 4 8}"

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
[[ $rounds =~ ^[1-9][0-9]*$ ]] || { echo "multi_gpu_check: FAIL: MULTI_GPU_ROUNDS=$rounds: a positive integer"; exit 1; }

gpus=$(nvidia-smi --query-gpu=name --format=csv,noheader 2>/dev/null | wc -l)
echo "== $gpus GPUs: $(nvidia-smi --query-gpu=name,driver_version --format=csv,noheader 2>/dev/null | sort | uniq -c | tr '\n' ' ')"
counts=(1)
for c in "${want_counts[@]}"; do
  [[ $c =~ ^[0-9]+$ ]] || { echo "multi_gpu_check: FAIL: MULTI_GPU_COUNTS has '$c': GPU counts"; exit 1; }
  if (( c > 1 && c <= gpus )); then counts+=("$c"); fi
done
if [[ ${#counts[@]} -lt 2 ]]; then
  echo "multi_gpu_check: FAIL: this needs a machine with at least 2 GPUs ($gpus found)"
  exit 1
fi
scenes=()
listed=$("$penumbra" scenes 2>/dev/null)
for s in "${want_scenes[@]}"; do
  if grep -qw -- "$s" <<<"$listed"; then scenes+=("$s"); else echo "== $s left out: penumbra does not list it here"; fi
done
[[ ${#scenes[@]} -gt 0 ]] || { echo "multi_gpu_check: FAIL: none of the scenes ${want_scenes[*]} is here"; exit 1; }
echo "== ground truths of ${scenes[*]}, 1920x1080, $spp spp; trace stages ${traversals[*]}; GPUs ${counts[*]};" \
     "$rounds rounds"

# 1. The ground truths, interleaved: every count within a round.
run_dir() { echo "$out/$1-$2-$3gpu-r$4"; }  # run_dir SCENE TRAVERSAL N ROUND
printf 'scene\ttraversal\tgpus\tround\tseconds\tprocess_seconds\n' >"$out/times.tsv"
for ((r = 1; r <= rounds; ++r)); do
  for scene in "${scenes[@]}"; do
    for trav in "${traversals[@]}"; do
      for n in "${counts[@]}"; do
        d=$(run_dir "$scene" "$trav" "$n" "$r")
        t0=$(date +%s.%N)
        "$penumbra" converge "$scene" --backend optix --traversal "$trav" --gpus "$n" --width 1920 --height 1080 \
          --reference-spp "$spp" --reference-chunk 4096 --max-spp 1 --seeds 1 --strategies solid-angle \
          --cache "$d/cache" --out "$d/converge" >"$d.log" 2>&1
        st=$?
        t1=$(date +%s.%N)
        if [[ $st -ne 0 || ! -f $d/converge/summary.json ]]; then
          tail -n 5 "$d.log"
          record "$scene $trav on $n GPUs, round $r" 1
          continue
        fi
        secs=$(python3 -c "import json,sys; print(json.load(open(sys.argv[1]))['reference']['seconds'])" \
               "$d/converge/summary.json")
        printf '%s\t%s\t%s\t%s\t%s\t%s\n' "$scene" "$trav" "$n" "$r" "$secs" \
          "$(python3 -c "print(f'{$t1 - $t0:.3f}')")" >>"$out/times.tsv"
        echo "$scene $trav on $n GPUs, round $r: ${secs} s"
      done
    done
  done
done

# 2. Speed-ups over the rounds' medians, and 3. the images across GPU counts (the first round's).
python3 - "$out/times.tsv" "$out/speedups.md" "$out/speedups.tsv" <<'PY'
import csv, statistics, sys
rows = list(csv.DictReader(open(sys.argv[1]), delimiter="\t"))
secs, proc = {}, {}
for r in rows:
    key = (r["scene"], r["traversal"], int(r["gpus"]))
    secs.setdefault(key, []).append(float(r["seconds"]))
    proc.setdefault(key, []).append(float(r["process_seconds"]))
table = ["| scene | trace stage | GPUs | rounds | ground truth s (median) | process s (median) | speed-up | target |",
         "| --- | --- | ---: | ---: | ---: | ---: | ---: | ---: |"]
checks = []
for (scene, trav, n), ts in sorted(secs.items()):
    one = secs.get((scene, trav, 1))
    s = statistics.median(one) / statistics.median(ts) if one else 0.0
    table.append(f"| {scene} | {trav} | {n} | {len(ts)} | {statistics.median(ts):.2f} | "
                 f"{statistics.median(proc[(scene, trav, n)]):.2f} | {s:.2f}x | {0.9 * n if n > 1 else 1:.1f}x |")
    if n > 1:
        checks.append(f"{scene}\t{trav}\t{n}\t{s:.4f}\t{0.9 * n:.1f}")
open(sys.argv[2], "w").write("\n".join(table) + "\n")
open(sys.argv[3], "w").write("".join(c + "\n" for c in checks))
PY
cat "$out/speedups.md"
while IFS=$'\t' read -r scene trav n s target; do
  python3 -c "import sys; sys.exit(0 if $s >= $target else 1)"
  st=$?  # before the record's arguments, whose $(printf) would reset it
  record "$scene $trav: speed-up $(printf '%.2f' "$s")x on $n GPUs >= ${target}x" $st
done <"$out/speedups.tsv"
for scene in "${scenes[@]}"; do
  for trav in "${traversals[@]}"; do
    one=$(run_dir "$scene" "$trav" 1 1)/cache
    for n in "${counts[@]:1}"; do
      many=$(run_dir "$scene" "$trav" "$n" 1)/cache
      [[ -d $one && -d $many ]] || continue
      same=0
      for f in "$one"/ref-*.exr; do
        cmp -s "$f" "$many/$(basename "$f")" || same=1
      done
      record "$scene $trav: ground truth the same bytes on 1 and $n GPUs" $same
      if [[ $same -ne 0 ]]; then
        mean=$(ls "$one"/ref-*.exr | grep -v _var | head -n 1)
        name=$(basename "$mean" .exr)
        "$penumbra" compare "$mean" "$one/${name}_var.exr" "$many/$name.exr" "$many/${name}_var.exr"
      fi
    done
  done
done

# 4. Per-GPU statistics of one render.
n=${counts[-1]}
echo "== penumbra render ${scenes[0]} --gpus $n --stats"
"$penumbra" render "${scenes[0]}" --backend optix --gpus "$n" --width 1920 --height 1080 --spp 1024 --stats \
  -o "$out/render.exr" 2>&1 | tee "$out/render.log" | grep -E "^backend|^stats|^wrote"
record "render --gpus $n --stats" "${PIPESTATUS[0]}"

finish_checks "multi_gpu_check"
