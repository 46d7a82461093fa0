"""What :func:`.parametrize` returns."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from . import metrics
from .report import IslandReport, SolverWarning, Stats, Timings
from .topology import Topology

__all__ = ["Parametrization", "per_corner_and_vertex"]


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
        Faces whose UV triangle is clockwise (folded) or collapsed.
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
        return Overlaps(found.crossings, found.area, (at[found.pairs[0]], at[found.pairs[1]]))


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
