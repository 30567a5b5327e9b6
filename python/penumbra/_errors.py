"""The exceptions penumbra raises (the C++ extension raises these too)."""
from __future__ import annotations

from typing import Optional


class PenumbraError(Exception):
    """Base class of penumbra's own errors."""


class SceneError(PenumbraError, ValueError):
    """A scene, a scene file or an override is invalid.

    ``str(error)`` is the one-line message of the command line
    (``<file>: <field>: <problem>``); ``file`` names the scene file (or
    ``builtin:<name>``, or ``<dict>``) and ``field`` the field in it (e.g.
    ``lights[0].radius``, or the override key), each ``None`` where the error
    has none.
    """

    def __init__(self, message: str, file: Optional[str] = None, field: Optional[str] = None):
        super().__init__(message)
        self.file = file
        self.field = field


class BackendError(PenumbraError, RuntimeError):
    """A backend cannot be used or failed: no GPU or driver for ``backend='optix'``,
    a CUDA or Embree error, a feature this build does not have."""
