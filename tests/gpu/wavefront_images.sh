#!/usr/bin/env bash
# GPU test: the wavefront path tracer (the default; backends/wavefront) computes the megakernel's and the CPU's
# images of a scene, with both trace stages (CTest gpu.wavefront.images.SCENE; what scripts/wavefront_check.sh's
# steps 2 and 3 were).
#
#   tests/gpu/wavefront_images.sh PENUMBRA OUT_DIR SCENE
#
# At 128x72 and 256 spp, per technique (solid-angle+power, projected-solid-angle+balance, area+none, bsdf+none,
# and solid-angle+power with restir without spatial reuse):
#   - same seed, `penumbra compare` PASS with rel. diff 0.00 (the same paths; the last bits differ: fast math,
#     float sums): megakernel == wavefront optix, wavefront optix == cuda (Sponza: within 0.1%, below); and CPU ==
#     wavefront cuda (PASS);
#   - independent seeds (CPU 0, wavefront 1, each trace stage): `penumbra compare` PASS; on glossy robust_pair
#     (lib.sh: compare's image z overstates there), its power reported (gpu.compare.glossy requires it).
name=${3:-none}
source "$(dirname "${BASH_SOURCE[0]}")/lib.sh" "wavefront_images_$name" "$@"

scene=${args[0]:-}
if [[ -z $scene ]]; then echo "usage: $0 PENUMBRA OUT_DIR SCENE"; exit 2; fi
if ! listed "$scene"; then
  echo "$title: skipped: $scene is not a built-in scene of this build (penumbra scenes does not list it)"
  exit 77
fi
spp=256

echo "== $scene at ${width}x${height}, $spp spp"
for t in solid-angle:power projected-solid-angle:balance area:none bsdf:none solid-angle:power:restir; do
  IFS=: read -r strategy mis sel <<<"$t"
  extra=(--strategy "$strategy" --mis "$mis")
  [[ -n $sel ]] && extra+=(--light-selection restir --restir-spatial 0)
  [[ $scene == glossy && $mis == none ]] && extra+=(--set defaults.roughness=0.6)
  n=${scene}_${strategy}_${mis}${sel:+_$sel}
  render "${n}_cpu" "$scene" 0 $spp --backend cpu "${extra[@]}" || { record "$n: cpu render" 1; continue; }
  ok=1
  for mode in mega wf_optix wf_cuda; do
    gpu_args $mode
    render "${n}_$mode" "$scene" 0 $spp "${garg[@]}" "${extra[@]}" || { record "$n: $mode render" 1; ok=0; }
  done
  if [[ $ok == 1 ]]; then
    if [[ $scene == sponza ]]; then
      # Sponza's shading points sit at their own error bound next to walls, floors and arches: each trace stage's
      # rounding decides some of their rays, and the same seed's paths part (up to 0.05% at 256 spp).
      # gpu.wavefront.seeds.sponza shows with independent seeds that no stage is biased.
      within_rel "${n}_mega" "${n}_wf_optix" 0.001 "$n, same seed: megakernel == wavefront optix within 0.1%"
      within_rel "${n}_wf_optix" "${n}_wf_cuda" 0.001 "$n, same seed: wavefront optix == cuda within 0.1%"
    else
      same_paths "${n}_mega" "${n}_wf_optix" "$n, same seed: megakernel == wavefront optix"
      same_paths "${n}_wf_optix" "${n}_wf_cuda" "$n, same seed: wavefront optix == cuda"
    fi
    compare "${n}_cpu" "${n}_wf_cuda" >/dev/null
    record "$n, same seed: cpu == wavefront cuda" $?
  fi
  for mode in wf_cuda wf_optix; do
    gpu_args $mode
    if ! render "${n}_${mode}_seed1" "$scene" 1 $spp "${garg[@]}" "${extra[@]}"; then
      record "$n: $mode seed 1 render" 1
    elif [[ $scene == glossy ]]; then
      robust_pair "${n}_cpu" "${n}_${mode}_seed1" "$n, seeds 0 / 1: cpu == $mode (robust)" --bias 0
    else
      compare "${n}_cpu" "${n}_${mode}_seed1" >/dev/null
      record "$n, seeds 0 / 1: cpu == $mode" $?
    fi
  done
done

finish_checks "$title"
