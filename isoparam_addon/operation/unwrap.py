"""The Isometric Unwrap operation between reading and writing, without Blender: each mesh
read (:class:`Input`) solved as Blender's own unwrap takes it, with its retries, and placed
in UV space (:func:`solve_one`); every mesh of a run solved in turn, cancellable, and
packed together by Fill Shapes (:func:`solve_all`); whether Blender's packer packs after
the write (:func:`blender_packs`); and the words of the run (:func:`report`).

:mod:`isoparam_addon.blender.unwrap` reads the meshes, calls these, then writes.
"""

from __future__ import annotations

import logging
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ..solver import Cancelled, InvalidMeshError, Timings, metrics, parametrize
from ..solver.errors import counted
from ..solver.layout.packing import pack_layout
from ..solver.layout.uv_space import FAR_UV, place_in_uv_space
from ..solver.progress import tracking
from .messages import (
    NOT_MANIFOLD_ERRORS,
    OVERLAP_ERRORS,
    OVERLAP_WARNINGS,
    describe,
    mesh_names,
    overlap_words,
    sorted_words,
)
from .options import FILL_SHAPES, OperatorOptions
from .record import RunRecord
from .selection import Selection, other_diagonals

__all__ = [
    "Input",
    "Solved",
    "Solving",
    "UnwrapError",
    "blender_packs",
    "far_uvs",
    "report",
    "solve_all",
    "solve_one",
]

_log = logging.getLogger("isoparam")

SOLVING = 0.95  # of the progress bar, when Fill Shapes packs after the solves

Progress = Callable[[float, str], bool]  # (fraction, stage) -> go on


@dataclass
class Input:
    """One mesh to unwrap as read: all the solve needs."""

    obj: Any  # where it came from (a Blender object; opaque here)
    sel: Selection
    aspect: float | None  # width / height of the image to correct for


@dataclass
class Solved:
    """One mesh solved and placed in UV space, with what the report says about it."""

    obj: Any  # (as its Input's)
    sel: Selection
    corner_uv: np.ndarray  # (t, 3, 2) per triangle corner
    held: np.ndarray  # (t, 3) bool: corners kept where they were (pins, locked)
    n_islands: int
    island: np.ndarray  # (t,) per unwrapped triangle
    aspect: float | None
    distortion: np.ndarray  # (t,) per unwrapped triangle
    stretch: metrics.StretchSummary
    warnings: list[str]
    notes: list[str]  # what the unwrap did that the artist may want to know (charts, cuts)
    details: list[str]  # what the solver met on the way (its four steps), for the debug log
    cuts: np.ndarray  # (k, 2) mesh vertex pairs of the edges it cut


@dataclass
class Solving:
    """How :func:`solve_all` ended: every mesh solved (and packed together, ``packed``), or
    the words why nothing is written (``error``), or cancelled."""

    solved: list[Solved] = field(default_factory=list)
    packed: bool = False
    error: str = ""
    cancelled: bool = False

    @property
    def ok(self) -> bool:
        return not (self.error or self.cancelled)


class UnwrapError(Exception):
    """A mesh that cannot be unwrapped: the report's words (nothing is written)."""


def solve_all(inputs: list[Input], opts: OperatorOptions, progressed: Progress, record: RunRecord) -> Solving:
    """Solve every mesh of ``inputs`` in turn, then, with Fill Shapes, pack them together;
    ``progressed(fraction, stage)`` sees the whole run's progress and returns False to
    cancel. The seconds go to ``record``. A mesh that cannot be solved, or any solver
    failure, ends the run with the words why (no mesh is half written)."""
    out = Solving()
    total = sum(len(i.sel.F) for i in inputs) / SOLVING
    done = 0
    for inp in inputs:
        lo, share = done / total, len(inp.sel.F) / total
        name = f"'{inp.sel.name}': " if len(inputs) > 1 else ""

        def progress(f: float, stage: str, lo=lo, share=share, name=name) -> bool:
            return progressed(lo + share * f, name + stage)

        t = time.perf_counter()
        try:
            solved, timings = solve_one(inp, opts, progress)
        except Cancelled:
            out.cancelled = True
            return out
        except UnwrapError as refused:
            out.error = str(refused)
            return out
        except Exception as err:  # noqa: BLE001 - a solver failure must not leave a half-written mesh
            why = f"{type(err).__name__}: {err}"
            out.error = f"Isometric Unwrap failed on '{inp.sel.name}' ({why}). Nothing was changed"
            return out
        record.solve += time.perf_counter() - t
        record.solver.append(timings)
        out.solved.append(solved)
        done += len(inp.sel.F)
    if fills_shapes(out.solved, opts):
        t = time.perf_counter()
        try:
            with tracking(lambda f, stage: progressed(SOLVING + (1.0 - SOLVING) * f, stage)):
                pack_together(out.solved, opts)
        except Cancelled:
            out.cancelled = True
            return out
        record.pack = time.perf_counter() - t
        out.packed = True
    return out


