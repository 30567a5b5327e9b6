#!/usr/bin/env bash
# Installs what penumbra builds with, from Debian's packages (idempotent).
# Used by the README's two commands and by CI (.ci/run).
set -euo pipefail
packages=(
  cmake ninja-build g++ pkg-config python3 python3-pip
  libembree-dev          # Embree 3: CPU ray traversal
  nlohmann-json3-dev     # scene files
  libcli11-dev           # command line
  libstb-dev             # PNG output
  libtinyexr-dev         # EXR output
  libtinyobjloader-dev   # OBJ meshes
  libtinygltf-dev        # glTF 2.0 models (header; compiled in src/scene/tinygltf_impl.cpp)
  assimp-testmodels      # tests: real OBJ and glTF files made by others (tests/test_models.cpp)
  libgtest-dev           # tests
  libglfw3-dev           # viewer: window and OpenGL context (penumbra view)
  libgl-dev              # viewer: OpenGL headers (GL/glcorearb.h)
  libimgui-dev           # viewer: Dear ImGui, with its GLFW and OpenGL 3 backends
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
# Python for the experiment reports (scripts/study.py), from PyPI.
if ! python3 -c "import numpy, matplotlib" >/dev/null 2>&1; then
  echo "install-deps: installing numpy and matplotlib from PyPI" >&2
  python3 -m pip install -q numpy matplotlib || python3 -m pip install -q --break-system-packages numpy matplotlib
fi
if command -v nvidia-smi >/dev/null 2>&1 && [ -z "${OptiX_ROOT:-}" ]; then
  echo "install-deps: an NVIDIA GPU is present but OptiX_ROOT is not set: the build will be CPU-only." >&2
  echo "  Set OptiX_ROOT to an OptiX SDK folder holding include/optix.h (OptiX 9.0 for driver 580) to build the GPU backend." >&2
fi
