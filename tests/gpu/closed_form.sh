#!/usr/bin/env bash
# The closed-form whole-render tests (tests/backends/test_closed_form.cpp: a plane under a sphere, a quad and a triangle,
# every strategy x MIS mode, pixel by pixel against the exact integral) on the GPU, with the power the GPU affords:
# PENUMBRA_TEST_SPP_SCALE times CI's samples, so that every technique's image mean has a standard error below
# 0.01% (CTest gpu.closed_form.MODE).
#
#   tests/gpu/closed_form.sh PENUMBRA OUT_DIR CLOSED_FORM_TESTS MODE SPP_SCALE [GTEST_FILTER]
#
# MODE: cuda or optix (the wavefront's trace stage) or megakernel. GTEST_FILTER narrows the cases.
source "$(dirname "${BASH_SOURCE[0]}")/lib.sh" "closed_form" "$@"
gpu_probe
binary=${args[0]:?closed-form test executable} mode=${args[1]:?mode} scale=${args[2]:?spp scale}
export PENUMBRA_TEST_BACKEND=optix PENUMBRA_TEST_SPP_SCALE=$scale
case $mode in
  cuda | optix) export PENUMBRA_TEST_TRAVERSAL=$mode ;;
  megakernel) export PENUMBRA_TEST_MEGAKERNEL=1 ;;
  *) echo "closed_form: unknown mode $mode" >&2; exit 2 ;;
esac
"$binary" --gtest_color=no --gtest_filter="${args[3]:-*}" >"$out/closed_form_$mode.log" 2>&1
st=$?
grep -E "^  [A-Za-z]" "$out/closed_form_$mode.log"
record "closed forms on the GPU ($mode, $scale x CI's samples)" $st
finish_checks "$title"
