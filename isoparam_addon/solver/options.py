"""How to solve: the options of :func:`.parametrize`, and the mesh data it is given."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from .mesh.halfedges import unique_sorted

__all__ = ["Options", "Problem"]


@dataclass(frozen=True)
class Options:
    """Every knob of :func:`.parametrize`.

    Attributes
    ----------
    pack : bool
        Place islands side by side without overlap (mesh units). If False every island
        is centred at the origin in its own frame.
    margin : float
        Gap between packed islands, as a fraction of the square root of their total area.
    tol, max_iter :
        Convergence of Step 3 (sine of the subspace change) and its iteration cap.
    split_nonmanifold : bool
        Split what is not a manifold, as Blender's unwrap does, and warn: a face that
        repeats another's vertices becomes an island of its own, an edge shared by more
        than two faces a seam, a vertex whose faces form several fans (a bow-tie) one
        vertex per fan. False raises :class:`.InvalidMeshError` instead.
    refine : int
        Iterations of isometric refinement (symmetric Dirichlet, no folds; see
        :mod:`.refinement`) after the four steps. 0 is the paper's method.
    unfold : bool
        Without refinement (``refine=0``): an island whose four-step layout folds is laid
        out again as the refinement would start it, by the lower-energy of a conformal
        map and (where that folds too) a Tutte embedding, whichever does not fold
        (islands with pins included: the pins are fitted afterwards). False keeps the
        paper's layout as it is. With refinement, such islands are always restarted so.
    refine_tol : float
        The refinement stops an island once its energy fell by less than this (relative)
        over 5 iterations.
    extra_cuts : int
        Islands that had to be cut automatically (closed, handles, holes) get up to this
        many more cuts while they help (see :mod:`.cuts`). 0: the shortest cut that
        opens the island, nothing more.
    charts : bool
        Cut every island that is not a disk, or that no seam of the caller's bounds (closed
        or open), into charts until within ``max_stretch`` (see :mod:`.charts`); islands
        with pins are left whole. Supersedes ``extra_cuts``.
    chart_disks : bool
        With ``charts``: islands the caller's seams bound that stretch beyond
        ``max_stretch`` are cut into charts too.
    max_stretch : float
        The charts' budget: an island is cut until its charts' symmetric Dirichlet energy
        per area (area-weighted, each chart at its best scale) is no more than that of a
        uniform stretch by this factor, ``2 (s^2 + 1 / s^2)``: 1.18 allows 4.22 (4 is
        isometric).
    split_overlaps : bool
        Cut an island whose layout overlaps itself where its overlapping parts are least
        apart, and solve the parts again (see :mod:`.untangle`); without, such islands
        are only warned about.
    """

    pack: bool = True
    margin: float = 0.02
    tol: float = 1e-8
    max_iter: int = 40
    split_nonmanifold: bool = True
    refine: int = 0
    unfold: bool = False
    refine_tol: float = 2e-4
    extra_cuts: int = 0
    charts: bool = False
    chart_disks: bool = False
    max_stretch: float = 1.18
    split_overlaps: bool = False


@dataclass(frozen=True)
class Problem:
    """The mesh data of one solve, as the caller gave it (validated by the topology).

    Attributes
    ----------
    vertices : (n, 3) array_like of float
    faces : (m, 3) array_like of int
    seams : (k, 2) array_like of int or None
        Vertex pairs of edges to cut along.
    inner_edges : (k, 2) array_like of int or None
        Vertex pairs of edges that automatic cuts avoid (polygon diagonals, and the edges
        at pinned vertices).
    pins : (corners (m, 3) bool, uv (m, 3, 2) float) or None
        Face corners whose UV is given.
    start : (m, 3, 2) float or None
        A fold-free layout to refine instead of the four steps' (a search that cut a solved
        layout further goes on from it), mesh units, per face corner.
    """

    vertices: npt.ArrayLike
    faces: npt.ArrayLike
    seams: npt.ArrayLike | None = None
    inner_edges: npt.ArrayLike | None = None
    pins: tuple[npt.ArrayLike, npt.ArrayLike] | None = None
    start: np.ndarray | None = None

    def pinned_vertices(self) -> np.ndarray | None:
        """The mesh vertices with a pinned corner, or None (no pins, or input that
        validation will reject: it is passed on as it is)."""
        if self.pins is None:
            return None
        try:
            F, mask = np.asarray(self.faces), np.asarray(self.pins[0], dtype=bool)
        except (TypeError, ValueError, IndexError, KeyError):
            return None
        if F.ndim != 2 or F.shape[1:] != (3,) or F.dtype.kind not in "iu" or mask.shape != F.shape or not mask.any():
            return None
        return unique_sorted(F[mask].astype(np.int64))
