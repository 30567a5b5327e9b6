#!/usr/bin/env bash
# GPU test: each GPU path against the CPU with independent seeds at high samples, where the same seed no longer
# gives the same paths (CTest gpu.wavefront.seeds.SCENE). Hit points sit at their own floating-point error bound
# (core/geometry.h), so the trace stages' roundings (OptiX's triangle test, the cuda traversal's box tests, Embree's)
# decide some rays near edges and close occluders differently, and same-seed images drift apart by more than their
# last bits (Sponza: up to 0.05% at 256 spp). Whether that is divergence of the same estimator or a bias of one
# trace stage is what independent seeds at about 0.01% standard error tell: here the CPU (seeds 0 and 2) against
# the wavefront with the cuda traversal and with OptiX's, and the megakernel (seed 1 each).
#
#   tests/gpu/trace_stage_seeds.sh PENUMBRA OUT_DIR SCENE [SPP]
#
# Solid-angle with MIS power at 128x72, SPP (default 32768) samples. Each pair must pass `penumbra compare`'s
# statistical test (image z and per-pixel criteria; Sponza's light is white, so its channels move together and
# the image z is checked against a correlated bound, Compare.ImageZKnowsAPixelsChannelsMoveTogether); the CPU's
# own two seeds are the control, and every pair's means are printed so that the report can quote them.
name=${3:-none}
source "$(dirname "${BASH_SOURCE[0]}")/lib.sh" "trace_stage_seeds_$name" "$@"

scene=${args[0]:-}
spp=${args[1]:-32768}
if [[ -z $scene ]]; then echo "usage: $0 PENUMBRA OUT_DIR SCENE [SPP]"; exit 2; fi
if ! listed "$scene"; then
  echo "$title: skipped: $scene is not a built-in scene of this build (penumbra scenes does not list it)"
  exit 77
fi
extra=(--strategy solid-angle --mis power)
echo "== $scene at ${width}x${height}, $spp spp, solid-angle + MIS power, independent seeds"
for seed in 0 2; do
  render "cpu_seed$seed" "$scene" $seed "$spp" --backend cpu "${extra[@]}" || record "cpu seed $seed render" 1
done
compare_pair cpu_seed0 cpu_seed2 "$scene: cpu seed 0 == cpu seed 2 (the control)"
for mode in wf_cuda wf_optix mega; do
  gpu_args $mode
  if render "${mode}_seed1" "$scene" 1 "$spp" "${garg[@]}" "${extra[@]}"; then
    compare_pair cpu_seed0 "${mode}_seed1" "$scene: cpu seed 0 == $mode seed 1"
  else
    record "$scene: $mode seed 1 render" 1
  fi
done

finish_checks "$title"
