"""The Isometric Unwrap operation: read every mesh in edit mode, solve, then write.

Nothing is written until every selected mesh has been read and solved: a bad mesh
cancels the whole operation with the mesh and its UVs exactly as they were.
"""

from __future__ import annotations

import logging
import threading
import time
from contextlib import contextmanager
from dataclasses import dataclass, field

import bpy
import numpy as np

from ..solver import Cancelled, InvalidMeshError, metrics, parametrize
from ..solver.errors import counted, offenders
from ..solver.placement import FAR, place_in_uv_space
from ..solver.report import solver_names
from . import mesh_io

__all__ = ["STRETCH_ATTRIBUTE", "Background", "Options", "RunRecord", "Unwrap", "last_run", "run", "show_stretch"]

STRETCH_ATTRIBUTE = "isoparam_stretch"  # the face colour attribute Show Stretch writes


@dataclass(frozen=True)
class Options:
    """The operator's options, as its redo panel shows them (built from ``as_keywords()``:
    one field per operator property)."""

    pack: bool = True
    pack_shape: str = "AABB"
    margin: float = 0.001
    correct_aspect: bool = True
    world_scale: bool = False
    refine: int = 1000
    charts: bool = True
    chart_disks: bool = False
    max_stretch: float = 1.18
    mark_seams: bool = False
    extra_cuts: int = 4
    split_overlaps: bool = True
    show_stretch: bool = False


_HINTS = {
    "non_finite": "Some vertices have invalid (NaN or infinite) coordinates",
    "non_finite_pin": "Clear the pins (UV > Unpin) of that face, or give them valid UVs",
    "non_manifold_edge": "Select > Select All by Trait > Non Manifold shows them",
    "non_manifold_vertex": "Select > Select All by Trait > Non Manifold shows them; "
    "Mesh > Split > Faces by Edges, or a seam through them, separates the fans",
    "duplicate_face": "Mesh > Clean Up > Merge by Distance, then Delete Loose, removes them",
    "repeated_vertex": "Mesh > Clean Up > Degenerate Dissolve removes them",
}


def _mesh_names(sel: mesh_io.Selection):
    """Names for the solver's elements as Blender numbers them: a triangle of the selection
    is the mesh face it comes from, a row of its vertices a mesh vertex."""

    def names(element: str, first: tuple[int, ...]) -> str:
        if element == "face" and first[0] < len(sel.tri_poly):
            return f"face {int(sel.tri_poly[first[0]])}"
        if element == "vertex" and first[0] < len(sel.vert_ids):
            return f"vertex {int(sel.vert_ids[first[0]])}"
        if element == "edge":
            a, b = (int(sel.vert_ids[v]) for v in first)
            return f"edge between vertices {a} and {b}"
        return solver_names(element, first)

    return names


def _describe(err: InvalidMeshError, sel: mesh_io.Selection) -> str:
    """The solver's error in mesh terms (its indices are rows of the selection), and a hint
    at what to do, prefixed with the mesh's name."""
    text, hint = _overlap_words(err, sel)
    return f"'{sel.name}': {text}" + (f". {hint}" if hint else "")


