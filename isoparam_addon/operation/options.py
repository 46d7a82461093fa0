"""The Isometric Unwrap operator's options and their defaults, written once.

:class:`OperatorOptions` has one field per property of the operator's redo panel; its
defaults are what an artist gets, and :data:`DEFAULTS` is that preset. The operator's
properties read their ``default=`` from it, the operator builds one from its
``as_keywords()``, and :meth:`OperatorOptions.solver_options` is what it asks the solver
for, so scripts and tests that solve "as the operator does" read it too.

This module imports neither ``bpy`` nor :mod:`~isoparam_addon.blender` (only the solver's
:class:`~isoparam_addon.solver.Options`), so the preset is at hand in plain CPython.
"""

from __future__ import annotations

from dataclasses import dataclass

from ..solver.options import Options

__all__ = ["DEFAULTS", "FILL_SHAPES", "OperatorOptions"]


FILL_SHAPES = "ISOPARAM"  # the Pack Shape that is isoparam's own packer (:mod:`~isoparam_addon.solver.layout.packing`)


@dataclass(frozen=True)
class OperatorOptions:
    """The operator's options, as its redo panel shows them (one field per operator
    property). Defaults are what an artist expects (refinement, charts, overlap cuts on);
    the solver's :class:`~isoparam_addon.solver.Options` default to the paper's method
    alone, and :meth:`solver_options` maps these onto them. Max Stretch is the solver's
    own charts budget."""

    pack: bool = True
    pack_shape: str = FILL_SHAPES
    margin: float = 0.001
    margin_pixels: int = 0
    texture_size: int = 1024
    correct_aspect: bool = True
    world_scale: bool = False
    refine: int = 1000
    charts: bool = True
    chart_disks: bool = False
    max_stretch: float = Options.max_stretch
    mark_seams: bool = False
    extra_cuts: int = 4
    split_overlaps: bool = True
    show_stretch: bool = False

    @property
    def in_pixels(self) -> bool:
        """The margin is given in pixels of the texture (Blender's pack margin method
        FRACTION: that share of the UV square around each island), not as Margin."""
        return self.margin_pixels > 0

    @property
    def blender_shape(self) -> str:
        """The shape Blender's packer is given: Fill Shapes falls back to Bounding Box."""
        return "AABB" if self.pack_shape == FILL_SHAPES else self.pack_shape

    @property
    def pack_margin(self) -> float:
        """The margin as the pack takes it: Margin, or the pixels as a share of the side."""
        return self.margin_pixels / self.texture_size if self.in_pixels else self.margin

    def solver_options(self) -> Options:
        """The solver's options for these: islands packed side by side in mesh units (the
        operator then places them in UV space), and at Refinement 0 the paper's layout, but
        never a fold where a fold-free map exists (``unfold``). What is not a manifold is
        split, as Blender's unwrap does (the operator may ask for ``split_nonmanifold=False``
        on a first try)."""
        return Options(
            pack=True,
            split_nonmanifold=True,
            refine=self.refine,
            unfold=True,
            extra_cuts=self.extra_cuts,
            charts=self.charts,
            chart_disks=self.chart_disks,
            max_stretch=self.max_stretch,
            split_overlaps=self.split_overlaps,
        )


DEFAULTS = OperatorOptions()  # the preset: what the operator does unless told otherwise
