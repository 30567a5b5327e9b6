# What the GPU tests (tests/gpu/*.sh; CTest label `gpu`, tests/gpu/CMakeLists.txt) share. A test sources it with
# its title and its own command line:
#
#   source "$(dirname "${BASH_SOURCE[0]}")/lib.sh" TITLE PENUMBRA OUT [ARGS...]
#
# PENUMBRA: the executable; OUT: the folder for the test's outputs (made here; CTest gives each test its own,
# <build>/tests/gpu/<test name>). It sets penumbra, out, args (ARGS), builtin (the scenes `penumbra scenes` lists)
# and the image size (width, height); defines the helpers below, and record / finish_checks
# (scripts/check_record.sh). First it probes the GPU backend: where this build or machine has none, the test exits
# 77 there, which CTest reports as skipped (SKIP_RETURN_CODE), unless PENUMBRA_GPU_TESTS=require
# (scripts/gpu_check.sh sets it): then that is a failure.
set -uo pipefail

gpu_tests_root=$(cd "$(dirname "${BASH_SOURCE[0]}")/../.." && pwd)
source "$gpu_tests_root/scripts/check_record.sh"  # record, finish_checks

if [[ $# -lt 3 ]]; then
  echo "usage: $(basename "$0") PENUMBRA OUT_DIR [ARGS...]" >&2
  exit 2
fi
title=$1
penumbra=$2
out=$3
shift 3
args=("$@")
[[ -x $penumbra ]] || { echo "$title: FAIL: no executable $penumbra"; exit 1; }
mkdir -p "$out" || exit 1
out=$(cd "$out" && pwd)
width=128
height=72
# glossy's sky from the tree that holds these tests: an executable built elsewhere looks for it where its own
# source tree was (scene/builtin_scenes.cpp, source_data_file).
export PENUMBRA_DATA=${PENUMBRA_DATA:-$gpu_tests_root/data}

# The GPU backend, or exit 77 (skipped) where there is none: a build without OptiX, or a machine without an NVIDIA
# GPU or driver. The executable says which in one line (backends/make_backend.cpp, backends/optix/context.cpp). Any other
# failure (a GPU and driver are there, the backend is built, and it does not work: an OptiX ABI the driver lacks, a
# driver older than the CUDA runtime, a crash) fails the test: that is what these tests are for.
gpu_probe() {
  local log=$out/probe.log
  if "$penumbra" render cornell-sphere --backend optix --width 8 --height 8 --spp 1 -o "$out/probe.exr" \
       >"$log" 2>&1; then
    grep -E "^(backend|== |wavefront)" "$log" | head -n 3 | sed 's/^/== /'
    return 0
  fi
  local why
  why=$(grep -m 1 "error" "$log" || tail -n 1 "$log")
  local none="built without the OptiX backend|no NVIDIA GPU found|no NVIDIA driver found"
  if grep -qE "$none|no usable NVIDIA driver or GPU" "$log"; then
    if [[ ${PENUMBRA_GPU_TESTS:-} == require ]]; then
      echo "$title: FAIL: no GPU backend here, and PENUMBRA_GPU_TESTS=require: $why"
      exit 1
    fi
    echo "$title: skipped: no GPU backend here ($why)"
    exit 77
  fi
  echo "$title: FAIL: the GPU backend does not render:"
  cat "$log"
  exit 1
}

# The GPU's ways of rendering, as `render` arguments: the wavefront with either trace stage, the megakernel.
gpu_args() {  # gpu_args MODE -> sets the array garg
  case $1 in
    wf_cuda) garg=(--backend optix --wavefront --traversal cuda) ;;
    wf_optix) garg=(--backend optix --wavefront --traversal optix) ;;
    mega) garg=(--backend optix --megakernel) ;;
    *) echo "gpu_args: unknown mode $1" >&2; return 1 ;;
  esac
}

# render NAME SCENE SEED SPP [penumbra render arguments...]: OUT/NAME.exr, its variance OUT/NAME_var.exr and its log
# OUT/NAME.log, at width x height; on failure prints the log's last lines and returns its status.
render() {
  local name=$1 scene=$2 seed=$3 n=$4
  shift 4
  "$penumbra" render "$scene" --seed "$seed" --width "$width" --height "$height" --spp "$n" -o "$out/$name.exr" \
    --variance "$out/${name}_var.exr" "$@" >"$out/$name.log" 2>&1
  local st=$?
  [[ $st == 0 ]] || tail -n 3 "$out/$name.log"
  return $st
}

