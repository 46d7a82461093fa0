"""Evaluation code for isoparam: meshes, reference methods, Blender helpers and figures
for the tests, the benchmarks and the demo. Never shipped in the add-on."""

from __future__ import annotations

import os
import tempfile

_home: tempfile.TemporaryDirectory | None = None


def blender_user_folder() -> str:
    """Point Blender's user resources at a temporary folder (removed at exit), before bpy
    is imported, so that nothing is written into ~/.config/blender. Idempotent."""
    global _home
    if _home is None:
        _home = tempfile.TemporaryDirectory(prefix="isoparam-blender-")
        os.environ.setdefault("BLENDER_USER_RESOURCES", _home.name)
    return os.environ["BLENDER_USER_RESOURCES"]
