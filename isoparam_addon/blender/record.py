"""What one Isometric Unwrap did (:class:`RunRecord`), and where the operator leaves it.

:func:`.unwrap.run` returns its record. The operator, which can only return
``{'FINISHED'}`` or ``{'CANCELLED'}``, reports the record's words and leaves the record
on the window manager (``window_manager.isoparam_run_record``, as JSON), where a script
that called ``bpy.ops.uv.isometric_unwrap()`` reads it back with :func:`last_record`, or
with ``json.loads`` alone (a batch job in a Blender whose add-on is an installed
extension). Window manager properties are runtime data: loading a file or the home file
clears it, and no .blend brings one back.
"""

from __future__ import annotations

import json
from dataclasses import asdict, dataclass, field, fields

import bpy
from bpy.props import StringProperty

from ..solver import Timings

__all__ = ["RunRecord", "last_record", "register", "store", "unregister"]


@dataclass
class RunRecord:
    """What one run of Isometric Unwrap did, for scripts (the batch job, the benchmarks):
    whether it wrote anything (``finished``: else cancelled or refused, nothing changed),
    what it reported, in order, as ``(level, text)`` with level ``'INFO'``, ``'WARNING'`` or
    ``'ERROR'``; where it spent its seconds (reading the meshes, the solver, with its own
    :class:`~isoparam_addon.solver.Timings` per mesh, writing the UVs, seams and stretch
    colours, the pack, and all of it, mode switches included), its notes and warnings per
    mesh, and the solver's own facts (``details``: what the four steps met), which go to
    the ``isoparam`` logger at DEBUG level only."""

    finished: bool = False
    reports: list[tuple[str, str]] = field(default_factory=list)
    read: float = 0.0
    solve: float = 0.0
    write: float = 0.0
    pack: float = 0.0
    total: float = 0.0
    solver: list[Timings] = field(default_factory=list)
    notes: list[str] = field(default_factory=list)
    warnings: list[str] = field(default_factory=list)
    details: list[str] = field(default_factory=list)
    coverage: float = 0.0  # the share of the UV square the unwrapped faces cover

    def report(self, level: str, text: str) -> None:
        """Say ``text`` at ``level`` (``'INFO'``, ``'WARNING'``, ``'ERROR'``) when the run ends."""
        self.reports.append((level, text))

    def to_json(self) -> str:
        return json.dumps(asdict(self))

    @classmethod
    def from_json(cls, text: str) -> RunRecord:
        """The record :meth:`to_json` wrote (keys it does not know are left out)."""
        data = json.loads(text)
        known = {f.name for f in fields(cls)}
        record = cls(**{k: v for k, v in data.items() if k in known})
        record.reports = [(level, words) for level, words in record.reports]
        record.solver = [Timings(**t) for t in data.get("solver", [])]
        return record


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