# compare A B -> `penumbra compare`'s report (also in OUT/B_vs_A.txt; its first line, the verdict, first), its
# status. The statistical test decides: --max-rel-diff 1 leaves the bound on the means out, since a pair of
# independent renders of a noisy technique (sponza's bsdf) may differ by more than 1% at its noise, which the
# statistical test weighs and a fixed bound does not (same_paths asks for a difference of 0.00% itself).
compare() {
  "$penumbra" compare --max-rel-diff 1 "$out/$1.exr" "$out/$1_var.exr" "$out/$2.exr" "$out/$2_var.exr" \
    | tee "$out/$2_vs_$1.txt"
  return "${PIPESTATUS[0]}"
}
compare_pair() {  # compare_pair A B LABEL: `penumbra compare` PASS
  compare "$1" "$2"
  record "$3" $?
}
same_paths() {  # same_paths A B LABEL: PASS with a relative difference of 0.00 (the same paths; the last bits differ)
  local line st
  line=$(compare "$1" "$2")
  st=$?
  line=$(head -n 1 <<<"$line")
  [[ $st == 0 && $line == *"rel. diff 0.00"* ]]
  record "$3" $?
}
within_rel() {  # within_rel A B MAX_REL_DIFF LABEL: `penumbra compare` PASS with the image means within the bound
  "$penumbra" compare --max-rel-diff "$3" "$out/$1.exr" "$out/$1_var.exr" "$out/$2.exr" "$out/$2_var.exr" \
    | tee "$out/$2_vs_$1.txt"
  record "$4" "${PIPESTATUS[0]}"
}
same_bytes() {  # same_bytes A B LABEL: the two EXR files byte for byte
  cmp -s "$out/$1.exr" "$out/$2.exr"
  record "$3" $?
}

# robust_pair A B LABEL [--no-pixel-z] [image_means.py options...]: two renders with independent seeds where
# `penumbra compare`'s image z is not to be trusted (tests/gpu/image_means.py says why: the standard error it gives
# the image mean takes a pixel's R, G and B as independent, up to sqrt(3) too small where they move together, as on
# glossy; and restir's temporal reuse correlates a pixel's samples). PASS where all hold:
#   - per pixel, `penumbra compare`'s own criteria: at most 0.2% of channels beyond 5 standard errors (not with
#     --no-pixel-z: where a pixel's samples are correlated its variance is too small, and so is every z), and no
#     channel with zero variance that differs;
#   - the image means by image_means.py over 8x8-pixel tiles (restir's spatial reuse correlates nearby pixels):
#     |z| < 4 with a standard error from the tiles' own differences, and the test sees a 1% bias with 95% power
#     (--bias B: the bias it must see; --bias 0: reported, not required).
robust_pair() {
  local a=$1 b=$2 label=$3 pixel_z=1 line st=0 outliers channels zvm
  shift 3
  local opts=()
  for o in "$@"; do
    if [[ $o == --no-pixel-z ]]; then pixel_z=0; else opts+=("$o"); fi
  done
  line=$(compare "$a" "$b")
  echo "$line"
  line=$(head -n 1 <<<"$line")
  outliers=$(sed -n 's|.*, \([0-9]*\)/\([0-9]*\) channels beyond.*|\1|p' <<<"$line")
  channels=$(sed -n 's|.*, \([0-9]*\)/\([0-9]*\) channels beyond.*|\2|p' <<<"$line")
  zvm=$(sed -n 's|.*, \([0-9]*\) zero-variance mismatches.*|\1|p' <<<"$line")
  if [[ -z $outliers || -z $channels || -z $zvm ]]; then
    st=1
  elif (( zvm != 0 || (pixel_z == 1 && outliers * 500 > channels) )); then
    st=1
  fi
  echo "  per pixel: $outliers of $channels channels beyond 5 sigma$([[ $pixel_z == 1 ]] && echo " (at most 0.2%)" ||
    echo " (not judged: correlated samples)"), $zvm zero-variance mismatches (none allowed): $([[ $st == 0 ]] &&
    echo ok || echo FAIL)"
  python3 "$gpu_tests_root/tests/gpu/image_means.py" "$out/$a.exr" "$out/$b.exr" --tile 8 "${opts[@]}" \
    | tee "$out/${b}_vs_${a}_means.txt"
  [[ ${PIPESTATUS[0]} == 0 ]] || st=1
  record "$label" $st
}

gpu_probe
builtin=$("$penumbra" scenes | awk '{print $1}')
listed() { grep -qx -- "$1" <<<"$builtin"; }
