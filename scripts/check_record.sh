# PASS/FAIL bookkeeping of the GPU-machine checks (the GPU tests, tests/gpu/lib.sh;
# python_gpu_check.sh, multi_gpu_check.sh) and their build (gpu_check.sh), sourced by them:
#   record NAME STATUS     prints NAME with PASS (STATUS 0) or FAIL, and remembers it
#   finish_checks TITLE    prints every verdict and "TITLE: PASS (N checks)" or "TITLE: FAIL";
#                          returns 0 only if every check passed and there was at least one
#   gpu_build DIR TITLE [TARGET]  configures (Release, CMAKE_CUDA_ARCHITECTURES=90, OptiX_ROOT from the
#                          environment or .optix/) and builds DIR; on failure prints "TITLE: FAIL" and exits
declare -a names=() verdicts=()
failed=0
record() {
  names+=("$1")
  if [[ $2 -eq 0 ]]; then verdicts+=("PASS"); else verdicts+=("FAIL"); failed=1; fi
  printf '%-52s %s\n' "$1" "${verdicts[-1]}"
}
finish_checks() {
  local i
  for i in "${!names[@]}"; do printf '  %-4s %s\n' "${verdicts[$i]}" "${names[$i]}"; done
  if [[ $failed -eq 0 && ${#names[@]} -gt 0 ]]; then
    echo "$1: PASS (${#names[@]} checks)"
    return 0
  fi
  [[ ${#names[@]} -eq 0 ]] && echo "$1: FAIL (no checks ran)" || echo "$1: FAIL"
  return 1
}
gpu_build() {
  local dir=$1 title=$2 root optix_root
  root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
  optix_root=${OptiX_ROOT:-$root/.optix}
  echo "== configure and build $dir (OptiX_ROOT=$optix_root)"
  cmake -S "$root" -B "$dir" -G Ninja -DCMAKE_BUILD_TYPE=Release -DCMAKE_CUDA_ARCHITECTURES=90 \
    -DOptiX_ROOT="$optix_root" || { echo "$title: FAIL: configure"; exit 1; }
  cmake --build "$dir" ${3:+--target "$3"} || { echo "$title: FAIL: build"; exit 1; }
}
