#!/usr/bin/env bash
# GPU test: how the wavefront runs does not change what it computes (CTest gpu.wavefront.orders; what
# scripts/wavefront_check.sh's step 4 was). backends/optix/WAVEFRONT.md says what each knob is.
#
#   tests/gpu/wavefront_orders.sh PENUMBRA OUT_DIR
#
#   - waves: a pool of 5,000 paths (--tune wavefront_paths: many waves a launch, pixels cut anywhere, through the
#     launch sums) renders the default pool's image (one wave a launch: straight into the film) byte for byte (the
#     accumulation sums each pixel's samples in order), with either trace stage;
#   - the cuda stage's shadow rays traced and applied in one kernel == in two (--tune wavefront_fuse=false, the
#     same paths); its trace kernels at 10 resident blocks == at 8 (--tune cuda_occ=0, byte for byte);
#   - shadow queries in direction order == queue order (byte for byte traced forward; the same paths within 0.05%
#     traced from the light, --tune shadow_reverse=true); the bounces' rays in cell order == queue order; the cuda
#     traversal's forms (auto) == its general form (byte for byte; Sponza within 0.05%), on cornell-sphere and sponza;
#   - restir with spatial reuse (its frame passes, stages of the wavefront) agrees with the CPU, with either stage.
source "$(dirname "${BASH_SOURCE[0]}")/lib.sh" wavefront_orders "$@"
spp=256
wf() {  # wf NAME SCENE TRAVERSAL [--tune KEY=VALUE ...]: a wavefront render, seed 7, solid-angle + MIS power
  render "$1" "$2" 7 $spp --backend optix --wavefront --traversal "$3" --strategy solid-angle --mis power "${@:4}"
}

for tr in optix cuda; do
  n=cornell-sphere_waves_$tr
  if wf "${n}_big" cornell-sphere "$tr" && wf "${n}_small" cornell-sphere "$tr" --tune wavefront_paths=5000; then
    same_bytes "${n}_big" "${n}_small" "pool of 5000 paths == default pool, byte for byte ($tr)"
  else
    record "waves: renders ($tr)" 1
  fi
done
n=cornell-sphere_waves_cuda
if [[ -f $out/${n}_big.exr ]]; then
  if wf "${n}_unfused" cornell-sphere cuda --tune wavefront_fuse=false; then
    same_paths "${n}_big" "${n}_unfused" "shadow rays traced and applied in one kernel == in two"
  else
    record "shadow rays in two kernels: render" 1
  fi
  if wf "${n}_occ0" cornell-sphere cuda --tune cuda_occ=0; then
    same_bytes "${n}_big" "${n}_occ0" "trace kernels at 10 resident blocks == at 8 (64 registers), byte for byte"
  else
    record "trace kernels at 8 resident blocks: render" 1
  fi
fi
# The shadow queue's order (wavefront.h's ShadowOrder; auto picks it by the scene's rays' length).
for scene in cornell-sphere sponza; do
  listed "$scene" || continue
  n=${scene}_shadow_order
  if wf "${n}_queue" "$scene" cuda --tune shadow_order=queue &&
     wf "${n}_forward" "$scene" cuda --tune shadow_order=direction &&
     wf "${n}_reversed" "$scene" cuda --tune shadow_order=direction,shadow_reverse=true; then
    same_bytes "${n}_queue" "${n}_forward" "$scene: shadow rays in direction order == queue order, byte for byte"
    # Traced from the light (opt-in: reversed_shadow_ray's slack hides occluders within 1e-5 of the coordinates
    # of a shading point; 0.021% on Sponza): the same paths, within 0.05%.
    within_rel "${n}_queue" "${n}_reversed" 0.0005 \
      "$scene: shadow rays in direction order, traced from the light == queue order within 0.05%"
  else
    record "$scene: shadow order renders" 1
  fi
done
# The bounces' closest-hit rays by direction and origin cells (wavefront.h's RayOrder).
for scene in cornell-sphere sponza; do
  listed "$scene" || continue
  n=${scene}_ray_order
  if wf "${n}_queue" "$scene" cuda --tune ray_order=queue && wf "${n}_cells" "$scene" cuda --tune ray_order=cells
  then
    same_bytes "${n}_queue" "${n}_cells" "$scene: the bounces' rays in cell order == queue order, byte for byte"
  else
    record "$scene: ray order renders" 1
  fi
done
# The cuda traversal's forms (backends/cuda/trace_forms.h): the same hits and answers as the general form.
for scene in cornell-sphere sponza; do
  listed "$scene" || continue
  n=${scene}_forms
  if wf "${n}_auto" "$scene" cuda &&
     wf "${n}_general" "$scene" cuda --tune cuda_loop=while,cuda_box=slab,cuda_flat=false; then
    if [[ $scene == sponza ]]; then
      # The one-FMA box test rounds differently from the slab test, and Sponza's shading points sit at their own
      # error bound next to walls and floors: some shadow rays from them are decided by that rounding (0.001%).
      within_rel "${n}_auto" "${n}_general" 0.0005 \
        "$scene: the cuda traversal's forms (auto) == its general form within 0.05%"
    else
      same_bytes "${n}_auto" "${n}_general" \
        "$scene: the cuda traversal's forms (auto) == its general form, byte for byte"
    fi
  else
    record "$scene: traversal form renders" 1
  fi
done
if listed many-spheres; then
  restir=(--strategy solid-angle --mis power --light-selection restir --set defaults.lights=200)
  if render restir_passes_cpu many-spheres 0 $spp --backend cpu "${restir[@]}"; then
    for tr in cuda optix; do
      if render "restir_passes_wf_$tr" many-spheres 1 $spp --backend optix --wavefront --traversal "$tr" \
           "${restir[@]}"; then
        compare_pair restir_passes_cpu "restir_passes_wf_$tr" \
          "restir with spatial reuse in the wavefront (its frame passes as stages): cpu == $tr"
      else
        record "restir with spatial reuse, wavefront $tr: render" 1
      fi
    done
  else
    record "restir with spatial reuse: cpu render" 1
  fi
fi

finish_checks "$title"
