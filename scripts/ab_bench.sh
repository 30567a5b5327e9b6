#!/usr/bin/env bash
# Before and after in one run: `penumbra bench` (and optionally `bench --probe` and same-seed renders) of two or
# more binaries, or of one binary with different GPU tuning (`--tune KEY=VALUE`, docs/guide.md), interleaved round
# by round so that the machine's drift falls on every variant alike; then one table of the medians.
#
#   scripts/ab_bench.sh [VARIANT ...]      VARIANT: TAG=BINARY[:KEY=VALUE,KEY=VALUE...] (each: --tune KEY=VALUE)
#
#   scripts/ab_bench.sh old=/tmp/penumbra-old new=build/penumbra
#   scripts/ab_bench.sh occ10=build/penumbra occ0=build/penumbra:cuda_occ=0 leaf4=build/penumbra:cuda_leaf=4
#
# Environment (defaults in brackets): AB_TASKS ["bench"; also "probe" (the trace stage on random rays, GPU
# build) and "same" (each variant renders the first scene with seed 3, AB_SAME_ARGS [--width 320 --height 180
# --spp 64], then `penumbra compare` of every variant against the first: the same paths give rel. diff 0.000%)],
# AB_SCENES [cornell-sphere,sponza],
# AB_STRATEGIES [area,solid-angle], AB_MIS [none], AB_DEPTH [8], AB_ROUNDS [2], AB_LAUNCHES [30], AB_WARMUP [5],
# AB_BACKEND [optix], AB_ARGS (more bench arguments, e.g. "--traversal cuda" or "--width 320 --height 180"),
# AB_OUT [ab_bench]: one JSON and log per task, variant and round, and summary.txt.
# Exits 1 if a run fails or a same-seed pair differs, 2 on bad arguments.
set -uo pipefail

