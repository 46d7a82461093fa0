"""The pack round trip: Blender's ``uv.pack_islands`` over what was unwrapped, with what it
would change besides the UVs (the UV selection, pins set for it) kept and put back."""

from __future__ import annotations

from dataclasses import dataclass

import bpy
import numpy as np

from ..operation.options import OperatorOptions
from . import mesh_io
from .modes import object_mode

__all__ = ["SYNC_RESELECTS", "Kept", "pack", "prepare_pack"]


# Switching sync selection rewrites the UV selection from the mesh selection in 5.0
# (measured on 5.0.1; 4.2.23 and 4.5.15 keep it), so the pack's switch is undone there.
SYNC_RESELECTS = bpy.app.version >= (5, 0, 0)


@dataclass
class Kept:
    """What :func:`pack` puts back on one mesh: its UV selection, and its pins where
    corners locked by the UV selection were pinned for the pack."""

    mesh: object
    uv_name: str
    uv_selection: dict
    pins: np.ndarray | None
    pins_set: bool


def prepare_pack(solved, objects, uv_selection_locks: bool, reselects: bool) -> list[Kept]:
    """Before the pack (object mode): pin the corners locked by the UV selection (UV
    editor, sync off; the packer keeps only pinned islands in place), and keep the UV
    selection and pins of the meshes whose pins change, and, where the pack's sync switch
    would rewrite the UV selection (``reselects``), of every mesh in edit mode (``objects``:
    the ones with nothing selected too)."""
    kept = []
    if reselects:
        done = {id(s.obj.data) for s in solved}
        for ob in objects:
            me = ob.data
            if id(me) not in done:  # (no UV map is made for it)
                name = me.uv_layers.active.name if me.uv_layers.active is not None else ""
                kept.append(Kept(me, name, mesh_io.uv_selection(me, name), None, False))
    for s in solved:
        mask = np.zeros(len(s.sel.locked), dtype=bool)
        if uv_selection_locks:
            loops = s.sel.tri_loops.ravel()
            mask[loops] = s.sel.locked[loops] & ~s.sel.pinned[loops]
        if not (mask.any() or reselects):
            continue
        me = s.obj.data
        name = mesh_io.uv_layer_name(me)
        kept.append(Kept(me, name, mesh_io.uv_selection(me, name), mesh_io.pins(me, name), bool(mask.any())))
        if mask.any():
            mesh_io.set_pins(me, name, s.sel.pinned | mask)
    return kept


def pack(context, solved, opts: OperatorOptions, pin: bool, kept: list[Kept]) -> list[np.ndarray]:
    """``uv.pack_islands`` over what was unwrapped, pinned islands left where they are;
    then what :func:`prepare_pack` kept is put back, and the packed corner UVs of every
    mesh solved (t, 3, 2) are read back for the report (object mode).

    The pack runs with sync selection on, so that it acts on whole selected faces whatever
    their UVs' own selection (off by default in 4.2; with it off, Blender's packer takes
    only faces whose UVs are all selected and would tear an island in two).
    """
    tool = context.scene.tool_settings
    sync_was = tool.use_uv_select_sync
    try:
        if not sync_was:  # (setting it at all resyncs the UV selection in 5.0)
            tool.use_uv_select_sync = True
        # the pack's poll wants an active object with a UV map: the active object may have
        # had no face selected and no UV map (then the pack would raise, the UVs written)
        ob = solved[0].obj
        with context.temp_override(active_object=ob, object=ob, edit_object=ob):
            bpy.ops.uv.pack_islands(
                margin=opts.pack_margin,
                margin_method="FRACTION" if opts.in_pixels else "SCALED",
                rotate=True,
                scale=not opts.world_scale,
                pin=pin,
                pin_method="LOCKED",
                shape_method=opts.blender_shape,
            )
    finally:
        if tool.use_uv_select_sync != sync_was:
            tool.use_uv_select_sync = sync_was
        with object_mode(context):
            for k in kept:
                if k.pins_set:
                    mesh_io.set_pins(k.mesh, k.uv_name, k.pins)
                mesh_io.set_uv_selection(k.mesh, k.uv_selection)
            packed = [mesh_io.read_uvs(s.obj.data, mesh_io.uv_layer_name(s.obj.data), s.sel.tri_loops) for s in solved]
    return packed
