"""Where the operator leaves what one Isometric Unwrap did
(:class:`~isoparam_addon.operation.record.RunRecord`).

:func:`.unwrap.run` returns its record. The operator, which can only return
``{'FINISHED'}`` or ``{'CANCELLED'}``, reports the record's words and leaves the record
on the window manager (``window_manager.isoparam_run_record``, as JSON), where a script
that called ``bpy.ops.uv.isometric_unwrap()`` reads it back with :func:`last_record`, or
with ``json.loads`` alone (a batch job in a Blender whose add-on is an installed
extension). Window manager properties are runtime data: loading a file or the home file
clears it, and no .blend brings one back.
"""

from __future__ import annotations

import bpy
from bpy.props import StringProperty

from ..operation.record import RunRecord

__all__ = ["RunRecord", "last_record", "register", "store", "unregister"]


def store(context, record: RunRecord) -> None:
    """Leave ``record`` on the window manager, in place of the last one."""
    context.window_manager.isoparam_run_record = record.to_json()


def last_record(context) -> RunRecord | None:
    """The record the operator left on the window manager; None if it has not run since
    the file was loaded."""
    text = context.window_manager.isoparam_run_record
    return RunRecord.from_json(text) if text else None


def register() -> None:
    bpy.types.WindowManager.isoparam_run_record = StringProperty(
        name="Isometric Unwrap Record",
        description="What the last Isometric Unwrap did (timings, coverage, notes, warnings), as JSON, for scripts",
        options={"HIDDEN"},
    )


def unregister() -> None:
    del bpy.types.WindowManager.isoparam_run_record
