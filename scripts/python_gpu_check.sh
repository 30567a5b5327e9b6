#!/usr/bin/env bash
# The Python module on a GPU machine, and the OptiX headers CMake fetches for a
# real NVIDIA driver. The GPU machine has no network and no Debian packages, so
# the work is split in two:
#
#   scripts/python_gpu_check.sh prepare [DIR]   # here: a machine with scripts/install-deps.sh's packages
#   scripts/python_gpu_check.sh check [DIR]     # there: carry DIR (default .deps/python-gpu, git-ignored)
#
# prepare configures and builds BUILD (default build-python-gpu: the CLI and the module, no tests, no viewer)
# for the GPU machine's Python (PYTHON, default pyenv's 3.12), with the GPU backend compiled against OptiX
# headers that the build fetches itself (cmake/FetchOptiX.cmake) for driver DRIVER (default 580.159.04, the
# GPU machine's) from OPTIX_DEV (a clone of NVIDIA's optix-dev; default: this workplace's mirror); with
# PACK_ONLY=1 it packs an existing BUILD (built for that Python) as it is. Then it fills DIR (about 16 MB):
#   python/       the package penumbra with its extension; bin/penumbra, the executable;
#   lib.tar.xz    the Debian libraries they need (Embree, TBB, tinyexr, tinyobjloader, stb, libjpeg);
#   optix-dev.git a bare clone of OPTIX_DEV, for the fetch test there.
#
# check, on the GPU machine (python3 with numpy, pytest; torch or cupy for DLPack):
#   1. FetchOptiX with the real driver (no injected version): tests/fetch_optix against DIR/optix-dev.git must
#      pick the tag of that driver (580: v9.0.0, 590+: v9.1.0) and fetch its headers;
#   2. the module sees the GPU (penumbra.build_info());
#   3. pytest python/tests, with the GPU tests (test_gpu.py: DLPack device tensors through torch/cupy, GPU vs
#      CPU z-test, progressive GPU renders, GPU image == `penumbra render --backend optix` bit for bit, Ctrl-C
#      between launches) required to run, not skip;
#   4. DLPack at 1920x1080: torch.from_dlpack(image) is a CUDA tensor at the image's own device pointer.
# Prints PASS/FAIL per step; exits 0 only if every step passed.
set -uo pipefail
root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
mode=${1:-}
dir=${2:-$root/.deps/python-gpu}
mkdir -p "$dir" 2>/dev/null || true
dir=$(cd "$dir" && pwd)

prepare() {
  local python=${PYTHON:-/root/.pyenv/versions/3.12.1/bin/python3}
  local driver=${DRIVER:-580.159.04}
  local optix_dev=${OPTIX_DEV:-/work/.mirror/NVIDIA+optix-dev/repo}
  local build=${BUILD:-$root/build-python-gpu}
  set -e
  if [[ ${PACK_ONLY:-0} != 1 ]]; then
    local nb_dir
    nb_dir=$(python3 -m nanobind --cmake_dir)  # nanobind's CMake files work for any Python
    echo "== configure $build for $("$python" --version), OptiX headers fetched for driver $driver from $optix_dev"
    env -u OptiX_ROOT PATH="$PATH:/usr/local/cuda/bin" cmake -S "$root" -B "$build" -G Ninja \
      -DCMAKE_BUILD_TYPE=Release -DCMAKE_CUDA_ARCHITECTURES=90 -DPENUMBRA_TESTS=OFF -DPENUMBRA_VIEWER=OFF \
      -DPENUMBRA_PYTHON=ON -DPython_EXECUTABLE="$python" -Dnanobind_DIR="$nb_dir" \
      -DPENUMBRA_NVIDIA_DRIVER_VERSION="$driver" -DPENUMBRA_OPTIX_GIT_URL="$optix_dev" | grep "penumbra:"
    cmake --build "$build"
  fi
  ls "$build"/python/penumbra/_penumbra*.so "$build/penumbra" >/dev/null
  rm -rf "$dir/python" "$dir/bin" "$dir/optix-dev.git" "$dir/lib.tar.xz"
  mkdir -p "$dir/python" "$dir/bin"
  cp -r "$build/python/penumbra" "$dir/python/"
  mkdir -p "$dir/python/penumbra/data"
  cp "$root/data/sky.hdr" "$dir/python/penumbra/data/"  # as a wheel holds it
  cp "$build/penumbra" "$dir/bin/"
  # The shared libraries from Debian packages (not glibc, libstdc++ or the driver's).
  local libs=()
  while read -r so; do libs+=("$so"); done < <(ldd "$dir"/python/penumbra/_penumbra*.so "$dir/bin/penumbra" |
    awk '/=> \//{print $3}' | grep -E 'embree|tbb|tinyexr|tinyobjloader|libstb|libjpeg' | sort -u)
  mkdir -p "$dir/lib"
  cp -L "${libs[@]}" "$dir/lib/"
  tar -C "$dir" -cJf "$dir/lib.tar.xz" lib
  rm -rf "$dir/lib"
  git clone -q --bare "$optix_dev" "$dir/optix-dev.git"
  echo "prepare: $dir ($(du -sh "$dir" | cut -f1)): carry it and run: bash scripts/python_gpu_check.sh check ${dir#"$root"/}"
}

