#!/usr/bin/env bash
# GPU test: the CPU's and the GPU's images of built-in scenes, every technique (strategy x MIS mode), on the
# wavefront with both trace stages (CTest gpu.compare.SCENE; what scripts/gpu_check.sh's step 2 was).
#
#   tests/gpu/compare_scenes.sh PENUMBRA OUT_DIR SCENE...
#   tests/gpu/compare_scenes.sh PENUMBRA OUT_DIR --others NAMED...   # every built-in scene not among NAMED
#
# Per scene and technique, at 128x72 and 1024 spp: the CPU with seed 0 against the GPU with seed 1
# (`--traversal cuda` and `--traversal optix`), each pair by `penumbra compare` (per pixel within the combined
# standard errors; image means within 1%, or 4 standard errors where that is larger); glossy by robust_pair
# (lib.sh) instead, with MIS at 2048 spp. Then the same seed on a few techniques: the GPU traces the CPU's very
# paths.
# A scene `penumbra scenes` does not list (sponza's files missing) is skipped with a note; exit 77 (skipped) if
# none is. GPU_TEST_TECHNIQUES (strategy:mis ...) narrows the techniques.
name=${3:-none}
[[ $name == --others ]] && name=others
source "$(dirname "${BASH_SOURCE[0]}")/lib.sh" "compare_$name" "$@"

spp=1024
techniques=${GPU_TEST_TECHNIQUES:-"area:none area:balance area:power solid-angle:none solid-angle:balance
  solid-angle:power projected-solid-angle:none projected-solid-angle:balance projected-solid-angle:power bsdf:none"}
techniques=$(xargs <<<"$techniques")  # one line
# Techniques a scene adds to the list: glossy's sky with MIS compensation (--mis-compensation), written
# strategy:MIS-compensated; ltc where polygon lights meet glossy surfaces (on a Lambertian surface or a sphere
# light it samples as projected-solid-angle does). Its pdf on the GPU reads the previous vertex's lobes, which the
# wavefront moves only for ltc: MIS balance and power test that.
scene_techniques() {
  case $1 in
    glossy) echo "solid-angle:power-compensated" ;;
    polygon-near) echo "ltc:none ltc:balance ltc:power" ;;
    cornell-quad) echo "ltc:power" ;;
  esac
}
# A technique's MIS options.
mis_args() {
  case $1 in
    *-compensated) echo "--mis ${1%-compensated} --mis-compensation" ;;
    *) echo "--mis $1" ;;
  esac
}
# The same-seed pairs of a scene (strategy:mis ...).
same_seed_techniques() {
  case $1 in
    cornell-sphere) echo "solid-angle:none projected-solid-angle:power" ;;
    polygon-near) echo "solid-angle:power ltc:power" ;;
    cornell-quad) echo "projected-solid-angle:balance" ;;
    glossy) echo "solid-angle:power solid-angle:power-compensated" ;;
    sponza) echo "solid-angle:power" ;;
  esac
}

scenes=()
if [[ ${args[0]:-} == --others ]]; then
  named=" ${args[*]:1} "
  for s in $builtin; do [[ $named == *" $s "* ]] || scenes+=("$s"); done
  if [[ ${#scenes[@]} == 0 ]]; then
    # Nothing to render: every built-in scene has its own test. (A new scene lands here until it gets one.)
    record "every built-in scene has its own gpu.compare test" 0
    finish_checks "$title"
    exit
  fi
  echo "== scenes without a test of their own (add them to tests/gpu/CMakeLists.txt): ${scenes[*]}"
else
  for s in "${args[@]}"; do
    if listed "$s"; then scenes+=("$s")
    else echo "skip: $s is not a built-in scene of this build (penumbra scenes does not list it)"; fi
  done
  [[ ${#scenes[@]} == 0 ]] && { echo "$title: skipped: none of the scenes is built in here"; exit 77; }
fi

echo "== CPU vs GPU at ${width}x${height}, $spp spp"
for scene in "${scenes[@]}"; do
  scene_all=$techniques  # with the scene's own techniques unless GPU_TEST_TECHNIQUES narrows them
  [[ -z ${GPU_TEST_TECHNIQUES:-} ]] && scene_all+=" $(scene_techniques "$scene")"
  for t in $scene_all; do
    strategy=${t%%:*} mis=${t##*:}
    n=${scene}_${strategy}_${mis}
    # shellcheck disable=SC2046
    extra=(--strategy "$strategy" $(mis_args "$mis"))
    # Light sampling alone is too heavy-tailed for a z-test on glossy's 0.2 roughness (tests/backends/test_render.cpp,
    # MisAgrees): compare it at 0.6.
    [[ $scene == glossy && $mis == none ]] && extra+=(--set defaults.roughness=0.6)
    # glossy: robust_pair, with the samples for its test to see a 1% bias (95% power). Measured on the CPU (seeds 0
    # and 1: the GPU's paths with the GPU's seed, 128x72): MIS balance or power at 1024 spp sees 1.12%
    # (solid-angle), at 2048 0.75%; light sampling alone at 0.6 roughness sees 0.5-0.65% at 1024 spp. BSDF sampling
    # alone finds the 1.5-degree sun by chance: at 1024 spp it sees 6% (40 times the samples for 1%); its power is
    # reported, not required (the same estimator is compared in every other scene).
    n_spp=$spp
    means_opts=()
    if [[ $scene == glossy ]]; then
      if [[ $strategy == bsdf ]]; then means_opts=(--bias 0); elif [[ $mis != none ]]; then n_spp=2048; fi
    fi
    if ! render "${n}_cpu" "$scene" 0 "$n_spp" --backend cpu "${extra[@]}"; then
      record "$n: cpu render" 1
      continue
    fi
    for mode in wf_cuda wf_optix; do
      gpu_args $mode
      if ! render "${n}_$mode" "$scene" 1 "$n_spp" "${garg[@]}" "${extra[@]}"; then
        record "$n: $mode render" 1
        continue
      fi
      label="$scene $strategy+$mis: cpu == $mode"
      if [[ $scene == glossy ]]; then
        robust_pair "${n}_cpu" "${n}_$mode" "$label (robust, $n_spp spp)" "${means_opts[@]}"
      else
        compare_pair "${n}_cpu" "${n}_$mode" "$label"
      fi
    done
  done
  # Same seed: the GPU traces the very paths the CPU traced (the same RNG streams).
  for t in $(same_seed_techniques "$scene"); do
    [[ " $scene_all " == *" $t "* ]] || continue
    strategy=${t%%:*} mis=${t##*:}
    n=${scene}_${strategy}_${mis}
    [[ -f $out/${n}_cpu.exr ]] || continue  # its CPU render failed above
    n_spp=$spp
    [[ $scene == glossy && $mis != none ]] && n_spp=2048
    # shellcheck disable=SC2046
    extra=(--strategy "$strategy" $(mis_args "$mis"))
    [[ $scene == glossy && $mis == none ]] && extra+=(--set defaults.roughness=0.6)
    for mode in wf_cuda wf_optix; do
      gpu_args $mode
      if render "${n}_${mode}_seed0" "$scene" 0 "$n_spp" "${garg[@]}" "${extra[@]}"; then
        compare_pair "${n}_cpu" "${n}_${mode}_seed0" "$scene $strategy+$mis, same seed: cpu == $mode"
      else
        record "$n, same seed: $mode render" 1
      fi
    done
  done
done

finish_checks "$title"
