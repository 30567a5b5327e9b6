#!/usr/bin/env bash
# image_means.py (the GPU tests' robust image-mean test) on the CPU, in a few seconds (CTest gpu_image_means_cpu,
# in the default run; no GPU needed):
#   - its EXR reader gives `penumbra compare`'s image means, for a ZIP-compressed and an uncompressed file;
#   - two seeds of one scene: PASS (its power reported with --bias 0), and FAIL where it must see a 1% bias and
#     this few samples cannot;
#   - the light 10% brighter in one of them: FAIL.
#
#   tests/gpu/image_means_test.sh PENUMBRA OUT_DIR
set -uo pipefail
here=$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)
penumbra=$1
out=$2
mkdir -p "$out" || exit 1
source "$here/../../scripts/check_record.sh"  # record, finish_checks

render() {  # render NAME SEED WIDTH HEIGHT [args...]
  local name=$1 seed=$2 w=$3 h=$4
  shift 4
  "$penumbra" render cornell-sphere --backend cpu --seed "$seed" --width "$w" --height "$h" --spp 256 \
    -o "$out/$name.exr" --variance "$out/${name}_var.exr" "$@" >"$out/$name.log" 2>&1 ||
    { cat "$out/$name.log"; exit 1; }
}
means() { python3 "$here/image_means.py" "$out/$1.exr" "$out/$2.exr" "${@:3}"; }

render a 0 64 36
render b 1 64 36
# The sphere light's power (cornell-sphere's [78.9, 66.9, 34.3]) times 1.1: the image is linear in it.
render bright 1 64 36 --set 'light.power=[86.79,73.59,37.73]'
render tiny_a 0 12 8  # below 16x16: written uncompressed
render tiny_b 1 12 8

for pair in "a b" "tiny_a tiny_b"; do
  set -- $pair
  c=$("$penumbra" compare "$out/$1.exr" "$out/$1_var.exr" "$out/$2.exr" "$out/$2_var.exr" | grep -o 'means [^(]*')
  m=$(means "$1" "$2" --bias 0 | grep -o 'means [^(]*')
  echo "compare: $c; image_means: $m"
  # The same means to 6 digits (penumbra sums in another order: allow the last one to differ).
  awk -v c="$c" -v m="$m" 'BEGIN { split(c, x, " "); split(m, y, " ");
    if (x[2] == "" || y[2] == "") exit 1
    for (i = 2; i <= 4; i += 2) if ((x[i] - y[i]) ^ 2 > (1e-5 * x[i]) ^ 2) exit 1 }'
  record "image_means reads $1.exr and $2.exr as penumbra does" $?
done
line=$(means a b --bias 0)
st=$?
echo "$line"
[[ $st == 0 && $line == PASS:* ]]
record "two seeds: PASS" $?
line=$(means a b --bias 0.01)
st=$?
echo "$line"
[[ $st == 3 && $line == *"too noisy to catch a 1% bias"* ]]
record "two seeds at 256 spp, a 1% bias required: FAIL (too few samples)" $?
line=$(means a bright --bias 0)
st=$?
echo "$line"
[[ $st == 3 && $line == FAIL:* ]]
record "the light 10% brighter: FAIL" $?
means a "missing" >/dev/null
[[ $? == 1 ]]
record "a missing file: exit 1" $?

finish_checks image_means_test
