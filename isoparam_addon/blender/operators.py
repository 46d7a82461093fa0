"""Operators: thin wrappers that read their options, call :mod:`.unwrap` and report.

The redo panel's properties (:class:`UnwrapProperties`) take their defaults from the preset
(:data:`~isoparam_addon.operation.options.DEFAULTS`), so the redo panel,
:class:`~isoparam_addon.operation.options.OperatorOptions` and the scripts agree.
"""

from __future__ import annotations

import bpy
from bpy.props import BoolProperty, EnumProperty, FloatProperty, IntProperty

from ..operation.options import DEFAULTS, FILL_SHAPES, OperatorOptions
from . import background, record, unwrap

__all__ = ["UV_OT_isometric_show_stretch", "UV_OT_isometric_unwrap", "UnwrapProperties"]


class UnwrapProperties:
    """The redo panel of Isometric Unwrap: one property per field of
    :class:`~isoparam_addon.operation.options.OperatorOptions`, its default the preset's
    (Blender registers the annotations of an operator's bases as its properties)."""

    pack: BoolProperty(
        name="Pack Islands",
        description="Pack the islands into the UV square afterwards; off keeps every island "
        "where its old UVs were (unwrap in place; new charts of one old island share its place)",
        default=DEFAULTS.pack,
    )
    pack_shape: EnumProperty(
        name="Pack Shape",
        description="Island shape the packer fits together",
        items=(
            (
                FILL_SHAPES,
                "Fill Shapes",
                "Isometric Unwrap's own packer: islands turned and fitted together by their shapes, small ones "
                "into the holes left (Blender's Bounding Box where islands are pinned or at True World Scale)",
            ),
            ("AABB", "Bounding Box", "Fast, as Unwrap packs"),
            ("CONVEX", "Convex Hull", "Tighter than boxes; on many islands it can take longer than Exact Shape"),
            ("CONCAVE", "Exact Shape", "Tightest; seconds on many islands"),
        ),
        default=DEFAULTS.pack_shape,
    )
    margin: FloatProperty(
        name="Margin",
        description="Space around every packed island, as a share of the UV square with Fill Shapes (Blender's "
        "scaled margin with its shapes); unused when Margin (px) is set",
        default=DEFAULTS.margin,
        min=0.0,
        max=1.0,
        precision=3,
    )
    margin_pixels: IntProperty(
        name="Margin (px)",
        description="Pixels of empty texture around every island at Texture Size, so islands lie at least "
        "twice that apart and bakes do not bleed; 0 uses Margin instead",
        default=DEFAULTS.margin_pixels,
        min=0,
        max=512,
    )
    texture_size: IntProperty(
        name="Texture Size",
        description="Pixels along the side of the texture the margin in pixels is meant for",
        default=DEFAULTS.texture_size,
        min=16,
        max=65536,
    )
    correct_aspect: BoolProperty(
        name="Correct Aspect",
        description="Account for the aspect ratio of the active image texture of the active face's material",
        default=DEFAULTS.correct_aspect,
    )
    world_scale: BoolProperty(
        name="True World Scale",
        description="One UV unit is one world unit (object scale and rotation included): texel density "
        "follows the size in the scene",
        default=DEFAULTS.world_scale,
    )
    refine: IntProperty(
        name="Refinement",
        description="Most iterations of isometric refinement after the four-step layout (symmetric "
        "Dirichlet, never folds). It stops once converged, so this only caps the time on hard islands. "
        "0 is Sun & Hancock's method alone (an island where it folds is laid out by a conformal map instead)",
        default=DEFAULTS.refine,
        min=0,
        max=5000,
    )
    charts: BoolProperty(
        name="Charts",
        description="Cut parts with no seams (closed or open) and islands that are closed or have holes or "
        "handles into a few charts: seams along short paths and creases, slits into squeezed tips, until "
        "no more stretched than Max Stretch. Islands your seams bound, and islands with pins, stay whole. "
        "Off: islands are only cut open as far as they must be",
        default=DEFAULTS.charts,
    )
    chart_disks: BoolProperty(
        name="Chart Marked Islands",
        description="With Charts: also cut islands that your seams already bound, when they stretch beyond Max Stretch",
        default=DEFAULTS.chart_disks,
    )
    max_stretch: FloatProperty(
        name="Max Stretch",
        description="Charts are cut until each island's distortion is no more than that of stretching it "
        "uniformly by this factor (symmetric Dirichlet energy per area at most 2(s\u00b2 + 1/s\u00b2)): "
        "lower gives more charts and less stretch",
        default=DEFAULTS.max_stretch,
        min=1.01,
        max=10.0,
        precision=2,
        step=1,
    )
    mark_seams: BoolProperty(
        name="Mark Seams",
        description="Mark the cuts the unwrap made (charts, openings, overlap cuts) as seams, to edit them "
        "and unwrap again",
        default=DEFAULTS.mark_seams,
    )
    extra_cuts: IntProperty(
        name="Extra Cuts",
        description="With Charts off: islands that have to be cut open (closed, with holes or handles, no "
        "seams marked) get up to this many more cuts, each from the cut to the most squeezed or stretched "
        "spot, while they help; every attempt solves again. 0 cuts only as much as opening needs",
        default=DEFAULTS.extra_cuts,
        min=0,
        max=20,
    )
    split_overlaps: BoolProperty(
        name="Cut Overlaps",
        description="Cut an island whose layout overlaps itself (two places of the model on one texel) in two "
        "where its overlapping parts are least apart, and unwrap the parts again",
        default=DEFAULTS.split_overlaps,
    )
    show_stretch: BoolProperty(
        name="Show Stretch",
        description="Colour the faces by distortion (colour attribute 'isoparam_stretch': white = true "
        "shape and scale, red = stretched or squeezed twice over)",
        default=DEFAULTS.show_stretch,
    )


