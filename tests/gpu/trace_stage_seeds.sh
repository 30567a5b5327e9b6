#!/usr/bin/env bash
# GPU test: each GPU path against the CPU with independent seeds at high samples, where the same seed no longer
# gives the same paths (CTest gpu.wavefront.seeds.SCENE). Hit points sit at their own floating-point error bound
# (core/geometry.h), so the trace stages' roundings (OptiX's triangle test, the cuda traversal's box tests, Embree's)
# decide some rays near edges and close occluders differently, and same-seed images drift apart by more than their
# last bits (Sponza: up to 0.05% at 256 spp). Whether that is divergence of the same estimator or a bias of one
# trace stage is what independent seeds at about 0.01% standard error tell: here the CPU (seed 0) against the
# wavefront with the cuda traversal and with OptiX's, and the megakernel (seed 1 each), and the default path's seeds
# 1 and 3 as the control.
#
#   tests/gpu/trace_stage_seeds.sh PENUMBRA OUT_DIR SCENE [SPP]
#
# Solid-angle with MIS power at 128x72, SPP (default 32768) samples. Each pair must pass `penumbra compare`'s
# statistical test (image z and per-pixel criteria; Sponza's light is white, so its channels move together and
# the image z is checked against a correlated bound, Compare.ImageZKnowsAPixelsChannelsMoveTogether), and every
# pair's means are printed so that the report can quote them.
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
render cpu_seed0 "$scene" 0 "$spp" --backend cpu "${extra[@]}" || record "cpu seed 0 render" 1
for mode in wf_cuda wf_optix mega; do
  gpu_args $mode
  if render "${mode}_seed1" "$scene" 1 "$spp" "${garg[@]}" "${extra[@]}"; then
    compare_pair cpu_seed0 "${mode}_seed1" "$scene: cpu seed 0 == $mode seed 1"
  else
    record "$scene: $mode seed 1 render" 1
  fi
done
# The control: the default path against itself with another seed (the CPU takes minutes where the GPU takes
# seconds): compare's test must pass between two seeds of one estimator at this power.
gpu_args wf_cuda
if render wf_cuda_seed3 "$scene" 3 "$spp" "${garg[@]}" "${extra[@]}"; then
  compare_pair wf_cuda_seed1 wf_cuda_seed3 "$scene: wf_cuda seed 1 == wf_cuda seed 3 (the control)"
else
  record "$scene: wf_cuda seed 3 render" 1
fi

finish_checks "$title"
