#!/usr/bin/env bash
# Installs what penumbra builds with, from Debian's packages (idempotent).
# Used by the README's two commands and by CI (.ci/run).
set -euo pipefail
packages=(
  cmake ninja-build g++ pkg-config python3 python3-pip
  python3-dev python3-venv  # the Python module: headers; CI installs it into a virtual environment
  libembree-dev          # Embree 3: CPU ray traversal
  nlohmann-json3-dev     # scene files
  libcli11-dev           # command line
  libstb-dev             # PNG output; PNG, BMP, TGA and HDR textures
  libjpeg-dev            # JPEG textures (libjpeg-turbo)
  libtinyexr-dev         # EXR input (EXR output is penumbra's own, src/io/exr_write.cpp)
  zlib1g-dev             # EXR output's ZIP compression
  libtinyobjloader-dev   # OBJ meshes
  libtinygltf-dev        # glTF 2.0 models (header; compiled in src/scene/tinygltf_impl.cpp)
  assimp-testmodels      # tests: real OBJ and glTF files made by others (tests/scene/test_models.cpp)
  libgtest-dev           # tests
  libglfw3-dev           # viewer: window and OpenGL context (penumbra view)
  libgl-dev              # viewer: OpenGL headers (GL/glcorearb.h)
  libimgui-dev           # viewer: Dear ImGui, with its GLFW and OpenGL 3 backends
  libegl-dev             # viewer: EGL headers, for --headless (libEGL.so.1 is opened at run time)
  libegl-mesa0           # viewer: Mesa's EGL, whose surfaceless platform runs --headless without a GPU (CI)
  xvfb xauth             # viewer test: a virtual X server (xvfb-run)
  libgl1-mesa-dri        # viewer test: Mesa's software OpenGL (llvmpipe) under Xvfb
  libglx-mesa0           # viewer test: Mesa's GLX, for that OpenGL on an X server
  clang                  # CI's sanitizer build and fuzz targets (.ci/sanitize.sh)
  libclang-rt-14-dev     # ... their runtimes: AddressSanitizer, UndefinedBehaviorSanitizer, libFuzzer
)
missing=()
for p in "${packages[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if [ ${#missing[@]} -gt 0 ]; then
  sudo=""
  [ "$(id -u)" -ne 0 ] && sudo="sudo"
  echo "install-deps: installing ${missing[*]}" >&2
  $sudo apt-get update -qq
  DEBIAN_FRONTEND=noninteractive $sudo apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
fi
# Python, from PyPI: numpy and matplotlib for the experiment reports (scripts/study.py);
# nanobind and scikit-build-core build the Python module (python/), pytest tests it;
# ray runs the study on a cluster (study.py --executor ray, docs/cluster.md; the test
# study_ray; about 240 MB); pyoidn ships Intel Open Image Denoise's libraries, which
# `--denoise` loads at run time (render/oidn.h; about 170 MB); mitsuba is the peer
# renderer scripts/anchors/mitsuba_anchor.py compares with (about 210 MB); scikit-image
# gives the denoising study its SSIM (study.py --part denoise).
py_missing=()
for m in numpy:numpy matplotlib:matplotlib nanobind:nanobind scikit_build_core:scikit-build-core pytest:pytest ray:ray \
         pyoidn:pyoidn mitsuba:mitsuba skimage:scikit-image; do
  python3 -c "import ${m%%:*}" >/dev/null 2>&1 || py_missing+=("${m#*:}")
done
if [ ${#py_missing[@]} -gt 0 ]; then
  echo "install-deps: installing ${py_missing[*]} from PyPI" >&2
  python3 -m pip install -q "${py_missing[@]}" || python3 -m pip install -q --break-system-packages "${py_missing[@]}"
fi
# The GPU backend: with OptiX_ROOT unset, CMake fetches the OptiX headers that match
# the NVIDIA driver (cmake/FetchOptiX.cmake); say what the build will do.
driver=""
if [ -r /proc/driver/nvidia/version ]; then
  driver=$(sed -n '1s/.*[[:space:]]\([0-9][0-9]*\.[0-9][0-9.]*\)[[:space:]].*/\1/p' /proc/driver/nvidia/version)
fi
if [ -z "$driver" ] && command -v nvidia-smi >/dev/null 2>&1; then
  driver=$(nvidia-smi --query-gpu=driver_version --format=csv,noheader 2>/dev/null | head -n 1 | tr -d ' ')
fi
if [ -n "$driver" ] && [ -z "${OptiX_ROOT:-}" ]; then
  if [ "${driver%%.*}" -lt 580 ] 2>/dev/null; then
    echo "install-deps: NVIDIA driver $driver supports no OptiX 9 (580 or later does): the build will be CPU-only" \
         "unless you update the driver or set OptiX_ROOT." >&2
  elif ! command -v nvcc >/dev/null 2>&1 && [ ! -x /usr/local/cuda/bin/nvcc ]; then
    echo "install-deps: NVIDIA driver $driver found, but no CUDA compiler (nvcc): install the CUDA toolkit" \
         "(12 or later) for the GPU backend, or the build will be CPU-only." >&2
  else
    echo "install-deps: NVIDIA driver $driver found: CMake will fetch the matching OptiX headers from NVIDIA's" \
         "optix-dev repository and build the GPU backend (offline, it prints the command to run instead)." >&2
  fi
fi