def _solve(sel: Selection, opts: OperatorOptions, progress: Progress, strict: bool = False):
    """The solver's result for one selection, and its triangle corners' locks (t, 3) and old
    UVs (t, 3, 2); ``progress`` as :func:`.parametrize` takes it; ``strict``: refuse what is
    not a manifold instead of splitting it."""
    locked = sel.locked[sel.tri_loops]
    old = np.take(sel.uv, sel.tri_loops, axis=0).astype(np.float64)
    # a corner locked by the UV selection whose UV is not finite holds nothing in place: it
    # keeps its value (place_in_uv_space) and its vertex is laid out as free, as by uv.unwrap;
    # a real pin there is an error (the solver names it)
    hold = locked & (np.isfinite(old).all(axis=2) | sel.pinned[sel.tri_loops])
    res = parametrize(
        sel.V,
        sel.F,
        sel.seams,
        pins=(hold, old) if hold.any() else None,
        inner_edges=sel.diagonals,
        options=opts.solver_options(),
        split_nonmanifold=not strict,
        progress=progress,
    )
    return res, locked, old


def _solve_as_blender_would(sel: Selection, opts: OperatorOptions, progress: Progress):
    """Solve one selection as Blender's unwrap takes it: where its triangulation repeats a
    triangle or puts three faces on an edge, quads split along their other diagonal when
    that clears it; what is still not a manifold is split (a seam, an island of its own)
    with a warning. Returns the selection solved, the solver's result, locks and old UVs,
    and the words on overlapping faces if they were split."""
    try:
        return sel, *_solve(sel, opts, progress, strict=True), ""
    except InvalidMeshError as err:
        if err.kind not in NOT_MANIFOLD_ERRORS:
            raise
        overlap = ""
        if err.kind in OVERLAP_ERRORS:  # (said as a warning if they stay: the faces, and what would clear it)
            text, hint = overlap_words(err, sel)
            overlap = f"{text}: cut apart where they meet" + (f". {hint}" if hint else "")
        other = other_diagonals(sel) if err.kind in OVERLAP_ERRORS else None
    if other is not None:
        try:
            return other, *_solve(other, opts, progress, strict=True), ""
        except InvalidMeshError as err:
            if err.kind not in NOT_MANIFOLD_ERRORS:
                raise
    return sel, *_solve(sel, opts, progress, strict=False), overlap


def solve_one(inp: Input, opts: OperatorOptions, progress: Progress) -> tuple[Solved, Timings]:
    """Solve one mesh read and place it in UV space; its record and the solver's timings.
    Raises :class:`UnwrapError` with the report's words when it cannot be unwrapped,
    :class:`~isoparam_addon.solver.Cancelled` when ``progress`` says stop."""
    sel = inp.sel
    try:
        sel, res, locked, old, overlap = _solve_as_blender_would(sel, opts, progress)
    except InvalidMeshError as err:
        raise UnwrapError("Isometric Unwrap: " + describe(err, sel) + ". Nothing was changed") from None
    if not np.isfinite(res.corner_uv).all():
        raise UnwrapError(f"Isometric Unwrap gave non-finite UVs on '{sel.name}'. Nothing was changed")
    uv, held = place_in_uv_space(
        res.corner_uv,
        res.face_island,
        res.n_islands,
        locked=locked,
        old=old,
        in_place=not opts.pack,
        world_scale=opts.world_scale,
        aspect=inp.aspect,
        margin=opts.pack_margin if opts.pack else 0.0,
        margin_share=opts.in_pixels,
        corner_vertex=sel.F,
    )
    with np.errstate(over="ignore"):
        stored = uv[~locked].astype(np.float32)  # what the UV map would hold (locked: as it was)
    if not np.isfinite(stored).all():
        raise UnwrapError(
            f"Isometric Unwrap: the UVs of '{sel.name}' would be beyond the range of Blender's UV map "
            "(True World Scale on a mesh this large?). Nothing was changed"
        )
    per_face, summary = metrics.face_stretch(sel.V, sel.F, uv)
    warnings, notes, details = sorted_words(res, sel, opts.refine > 0)
    if overlap:  # the same cut in the triangulation's terms, which Select Non Manifold cannot show
        gone = {w.worded(mesh_names(sel)) for w in res.warnings if w.kind in OVERLAP_WARNINGS}
        warnings = [overlap] + [w for w in warnings if w not in gone]
    cuts = sel.vert_ids[res.cut_edges] if len(res.cut_edges) else np.zeros((0, 2), dtype=np.int64)
    solved = Solved(
        inp.obj,
        sel,
        uv,
        held,
        res.n_islands,
        res.face_island,
        inp.aspect,
        per_face,
        summary,
        warnings,
        notes,
        details,
        cuts,
    )
    return solved, res.timings


