#!/usr/bin/env bash
# How much a change to the renderer changes its images: every built-in scene
# rendered by two penumbra binaries with the same seed and settings, and the
# pairs compared by `penumbra compare` (the image means, their relative
# difference and its standard error; the per-pixel z-test).
#
#   scripts/image_change.sh OLD_PENUMBRA NEW_PENUMBRA OUT_DIR [render options...]
#
# Default render options: --backend cpu --width 160 --height 90 --spp 64
# --seed 1. Scenes: IMAGE_CHANGE_SCENES (default: every scene `NEW scenes`
# lists; those a binary cannot load, e.g. without ../shared/scenes, are
# skipped with a note). Prints a Markdown table and writes it to
# OUT_DIR/image_change.md.
set -uo pipefail
if [[ $# -lt 3 ]]; then
  echo "usage: $0 OLD_PENUMBRA NEW_PENUMBRA OUT_DIR [render options...]" >&2
  exit 2
fi
old=$1 new=$2 out=$3
shift 3
opts=("$@")
[[ ${#opts[@]} -gt 0 ]] || opts=(--backend cpu --width 160 --height 90 --spp 64 --seed 1)
mkdir -p "$out"
scenes=${IMAGE_CHANGE_SCENES:-$("$new" scenes | awk '{print $1}')}
table=$out/image_change.md
{
  echo "Renders: \`${opts[*]}\`; old: \`$("$old" --version 2>/dev/null || echo "$old")\`;" \
    "new: \`$("$new" --version 2>/dev/null || echo "$new")\`."
  echo
  echo "| scene | mean before | mean after | rel. difference | its standard error | \`penumbra compare\` |"
  echo "| --- | ---: | ---: | ---: | ---: | --- |"
} >"$table"
for s in $scenes; do
  ok=1
  for which in old new; do
    bin=${!which}
    if ! "$bin" render "$s" "${opts[@]}" -o "$out/${s}_$which.exr" --variance "$out/${s}_${which}_var.exr" \
      >"$out/${s}_$which.log" 2>&1; then
      echo "$s: skipped ($which: $(tail -n 1 "$out/${s}_$which.log"))" >&2
      ok=0
      break
    fi
  done
  [[ $ok == 1 ]] || continue
  # "A.exr vs B.exr: PASS: means a vs b (rel. diff X%), image z ..." then the bound's line with the standard
  # error of the difference (as if the renders were independent; with one seed they are not, and agree closer).
  report=$("$new" compare --max-rel-diff 1 "$out/${s}_old.exr" "$out/${s}_old_var.exr" "$out/${s}_new.exr" \
    "$out/${s}_new_var.exr" 2>&1)
  line=$(head -n 1 <<<"$report")
  a=$(sed -n 's/.*means \([^ ]*\) vs \([^ ]*\) .*/\1/p' <<<"$line")
  b=$(sed -n 's/.*means \([^ ]*\) vs \([^ ]*\) .*/\2/p' <<<"$line")
  d=$(sed -n 's/.*rel\. diff \([^%]*%\).*/\1/p' <<<"$line")
  se=$(sed -n 's/.*standard error of the difference: \([^%]*%\).*/\1/p' <<<"$report")
  verdict=$(sed -n 's/^[^ ]* vs [^ ]*: \([A-Z]*\):.*image z \([^,]*\),.*/\1 (image z \2)/p' <<<"$line")
  echo "| $s | $a | $b | $d | $se | $verdict |" >>"$table"
done
cat "$table"
