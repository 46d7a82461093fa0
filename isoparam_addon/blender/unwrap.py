"""The Isometric Unwrap operation: read every mesh in edit mode, solve, then write.

Nothing is written until every selected mesh has been read and solved: a bad mesh
cancels the whole operation with the mesh and its UVs exactly as they were. A run
returns its :class:`~.record.RunRecord`, with the words for the operator to report. The
words are :mod:`.messages`', the pack round trip :mod:`.pack`'s, the run in a worker
thread :mod:`.background`'s.
"""

from __future__ import annotations

import logging
import time
from dataclasses import dataclass

import bpy
import numpy as np

from ..operator_options import FILL_SHAPES, OperatorOptions
from ..solver import Cancelled, InvalidMeshError, Timings, metrics, parametrize
from ..solver.errors import counted
from ..solver.layout.packing import pack_layout
from ..solver.layout.uv_space import FAR_UV, place_in_uv_space
from ..solver.progress import tracking
from . import mesh_io
from .messages import (
    NOT_MANIFOLD_ERRORS,
    OVERLAP_ERRORS,
    OVERLAP_WARNINGS,
    describe,
    mesh_names,
    overlap_words,
    sorted_words,
)
from .modes import object_mode
from .pack import SYNC_RESELECTS, Kept, pack, prepare_pack
from .record import RunRecord

__all__ = [
    "STRETCH_ATTRIBUTE",
    "Unwrap",
    "run",
    "show_stretch",
]


STRETCH_ATTRIBUTE = "isoparam_stretch"  # the face colour attribute Show Stretch writes


def _aspect(obj, sel: mesh_io.Selection) -> float | None:
    """Width / height of the image Blender's own unwrap corrects for: the active image
    texture of the material of the active face (selected or not), or else of the first
    unwrapped face. One value per object, so an island spanning several materials does
    not tear (as with ``uv.unwrap``; measured on bpy 4.2.23 and 5.0.1)."""
    polygons = obj.data.polygons
    face = polygons.active
    slot = polygons[face].material_index if 0 <= face < len(polygons) else int(sel.face_material[0])
    if not 0 <= slot < len(obj.material_slots):
        return None
    mat = obj.material_slots[slot].material
    if mat is None or mat.node_tree is None:  # (use_nodes is deprecated in 5.0)
        return None
    nodes = mat.node_tree.nodes
    node = nodes.active if nodes.active is not None and nodes.active.type == "TEX_IMAGE" else None
    node = node or next((nd for nd in nodes if nd.type == "TEX_IMAGE" and nd.image is not None), None)
    if node is None or node.image is None or node.image.size[1] == 0:
        return None
    return node.image.size[0] / node.image.size[1]


_log = logging.getLogger("isoparam")


@dataclass
class _Input:
    """One mesh to unwrap as read (object mode): all the solve needs, no Blender call."""

    obj: bpy.types.Object
    sel: mesh_io.Selection
    aspect: float | None  # width / height of the image to correct for


@dataclass
class _Solved:
    obj: bpy.types.Object
    sel: mesh_io.Selection
    corner_uv: np.ndarray
    held: np.ndarray
    n_islands: int
    island: np.ndarray  # (t,) per unwrapped triangle
    aspect: float | None
    distortion: np.ndarray  # (t,) per unwrapped triangle
    stretch: metrics.StretchSummary
    warnings: list
    notes: list  # what the unwrap did that the artist may want to know (charts, cuts)
    details: list  # what the solver met on the way (its four steps), for the debug log
    cuts: np.ndarray  # (k, 2) mesh vertex pairs of the edges it cut


class _UnwrapError(Exception):
    """A mesh that cannot be unwrapped: the report's words (nothing is written)."""


