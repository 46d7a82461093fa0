"""Fixtures for tests that drive the real bpy module (Blender as a Python module).

bpy is imported once per process (it cannot be reloaded); user resources go to a
temporary folder so nothing is written into ~/.config/blender. The helpers that build
meshes and read them back live in :mod:`isoparam_eval.blender`, shared with the scripts.
"""

import pytest

from isoparam_eval import blender_user_folder

blender_user_folder()
bpy = pytest.importorskip("bpy", reason="bpy (Blender as a Python module) is not installed")

import isoparam_addon  # noqa: E402
from isoparam_eval.blender import (  # noqa: E402, F401 - helpers the tests import from here
    add_mesh,
    corner_uvs,
    corner_verts,
    edit,
    object_mode,
    positions,
    set_uvs_and_pins,
    snapshot,
    triangles,
)

_registered = False


@pytest.fixture(scope="session", autouse=True)
def addon():
    global _registered
    if not _registered:
        isoparam_addon.register()
        _registered = True
    yield


@pytest.fixture
def scene():
    """An empty scene (add-ons stay registered)."""
    if bpy.context.object is not None and bpy.context.object.mode != "OBJECT":
        bpy.ops.object.mode_set(mode="OBJECT")
    bpy.ops.wm.read_homefile(use_empty=True)
    return bpy.context.scene
