#!/usr/bin/env bash
# Proof that the wavefront GPU path tracer (the default; backends/wavefront) computes the megakernel's (--megakernel) and the
# CPU's images, with both trace stages (--traversal optix|cuda), without memory errors, and how fast it is.
# Needs an NVIDIA GPU (cannot run in CI); backends/optix/WAVEFRONT.md says what to look at.
#
#   scripts/wavefront_check.sh [BUILD_DIR]
#
# Without BUILD_DIR it configures and builds build-gpu-check (as gpu_check.sh). Then:
#   1. the CPU's proof of the stage functions: tests Builtins/Wavefront.* (bit-identical to depth-first) and
#      WavefrontMemory.* (the pool's bytes; printed);
#   2. same seed, every pair must give `penumbra compare` PASS with rel. diff 0.00 (the same paths; the last
#      bits differ: fast math, float sums): megakernel vs wavefront (optix traversal), wavefront optix vs cuda
#      traversal; and CPU vs wavefront (PASS); on WAVEFRONT_CHECK_SCENES x techniques, restir without spatial
#      reuse too;
#   3. independent seeds (CPU 0, wavefront 1): `penumbra compare`'s statistical test PASS (as gpu_check.sh:
#      --max-rel-diff 1, the bound on the means left to the statistical test);
#   4. waves: a pool of 5,000 paths (PENUMBRA_WAVEFRONT_PATHS: many waves a launch, pixels cut anywhere, through
#      the launch sums) renders the default pool's image (one wave a launch: straight into the film) byte for byte
#      (the accumulation sums each pixel's samples in order); the cuda stage's shadow rays traced and applied in
#      one kernel == in two (PENUMBRA_WAVEFRONT_FUSE=0, same paths), its trace kernels at 10 resident blocks ==
#      at 8 (PENUMBRA_CUDA_OCC=0, byte for byte); shadow queries in direction order == queue order (byte for byte
#      traced forward; the same paths traced from the light); the bounces' rays in cell order == queue order and
#      the cuda traversal's forms (auto) == its general form (byte for byte); restir with spatial reuse (its frame
#      passes, in the wavefront since session 20) agrees with the CPU;
#   5. compute-sanitizer --tool memcheck on short wavefront renders, both traversals: 0 errors;
#   6. `penumbra bench` at 1920x1080, 1 spp a launch, depth 8, solid-angle: megakernel, wavefront optix,
#      wavefront cuda on cornell-sphere and sponza (the issue's targets: <= 2.0 and <= 8 ms per sample),
#      JSON in the output folder (not a PASS/FAIL: the numbers go to NOTES.md).
# Prints PASS/FAIL per check and a summary; exits 0 only if every check passed.
#
# Environment: WAVEFRONT_CHECK_OUT (default BUILD_DIR/wavefront_check), WAVEFRONT_CHECK_WIDTH/HEIGHT/SPP (default
# 128x72, 256 spp), WAVEFRONT_CHECK_SCENES (default "cornell-sphere cornell-quad occlusion glossy sponza"),
# WAVEFRONT_CHECK_BENCH=0 (skip step 6), WAVEFRONT_CHECK_UNIT_TESTS=0 (skip step 1: a build folder without the
# tests, as an executable carried to a GPU machine is; without it, that folder fails step 1), OptiX_ROOT,
# PENUMBRA_SCENES.
set -uo pipefail

root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
build=${1:-}
width=${WAVEFRONT_CHECK_WIDTH:-128}
height=${WAVEFRONT_CHECK_HEIGHT:-72}
spp=${WAVEFRONT_CHECK_SPP:-256}
check_scenes=${WAVEFRONT_CHECK_SCENES:-"cornell-sphere cornell-quad occlusion glossy sponza"}

source "$root/scripts/check_record.sh"  # record, finish_checks, gpu_build, check_build

check_build wavefront_check "$build" "${WAVEFRONT_CHECK_OUT:-}"  # sets build, penumbra, out
builtin=$("$penumbra" scenes | awk '{print $1}')
listed() { grep -qx -- "$1" <<<"$builtin"; }

