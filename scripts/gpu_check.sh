#!/usr/bin/env bash
# The GPU proof on a GPU machine: the CTest tests labelled gpu (tests/gpu; DEVELOPERS.md, "GPU tests"): the
# CPU's and the GPU's images of every built-in scene and technique and of every light selection, on the wavefront
# with both trace stages (and the megakernel where a test says so), same-seed identities, the wavefront against
# the megakernel, compute-sanitizer memcheck, bad input on the GPU, bench.
#
#   scripts/gpu_check.sh [BUILD_DIR [CTEST ARGUMENTS...]]
#
# Without BUILD_DIR (or with "") it configures build-gpu-check (Release, CMAKE_CUDA_ARCHITECTURES=90, OptiX_ROOT
# from the environment or .optix/) and builds the executable there (what the GPU tests need; `cmake --build
# build-gpu-check` for the unit tests too). Then `ctest -L gpu --output-on-failure` there, or ctest with the
# arguments given instead (e.g. `-R 'gpu\.(compare|selection)\.glossy'`, `-L wavefront`; `-LE gpu` for the unit
# tests, whose GPU parts, such as the viewer's device image, run where a GPU is), with PENUMBRA_GPU_TESTS=require:
# a test that finds no GPU backend fails instead of being skipped.
# CTest runs them one at a time (each uses the GPU and every core), each under 8 minutes on the H200; every
# test's checks and verdicts are in BUILD_DIR/Testing/Temporary/LastTest.log (add -V to see them as they run),
# its images in BUILD_DIR/tests/gpu/<test>/. Exits with ctest's status.
set -uo pipefail
root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
source "$root/scripts/check_record.sh"  # gpu_build

build=${1:-}
shift $(( $# > 0 ? 1 : 0 ))
ctest_args=("$@")
[[ ${#ctest_args[@]} -gt 0 ]] || ctest_args=(-L gpu)
if [[ -z $build ]]; then
  build=$root/build-gpu-check
  gpu_build "$build" gpu_check penumbra
fi
PENUMBRA_GPU_TESTS=require ctest --test-dir "$build" --output-on-failure --no-tests=error "${ctest_args[@]}"
