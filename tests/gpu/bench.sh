#!/usr/bin/env bash
# GPU test: `penumbra bench` at 1920x1080, 1 spp a launch, depth 8, solid-angle: the megakernel and the wavefront
# with either trace stage, on cornell-sphere and sponza (the targets: <= 2.0 and <= 8 ms a sample) (CTest
# gpu.wavefront.bench, labels gpu, wavefront and bench; what scripts/wavefront_check.sh's step 6 was). It passes
# when the runs succeed: the numbers are not a verdict (they go to backends/optix/NOTES.md); the JSON and the
# tables are in OUT_DIR/bench.
#
#   tests/gpu/bench.sh PENUMBRA OUT_DIR
source "$(dirname "${BASH_SOURCE[0]}")/lib.sh" bench "$@"

scenes=cornell-sphere
listed sponza && scenes=cornell-sphere,sponza
echo "== bench 1920x1080, 1 spp a launch, depth 8 ($scenes)"
for mode in mega wf_optix wf_cuda; do
  gpu_args $mode
  "$penumbra" bench "${garg[@]}" --scenes "$scenes" --strategies solid-angle --width 1920 --height 1080 \
    --spp-per-launch 1 --max-depth 8 --json "$out/bench_$mode.json" 2>&1 | tee "$out/bench_$mode.txt"
  record "bench $mode runs" "${PIPESTATUS[0]}"
done

finish_checks "$title"