# 1. The CPU's proof.
echo "== CPU: the stage functions against depth-first"
if [[ ${WAVEFRONT_CHECK_UNIT_TESTS:-1} == 0 ]]; then
  echo "skipped (WAVEFRONT_CHECK_UNIT_TESTS=0: a build without tests, e.g. an executable carried to the GPU machine;"
  echo "the tests run on the CPU machine and in CI)"
elif [[ -x $build/tests/penumbra_tests ]]; then
  "$build/tests/penumbra_tests" --gtest_filter='Builtins/Wavefront.*:WavefrontMemory.*' >"$out/cpu_tests.log" 2>&1
  st=$?
  grep -E '^wavefront path state|PASSED|FAILED' "$out/cpu_tests.log"
  record "CPU wavefront == depth-first (gtest)" $st
else
  record "CPU wavefront tests: no tests/penumbra_tests" 1
fi

# render NAME SCENE STRATEGY MIS SEED BACKEND_ARGS... : an image and its variance
render() {
  local name=$1 scene=$2 strategy=$3 mis=$4 seed=$5
  shift 5
  "$penumbra" render "$scene" --strategy "$strategy" --mis "$mis" --seed "$seed" --width "$width" \
    --height "$height" --spp "$spp" -o "$out/$name.exr" --variance "$out/${name}_var.exr" "$@" >"$out/$name.log" 2>&1
  local st=$?
  [[ $st != 0 ]] && tail -n 3 "$out/$name.log"
  return $st
}
compare() {  # compare A B [compare options...] -> stdout: penumbra compare's lines
  "$penumbra" compare "$out/$1.exr" "$out/$1_var.exr" "$out/$2.exr" "$out/$2_var.exr" "${@:3}" |
    tee "$out/$2_vs_$1.txt"
  return "${PIPESTATUS[0]}"
}
same_paths() {  # same_paths A B LABEL: PASS with a relative difference of 0.00
  local line
  line=$(compare "$1" "$2")
  local st=$?
  [[ $st == 0 && $line == *"rel. diff 0.00"* ]] && st=0 || st=1
  record "$3" $st
}

# 2 and 3. Images.
echo "== images at ${width}x${height}, $spp spp"
techniques="solid-angle:power projected-solid-angle:balance area:none bsdf:none"
for scene in $check_scenes; do
  if ! listed "$scene"; then echo "skip: $scene is not a built-in scene of this build"; continue; fi
  for t in $techniques "solid-angle:power:restir"; do
    IFS=: read -r strategy mis sel <<<"$t"
    extra=()
    [[ -n $sel ]] && extra=(--light-selection restir --restir-spatial 0)
    [[ $scene == glossy && $mis == none ]] && extra+=(--set defaults.roughness=0.6)
    n=${scene}_${strategy}_${mis}${sel:+_$sel}
    if ! render "${n}_cpu" "$scene" "$strategy" "$mis" 0 --backend cpu "${extra[@]}"; then
      record "$n: cpu render" 1; continue
    fi
    if ! render "${n}_mega" "$scene" "$strategy" "$mis" 0 --backend optix --megakernel "${extra[@]}"; then
      record "$n: megakernel render" 1; continue
    fi
    ok=1
    for tr in optix cuda; do
      render "${n}_wf_$tr" "$scene" "$strategy" "$mis" 0 --backend optix --wavefront --traversal "$tr" "${extra[@]}" \
        || { record "$n: wavefront $tr render" 1; ok=0; }
    done
    [[ $ok == 1 ]] || continue
    same_paths "${n}_mega" "${n}_wf_optix" "$n, same seed: megakernel == wavefront optix"
    same_paths "${n}_wf_optix" "${n}_wf_cuda" "$n, same seed: wavefront optix == cuda"
    compare "${n}_cpu" "${n}_wf_cuda" >/dev/null
    record "$n, same seed: cpu == wavefront cuda" $?
    if render "${n}_wf_seed1" "$scene" "$strategy" "$mis" 1 --backend optix --wavefront "${extra[@]}"; then
      # Independent seeds: the statistical test alone, as in gpu_check.sh (`independent` there): bsdf:none's
      # image mean on sponza has a standard error of about 10% at 256 spp (5.5% at gpu_check.sh's 1024), far
      # above compare's default 1% bound. The verdict this check always had: compare used to widen its bound to
      # 4 standard errors.
      compare "${n}_cpu" "${n}_wf_seed1" --max-rel-diff 1 >/dev/null
      record "$n, seeds 0 / 1: cpu == wavefront" $?
    else
      record "$n: wavefront seed 1 render" 1
    fi
  done
