"""Shared fixtures of the Python tests. CTest runs them against the module in the
build tree (python/CMakeLists.txt sets PYTHONPATH and PENUMBRA_EXE, the CLI)."""
import os
import shutil

import pytest

import penumbra

# Small images: the whole suite runs in well under a minute on two cores.
SMALL = dict(width=48, height=27)


@pytest.fixture(scope="session")
def cli():
    """The `penumbra` executable of the same build, for the same-image tests."""
    exe = os.environ.get("PENUMBRA_EXE") or shutil.which("penumbra")
    if not exe or not os.path.exists(exe):
        pytest.skip("no penumbra executable (set PENUMBRA_EXE)")
    return exe


def gpu_reason():
    """None when the GPU backend can run here, else why not."""
    info = penumbra.build_info()
    if not info["optix"]:
        return "this build has no GPU backend"
    if not info["gpu_available"]:
        return "no usable GPU: " + info["gpu_unavailable_reason"]
    return None