def _overlap_words(err: InvalidMeshError, sel: mesh_io.Selection) -> tuple[str, str]:
    """The error's sentence in mesh terms and a hint; for triangles of Blender's
    triangulation that overlap (not faces of the mesh), the two faces they come from."""
    text = err.worded(_mesh_names(sel))
    if err.element == "face" and err.what and err.count and (err.indices < len(sel.tri_poly)).all():
        # triangles -> the mesh faces they come from, counted once each (a quad is two)
        poly = sel.tri_poly[err.indices]
        _, at = np.unique(poly, return_index=True)
        text = str(offenders(err.kind, err.what, "face", poly[np.sort(at)]))
    hint = _HINTS.get(err.kind, "")
    if err.kind == "duplicate_face" and err.count:
        pair = _overlapping_faces(sel, int(err.indices[0]))
        if pair is not None:  # two faces, not a face given twice: Merge by Distance does not help
            a, b = pair
            text = (
                f"{counted(err.count, 'triangle', 'triangles')} of Blender's triangulation "
                f"{'comes' if err.count == 1 else 'come'} twice (first: faces {a} and {b} "
                "share three vertices, so one lies across the other)"
            )
            hint = "Delete or dissolve one of the two faces, or move a vertex off the other's diagonal"
    if err.kind == "non_manifold_edge" and err.edges is not None and len(err.edges):
        overlap = _faces_across(sel, err.edges[0])
        if overlap is not None:  # not an edge of the mesh: Select Non Manifold would show nothing
            a, b, both = overlap
            x, y = (int(sel.vert_ids[v]) for v in err.edges[0])
            if both:
                text = (
                    f"faces {a} and {b} overlap: Blender splits both along their diagonal between vertices {x} and {y}"
                )
            else:
                text = (
                    f"faces {a} and {b} overlap: Blender splits face {a} along its diagonal between "
                    f"vertices {x} and {y}, which is a side of face {b}"
                )
            quads = [f for f in ((a, b) if both else (a,)) if np.count_nonzero(sel.tri_poly == f) == 2]
            hint = "Delete or dissolve one of the two faces"
            if quads:  # a convex quad is split along its other diagonal when this one clashes
                which = f"face {quads[0]}" if len(quads) == 1 else "one of them"
                hint = (
                    f"Make {which} convex (it is then split along its other diagonal), "
                    "or delete or dissolve one of the two faces"
                )
    return text, hint


def _faces_across(sel: mesh_io.Selection, edge) -> tuple[int, int, bool] | None:
    """For a vertex pair ``edge`` of the selection that is a diagonal inside a mesh face
    (a quad or n-gon split there) and a side or a diagonal of another: those two faces,
    and whether it is a diagonal of both."""
    a, b = sorted(int(v) for v in edge)
    if not len(sel.diagonals) or not (np.sort(sel.diagonals, axis=1) == (a, b)).all(axis=1).any():
        return None
    on = (sel.F == a).any(axis=1) & (sel.F == b).any(axis=1)
    polys, count = np.unique(sel.tri_poly[on], return_counts=True)
    inside = polys[count == 2]  # both triangles of a split face hold its diagonal
    others = polys[count == 1]
    if len(inside) >= 2:
        return int(inside[0]), int(inside[1]), True
    if len(inside) and len(others):
        return int(inside[0]), int(others[0]), False
    return None


def _overlapping_faces(sel: mesh_io.Selection, t: int) -> tuple[int, int] | None:
    """The mesh faces of triangle ``t`` and of the earlier triangle with the same vertices,
    when they are different faces that are not the same vertices twice."""
    key = np.sort(sel.F, axis=1)
    earlier = int(np.flatnonzero((key == key[t]).all(axis=1))[0])
    a, b = int(sel.tri_poly[earlier]), int(sel.tri_poly[t])
    if a == b or np.count_nonzero(sel.tri_poly == a) == np.count_nonzero(sel.tri_poly == b) == 1:
        return None  # one face folded onto itself, or a triangle given twice
    return a, b


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


@contextmanager
def _object_mode(context):
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


@dataclass
class RunRecord:
    """What the last :func:`run` did, for scripts (the batch job, the benchmarks): where it
    spent its seconds (reading the meshes, the solver, with its own
    :class:`~isoparam_addon.solver.Timings` per mesh, writing the UVs, seams and stretch
    colours, Blender's pack, and all of it, mode switches included), the notes and
    warnings it reported, as reported, and the solver's own facts (``details``: what the
    four steps met), which go to the ``isoparam`` logger at DEBUG level only."""

    read: float = 0.0
    solve: float = 0.0
    write: float = 0.0
    pack: float = 0.0
    total: float = 0.0
    solver: list = field(default_factory=list)
    notes: list[str] = field(default_factory=list)
    warnings: list[str] = field(default_factory=list)
    details: list[str] = field(default_factory=list)