done

# 4. Waves and restir's passes.
echo "== waves"
for tr in optix cuda; do
  n=cornell-sphere_waves_$tr
  if render "${n}_big" cornell-sphere solid-angle power 7 --backend optix --wavefront --traversal "$tr" &&
     PENUMBRA_WAVEFRONT_PATHS=5000 render "${n}_small" cornell-sphere solid-angle power 7 --backend optix \
       --wavefront --traversal "$tr"; then
    cmp -s "$out/${n}_big.exr" "$out/${n}_small.exr"
    record "pool of 5000 paths == default pool, byte for byte ($tr)" $?
  else
    record "waves: renders ($tr)" 1
  fi
done
# The measurement knobs change how the cuda stage runs, not what it computes: the shadow stage in two kernels
# (PENUMBRA_WAVEFRONT_FUSE=0: traced, then applied) and the trace kernels at 64 registers (PENUMBRA_CUDA_OCC=0).
n=cornell-sphere_waves_cuda
if [[ -f $out/${n}_big.exr ]]; then
  PENUMBRA_WAVEFRONT_FUSE=0 render "${n}_unfused" cornell-sphere solid-angle power 7 --backend optix --wavefront \
    --traversal cuda && same_paths "${n}_big" "${n}_unfused" "shadow rays traced and applied in one kernel == in two"
  if PENUMBRA_CUDA_OCC=0 render "${n}_occ0" cornell-sphere solid-angle power 7 --backend optix --wavefront \
    --traversal cuda; then
    cmp -s "$out/${n}_big.exr" "$out/${n}_occ0.exr"
    record "trace kernels at 10 resident blocks == at 8 (64 registers), byte for byte" $?
  else
    record "trace kernels at 8 resident blocks: render" 1
  fi
fi
# The shadow queue's order (wavefront.h's ShadowOrder; auto picks it by the scene's rays' length): by direction
# and traced forward, every query gets its answer and each path its contributions in the same order as in queue
# order, byte for byte; traced from the light back (the default with the order), the same paths.
for scene in cornell-sphere sponza; do
  listed "$scene" || continue
  n=${scene}_shadow_order
  if PENUMBRA_SHADOW_ORDER=queue render "${n}_queue" "$scene" solid-angle power 7 --backend optix --wavefront \
       --traversal cuda &&
     PENUMBRA_SHADOW_ORDER=direction PENUMBRA_SHADOW_REVERSE=0 render "${n}_forward" "$scene" solid-angle power 7 \
       --backend optix --wavefront --traversal cuda &&
     PENUMBRA_SHADOW_ORDER=direction render "${n}_reversed" "$scene" solid-angle power 7 --backend optix \
       --wavefront --traversal cuda; then
    cmp -s "$out/${n}_queue.exr" "$out/${n}_forward.exr"
    record "$scene: shadow rays in direction order == queue order, byte for byte" $?
    same_paths "${n}_queue" "${n}_reversed" "$scene: shadow rays in direction order, traced from the light == queue order"
  else
    record "$scene: shadow order renders" 1
  fi
