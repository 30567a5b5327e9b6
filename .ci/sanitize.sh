#!/usr/bin/env bash
# CI, second part: the sanitizer build (issue 12). Debian's clang compiles the
# project with AddressSanitizer + UndefinedBehaviorSanitizer in build-asan
# (cmake/Sanitizers.cmake); there
#   1. the unit tests and the executable's tests run (time-bounded), then
#   2. each libFuzzer target of tests/fuzz runs a fixed number of inputs
#      (FUZZ_RUNS) from a fixed seed (FUZZ_SEED), two at a time (one per core),
#      from its seed corpus and regression files: the same inputs on every run,
#      so that CI fails for a problem in the code, never by the luck of the
#      draw. Any sanitizer report, crash, leak, timeout (FUZZ_TIMEOUT s an
#      input) or out-of-memory (4 GiB) fails CI; the input that caused it is
#      kept under build-asan/fuzz/<target>/artifacts/ and printed: add it to
#      tests/fuzz/regressions/<target>/ with the fix. Then
#   3. exploration: each target for EXPLORE_SECONDS from a random seed (printed),
#      starting from the corpus that step 2 grew: inputs step 2 never tries.
#      What it finds is printed and kept under build-asan/fuzz/explore-<target>/
#      artifacts/ but does not fail CI: reproduce it, fix it and add it to
#      regressions/, which every later run replays. It is off in CI (0 s, the
#      default: CI's 30 minutes go to what can fail it); EXPLORE_SECONDS=60
#      bash .ci/sanitize.sh explores a minute a target.
set -euo pipefail
cd "$(dirname "$0")/.."
TARGETS=(scene obj gltf image)
# Step 2's inputs a target: about 22 s each on a core of an idle machine, which
# runs some 11,000 scene, 8,000 OBJ, 3,300 glTF and 6,000 image inputs a second
# under the sanitizers (README); at twice these counts the four took 90 s on a
# quiet shared two-core machine, 180 to 200 s on it at a load of 4 to 7. The same build, seed and count give the
# same inputs (two runs, at different loads and free memory, and from parent
# environments 5 kB apart, grew identical corpora) with: address-space
# randomization off (setarch -R), the same environment (env -i: its size moves
# the stack, and libFuzzer counts stack depth as coverage), no comparison
# operands as mutations (-use_cmp=0: addresses among them steer the inputs;
# it cost 0 to 4% of the coverage these runs reach), and the memory checks out
# of the coverage feedback (tests/fuzz/coverage_ignore.txt). Without any one of
# the first three, two such runs grew different corpora. A change to the
# code changes its coverage, and so the inputs tried (a rebuild at another
# commit of the same code grew the same corpora).
declare -A FUZZ_RUNS=([scene]=250000 [obj]=180000 [gltf]=75000 [image]=135000)
FUZZ_SEED=${FUZZ_SEED:-1}
# A slower input is a finding. Replayed one by one, no input of step 2's
# corpora, the seeds or the regressions took more than 120 ms (a shared
# two-core machine at a load of 5 to 12, four replays at once): step 2 allows
# 500 times that, 60 s; step 3 10 s (it reports a slow input, CI goes on).
FUZZ_TIMEOUT=${FUZZ_TIMEOUT:-60}
EXPLORE_TIMEOUT=${EXPLORE_TIMEOUT:-10}
EXPLORE_SECONDS=${EXPLORE_SECONDS:-0}
export ASAN_OPTIONS=${ASAN_OPTIONS:-detect_leaks=1:abort_on_error=0:strict_string_checks=1}
export UBSAN_OPTIONS=${UBSAN_OPTIONS:-print_stacktrace=1:halt_on_error=1}

t0=$SECONDS
# -O1 with line tables keeps asserts and stack traces with file and line, runs
# fast enough and compiles faster than full -g; no viewer (OpenGL
# drivers are not built with the sanitizers), no GPU code, no Python module (an
# instrumented extension cannot load into an uninstrumented interpreter).
cmake -S . -B build-asan -G Ninja -DCMAKE_CXX_COMPILER=clang++ -DCMAKE_BUILD_TYPE=Debug \
  -DCMAKE_CXX_FLAGS_DEBUG="-O1 -gline-tables-only" -DPENUMBRA_FUZZ=ON -DPENUMBRA_OPTIX=OFF -DPENUMBRA_VIEWER=OFF \
  -DPENUMBRA_PYTHON=OFF >/dev/null
