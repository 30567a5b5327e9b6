#!/usr/bin/env bash
# Unpacks OptiX headers for CI, which has no GPU and no OptiX SDK: the PyPI
# package pyoptix-contrib ships them (optix/include in its wheels). Prints the
# folder to pass as OptiX_ROOT on stdout and nothing else; messages go to stderr.
#
#   OptiX_ROOT=$(bash .ci/optix_headers.sh [DEST]) || exit 1
#
# DEST defaults to .deps/optix-pypi under the repository root. The headers are
# only for compiling: at run time the NVIDIA driver must support their ABI
# (driver 580 supports up to OptiX 9.0; these are 9.1).
set -euo pipefail

root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
dest=${1:-$root/.deps/optix-pypi}
version=${PYOPTIX_CONTRIB_VERSION:-0.1.2}

if [[ -f $dest/include/optix.h ]]; then
  echo "optix headers: already in $dest" >&2
  echo "$dest"
  exit 0
fi

python=${PYTHON:-python3}
if ! "$python" -m pip --version >/dev/null 2>&1; then
  echo "optix_headers.sh: error: '$python -m pip' is not available (install python3-pip)" >&2
  exit 1
fi

tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
# The headers are the same in every wheel: ask for one explicit wheel so that the
# host's Python version does not matter.
if ! "$python" -m pip download --quiet --no-deps --only-binary=:all: --python-version 3.11 \
      --implementation cp --platform manylinux_2_28_x86_64 -d "$tmp" "pyoptix-contrib==$version" >&2; then
  echo "optix_headers.sh: error: pip could not download pyoptix-contrib==$version" >&2
  exit 1
fi
wheel=$(ls "$tmp"/pyoptix_contrib-*.whl 2>/dev/null | head -n 1 || true)
if [[ -z $wheel ]]; then
  echo "optix_headers.sh: error: no pyoptix-contrib wheel was downloaded" >&2
  exit 1
fi
"$python" - "$wheel" "$tmp/x" <<'PY'
import sys, zipfile
wheel, out = sys.argv[1], sys.argv[2]
with zipfile.ZipFile(wheel) as z:
    names = [n for n in z.namelist() if n.startswith("optix/include/") and not n.endswith("/")]
    if not names:
        sys.exit("optix_headers.sh: error: the wheel has no optix/include")
    for n in names:
        z.extract(n, out)
PY
if [[ ! -f $tmp/x/optix/include/optix.h ]]; then
  echo "optix_headers.sh: error: optix.h missing from the wheel" >&2
  exit 1
fi
mkdir -p "$(dirname "$dest")"
rm -rf "$dest"
mv "$tmp/x/optix" "$dest"
v=$(sed -n 's/^#define OPTIX_VERSION \([0-9]*\).*/\1/p' "$dest/include/optix.h")
echo "optix headers: OptiX ${v:-?} from pyoptix-contrib $version in $dest" >&2
echo "$dest"
