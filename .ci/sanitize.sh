#!/usr/bin/env bash
# CI, second part: the sanitizer build (issue 12). Debian's clang compiles the
# project with AddressSanitizer + UndefinedBehaviorSanitizer in build-asan
# (cmake/Sanitizers.cmake); there
#   1. the unit tests and the executable's tests run (time-bounded), then
#   2. each libFuzzer target of tests/fuzz runs for FUZZ_SECONDS (75), two at a time
#      (one per core), from its seed corpus and regression files.
# Any sanitizer report, crash, leak, timeout (10 s an input) or out-of-memory
# (4 GiB) fails CI; the input that caused it is kept under build-asan/fuzz/ and
# printed: add it to tests/fuzz/regressions/<target>/ with the fix. Where the
# targets ran fewer than MIN_EXECS inputs in all (a slow or busy machine), the
# scene target tops the count up, for at most TOPUP_SECONDS; CI fails if it
# still falls short.
set -euo pipefail
cd "$(dirname "$0")/.."
FUZZ_SECONDS=${FUZZ_SECONDS:-75}
MIN_EXECS=${MIN_EXECS:-1000000}
TARGETS=(scene obj gltf image)
export ASAN_OPTIONS=${ASAN_OPTIONS:-detect_leaks=1:abort_on_error=0:strict_string_checks=1}
export UBSAN_OPTIONS=${UBSAN_OPTIONS:-print_stacktrace=1:halt_on_error=1}

t0=$SECONDS
# -O1 -g keeps asserts and stack traces and runs fast enough; no viewer (OpenGL
# drivers are not built with the sanitizers), no GPU code, no Python module (an
# instrumented extension cannot load into an uninstrumented interpreter).
cmake -S . -B build-asan -G Ninja -DCMAKE_CXX_COMPILER=clang++ -DCMAKE_BUILD_TYPE=Debug \
  -DCMAKE_CXX_FLAGS_DEBUG="-O1 -g" -DPENUMBRA_FUZZ=ON -DPENUMBRA_OPTIX=OFF -DPENUMBRA_VIEWER=OFF \
  -DPENUMBRA_PYTHON=OFF >/dev/null
cmake --build build-asan
t_build=$((SECONDS - t0))

# 1. The tests under the sanitizers. Left out: cli_robustness_memory (it limits
# the address space, which AddressSanitizer's shadow memory cannot live in), the
# viewer's window tests (not built), and scripts/study.py's tests (study_*: the
# Python pipeline driving the same CLI commands the cli_* tests run here; they
# run uninstrumented in the main stage, and under the sanitizers study_smoke
# alone took 509 of this stage's 583 s, which held CI over its 30 minutes).
t1=$SECONDS
ctest --test-dir build-asan --output-on-failure -j2 --timeout 900 -E 'cli_robustness_memory|viewer_xvfb|^study_'
t_tests=$((SECONDS - t1))

# 2. Fuzzing.
t2=$SECONDS
work=build-asan/fuzz
rm -rf "$work"
# run_target TARGET NAME [libFuzzer flags...]: one run into build-asan/fuzz/NAME.
run_target() {
  local t=$1 dir=$work/$2
  shift 2
  mkdir -p "$dir/corpus" "$dir/artifacts"
  local inputs=("$dir/corpus" "tests/fuzz/corpus/$t")
  [ -d "tests/fuzz/regressions/$t" ] && inputs+=("tests/fuzz/regressions/$t")
  local dict=()
  [ -f "tests/fuzz/$t.dict" ] && dict=(-dict="tests/fuzz/$t.dict")
  set +e
  "build-asan/tests/fuzz/fuzz_$t" -timeout=10 -rss_limit_mb=4096 -print_final_stats=1 \
    -artifact_prefix="$dir/artifacts/" "$@" "${dict[@]}" "${inputs[@]}" >"$dir/log" 2>&1
  echo $? >"$dir/rc"
  set -e
}
total=0
failed=0
# report NAME: adds the run's inputs to the total; a non-zero status is a finding.
report() {
  local name=$1 execs rc
  execs=$(sed -n 's/^stat::number_of_executed_units: *//p' "$work/$name/log" | tail -1)
  execs=${execs:-0}
  total=$((total + execs))
  rc=$(cat "$work/$name/rc")
  echo "fuzz $name: $execs inputs, exit status $rc"
  if [ "$rc" -ne 0 ]; then
    failed=1
    echo "fuzz $name FOUND A PROBLEM (inputs: $(ls "$work/$name/artifacts" | tr '\n' ' ')):" >&2
    grep -E "ERROR|SUMMARY|runtime error|Test unit written" "$work/$name/log" | head -20 >&2 || true
  fi
}
for ((i = 0; i < ${#TARGETS[@]}; i += 2)); do
  run_target "${TARGETS[i]}" "${TARGETS[i]}" -max_total_time="$FUZZ_SECONDS" &
  [ $((i + 1)) -lt ${#TARGETS[@]} ] && run_target "${TARGETS[i + 1]}" "${TARGETS[i + 1]}" -max_total_time="$FUZZ_SECONDS" &
  wait
done
for t in "${TARGETS[@]}"; do report "$t"; done
# A slow or busy machine: the fastest target (the scene parser, about 11,000
# inputs a core-second) tops the total up to MIN_EXECS, on both cores, for at
# most TOPUP_SECONDS more.
if [ "$failed" -eq 0 ] && [ "$total" -lt "$MIN_EXECS" ]; then
  need=$(((MIN_EXECS - total + 1) / 2))
  echo "fuzz: $total inputs; fuzz_scene runs $need more on each core (at most ${TOPUP_SECONDS:-180}s)"
  run_target scene scene-topup-1 -runs="$need" -max_total_time="${TOPUP_SECONDS:-180}" -seed=1 &
  run_target scene scene-topup-2 -runs="$need" -max_total_time="${TOPUP_SECONDS:-180}" -seed=2 &
  wait
  report scene-topup-1
  report scene-topup-2
fi
t_fuzz=$((SECONDS - t2))
echo "sanitize: build ${t_build}s, tests under ASan+UBSan ${t_tests}s, fuzzing ${t_fuzz}s: $total inputs in all"
if [ "$failed" -ne 0 ]; then
  echo "sanitize: a fuzz target found a problem: see above and build-asan/fuzz/<name>/log" >&2
  exit 1
fi
if [ "$total" -lt "$MIN_EXECS" ]; then
  echo "sanitize: only $total fuzz inputs ran, fewer than $MIN_EXECS" >&2
  exit 1
fi
