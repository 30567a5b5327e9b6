#!/usr/bin/env bash
# CTest multi_gpu_check_logic: scripts/multi_gpu_check.sh (run on machines with several GPUs only) against stand-ins
# for penumbra and nvidia-smi (fake_gpu/), so that its arithmetic and verdicts are checked where it cannot run: two
# GPUs scaling at 0.95 pass; at 0.8 the speed-up check fails; images that differ across GPU counts fail; one GPU is
# refused; eight GPUs give every count; a scene penumbra does not list is left out.
#
#   tests/scripts/multi_gpu_check_test.sh SCRIPT WORK_DIR
set -uo pipefail
script=$1 work=$2
here=$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)
rm -rf "$work"
mkdir -p "$work/build"
cp "$here/fake_gpu/penumbra" "$work/build/penumbra"
export PATH="$here/fake_gpu:$PATH" MULTI_GPU_ROUNDS=2 MULTI_GPU_SPP=4096
failed=0
# expect NAME STATUS PATTERN [ENV...]: the check exits with STATUS and prints a line matching PATTERN.
expect() {
  local name=$1 status=$2 pattern=$3
  shift 3
  local log="$work/$name.log"
  env "$@" MULTI_GPU_OUT="$work/$name" bash "$script" "$work/build" >"$log" 2>&1
  local st=$?
  if [[ $st -ne $status ]] || ! grep -qE -- "$pattern" "$log"; then
    echo "multi_gpu_check_logic: FAILED: $name: exit $st (expected $status), pattern '$pattern' $(grep -qE -- "$pattern" "$log" && echo found || echo missing)"
    tail -n 20 "$log"
    failed=1
  else
    echo "multi_gpu_check_logic: ok: $name"
  fi
}
expect scaling 0 '\| cornell-sphere \| cuda \| 2 \| 2 \| 52\.63 \| .* \| 1\.90x \| 1\.8x \|' FAKE_GPUS=2
expect slow 1 'FAIL.*sponza optix: speed-up 1\.60x on 2 GPUs >= 1\.8x' FAKE_GPUS=2 FAKE_EFF=0.8
expect differ 1 'FAIL.*cornell-sphere cuda: ground truth the same bytes on 1 and 2 GPUs' FAKE_GPUS=2 FAKE_DIFFER=1
expect one_gpu 1 'needs a machine with at least 2 GPUs \(1 found\)' FAKE_GPUS=1
expect eight 0 '\| sponza \| optix \| 8 \| 2 \| .* \| 7\.60x \| 7\.2x \|' FAKE_GPUS=8
expect no_sponza 0 '== sponza left out' FAKE_GPUS=2 FAKE_SPONZA=
exit $failed