die() { echo "ab_bench.sh: $*" >&2; exit 2; }
[[ $# -ge 1 ]] || die "give at least one variant TAG=BINARY[:KEY=VALUE,...] (scripts/ab_bench.sh has examples)"
tags=() bins=() tunes=()
for v in "$@"; do
  [[ $v == *=* ]] || die "'$v' is not TAG=BINARY[:KEY=VALUE,...]"
  tag=${v%%=*} rest=${v#*=}
  bin=${rest%%:*} tune=""
  [[ $rest == *:* ]] && tune=${rest#*:}
  [[ $tag =~ ^[A-Za-z0-9_-]+$ ]] || die "tag '$tag': letters, digits, '-' and '_' only"
  [[ -x $bin ]] || die "$tag: '$bin' is not an executable"
  [[ -z $tune || $tune =~ ^[a-z0-9_]+=[^,\ ]+(,[a-z0-9_]+=[^,\ ]+)*$ ]] || die "$tag: '$tune' is not KEY=VALUE,..."
  tags+=("$tag") bins+=("$bin") tunes+=("$tune")
done
for task in ${AB_TASKS:-bench}; do
  [[ $task == bench || $task == probe || $task == same ]] || die "AB_TASKS: unknown task '$task' (bench, probe, same)"
done
out=${AB_OUT:-ab_bench}
mkdir -p "$out" || die "cannot create $out"
scenes=${AB_SCENES:-cornell-sphere,sponza}
rounds=${AB_ROUNDS:-2}
read -r -a extra <<<"${AB_ARGS:-}"
failed=0

run_variant() {  # run_variant INDEX COMMAND ARGS...: the variant's binary, with its tuning where COMMAND renders
  local i=$1 cmd=$2
  shift 2
  if [[ -n ${tunes[$i]} && ( $cmd == bench || $cmd == render ) ]]; then
    "${bins[$i]}" "$cmd" --tune "${tunes[$i]}" "$@"
  else
    "${bins[$i]}" "$cmd" "$@"
  fi
}

for task in ${AB_TASKS:-bench}; do
  case $task in
  bench | probe)
    for r in $(seq "$rounds"); do
      for i in "${!tags[@]}"; do
        base=$out/${task}_${tags[$i]}_r$r
        if [[ $task == bench ]]; then
          run_variant "$i" bench --backend "${AB_BACKEND:-optix}" --scenes "$scenes" \
            --strategies "${AB_STRATEGIES:-area,solid-angle}" --mis "${AB_MIS:-none}" --max-depth "${AB_DEPTH:-8}" \
            --launches "${AB_LAUNCHES:-30}" --warmup "${AB_WARMUP:-5}" "${extra[@]}" --json "$base.json" >"$base.log" 2>&1
        else
          run_variant "$i" bench --probe --scenes "$scenes" --launches "${AB_LAUNCHES:-20}" "${extra[@]}" \
            --json "$base.json" >"$base.log" 2>&1
        fi
        st=$?
        echo "$task ${tags[$i]} round $r: exit $st"
        [[ $st == 0 ]] || { tail -n 3 "$base.log"; failed=1; }
      done
    done ;;
  same)
    scene=${scenes%%,*}
    for i in "${!tags[@]}"; do
      base=$out/same_${tags[$i]}
      run_variant "$i" render "$scene" --backend "${AB_BACKEND:-optix}" --strategy solid-angle --mis power \
        ${AB_SAME_ARGS:---width 320 --height 180 --spp 64} --seed 3 -o "$base.exr" --variance "${base}_var.exr" >"$base.log" 2>&1 ||
        { echo "same ${tags[$i]}: render failed"; tail -n 3 "$base.log"; failed=1; continue; }
      if [[ $i -gt 0 ]]; then
        line=$(run_variant 0 compare "$out/same_${tags[0]}.exr" "$out/same_${tags[0]}_var.exr" "$base.exr" \
          "${base}_var.exr" | head -n 1)  # the verdict and the numbers; the two tests' lines follow
        echo "same seed, $scene, ${tags[0]} vs ${tags[$i]}: $line"
        [[ $line == *"rel. diff 0.000%"* ]] || failed=1
      fi
    done ;;
  esac
done

# One table: the median of each variant and round (bench: ms a sample; probe: Grays/s, closest / shadow, cuda).
python3 - "$out" "${tags[@]}" <<'EOF' | tee "$out/summary.txt"
import glob, json, os, sys
out, tags = sys.argv[1], sys.argv[2:]
def load(task, tag):
    runs = []
    for p in sorted(glob.glob(os.path.join(out, f"{task}_{tag}_r*.json"))):
        with open(p) as f:
            runs.append(json.load(f))
    return runs
for task in ("bench", "probe"):
    data = {t: load(task, t) for t in tags}
    if not any(data.values()):
        continue
    rows = {}
    for t, runs in data.items():
        for k, run in enumerate(runs):
            for res in run.get("results", []):
                if task == "bench":
                    what = res["strategy"]  # with its MIS mode: "solid-angle+power"
                    if res.get("light_selection") not in (None, "power"):
                        what += ", " + res["light_selection"]
                    key = (res["scene"], what)
                    wall = res.get("wall_ms_per_launch")
                    val = "%.3f" % res["ms_per_launch"]["median"] + ("" if wall is None else " (%.3f)" % wall)
                else:
                    key = (res["scene"], "Grays/s closest / shadow: cuda (optix)")
                    c, o = res["cuda"], res["optix"]
                    val = "%.2f / %.2f (%.2f / %.2f)" % (c["closest_grays"], c["shadow_grays"], o["closest_grays"],
                                                         o["shadow_grays"])
                rows.setdefault(key, {}).setdefault(t, []).append(val)
    print(f"\n{task}: " + ("median ms a sample, GPU (wall)" if task == "bench" else "the trace stage on random rays") +
          ", each variant's rounds in order")
    print("| scene | what | " + " | ".join(tags) + " |")
    print("| --- | --- | " + " | ".join("---:" for _ in tags) + " |")
    for (scene, what), vals in rows.items():
        print(f"| {scene} | {what} | " + " | ".join(", ".join(vals.get(t, ["-"])) for t in tags) + " |")
EOF
exit $failed
