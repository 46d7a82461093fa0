"""What :func:`.parametrize` returns."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from . import metrics
from .geometry import signed_areas, triangles
from .mesh.topology import Topology
from .overlap import boundary_crossings
from .report import IslandReport, SolverWarning, Stats, Timings, defects, opened, warnings

__all__ = ["Parametrization", "assemble", "per_corner_and_vertex", "topology_warnings"]


@dataclass
class Parametrization:
    """A layout and what the solver found on the way.

    Attributes
    ----------
    uv : (n, 2) float64
        One UV per input vertex, in mesh units (true scale). A vertex on a seam or an
        automatic cut has several UVs; ``uv`` holds the one of its lowest split copy and
        ``corner_uv`` holds them all. Vertices used by no face get (0, 0).
    corner_uv : (m, 3, 2) float64
        UV of every face corner, in the input corner order.
    face_island : (m,) int64
        Island of each face, numbered by lowest face index.
    n_islands : int
    cut_edges : (k, 2) int64
        Vertex pairs of edges cut automatically to open non-disk islands (and to lower
        their distortion, with ``extra_cuts``).
    cut_islands : (j,) int64
        Islands that were not topological disks (closed, with handles, several boundary
        loops, non-orientable) and were cut.
    flipped : (m,) bool
        Faces whose UV triangle is clockwise (folded) or collapsed, of those with a 3D
        area (:attr:`.geometry.Triangles.collapsed`: no orientation to keep).
    eigenvalues : (n_islands, 2) float64
        Ritz values of ``M`` for the two embedding vectors (Step 3).
    converged : (n_islands,) bool
        Whether Step 3 met its tolerance on each island.
    warnings : list of SolverWarning
    timings : Timings
    stats : Stats
    islands : IslandReport
        Per-island facts (Step 3 change, pins, restarts, refined energy, ...).
    vertices : (n, 3) float64, faces : (m, 3) int64
        The validated input (for :meth:`distortion` and later solves).
    turned : (m,) bool
        Faces whose corner order the solver reversed to orient their island.
    """

    uv: np.ndarray
    corner_uv: np.ndarray
    face_island: np.ndarray
    n_islands: int
    cut_edges: np.ndarray
    cut_islands: np.ndarray
    flipped: np.ndarray
    eigenvalues: np.ndarray
    converged: np.ndarray
    islands: IslandReport
    vertices: np.ndarray = field(repr=False)
    faces: np.ndarray = field(repr=False)
    turned: np.ndarray = field(repr=False)
    warnings: list[SolverWarning] = field(default_factory=list)
    timings: Timings = field(default_factory=Timings)
    stats: Stats = field(default_factory=Stats)

    def distortion(self) -> metrics.Distortion:
        """All measures of :mod:`.metrics` for this layout.

        Faces the solver turned round to orient their island consistently are measured
        turned round too, so ``flipped`` counts what :attr:`flipped` flags.
        """
        turned = self.turned[:, None]
        F = np.where(turned, self.faces[:, ::-1], self.faces)
        cuv = np.where(turned[:, :, None], self.corner_uv[:, ::-1], self.corner_uv)
        return metrics.distortion(self.vertices, F, cuv, self.face_island)

    def overlaps(self, islands: np.ndarray | None = None):
        """How its islands overlap themselves (:class:`.overlap.Overlaps`: boundary
        crossings, UV area covered twice, the faces involved); only ``islands`` (k,) if
        given (the others count as not overlapping)."""
        from .overlap import Overlaps, self_overlaps

        if islands is None:
            return self_overlaps(self.faces, self.corner_uv, self.face_island, self.n_islands)
        at = np.flatnonzero(np.isin(self.face_island, islands))
        found = self_overlaps(self.faces[at], self.corner_uv[at], self.face_island[at], self.n_islands)
        return Overlaps(found.crossings, found.area, (at[found.pairs[0]], at[found.pairs[1]]), found.pair_area)


def per_corner_and_vertex(uv_split: np.ndarray, topo: Topology, n: int):
    """UVs of the split vertices (mesh units) as ``corner_uv`` (m, 3, 2) and ``uv`` (n, 2),
    and how many mesh vertices no face uses: a mesh vertex takes the UV of its lowest
    split copy, (0, 0) if it has none."""
    corner_uv = np.take(uv_split, topo.corner_vertex, axis=0)  # np.take: row gathers 5x faster
    uv = np.zeros((n, 2))
    first = np.full(n, len(uv_split), dtype=np.int64)
    np.minimum.at(first, topo.vertex_of, np.arange(len(uv_split)))
    used = first < len(uv_split)
    uv[used] = np.take(uv_split, first[used], axis=0)
    return corner_uv, uv, int(n - used.sum())


def assemble(
    V: np.ndarray,
    F: np.ndarray,
    topo: Topology,
    layout: np.ndarray,
    unit: float,
    report: IslandReport,
    eigenvalues: np.ndarray,
    converged: np.ndarray,
    stats: Stats,
    timings: Timings,
) -> Parametrization:
    """The :class:`Parametrization` of a layout over the split vertices of ``topo``,
    ``layout`` (n, 2) in units of ``unit`` (a power of two), with the per-island facts
    gathered on the way: the corner and vertex UVs, folds and overlaps measured on the
    layout as returned, the counts, and the warnings."""
    # of the layout as returned (up to the power-of-two unit, which keeps every sign):
    # moving an island rounds a face of 1e-26 the mesh's area to clockwise or nothing;
    # a face with no 3D area has no orientation to keep
    flipped = (signed_areas(layout, topo.faces) <= 0) & ~triangles(V / unit, F).collapsed
    corner_uv, uv, unused = per_corner_and_vertex(layout * unit, topo, len(V))
    report.crossings = boundary_crossings(layout, topo)
    stats.split_vertices = len(topo.vertex_of)
    stats.count(report)
    return Parametrization(
        uv=uv,
        corner_uv=corner_uv,
        face_island=topo.face_island,
        n_islands=topo.n_islands,
        cut_edges=topo.cut_edges,
        cut_islands=topo.cut_islands,
        flipped=flipped,
        eigenvalues=eigenvalues,
        converged=converged,
        islands=report,
        vertices=V,
        faces=F,
        turned=topo.turned,
        warnings=topology_warnings(topo) + warnings(report, converged, flipped, unused),
        timings=timings,
        stats=stats,
    )


def topology_warnings(topo: Topology):
    """The warnings about what the topology split or cut open."""
    return defects(topo.defects) + opened(
        topo.closed_islands, topo.handle_islands, topo.multi_boundary_islands, topo.nonorientable_islands
    )