done
# The bounces' closest-hit rays traced by direction and origin cells (wavefront.h's RayOrder; auto picks it as the
# shadow order): every ray gets the same hit at its queue position, so the image is queue order's byte for byte.
for scene in cornell-sphere sponza; do
  listed "$scene" || continue
  n=${scene}_ray_order
  if PENUMBRA_RAY_ORDER=queue render "${n}_queue" "$scene" solid-angle power 7 --backend optix --wavefront \
       --traversal cuda &&
     PENUMBRA_RAY_ORDER=cells render "${n}_cells" "$scene" solid-angle power 7 --backend optix --wavefront \
       --traversal cuda; then
    cmp -s "$out/${n}_queue.exr" "$out/${n}_cells.exr"
    record "$scene: the bounces' rays in cell order == queue order, byte for byte" $?
  else
    record "$scene: ray order renders" 1
  fi
done
# The cuda traversal's forms (backends/cuda/trace_forms.h; auto picks them by the scene: the flat form, the if-if
# loop where rays are long, the FMA box test for shadow rays in flat scenes): every ray gets the same hit and every
# shadow query the same answer as in the general while-while form with the subtract-multiply box test, so the
# image is the same byte for byte.
for scene in cornell-sphere sponza; do
  listed "$scene" || continue
  n=${scene}_forms
  if render "${n}_auto" "$scene" solid-angle power 7 --backend optix --wavefront --traversal cuda &&
     PENUMBRA_CUDA_LOOP=while PENUMBRA_CUDA_BOX=slab PENUMBRA_CUDA_FLAT=0 render "${n}_general" "$scene" solid-angle \
       power 7 --backend optix --wavefront --traversal cuda; then
    cmp -s "$out/${n}_auto.exr" "$out/${n}_general.exr"
    record "$scene: the cuda traversal's forms (auto) == its general form, byte for byte" $?
  else
    record "$scene: traversal form renders" 1
  fi
done
if listed many-spheres; then
  render restir_passes_cpu many-spheres solid-angle power 0 --backend cpu --light-selection restir \
    --set defaults.lights=200 &&
    render restir_passes_wf many-spheres solid-angle power 1 --backend optix --wavefront --light-selection restir \
      --set defaults.lights=200 && compare restir_passes_cpu restir_passes_wf >/dev/null
  record "restir with spatial reuse in the wavefront (its frame passes as stages): cpu == optix" $?
fi

# 5. memcheck.
echo "== compute-sanitizer --tool memcheck"
if command -v compute-sanitizer >/dev/null; then
  for scene in cornell-sphere sponza; do
    listed "$scene" || continue
    for tr in optix cuda; do
      log=$out/memcheck_${scene}_$tr.log
      compute-sanitizer --tool memcheck --error-exitcode 9 "$penumbra" render "$scene" --backend optix --wavefront \
        --traversal "$tr" --width 64 --height 36 --spp 4 -o "$out/memcheck_${scene}_$tr.exr" >"$log" 2>&1
      st=$?
      grep -E 'ERROR SUMMARY' "$log"
      record "memcheck $scene wavefront $tr" $st
    done
  done
else
  record "compute-sanitizer not found" 1
fi

# 6. bench.
if [[ ${WAVEFRONT_CHECK_BENCH:-1} != 0 ]]; then
  echo "== bench 1920x1080, 1 spp a launch, depth 8"
  bench_scenes=cornell-sphere
  listed sponza && bench_scenes=cornell-sphere,sponza
  for mode in mega wf_optix wf_cuda; do
    args=()
    case $mode in
      mega) args=(--megakernel) ;;
      wf_optix) args=(--wavefront --traversal optix) ;;
      wf_cuda) args=(--wavefront --traversal cuda) ;;
    esac
    "$penumbra" bench --backend optix --scenes "$bench_scenes" --strategies solid-angle --width 1920 --height 1080 \
      --spp-per-launch 1 --max-depth 8 --json "$out/bench_$mode.json" "${args[@]}" 2>&1 | tee "$out/bench_$mode.txt"
    record "bench $mode runs" "${PIPESTATUS[0]}"
  done
fi

finish_checks wavefront_check