cmake --build build-asan
t_build=$((SECONDS - t0))

# 1. The tests under the sanitizers. Left out: cli_robustness_memory (it limits
# the address space, which AddressSanitizer's shadow memory cannot live in), the
# viewer's window tests (not built), and scripts/study.py's tests (study_*: the
# Python pipeline driving the same CLI commands the cli_* tests run here, and
# study_metrics, Python alone; they run uninstrumented in the main stage, and
# under the sanitizers study_smoke alone took 509 of this stage's 583 s, which
# held CI over its 30 minutes), and the closed-form renders (ClosedForm: a
# billion samples of the integrator the unit tests already run here; about a
# minute uninstrumented in the main stage), the closed box and MIS agreement renders
# (ClosedBox, MisAgrees: about 380 of the 740 core-seconds this stage took, rendering
# through the integrator that the smaller render tests drive here too; they run
# uninstrumented in the main stage), the strategies' image agreement renders
# (StrategiesAgree: 113 of this stage's 378 test-seconds, the same integrator
# again), the interrupted long runs (cli_robustness_long: 57 s of waiting out
# signals and refusals, none of it new code under the sanitizers), the
# ltc chi-square at 64 x 64 points a cell (LtcOnGlossy: the sampling code runs
# here in StrategyOnLight), and Intel Open Image Denoise
# (Denoise.Oidn*: a library loaded at run time, not instrumented, whose thread
# pools outlive the test; it runs in the main stage). All of them run in the
# main stage.
t1=$SECONDS
ctest --test-dir build-asan --output-on-failure -j2 --timeout 900 \
  -E 'cli_robustness_memory|cli_robustness_long|viewer_xvfb|^study_|ClosedForm|ClosedBox|MisAgrees|StrategiesAgree|LtcOnGlossy|Denoise.Oidn'
t_tests=$((SECONDS - t1))

# 2. Fuzzing from fixed seeds, and 3. exploration from random ones.
t2=$SECONDS
work=build-asan/fuzz
rm -rf "$work"
# Every fuzz run in the same environment, with address-space randomization off where setarch may do it.
fixed_env=(env -i PATH=/usr/bin:/bin ASAN_OPTIONS="$ASAN_OPTIONS" UBSAN_OPTIONS="$UBSAN_OPTIONS")
fixed_addresses=(setarch "$(uname -m)" -R)
if ! "${fixed_addresses[@]}" true 2>/dev/null; then
  echo "fuzz: setarch -R is not allowed here: address-space randomization stays on, and step 2's inputs may" \
    "differ a little from run to run" >&2
  fixed_addresses=()
