#!/usr/bin/env bash
# Unit tests whose GPU parts skip where there is no GPU (GoogleTest's GTEST_SKIP), run where there is one: past
# gpu_probe a skipped case is a failure, since the GPU it needs is there (CTest gpu.unit.NAME).
#
#   tests/gpu/unit_tests.sh PENUMBRA OUT_DIR TEST_EXECUTABLE GTEST_FILTER
source "$(dirname "${BASH_SOURCE[0]}")/lib.sh" "unit_tests" "$@"
gpu_probe
binary=${args[0]:?unit test executable} filter=${args[1]:?gtest filter}
log=$out/unit_tests.log
"$binary" --gtest_color=no --gtest_filter="$filter" >"$log" 2>&1
st=$?
grep -E "^\[ +(OK|FAILED|SKIPPED) +\]" "$log"
# A failure's assertions (file:line and the values), so that the test's own output says what failed.
[[ $st == 0 ]] || grep -E -A8 ": Failure$" "$log" | head -n 120
record "$filter on the GPU" $st
if grep -q "^\[  SKIPPED \] [A-Za-z]" "$log"; then st=1; else st=0; fi
record "no case skipped where the GPU is" $st
finish_checks "$title"