def far_uvs(solved: list[Solved]) -> bool:
    """Whether a mesh has UVs beyond ``FAR_UV`` or not finite (far pins, world scale, a
    kept corner), which Blender's packer makes NaN of."""
    return any(not (np.abs(s.corner_uv) <= FAR_UV).all() for s in solved)


def fills_shapes(solved: list[Solved], opts: OperatorOptions) -> bool:
    """Whether isoparam's own packer packs (Fill Shapes), rather than Blender's: not with
    pinned or locked islands (Blender's packer leaves them where they are), at True World
    Scale, with UVs out of range, or for meshes whose images differ in aspect."""
    if not (opts.pack and opts.pack_shape == FILL_SHAPES and not opts.world_scale):
        return False
    if any(s.held.any() for s in solved) or far_uvs(solved):
        return False
    return len({s.aspect or 1.0 for s in solved}) == 1


def blender_packs(solved: list[Solved], opts: OperatorOptions, packed: bool) -> bool:
    """Whether Blender's packer packs after the write: when asked to, not ``packed`` by Fill
    Shapes already, no UV far out, and more than one island or some held (a single island
    was fitted into the unit square by ``place_in_uv_space`` already; Blender's pack would
    spend 0.17 s on it at 100k vertices)."""
    several = sum(s.n_islands for s in solved) > 1 or any(s.held.any() for s in solved)
    return opts.pack and not packed and not far_uvs(solved) and several


def pack_together(solved: list[Solved], opts: OperatorOptions) -> None:
    """Pack the islands of every mesh solved together (:func:`.packing.pack_layout`), in
    the shape of the image (``aspect``), and put the packed UVs in their place."""
    offsets = np.cumsum([0] + [s.n_islands for s in solved])
    packed = pack_layout(
        np.concatenate([s.corner_uv for s in solved]),
        np.concatenate([s.island + o for s, o in zip(solved, offsets)]),
        int(offsets[-1]),
        margin=opts.pack_margin,
        aspect=solved[0].aspect or 1.0,
    )
    start = np.cumsum([0] + [len(s.corner_uv) for s in solved])
    for s, a, b in zip(solved, start, start[1:]):
        s.corner_uv = packed.uv[a:b]
    if packed.gap_kept < 1.0 - 1e-6:  # (said once, with the first mesh's words)
        gap = 2.0 * opts.pack_margin
        solved[0].warnings.append(
            f"the pack margin {opts.pack_margin:g} is too wide for {int(offsets[-1])} islands: they end "
            f"{gap * packed.gap_kept:.3g} apart, not {gap:g} (a smaller margin keeps it)"
        )


def report(solved: list[Solved], record: RunRecord) -> None:
    """The words of a run that wrote: a summary, then every mesh's notes and warnings
    (its solver's details go to the debug log)."""
    islands = sum(s.n_islands for s in solved)
    worst, mean, _ = metrics.combine_stretch([s.stretch for s in solved])
    where = f" on {len(solved)} meshes" if len(solved) > 1 else ""
    record.report(
        "INFO",
        f"Isometric Unwrap: {counted(islands, 'island', 'islands')}{where}, stretch worst {worst:#.3g} "
        f"mean {mean:#.4g}, coverage {record.coverage:.0%}, {record.total:.2f} s",
    )
    for s in solved:  # notes and warnings per mesh
        for note in s.notes:
            record.notes.append(f"'{s.sel.name}': {note}")
            record.report("INFO", f"Isometric Unwrap, '{s.sel.name}': {note}")
        for w in s.warnings:
            record.warnings.append(f"'{s.sel.name}': {w}")
            record.report("WARNING", f"Isometric Unwrap, '{s.sel.name}': {w}")
        for detail in s.details:
            record.details.append(f"'{s.sel.name}': {detail}")
            _log.debug("'%s': %s", s.sel.name, detail)
