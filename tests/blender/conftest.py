"""Fixtures for tests that drive the real bpy module (Blender as a Python module).

bpy is imported once per process (it cannot be reloaded); user resources go to a
temporary folder so nothing is written into ~/.config/blender.
"""

import os
import tempfile

import numpy as np
import pytest

_home = tempfile.TemporaryDirectory(prefix="isoparam-blender-")  # removed at exit
os.environ.setdefault("BLENDER_USER_RESOURCES", _home.name)
bpy = pytest.importorskip("bpy", reason="bpy (Blender as a Python module) is not installed")

import isoparam_addon  # noqa: E402

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


def add_mesh(name, V, F, location=(0, 0, 0)):
    """A mesh object from arrays (faces may be lists of different lengths)."""
    me = bpy.data.meshes.new(name)
    faces = F.tolist() if isinstance(F, np.ndarray) else F
    me.from_pydata(np.asarray(V, dtype=float).tolist(), [], faces)
    me.update()
    ob = bpy.data.objects.new(name, me)
    ob.location = location
    bpy.context.scene.collection.objects.link(ob)
    return ob


def edit(*objects, select_all=True):
    """Enter edit mode on these objects (the first one active), everything selected."""
    if bpy.context.object is not None and bpy.context.object.mode != "OBJECT":
        bpy.ops.object.mode_set(mode="OBJECT")
    for ob in bpy.context.scene.objects:
        ob.select_set(False)
    for ob in objects:
        ob.select_set(True)
    bpy.context.view_layer.objects.active = objects[0]
    bpy.ops.object.mode_set(mode="EDIT")
    if select_all:
        bpy.ops.mesh.select_all(action="SELECT")


def object_mode():
    if bpy.context.object is not None and bpy.context.object.mode != "OBJECT":
        bpy.ops.object.mode_set(mode="OBJECT")


def set_uvs_and_pins(ob, uv, pins):
    """Write the active map's corner UVs (corners, 2) and pins (corners,) bool, object mode."""
    layer = ob.data.uv_layers.active
    layer.uv.foreach_set("vector", np.asarray(uv, dtype=np.float32).ravel())
    if hasattr(layer, "pin_ensure"):  # 5.0 creates pins lazily; 4.2 always has them
        layer.pin_ensure()
    layer.pin.foreach_set("value", np.asarray(pins, dtype=bool))


def corner_uvs(ob):
    """(corners, 2) float32 UVs of the active map."""
    me = ob.data
    out = np.empty(2 * len(me.loops), dtype=np.float32)
    me.uv_layers.active.uv.foreach_get("vector", out)
    return out.reshape(-1, 2)


def corner_verts(ob):
    me = ob.data
    out = np.empty(len(me.loops), dtype=np.int32)
    me.attributes[".corner_vert"].data.foreach_get("value", out)
    return out


def triangles(ob):
    """Loop triangles as (t, 3) corner indices."""
    me = ob.data
    me.calc_loop_triangles()
    t = np.empty(3 * len(me.loop_triangles), dtype=np.int32)
    me.loop_triangles.foreach_get("loops", t)
    return t.reshape(-1, 3)


def positions(ob):
    me = ob.data
    out = np.empty(3 * len(me.vertices), dtype=np.float32)
    me.attributes["position"].data.foreach_get("vector", out)
    return out.reshape(-1, 3).astype(np.float64)


def snapshot(ob):
    """Every attribute of the mesh as raw bytes, plus its UV maps' names."""
    me = ob.data
    out = {"uv_maps": tuple(u.name for u in me.uv_layers)}
    sizes = {"POINT": len(me.vertices), "EDGE": len(me.edges), "FACE": len(me.polygons), "CORNER": len(me.loops)}
    widths = {"FLOAT_VECTOR": 3, "FLOAT2": 2, "INT32_2D": 2, "FLOAT_COLOR": 4, "BYTE_COLOR": 4, "QUATERNION": 4}
    for attr in me.attributes:
        n = sizes.get(attr.domain, 0) * widths.get(attr.data_type, 1)
        kind = (
            "vector"
            if attr.data_type in ("FLOAT_VECTOR", "FLOAT2")
            else ("color" if "COLOR" in attr.data_type else "value")
        )
        dtype = bool if attr.data_type == "BOOLEAN" else (np.int32 if "INT" in attr.data_type else np.float32)
        buf = np.empty(n, dtype=dtype)
        attr.data.foreach_get(kind, buf)
        out[attr.name] = buf.tobytes()
    return out