last_run = RunRecord()

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
    packs and reports (edit mode). Nothing is written unless every mesh was solved, and
    nothing at all once a cancel was asked for."""

    def __init__(self, context, opts: Options, wm=None):
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
        self.pack = self.held = self.far = False
        self.kept: list[_Kept] = []

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
        total = sum(len(i.sel.F) for i in self.inputs)
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
        self.far = any(not (np.abs(s.corner_uv) <= FAR).all() for s in solved)
        # a single island was fitted into the unit square by place_in_uv_space already
        # (Blender's pack would spend 0.17 s on it at 100k vertices)
        self.pack = opts.pack and not self.far and (sum(s.n_islands for s in solved) > 1 or self.held)
        if self.pack:  # what the pack changes besides the UVs, kept while the mesh arrays are at hand
            reselects = not self.sync and _SYNC_RESELECTS
            self.kept = _prepare_pack(solved, self.objects, self.uv_selection_locks, reselects)
        self.record.write = time.perf_counter() - t_write

    def refuse(self, op) -> set:
        """Report why nothing was written."""
        if self.cancelled or self.cancel_requested:
            op.report({"INFO"}, "Isometric Unwrap cancelled: nothing was changed")
        else:
            op.report({"ERROR"}, self.error)
        return {"CANCELLED"}

    def finish(self, op, context) -> set:
        """After :meth:`write`: Blender's pack (edit mode), then the report."""
        if self.far and self.opts.pack:  # Blender's packer makes NaN of such UVs, or crashes
            text = f"not packed: UVs beyond {FAR:.0e} or not finite (far pins, world scale, or a kept corner)"
            self.record.warnings.append(text)
            op.report({"WARNING"}, f"Isometric Unwrap: {text}")
        if self.pack:
            t_pack = time.perf_counter()
            _pack(context, self.solved, self.opts, self.held or any(k.pins_set for k in self.kept), self.kept)
            self.record.pack = time.perf_counter() - t_pack
        self.record.total = time.perf_counter() - self.started
        _report(op, self.solved, self.record)
        return {"FINISHED"}


def run(op, context, opts: Options) -> set:
    """Unwrap the selected faces of every mesh in edit mode, in this thread (scripts, the
    redo panel, background mode). Returns the operator result."""
    global last_run
    wm = context.window_manager
    job = Unwrap(context, opts, wm)
    last_run = job.record
    wm.progress_begin(0.0, 1.0)
    # in edit mode the Mesh arrays are stale: read and write them in object mode
    try:
        with _object_mode(context):
            solved = job.read() and job.solve()
            if solved:
                job.write()
    finally:
        wm.progress_end()
    return job.finish(op, context) if solved else job.refuse(op)


_POLL = 0.1  # seconds between two looks at a solve running in the background
# events a modal unwrap lets through: looking around the scene changes nothing
_NAVIGATION = frozenset(
    {
        "MIDDLEMOUSE",
        "WHEELUPMOUSE",
        "WHEELDOWNMOUSE",
        "MOUSEMOVE",
        "INBETWEEN_MOUSEMOVE",
        "TRACKPADPAN",
        "TRACKPADZOOM",
        "MOUSEROTATE",
        "MOUSESMARTZOOM",
        "NDOF_MOTION",
    }
)