source "$root/scripts/check_record.sh"  # record NAME STATUS, finish_checks TITLE

check() {
  local python=${PYTHON:-python3}
  local work
  work=$(mktemp -d)
  [[ -f $dir/lib.tar.xz ]] || { echo "check: no $dir/lib.tar.xz: run prepare first"; exit 1; }
  tar -C "$work" -xJf "$dir/lib.tar.xz"
  export LD_LIBRARY_PATH="$work/lib${LD_LIBRARY_PATH:+:$LD_LIBRARY_PATH}"
  export PYTHONPATH="$dir/python${PYTHONPATH:+:$PYTHONPATH}"
  export PENUMBRA_EXE="$dir/bin/penumbra"
  echo "== $(nvidia-smi --query-gpu=name,driver_version --format=csv,noheader 2>&1 | head -n 1)"

  # 1. The headers for this driver, fetched by FetchContent from the carried clone.
  echo "== FetchOptiX with this machine's driver"
  local drv major expected_tag expected_version line
  drv=$(nvidia-smi --query-gpu=driver_version --format=csv,noheader 2>/dev/null | head -n 1 | tr -d ' ')
  major=${drv%%.*}
  if [[ ${major:-0} -ge 590 ]]; then expected_tag=v9.1.0; expected_version=90100
  else expected_tag=v9.0.0; expected_version=90000; fi
  line=$(cmake -S "$root/tests/fetch_optix" -B "$work/fetch" -DPENUMBRA_OPTIX_GIT_URL="$dir/optix-dev.git" 2>&1 |
         grep "fetch_optix:")
  echo "$line"
  [[ $line == *"driver=[$drv]"* && $line == *"tag=[$expected_tag]"* && $line == *"version=[$expected_version]"* ]]
  record "FetchOptiX: driver $drv -> $expected_tag, OPTIX_VERSION $expected_version" $?

  # 2. The module and the GPU.
  echo "== the module"
  "$python" -c "import penumbra, json; i = penumbra.build_info(); print(json.dumps(i)); assert i['optix'] and i['gpu_available']"
  record "penumbra.build_info(): built with OptiX, GPU available" $?

  # 3. The test suite, GPU tests included (they must run, not skip).
  echo "== pytest python/tests"
  (cd "$work" && "$python" -m pytest -q -p no:cacheprovider -rs "$root/python/tests" 2>&1) | tee "$work/pytest.log" | tail -n 15
  local st=${PIPESTATUS[0]}
  record "pytest python/tests" "$st"
  (cd "$work" && "$python" -m pytest -q -p no:cacheprovider "$root/python/tests/test_gpu.py" 2>&1) | tail -n 3 |
    tee "$work/pytest_gpu.log"
  # None failed; none skipped, except the two-GPU test on a machine of one GPU.
  local gpus allowed=0
  gpus=$(nvidia-smi -L 2>/dev/null | grep -c "^GPU")
  [[ ${gpus:-0} -lt 2 ]] && allowed=1
  ! grep -qE "failed|error" "$work/pytest_gpu.log" && grep -qE "^[0-9]+ passed" "$work/pytest_gpu.log" &&
    [[ $(grep -oE "[0-9]+ skipped" "$work/pytest_gpu.log" | cut -d' ' -f1 || true) -le $allowed ]]
  record "pytest test_gpu.py: none failed, none skipped (but the 2-GPU test on $gpus GPU)" $?

  # 4. DLPack: the image's own device memory.
  echo "== DLPack"
  "$python" - <<'PY'
import numpy as np, penumbra, torch
img = penumbra.render("cornell-sphere", spp=64, width=1920, height=1080, backend="optix")
t = torch.from_dlpack(img)
print(f"{img.stats['device']}: {img.spp} spp at 1920x1080, {img.stats['gpu_ms']:.1f} ms GPU; torch tensor "
      f"{tuple(t.shape)} {t.dtype} on {t.device}, data_ptr {t.data_ptr():#x}")
assert t.is_cuda and tuple(t.shape) == (1080, 1920, 3) and t.dtype == torch.float32
assert t.data_ptr() == torch.from_dlpack(img.rgb_dlpack()).data_ptr()
assert np.array_equal(t.cpu().numpy(), img.rgb)
PY
  record "DLPack: torch.from_dlpack(image) on the GPU, no copy" $?

  rm -rf "$work"
  echo "== python_gpu_check summary"
  finish_checks python_gpu_check
}

case $mode in
  prepare) prepare ;;
  check) check ;;
  *) echo "usage: $0 prepare|check [DIR]  (DIR default: .deps/python-gpu)" >&2; exit 2 ;;
esac
