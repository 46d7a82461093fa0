"""What one Isometric Unwrap did (:class:`RunRecord`): its words, its seconds per phase,
its notes and warnings, as data a script reads back from JSON."""

from __future__ import annotations

import json
from dataclasses import asdict, dataclass, field, fields

from ..solver import Timings

__all__ = ["RunRecord"]


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