class Unwrap:
    """One run of Isometric Unwrap, in phases: :meth:`read` and :meth:`write` touch
    Blender (main thread, object mode); :meth:`solve` touches only numpy, so it may run in
    a worker thread while Blender stays responsive (:class:`Background`); :meth:`finish`
    packs and says what was done (edit mode), or :meth:`refuse` why not. Nothing is
    written unless every mesh was solved, and nothing at all once a cancel was asked for."""

    def __init__(self, context, opts: OperatorOptions, wm=None):
        self.opts = opts
        space = getattr(context, "space_data", None)
        self.sync = context.scene.tool_settings.use_uv_select_sync
        self.uv_selection_locks = space is not None and space.type == "IMAGE_EDITOR" and not self.sync
        self.objects = [ob for ob in context.objects_in_mode_unique_data if ob.type == "MESH"]
        self.record = RunRecord()
        self.inputs: list[_Input] = []
        self.solved: list[_Solved] = []
        self.error = ""  # why nothing is written
        self.cancel_requested = self.cancelled = False
        self.fraction, self.stage = 0.0, "reading"
        self.wm = wm  # shows the progress as it goes (when solving in the main thread)
        self.started = time.perf_counter()
        self.pack = self.held = self.far = self.packed = False
        self.kept: list[Kept] = []

    def read(self) -> bool:
        """Read the selection of every mesh (object mode); False if none has a face selected."""
        for ob in self.objects:  # one read per mesh in edit mode
            t = time.perf_counter()
            sel = mesh_io.read_selection(
                ob, world_space=self.opts.world_scale, uv_selection_locks=self.uv_selection_locks
            )
            self.record.read += time.perf_counter() - t
            if not sel.empty:
                self.inputs.append(_Input(ob, sel, _aspect(ob, sel) if self.opts.correct_aspect else None))
        if not self.inputs:
            self.error = "Isometric Unwrap: no faces selected. Select the faces to unwrap in edit mode"
        return not self.error

    def progressed(self, fraction: float, stage: str) -> bool:
        """The solver's progress over the whole run (any thread); False once a cancel was asked."""
        self.fraction, self.stage = max(self.fraction, fraction), stage
        if self.wm is not None:
            self.wm.progress_update(self.fraction)
        return not self.cancel_requested

    def solve(self) -> bool:
        """Solve every mesh read (numpy only: any thread); False, with :attr:`error` or
        :attr:`cancelled` set, if one cannot be solved or a cancel was asked for."""
        total = sum(len(i.sel.F) for i in self.inputs) / _SOLVING
        done = 0
        for inp in self.inputs:
            lo, share = done / total, len(inp.sel.F) / total
            name = f"'{inp.sel.name}': " if len(self.inputs) > 1 else ""

            def progress(f: float, stage: str, lo=lo, share=share, name=name) -> bool:
                return self.progressed(lo + share * f, name + stage)

            t = time.perf_counter()
            try:
                solved, timings = _solve_one(inp, self.opts, progress)
            except Cancelled:
                self.cancelled = True
                return False
            except _UnwrapError as refused:
                self.error = str(refused)
                return False
            except Exception as err:  # noqa: BLE001 - a solver failure must not leave a half-written mesh
                why = f"{type(err).__name__}: {err}"
                self.error = f"Isometric Unwrap failed on '{inp.sel.name}' ({why}). Nothing was changed"
                return False
            self.record.solve += time.perf_counter() - t
            self.record.solver.append(timings)
            self.solved.append(solved)
            done += len(inp.sel.F)
        if _fills_shapes(self.solved, self.opts):
            t = time.perf_counter()
            try:
                with tracking(lambda f, stage: self.progressed(_SOLVING + (1.0 - _SOLVING) * f, stage)):
                    _pack_together(self.solved, self.opts)
            except Cancelled:
                self.cancelled = True
                return False
            self.record.pack = time.perf_counter() - t
            self.packed = True
        return True

    def write(self) -> None:
        """Write the UVs (and seams, stretch colours) of every mesh solved (object mode), and
        keep what the pack would change besides them."""
        t_write = time.perf_counter()
        opts, solved = self.opts, self.solved
        for s in solved:  # one write per mesh
            _write(s)
            if opts.mark_seams:
                mesh_io.mark_seams(s.obj.data, s.cuts)
            if opts.show_stretch:
                _write_stretch(s.obj.data, s.sel, s.distortion)
        self.held = any(s.held.any() for s in solved)
        # (a corner locked by the UV selection may keep a UV that is not finite)
        self.far = any(not (np.abs(s.corner_uv) <= FAR_UV).all() for s in solved)
        # a single island was fitted into the unit square by place_in_uv_space already
        # (Blender's pack would spend 0.17 s on it at 100k vertices)
        several = sum(s.n_islands for s in solved) > 1 or self.held
        self.pack = opts.pack and not self.packed and not self.far and several
        if self.pack:  # what the pack changes besides the UVs, kept while the mesh arrays are at hand
            reselects = not self.sync and SYNC_RESELECTS
            self.kept = prepare_pack(solved, self.objects, self.uv_selection_locks, reselects)
        self.record.write = time.perf_counter() - t_write

    def refuse(self) -> RunRecord:
        """The record of a run that wrote nothing, with the words why."""
        if self.cancelled or self.cancel_requested:
            self.record.report("INFO", "Isometric Unwrap cancelled: nothing was changed")
        else:
            self.record.report("ERROR", self.error)
        return self.record

    def finish(self, context) -> RunRecord:
        """After :meth:`write`: Blender's pack (edit mode); the record, with its words."""
        if self.far and self.opts.pack:  # Blender's packer makes NaN of such UVs, or crashes
            text = f"not packed: UVs beyond {FAR_UV:.0e} or not finite (far pins, world scale, or a kept corner)"
            self.record.warnings.append(text)
            self.record.report("WARNING", f"Isometric Unwrap: {text}")
        written = [s.corner_uv for s in self.solved]
        if self.pack:
            t_pack = time.perf_counter()
            written = pack(context, self.solved, self.opts, self.held or any(k.pins_set for k in self.kept), self.kept)
            self.record.pack = time.perf_counter() - t_pack
        self.record.coverage = metrics.coverage(*written)
        self.record.total = time.perf_counter() - self.started
        self.record.finished = True
        _report(self.solved, self.record)
        return self.record