fi
# run_target TARGET NAME [libFuzzer flags...]: one run into build-asan/fuzz/NAME,
# from the target's seeds and regressions (and, for an exploration, from the
# corpus its fixed-seed run grew).
run_target() {
  local t=$1 dir=$work/$2
  shift 2
  mkdir -p "$dir/corpus" "$dir/artifacts"
  local inputs=("$dir/corpus")
  [ "$dir" != "$work/$t" ] && inputs+=("$work/$t/corpus")
  inputs+=("tests/fuzz/corpus/$t")
  [ -d "tests/fuzz/regressions/$t" ] && inputs+=("tests/fuzz/regressions/$t")
  local dict=()
  [ -f "tests/fuzz/$t.dict" ] && dict=(-dict="tests/fuzz/$t.dict")
  set +e
  "${fixed_env[@]}" "${fixed_addresses[@]}" "build-asan/tests/fuzz/fuzz_$t" -rss_limit_mb=4096 -reload=0 -print_final_stats=1 \
    -artifact_prefix="$dir/artifacts/" "$@" "${dict[@]}" "${inputs[@]}" >"$dir/log" 2>&1
  echo $? >"$dir/rc"
  set -e
}
fuzz_stat() { sed -n "s/^stat::$2: *//p" "$work/$1/log" | tail -1; }
# slowest NAME: the run's slowest input, in whole seconds as libFuzzer counts them.
slowest() {
  local s
  s=$(fuzz_stat "$1" slowest_unit_time_sec)
  [ "${s:-0}" -gt 0 ] && echo "slowest input ${s} s" || echo "every input under 1 s"
}
# in_pairs NAME_PREFIX FLAGS_FN: the targets two at a time, FLAGS_FN TARGET INDEX giving each one's flags.
in_pairs() {
  local prefix=$1 flags_fn=$2 i
  for ((i = 0; i < ${#TARGETS[@]}; i += 2)); do
    run_target "${TARGETS[i]}" "$prefix${TARGETS[i]}" $($flags_fn "${TARGETS[i]}" "$i") &
    if [ $((i + 1)) -lt ${#TARGETS[@]} ]; then
      run_target "${TARGETS[i + 1]}" "$prefix${TARGETS[i + 1]}" $($flags_fn "${TARGETS[i + 1]}" $((i + 1))) &
    fi
    wait
  done
}
# finding NAME WHAT: prints what a run found and where its inputs are.
finding() {
  echo "fuzz $1 $2 (inputs: $(ls "$work/$1/artifacts" | sed "s|^|$work/$1/artifacts/|" | tr '\n' ' ')):" >&2
  grep -E "ERROR|SUMMARY|runtime error|Test unit written" "$work/$1/log" | head -20 >&2 || true
}

gate_flags() { echo "-seed=$FUZZ_SEED -runs=${FUZZ_RUNS[$1]} -use_cmp=0 -timeout=$FUZZ_TIMEOUT"; }
in_pairs "" gate_flags
failed=0
for t in "${TARGETS[@]}"; do
  execs=$(fuzz_stat "$t" number_of_executed_units)
  rc=$(cat "$work/$t/rc")
  echo "fuzz $t: ${execs:-0} of ${FUZZ_RUNS[$t]} inputs from seed $FUZZ_SEED, $(slowest "$t"), exit status $rc"
  if [ "$rc" -ne 0 ]; then
    failed=1
    finding "$t" "FOUND A PROBLEM"
  elif [ "${execs:-0}" -lt "${FUZZ_RUNS[$t]}" ]; then
    failed=1
    echo "fuzz $t ran ${execs:-0} inputs, not ${FUZZ_RUNS[$t]}: see $work/$t/log" >&2
  fi
done
t_fuzz=$((SECONDS - t2))

t3=$SECONDS
explored=0
if [ "$EXPLORE_SECONDS" -gt 0 ]; then
  explore_seed=${EXPLORE_SEED:-$(((RANDOM << 15 | RANDOM) + 1))}
  explore_flags() { echo "-seed=$((explore_seed + $2)) -max_total_time=$EXPLORE_SECONDS -timeout=$EXPLORE_TIMEOUT"; }
  in_pairs explore- explore_flags
  for i in "${!TARGETS[@]}"; do
    name=explore-${TARGETS[i]}
    execs=$(fuzz_stat "$name" number_of_executed_units)
    rc=$(cat "$work/$name/rc")
    echo "fuzz $name: ${execs:-0} inputs from seed $((explore_seed + i)) in ${EXPLORE_SECONDS} s, $(slowest "$name"), exit status $rc"
    if [ "$rc" -ne 0 ]; then
      explored=1
      finding "$name" "FOUND A PROBLEM (exploration: reported, CI does not fail for it)"
    fi
  done
fi
t_explore=$((SECONDS - t3))
echo "sanitize: build ${t_build}s, tests under ASan+UBSan ${t_tests}s, fuzzing from fixed seeds ${t_fuzz}s, exploration ${t_explore}s"
if [ "$explored" -ne 0 ]; then
  echo "sanitize: exploration found a problem (above; not a CI failure): reproduce it with" \
    "build-asan/tests/fuzz/fuzz_<target> FILE, fix it, add FILE to tests/fuzz/regressions/<target>/" >&2
fi
if [ "$failed" -ne 0 ]; then
  echo "sanitize: a fuzz target found a problem from its fixed seed: see above and build-asan/fuzz/<target>/log" >&2
  exit 1
fi
