"""The Isometric Unwrap operation in Blender: read every mesh in edit mode, solve, then write.

Nothing is written until every selected mesh has been read and solved: a bad mesh
cancels the whole operation with the mesh and its UVs exactly as they were. A run
returns its :class:`~isoparam_addon.operation.record.RunRecord`, with the words for the
operator to report. What happens between reading and writing (the solves and their
retries, Fill Shapes, the pack choice, the words) is :mod:`isoparam_addon.operation`'s,
without Blender; Blender's pack round trip is :mod:`.pack`'s, the run in a worker thread
:mod:`.background`'s.
"""

from __future__ import annotations

import time

import numpy as np

from ..operation.messages import NOT_PACKED_FAR
from ..operation.options import OperatorOptions
from ..operation.record import RunRecord
from ..operation.selection import Selection
from ..operation.unwrap import Input, Solved, blender_packs, far_uvs, report, solve_all
from ..solver import metrics
from . import mesh_io
from .modes import object_mode
from .pack import SYNC_RESELECTS, Kept, pack, prepare_pack

__all__ = [
    "STRETCH_ATTRIBUTE",
    "Unwrap",
    "run",
    "show_stretch",
]


STRETCH_ATTRIBUTE = "isoparam_stretch"  # the face colour attribute Show Stretch writes


def _aspect(obj, sel: Selection) -> float | None:
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
        self.inputs: list[Input] = []
        self.solved: list[Solved] = []
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
                self.inputs.append(Input(ob, sel, _aspect(ob, sel) if self.opts.correct_aspect else None))
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
        outcome = solve_all(self.inputs, self.opts, self.progressed, self.record)
        self.solved, self.packed = outcome.solved, outcome.packed
        self.error, self.cancelled = outcome.error, outcome.cancelled
        return outcome.ok

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
        self.far = far_uvs(solved)
        self.pack = blender_packs(solved, opts, self.packed)
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
            self.record.warnings.append(NOT_PACKED_FAR)
            self.record.report("WARNING", f"Isometric Unwrap: {NOT_PACKED_FAR}")
        written = [s.corner_uv for s in self.solved]
        if self.pack:
            t_pack = time.perf_counter()
            written = pack(context, self.solved, self.opts, self.held or any(k.pins_set for k in self.kept), self.kept)
            self.record.pack = time.perf_counter() - t_pack
        self.record.coverage = metrics.coverage(*written)
        self.record.total = time.perf_counter() - self.started
        self.record.finished = True
        report(self.solved, self.record)
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


def _write(s: Solved) -> None:
    """Write one mesh's corner UVs (object mode); every corner of a face gets its triangle's UV."""
    me = s.obj.data
    name = mesh_io.uv_layer_name(me)
    uv = s.sel.uv.copy() if s.sel.uv_name == name else np.zeros((len(me.loops), 2), np.float32)
    for c in range(2):  # column by column: 1-D scatters are 3x faster than row scatters
        uv[:, c][s.sel.tri_loops] = s.corner_uv[..., c]
    mesh_io.write_uvs(me, name, uv)


def _write_stretch(me, sel: Selection, distortion: np.ndarray) -> None:
    """Colour the faces of ``sel`` by the distortion of their triangles, (t,) (object mode);
    a face shows its worst triangle."""
    faces, inverse = np.unique(sel.tri_poly, return_inverse=True)
    worst = np.zeros(len(faces))
    np.maximum.at(worst, inverse, distortion)
    mesh_io.write_face_colours(me, STRETCH_ATTRIBUTE, metrics.stretch_colours(worst), faces)


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
