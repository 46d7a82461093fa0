"""Mode switching around the bulk mesh I/O: in edit mode a Mesh's arrays are stale, so they
are read and written in object mode, and edit mode is entered again for exactly the objects
that were in it."""

from __future__ import annotations

from contextlib import contextmanager

import bpy

__all__ = ["object_mode"]


@contextmanager
def object_mode(context):
    """Object mode for the bulk mesh I/O, then edit mode again for exactly the objects
    that were in it, with the object selection and the active object as they were.

    ``object.mode_set(mode="EDIT")`` enters every *selected* mesh: an object in edit
    mode but deselected would be left out, a selected one that was not in edit mode
    would be pulled in, unless the selection is set to the edit set around the call.
    Hidden or unselectable objects cannot be selected, so they are shown and made
    selectable for the call: an object hidden while in edit mode (which
    ``context.objects_in_mode`` leaves out, so it is not unwrapped, as with
    ``uv.unwrap``) stays in edit mode, hidden.
    """
    layer = context.view_layer
    in_mode = [ob for ob in layer.objects if ob.mode == "EDIT"]  # hidden ones too
    active = layer.objects.active
    selected = list(context.selected_objects)
    bpy.ops.object.mode_set(mode="OBJECT")
    try:
        yield
    finally:
        hidden = [(ob, ob.hide_get(), ob.hide_select) for ob in in_mode]
        for ob in selected:  # objects, not mesh elements
            ob.select_set(False)
        for ob in in_mode:
            ob.hide_set(False)
            ob.hide_select = False
            ob.select_set(True)
        layer.objects.active = active
        bpy.ops.object.mode_set(mode="EDIT")
        for ob in in_mode:
            ob.select_set(False)
        for ob in selected:
            ob.select_set(True)
        for ob, hide, hide_select in hidden:  # after the selection, which they would block
            ob.hide_set(hide)
            ob.hide_select = hide_select
