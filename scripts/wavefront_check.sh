#!/usr/bin/env bash
# The wavefront path tracer's proof on a GPU machine: the CTest tests labelled wavefront (tests/gpu; DEVELOPERS.md,
# "GPU tests"), through scripts/gpu_check.sh. backends/optix/WAVEFRONT.md says what to look at.
#
#   scripts/wavefront_check.sh [BUILD_DIR [CTEST ARGUMENTS...]]
#
# Without BUILD_DIR (or with "") it configures and builds build-gpu-check (as gpu_check.sh). Then `ctest -L
# wavefront` there (more ctest arguments add to it; e.g. `-LE bench` leaves the bench out):
#   gpu.wavefront.images.SCENE (cornell-sphere, cornell-quad, occlusion, glossy, sponza): same seed, the megakernel
#     == the wavefront with the optix trace stage == with the cuda one (PASS with rel. diff 0.00: the same paths),
#     CPU == wavefront; independent seeds, CPU == wavefront with either stage;
#   gpu.wavefront.orders: a pool of 5,000 paths == the default pool byte for byte, the measurement knobs, shadow and
#     ray orders, the cuda traversal's forms, restir's frame passes against the CPU;
#   gpu.memcheck: compute-sanitizer on short renders, the wavefront with either stage and the megakernel;
#   gpu.wavefront.bench: `penumbra bench` at 1080p, megakernel and both stages, on cornell-sphere and sponza (JSON in
#     BUILD_DIR/tests/gpu/bench; the numbers go to NOTES.md, not a verdict).
# The CPU's proof of the stage functions (Builtins/Wavefront.*, WavefrontMemory.*) is in the unit tests.
root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
build=${1:-}
shift $(( $# > 0 ? 1 : 0 ))
exec bash "$root/scripts/gpu_check.sh" "$build" -L wavefront "$@"
