#!/usr/bin/env bash
# GPU test: compute-sanitizer --tool memcheck on short GPU renders: 0 errors (CTest gpu.memcheck; what
# scripts/gpu_check.sh's step 4 and scripts/wavefront_check.sh's step 5 were).
#
#   tests/gpu/memcheck.sh PENUMBRA OUT_DIR
#
# At 64x36 and 4 spp, on the wavefront with both trace stages and on the megakernel: projected-solid-angle with MIS
# (the sampling code that runs most: spherical polygons, projected caps, every pdf) on cornell-sphere,
# polygon-near, glossy and sponza (textures, environment, GGX, alpha masks; those this build lists); solid-angle,
# the default, on cornell-sphere and sponza; bvh and restir (its frame passes) on many-spheres, on the wavefront.
source "$(dirname "${BASH_SOURCE[0]}")/lib.sh" memcheck "$@"

if ! command -v compute-sanitizer >/dev/null 2>&1; then
  record "compute-sanitizer memcheck: compute-sanitizer not found (it comes with the CUDA toolkit)" 1
  finish_checks "$title"
  exit
fi

# memcheck NAME LABEL [penumbra render arguments...]
memcheck() {
  local name=$1 label=$2 log=$out/$1.log st
  shift 2
  compute-sanitizer --tool memcheck --leak-check full --error-exitcode 9 "$penumbra" render "$@" --width 64 \
    --height 36 --spp 4 -o "$out/$name.exr" >"$log" 2>&1
  st=$?
  grep -E "ERROR SUMMARY|LEAK SUMMARY" "$log" || tail -n 5 "$log"
  grep -q "ERROR SUMMARY: 0 errors" "$log" || st=1
  record "compute-sanitizer memcheck $label: 0 errors" $st
}

for scene in cornell-sphere polygon-near glossy sponza; do
  listed "$scene" || { echo "skip: $scene is not a built-in scene of this build"; continue; }
  for mode in wf_cuda wf_optix mega; do
    gpu_args $mode
    memcheck "${scene}_psa_power_$mode" "$scene projected-solid-angle+power $mode" "$scene" "${garg[@]}" \
      --strategy projected-solid-angle --mis power
  done
done
for scene in cornell-sphere sponza; do
  listed "$scene" || continue
  for mode in wf_cuda wf_optix; do
    gpu_args $mode
    memcheck "${scene}_$mode" "$scene (its own settings) $mode" "$scene" "${garg[@]}"
  done
done
if listed many-spheres; then
  for spec in bvh restir restir:--restir-pairwise,--restir-unshadowed; do
    method=${spec%%:*}
    extra=()
    [[ $spec == *:* ]] && IFS=, read -r -a extra <<<"${spec#*:}"
    for mode in wf_cuda wf_optix; do
      gpu_args $mode
      memcheck "many-spheres_$(tr ':,=' '___' <<<"$spec" | tr -d -)_$mode" \
        "many-spheres --light-selection $method${extra[*]:+ ${extra[*]}} $mode" many-spheres "${garg[@]}" \
        --light-selection "$method" "${extra[@]}"
    done
  done
fi

finish_checks "$title"