def run(context, opts: OperatorOptions) -> RunRecord:
    """Unwrap the selected faces of every mesh in edit mode, in this thread (the operator's
    :meth:`execute`: scripts, the redo panel, background mode). Returns the run's record:
    whether anything was written, and the words to report (the caller reports them)."""
    wm = context.window_manager
    job = Unwrap(context, opts, wm)
    wm.progress_begin(0.0, 1.0)
    # in edit mode the Mesh arrays are stale: read and write them in object mode
    try:
        with object_mode(context):
            solved = job.read() and job.solve()
            if solved:
                job.write()
    finally:
        wm.progress_end()
    return job.finish(context) if solved else job.refuse()


def _solve(sel: mesh_io.Selection, opts: OperatorOptions, progress, strict: bool = False):
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


def _solve_as_blender_would(sel: mesh_io.Selection, opts: OperatorOptions, progress):
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
        other = mesh_io.other_diagonals(sel) if err.kind in OVERLAP_ERRORS else None
    if other is not None:
        try:
            return other, *_solve(other, opts, progress, strict=True), ""
        except InvalidMeshError as err:
            if err.kind not in NOT_MANIFOLD_ERRORS:
                raise
    return sel, *_solve(sel, opts, progress, strict=False), overlap


def _solve_one(inp: _Input, opts: OperatorOptions, progress) -> tuple[_Solved, Timings]:
    """Solve one mesh read and place it in UV space (numpy only); its record and the
    solver's timings. Raises :class:`_UnwrapError` with the report's words when it cannot be
    unwrapped, :class:`~isoparam_addon.solver.Cancelled` when ``progress`` says stop."""
    sel = inp.sel
    try:
        sel, res, locked, old, overlap = _solve_as_blender_would(sel, opts, progress)
    except InvalidMeshError as err:
        raise _UnwrapError("Isometric Unwrap: " + describe(err, sel) + ". Nothing was changed") from None
    if not np.isfinite(res.corner_uv).all():
        raise _UnwrapError(f"Isometric Unwrap gave non-finite UVs on '{sel.name}'. Nothing was changed")
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
        raise _UnwrapError(
            f"Isometric Unwrap: the UVs of '{sel.name}' would be beyond the range of Blender's UV map "
            "(True World Scale on a mesh this large?). Nothing was changed"
        )
    per_face, summary = metrics.face_stretch(sel.V, sel.F, uv)
    warnings, notes, details = sorted_words(res, sel, opts.refine > 0)
    if overlap:  # the same cut in the triangulation's terms, which Select Non Manifold cannot show
        gone = {w.worded(mesh_names(sel)) for w in res.warnings if w.kind in OVERLAP_WARNINGS}
        warnings = [overlap] + [w for w in warnings if w not in gone]
    cuts = sel.vert_ids[res.cut_edges] if len(res.cut_edges) else np.zeros((0, 2), dtype=np.int64)
    solved = _Solved(
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


_SOLVING = 0.95  # of the progress bar, when Fill Shapes packs after the solves


def _fills_shapes(solved: list[_Solved], opts: OperatorOptions) -> bool:
    """Whether isoparam's own packer packs (Fill Shapes), rather than Blender's: not with
    pinned or locked islands (Blender's packer leaves them where they are), at True World
    Scale, with UVs out of range, or for meshes whose images differ in aspect."""
    if not (opts.pack and opts.pack_shape == FILL_SHAPES and not opts.world_scale):
        return False
    if any(s.held.any() or not (np.abs(s.corner_uv) <= FAR_UV).all() for s in solved):
        return False
    return len({s.aspect or 1.0 for s in solved}) == 1


def _pack_together(solved: list[_Solved], opts: OperatorOptions) -> None:
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


def _write(s: _Solved) -> None:
    """Write one mesh's corner UVs (object mode); every corner of a face gets its triangle's UV."""
    me = s.obj.data
    name = mesh_io.uv_layer_name(me)
    uv = s.sel.uv.copy() if s.sel.uv_name == name else np.zeros((len(me.loops), 2), np.float32)
    for c in range(2):  # column by column: 1-D scatters are 3x faster than row scatters
        uv[:, c][s.sel.tri_loops] = s.corner_uv[..., c]
    mesh_io.write_uvs(me, name, uv)


def _write_stretch(me, sel: mesh_io.Selection, distortion: np.ndarray) -> None:
    """Colour the faces of ``sel`` by the distortion of their triangles, (t,) (object mode);
    a face shows its worst triangle."""
    faces, inverse = np.unique(sel.tri_poly, return_inverse=True)
    worst = np.zeros(len(faces))
    np.maximum.at(worst, inverse, distortion)
    mesh_io.write_face_colours(me, STRETCH_ATTRIBUTE, metrics.stretch_colours(worst), faces)


def _report(solved, record: RunRecord) -> None:
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


def show_stretch(op, context) -> set:
    """Colour every face of the meshes in edit mode by the distortion of the active UV map."""
    objects = [ob for ob in context.objects_in_mode_unique_data if ob.type == "MESH"]
    parts = []
    with object_mode(context):
        for ob in objects:  # one mesh at a time
            me = ob.data
            if me.uv_layers.active is None or not len(me.polygons):
                continue
            sel = mesh_io.read_selection(ob, world_space=False, uv_selection_locks=False, every_face=True)
            cuv = sel.uv[sel.tri_loops].astype(np.float64)
            d, part = metrics.face_stretch(sel.V, sel.F, cuv)
            _write_stretch(me, sel, d)
            parts.append(part)
    if not parts:
        op.report({"ERROR"}, "Show Stretch: no mesh in edit mode has a UV map")
        return {"CANCELLED"}
    worst, mean, _ = metrics.combine_stretch(parts)
    op.report(
        {"INFO"},
        f"Show Stretch: worst {worst:.2f}, mean {mean:.3f} "
        f"(colour attribute '{STRETCH_ATTRIBUTE}': white 1, red 2 or more)",
    )
    return {"FINISHED"}