class Background:
    """An :class:`Unwrap` whose solve runs in a worker thread while a modal operator
    watches it (:meth:`on_event`): the progress shows in Blender's progress indicator and
    status bar, Esc cancels, and every other event that could edit the mesh is held back
    until the run ends (looking around the scene still works)."""

    def __init__(self, context, opts: Options):
        global last_run
        self.job = Unwrap(context, opts)
        last_run = self.job.record
        self.thread: threading.Thread | None = None
        self.timer = None
        with _object_mode(context):
            if not self.job.read():
                return
        self.thread = threading.Thread(target=self.job.solve, name="isoparam-unwrap", daemon=True)
        self.thread.start()
        wm = context.window_manager
        if context.window is not None:
            self.timer = wm.event_timer_add(_POLL, window=context.window)
        wm.progress_begin(0.0, 1.0)

    @property
    def running(self) -> bool:
        return self.thread is not None and self.thread.is_alive()

    def on_event(self, op, context, kind: str, value: str = "PRESS") -> set:
        """What the modal operator returns for an event of type ``kind``."""
        if kind == "ESC" and value == "PRESS":
            self.job.cancel_requested = True
        elif kind in _NAVIGATION:
            return {"PASS_THROUGH"}
        if self.running:
            if kind == "TIMER":
                self._show(context)
            return {"RUNNING_MODAL"}
        return self.conclude(op, context)

    def conclude(self, op, context) -> set:
        """Once the solve has ended: write and finish, or report why not."""
        self._close(context)
        job = self.job
        if self.thread is None or job.error or job.cancelled or job.cancel_requested:
            return job.refuse(op)
        with _object_mode(context):
            job.write()
        return job.finish(op, context)

    def _show(self, context) -> None:
        context.window_manager.progress_update(self.job.fraction)
        what = "cancelling" if self.job.cancel_requested else f"{self.job.stage}, {self.job.fraction:.0%}"
        _status(context, f"Isometric Unwrap: {what} (Esc to cancel)")

    def _close(self, context) -> None:
        wm = context.window_manager
        if self.timer is not None:
            wm.event_timer_remove(self.timer)
            self.timer = None
        if self.thread is not None:
            wm.progress_end()
        _status(context, None)


def _status(context, text: str | None) -> None:
    workspace = getattr(context, "workspace", None)
    if workspace is not None:
        workspace.status_text_set(text)


# Switching sync selection rewrites the UV selection from the mesh selection in 5.0
# (measured on 5.0.1; 4.2.23 and 4.5.15 keep it), so the pack's switch is undone there.
_SYNC_RESELECTS = bpy.app.version >= (5, 0, 0)


@dataclass
class _Kept:
    """What :func:`_pack` puts back on one mesh: its UV selection, and its pins where
    corners locked by the UV selection were pinned for the pack."""

    mesh: object
    uv_name: str
    uv_selection: dict
    pins: np.ndarray | None
    pins_set: bool


def _prepare_pack(solved, objects, uv_selection_locks: bool, reselects: bool) -> list[_Kept]:
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
                kept.append(_Kept(me, name, mesh_io.uv_selection(me, name), None, False))
    for s in solved:
        mask = np.zeros(len(s.sel.locked), dtype=bool)
        if uv_selection_locks:
            loops = s.sel.tri_loops.ravel()
            mask[loops] = s.sel.locked[loops] & ~s.sel.pinned[loops]
        if not (mask.any() or reselects):
            continue
        me = s.obj.data
        name = mesh_io.uv_layer_name(me)
        kept.append(_Kept(me, name, mesh_io.uv_selection(me, name), mesh_io.pins(me, name), bool(mask.any())))
        if mask.any():
            mesh_io.set_pins(me, name, s.sel.pinned | mask)
    return kept


