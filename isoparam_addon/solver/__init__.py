"""isoparam's solver: Sun & Hancock's fast isometric parametrization, in numpy/scipy.

>>> from isoparam_addon.solver import parametrize
>>> result = parametrize(vertices, faces)        # doctest: +SKIP
>>> result.uv                                    # (n, 2) float64, one UV per vertex

This package never imports bpy: it runs in plain CPython and inside Blender alike. One
solve reads top to bottom in :mod:`.pipeline`, a sub-package per stage:

``mesh/``
    topology: validation, half-edges, islands, cuts that make every island a disk;
``steps/``
    the paper's four steps, :mod:`.local`, :mod:`.weights`, :mod:`.embed`, :mod:`.align`;
``refinement/``
    beyond the paper: isometric refinement without folds;
``layout/``
    pins, placement, and (for the operator) packing and Blender's UV space;
``charting/``
    beyond one solve: charts, extra cuts and overlap repair, each solving islands again.

Beside them: the options, errors, result and report types, progress, the shared kernels
(:mod:`.geometry`, :mod:`.overlap`, concurrency and memory) and :mod:`.metrics`.

References
----------
Sun, X. and Hancock, E. R. "Fast Isometric Parametrization of 3D Triangular Mesh."
In *Structural, Syntactic, and Statistical Pattern Recognition* (SSPR & SPR 2008),
Lecture Notes in Computer Science 5342, Springer, 2008.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from . import metrics
from ._memory import retained
from ._parallel import one_blas_thread
from .charting.charts import with_charts
from .charting.cuts import with_extra_cuts
from .charting.untangle import without_overlaps
from .errors import ErrorKind, InvalidMeshError, IsoparamError, SolverError
from .options import Options, Problem
from .pipeline import solve
from .progress import Cancelled, ProgressCallback, stage, tracking
from .report import IslandReport, SolverWarning, Stats, Timings, WarningKind
from .result import Parametrization

__all__ = [
    "parametrize",
    "Options",
    "Parametrization",
    "IslandReport",
    "SolverWarning",
    "WarningKind",
    "Stats",
    "Timings",
    "IsoparamError",
    "InvalidMeshError",
    "ErrorKind",
    "SolverError",
    "Cancelled",
    "metrics",
]


def parametrize(
    vertices,
    faces,
    seams=None,
    *,
    pins=None,
    inner_edges=None,
    options: Options | None = None,
    progress: ProgressCallback | None = None,
    **option_values,
) -> Parametrization:
    """Unwrap a triangle mesh with Sun & Hancock's isometric parametrization.

    Parameters
    ----------
    vertices : (n, 3) array_like of float
    faces : (m, 3) array_like of int
    seams : (k, 2) array_like of int, optional
        Vertex pairs of edges to cut along; pairs that are not edges are ignored.
    pins : (corners (m, 3) bool, uv (m, 3, 2) float), optional
        Face corners whose UV is given. An island with pins is fitted to them (rotation,
        scale and shift from two pins on, shift from one); refinement keeps them fixed,
        so three or more also shape the island. Automatic cuts keep off pinned vertices
        where they can.
    inner_edges : (k, 2) array_like of int, optional
        Vertex pairs of edges that automatic cuts avoid whenever they can: the diagonals
        of triangulated quads and n-gons, which a polygon mesh does not have (a cut
        there would give one face corner two UVs).
    options : Options, optional
        How to solve; ``option_values`` (the fields of :class:`Options`, e.g.
        ``refine=100``) override it.
    progress : callable(fraction: float, stage: str) -> bool | None, optional
        Called as the solve goes (at stage changes, and at most every 0.05 s within one):
        the fraction done, never decreasing, first 0 and last 1.0 (stage ``"done"``), and
        the stage's name (``"refinement"``, ``"charting, round 2, refinement"``...).
        Returning ``False`` stops the solve: it raises :class:`Cancelled` from that call.

    Returns
    -------
    Parametrization

    Raises
    ------
    InvalidMeshError
        For invalid input (see :func:`.halfedges.check`); nothing is modified in place.
    Cancelled
        When ``progress`` returned ``False``; nothing is modified in place.
    """
    options = replace(options or Options(), **option_values)
    problem = Problem(vertices, faces, seams, inner_edges, pins)
    problem = replace(problem, inner_edges=_off_pins(problem))
    with retained(enabled=_is_large(vertices)), tracking(progress), one_blas_thread():
        if options.charts:  # (cuts apart what overlaps itself too)
            return with_charts(problem, options)
        with stage("", 0.0, 0.9 if options.split_overlaps else 1.0):
            result = with_extra_cuts(problem, options) if options.extra_cuts > 0 else solve(problem, options)
        if options.split_overlaps and (result.islands.crossings > 0).any():
            with stage("overlap cuts", 0.9, 1.0):
                result = without_overlaps(result, problem, options)
        return result


def _off_pins(problem: Problem):
    """``inner_edges`` and every edge at a pinned vertex: automatic and extra cuts keep off
    those where they can. A cut through a pinned vertex splits it into copies that its
    pins, all on the vertex's one UV, would glue back together, folding the layout there."""
    pinned = problem.pinned_vertices()
    if pinned is None:
        return problem.inner_edges
    F = np.asarray(problem.faces, dtype=np.int64)
    E = np.zeros((0, 2), dtype=np.int64) if problem.inner_edges is None else np.asarray(problem.inner_edges)
    if E.size and (E.ndim != 2 or E.shape[1] != 2 or E.dtype.kind not in "iu"):
        return problem.inner_edges  # validation reports it
    at = np.isin(F, pinned)
    edges = np.stack([F, F[:, [1, 2, 0]]], axis=2)[at | at[:, [1, 2, 0]]]  # each corner's edge to the next
    return np.vstack([E.reshape(-1, 2).astype(np.int64), edges])


def _is_large(vertices) -> bool:
    try:
        return len(vertices) >= 200_000
    except TypeError:
        return False