class UV_OT_isometric_unwrap(UnwrapProperties, bpy.types.Operator):
    """Unwrap the selected faces so that UV edge lengths match the 3D edge lengths"""

    bl_idname = "uv.isometric_unwrap"
    bl_label = "Isometric Unwrap"
    bl_options = {"REGISTER", "UNDO"}

    @classmethod
    def poll(cls, context):
        ob = context.active_object
        return ob is not None and ob.type == "MESH" and context.mode == "EDIT_MESH"

    def execute(self, context):
        return self._ended(context, unwrap.run(context, OperatorOptions(**self.as_keywords())))

    def invoke(self, context, event):
        """From the UI: solve in a worker thread, Blender responsive, Esc to cancel (scripts
        and background mode call :meth:`execute`, which solves in this thread)."""
        if bpy.app.background or context.window is None:
            return self.execute(context)
        self._background = background.Background(context, OperatorOptions(**self.as_keywords()))
        if not self._background.running:
            return self._ended(context, self._background.conclude(context))
        context.window_manager.modal_handler_add(self)
        return {"RUNNING_MODAL"}

    def modal(self, context, event):
        answer = self._background.on_event(context, event.type, event.value)
        if answer is None:  # the solve has ended
            return self._ended(context, self._background.conclude(context))
        return answer

    def _ended(self, context, run: record.RunRecord) -> set:
        """Report what the run said, leave its record on the window manager for scripts
        (:func:`.record.last_record`), and end as it did."""
        for level, text in run.reports:
            self.report({level}, text)
        record.store(context, run)
        return {"FINISHED"} if run.finished else {"CANCELLED"}


class UV_OT_isometric_show_stretch(bpy.types.Operator):
    """Colour the faces by how much the active UV map stretches the texture (white: none, red: 2x or more)"""

    bl_idname = "uv.isometric_show_stretch"
    bl_label = "Show UV Stretch"
    bl_options = {"REGISTER", "UNDO"}

    @classmethod
    def poll(cls, context):
        ob = context.active_object
        return ob is not None and ob.type == "MESH" and context.mode == "EDIT_MESH"

    def execute(self, context):
        return unwrap.show_stretch(self, context)