def _pack(context, solved, opts: Options, pin: bool, kept: list[_Kept]) -> None:
    """``uv.pack_islands`` over what was unwrapped, pinned islands left where they are;
    then what :func:`_prepare_pack` kept is put back (object mode, only if there is any).

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
                margin=opts.margin,
                rotate=True,
                scale=not opts.world_scale,
                pin=pin,
                pin_method="LOCKED",
                shape_method=opts.pack_shape,
            )
    finally:
        if tool.use_uv_select_sync != sync_was:
            tool.use_uv_select_sync = sync_was
        if kept:
            with _object_mode(context):
                for k in kept:
                    if k.pins_set:
                        mesh_io.set_pins(k.mesh, k.uv_name, k.pins)
                    mesh_io.set_uv_selection(k.mesh, k.uv_selection)


_NOTES = ("charts", "cut_apart")  # solver warnings that are news, not trouble: reported as INFO
# what the solver says of its four-step layout: with refinement, which starts from it, the
# refined layout is what counts (its folds, overlaps or stretch are warned about), so these
# go to the debug log; without, they are the layout's own trouble, said in the artist's words
_FOUR_STEP = ("not_converged", "degenerate_scale", "degenerate_fans", "restarted")
_OVERLAP = ("duplicate_face", "non_manifold_edge")  # what overlapping triangles raise
_NOT_MANIFOLD = (*_OVERLAP, "non_manifold_vertex")  # what the solver splits when not strict
_OVERLAP_WARNINGS = ("duplicate_faces", "non_manifold_edges")  # how the solver says it split them


def _solve(sel: mesh_io.Selection, opts: Options, progress, strict: bool = False):
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
        pack=True,
        split_nonmanifold=not strict,
        refine=opts.refine,
        unfold=True,  # Refinement 0: the paper's layout, but never a fold where a fold-free map exists
        pins=(hold, old) if hold.any() else None,
        inner_edges=sel.diagonals,
        charts=opts.charts,
        chart_disks=opts.chart_disks,
        max_stretch=opts.max_stretch,
        extra_cuts=opts.extra_cuts,
        split_overlaps=opts.split_overlaps,
        progress=progress,
    )
    return res, locked, old


def _solve_as_blender_would(sel: mesh_io.Selection, opts: Options, progress):
    """Solve one selection as Blender's unwrap takes it: where its triangulation repeats a
    triangle or puts three faces on an edge, quads split along their other diagonal when
    that clears it; what is still not a manifold is split (a seam, an island of its own)
    with a warning. Returns the selection solved, the solver's result, locks and old UVs,
    and the words on overlapping faces if they were split."""
    try:
        return sel, *_solve(sel, opts, progress, strict=True), ""
    except InvalidMeshError as err:
        if err.kind not in _NOT_MANIFOLD:
            raise
        overlap = ""
        if err.kind in _OVERLAP:  # (said as a warning if they stay: the faces, and what would clear it)
            text, hint = _overlap_words(err, sel)
            overlap = f"{text}: cut apart where they meet" + (f". {hint}" if hint else "")
        other = mesh_io.other_diagonals(sel) if err.kind in _OVERLAP else None
    if other is not None:
        try:
            return other, *_solve(other, opts, progress, strict=True), ""
        except InvalidMeshError as err:
            if err.kind not in _NOT_MANIFOLD:
                raise
    return sel, *_solve(sel, opts, progress, strict=False), overlap


def _solve_one(inp: _Input, opts: Options, progress) -> tuple[_Solved, object]:
    """Solve one mesh read and place it in UV space (numpy only); its record and the
    solver's timings. Raises :class:`_UnwrapError` with the report's words when it cannot be
    unwrapped, :class:`~isoparam_addon.solver.Cancelled` when ``progress`` says stop."""
    sel = inp.sel
    try:
        sel, res, locked, old, overlap = _solve_as_blender_would(sel, opts, progress)
    except InvalidMeshError as err:
        raise _UnwrapError("Isometric Unwrap: " + _describe(err, sel) + ". Nothing was changed") from None
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
        margin=opts.margin if opts.pack else 0.0,
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
    warnings, notes, details = _sorted_words(res, sel, opts)
    if overlap:  # the same cut in the triangulation's terms, which Select Non Manifold cannot show
        gone = {w.worded(_mesh_names(sel)) for w in res.warnings if w.kind in _OVERLAP_WARNINGS}
        warnings = [overlap] + [w for w in warnings if w not in gone]
    cuts = sel.vert_ids[res.cut_edges] if len(res.cut_edges) else np.zeros((0, 2), dtype=np.int64)
    solved = _Solved(inp.obj, sel, uv, held, res.n_islands, per_face, summary, warnings, notes, details, cuts)
    return solved, res.timings


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


def _sorted_words(res, sel: mesh_io.Selection, opts: Options) -> tuple[list[str], list[str], list[str]]:
    """The solver's warnings as the report says them, mesh faces and vertices named as
    Blender numbers them: warnings (what may need the artist), notes (what the unwrap did:
    charts, cuts) and details (what its four steps met: debug log only, or, without
    refinement, also a warning in the artist's words). As they hold for what the operator
    writes: the solver holds a vertex whose corners are pinned to different UVs at their
    mean, but pins never move here (``place_in_uv_space`` puts every pinned corner back
    on its own UV)."""
    names = _mesh_names(sel)
    warnings, notes, details = [], [], []
    for w in res.warnings:
        if w.kind in _NOTES:
            notes.append(w.worded(names))
        elif w.kind in _FOUR_STEP:
            details.append(w.worded(names))
            if not opts.refine:
                warnings.append(_fast_layout_words(w, names))
        elif w.kind != "pin_conflict":
            warnings.append(w.worded(names))
    if res.stats.pin_conflicts:
        warnings.append(
            f"{counted(res.stats.pin_conflicts, 'pinned vertex has', 'pinned vertices have')} corners pinned "
            "to different UVs: each corner "
            "stays on its pin, so the faces around them stretch between the pins "
            "(unpin all but one UV of each to avoid it)"
        )
    return warnings, notes, details


def _fast_layout_words(w, names) -> str:
    """What the four steps met (a warning of a ``_FOUR_STEP`` kind), said to an artist who
    unwrapped with Refinement 0, and what to do about it."""
    n = w.count
    first = f" (first: {names(w.element, w.first)})" if w.first else ""
    was = "was" if n == 1 else "were"
    if w.kind == "degenerate_fans":
        what = f"around {counted(n, 'vertex', 'vertices')} the faces are too thin to lay out exactly"
    elif w.kind == "restarted":
        what = (
            f"{counted(n, 'island', 'islands')} would fold in the fast layout and {was} laid out with "
            f"angles kept instead, areas uneven{first}"
        )
    elif w.kind == "degenerate_scale":
        what = f"{counted(n, 'island', 'islands')} could not be sized to the model and may be too large or small"
    else:  # not_converged
        what = f"{counted(n, 'island', 'islands')} {was} laid out before the fast solve settled{first}"
    return f"{what}: a Refinement above 0 corrects it"


def _report(op, solved, record: RunRecord) -> None:
    islands = sum(s.n_islands for s in solved)
    worst, mean, _ = metrics.combine_stretch([s.stretch for s in solved])
    where = f" on {len(solved)} meshes" if len(solved) > 1 else ""
    op.report(
        {"INFO"},
        f"Isometric Unwrap: {counted(islands, 'island', 'islands')}{where}, stretch worst {worst:#.3g} "
        f"mean {mean:#.4g}, {record.total:.2f} s",
    )
    for s in solved:  # notes and warnings per mesh
        for note in s.notes:
            record.notes.append(f"'{s.sel.name}': {note}")
            op.report({"INFO"}, f"Isometric Unwrap, '{s.sel.name}': {note}")
        for w in s.warnings:
            record.warnings.append(f"'{s.sel.name}': {w}")
            op.report({"WARNING"}, f"Isometric Unwrap, '{s.sel.name}': {w}")
        for detail in s.details:
            record.details.append(f"'{s.sel.name}': {detail}")
            _log.debug("'%s': %s", s.sel.name, detail)


def show_stretch(op, context) -> set:
    """Colour every face of the meshes in edit mode by the distortion of the active UV map."""
    objects = [ob for ob in context.objects_in_mode_unique_data if ob.type == "MESH"]
    parts = []
    with _object_mode(context):
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
