"""Topology: islands, their orientation, and cuts that make every island a disk.

:func:`build_topology` validates the mesh (:func:`.halfedges.check`), splits it along seams,
finds the islands, orients each consistently, opens every island that is not a disk
(:mod:`.cutgraph`) and walks the ordered 1-rings (fans) that Step 1 flattens.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import scipy.sparse as sp
from scipy.sparse import csgraph

from ..errors import SolverError
from ..geometry import face_areas
from .cutgraph import cut_to_disks
from .halfedges import (
    Defects,
    Fans,
    HalfEdges,
    check,
    edge_mask,
    face_components,
    fans,
    orientation,
    split,
    unique_sorted,
    unit_of,
)

__all__ = ["Topology", "build_topology"]


@dataclass
class Topology:
    """The mesh as the solver sees it: split along seams and cuts, oriented per island.

    Split vertices are numbered island by island (each island a contiguous range).

    Attributes
    ----------
    faces : (m, 3) int64
        Split-vertex indices, each island consistently oriented (counter-clockwise in the
        final layout).
    he : HalfEdges
        Half-edges of ``faces``.
    fans : Fans
        Ordered 1-rings of ``faces``.
    corner_vertex : (m, 3) int64
        Split vertex of each input corner, in the input corner order.
    vertex_of : (ns,) int64
        Input vertex of each split vertex.
    face_island : (m,) int64
        Island of each face, numbered by lowest face index.
    vertex_island : (ns,) int64
    n_islands : int
    turned : (m,) bool
        Faces whose corner order was reversed to orient their island.
    cut_edges : (k, 2) int64
        Input-vertex pairs of the edges cut automatically to make islands disks.
    cut_islands : (j,) int64
        Islands that were not disks and got cut.
    closed_islands, handle_islands, multi_boundary_islands, nonorientable_islands : (j,) int64
        Why they were cut (an island can appear in several).
    defects : Defects
        What validation split because it was not a manifold.
    """

    faces: np.ndarray
    he: HalfEdges
    fans: Fans
    corner_vertex: np.ndarray
    vertex_of: np.ndarray
    face_island: np.ndarray
    vertex_island: np.ndarray
    n_islands: int
    turned: np.ndarray
    cut_edges: np.ndarray
    cut_islands: np.ndarray
    closed_islands: np.ndarray = field(default_factory=lambda: np.zeros(0, np.int64))
    handle_islands: np.ndarray = field(default_factory=lambda: np.zeros(0, np.int64))
    multi_boundary_islands: np.ndarray = field(default_factory=lambda: np.zeros(0, np.int64))
    nonorientable_islands: np.ndarray = field(default_factory=lambda: np.zeros(0, np.int64))
    defects: Defects = field(default_factory=lambda: Defects.none())


def _island_counts(Fs, ns, he, face_island, n_islands):
    """Euler characteristic and number of boundary loops of each island."""
    v_isl = np.full(ns, -1, dtype=np.int64)
    v_isl[Fs.ravel()] = np.repeat(face_island, 3)
    nv = np.bincount(v_isl[v_isl >= 0], minlength=n_islands)
    nf = np.bincount(face_island, minlength=n_islands)
    e_isl = np.empty(he.n_edges, dtype=np.int64)
    e_isl[he.edge] = np.repeat(face_island, 3)
    ne = np.bincount(e_isl, minlength=n_islands)
    chi = nv - ne + nf
    bnd = np.flatnonzero(he.edge_count == 1)
    ev = he.edge_vertices[bnd]
    graph = sp.coo_matrix((np.ones(len(bnd), dtype=np.int8), (ev[:, 0], ev[:, 1])), shape=(ns, ns))
    _, lab = csgraph.connected_components(graph, directed=False)
    on_bnd = np.zeros(ns, dtype=bool)
    on_bnd[ev.ravel()] = True
    loops = unique_sorted(lab[on_bnd])
    loop_island = np.full(lab.max() + 1, -1, dtype=np.int64)
    loop_island[lab[on_bnd]] = v_isl[on_bnd]
    n_loops = np.bincount(loop_island[loops], minlength=n_islands)
    return chi, n_loops


def build_topology(vertices, faces, seams=None, split_nonmanifold: bool = True, inner_edges=None, avoid=None):
    """Validate, split along seams, find islands, orient them, cut non-disks into disks.

    Parameters
    ----------
    vertices : (n, 3) array_like of float
    faces : (m, 3) array_like of int
    seams : (k, 2) int, optional
        Vertex pairs of edges to cut along (Blender's UV seams).
    split_nonmanifold : bool
        Split what is not a manifold as Blender's unwrap does (see :func:`.halfedges.check`):
        repeated faces become islands of their own, edges shared by more than two faces
        seams, and a vertex whose faces form several fans one copy per fan; instead of
        raising ``InvalidMeshError``.
    inner_edges : (k, 2) int, optional
        Vertex pairs of edges that automatic cuts avoid where they can (the diagonals of
        triangulated polygons); pairs that are not edges are ignored.
    avoid : (k,) int, optional
        Vertices not to root a closed island's cut at where another can be (pinned
        vertices: every loop of the cut passes through the root, which splits it); ids
        out of range are ignored.

    Returns
    -------
    V : (n, 3) float64, F : (m, 3) int64
        Validated copies of the input.
    topo : Topology

    The common case (no seams, consistently oriented disks) reuses the half-edges built
    for validation and renumbers nothing.
    """
    V, F, he0, fan0, defects = check(vertices, faces, split_nonmanifold)
    n = len(V)
    seam = edge_mask(he0, n, seams)
    inner = edge_mask(he0, n, inner_edges, "inner_edges")
    Fs, vertex_of, he = _split_along_seams(F, n, he0, seam, defects.any)
    face_island = face_components(len(F), he, np.zeros(he.n_edges, dtype=bool))
    n_islands = int(face_island.max()) + 1
    Vu = V / unit_of(V)  # areas and lengths below only compare with each other
    flip, orientable, area = _orientation(Vu, F, Fs, fan0, he, face_island, n_islands)
    shapes = _Shapes.of(Fs, len(vertex_of), he, face_island, n_islands, orientable)
    cut = _Cut(Fs, vertex_of, he, flip, np.zeros((0, 2), dtype=np.int64))
    if not shapes.disk.all():
        cut = _cut_to_disks(Vu, cut, he0, face_island, ~shapes.disk, area, inner, avoid)
    return V, F, _topology(F, fan0, cut, face_island, n_islands, shapes, defects)


@dataclass
class _Cut:
    """The mesh over split vertices, as seams, defects and automatic cuts left it.

    Attributes
    ----------
    faces : (m, 3) int64
        Split-vertex indices, in the input corner order.
    vertex_of : (ns,) int64
        Input vertex of each split vertex.
    he : HalfEdges or None
        Half-edges of ``faces``; None once a cut has made them stale.
    flip : (m,) bool
        Faces whose corner order is reversed to orient their island.
    cut_edges : (k, 2) int64
        Input-vertex pairs of the edges cut automatically.
    """

    faces: np.ndarray
    vertex_of: np.ndarray
    he: HalfEdges | None
    flip: np.ndarray
    cut_edges: np.ndarray


@dataclass(frozen=True)
class _Shapes:
    """Which islands are disks, and why the others are not (an island can fail in several
    ways).

    Attributes
    ----------
    disk : (n_islands,) bool
        Orientable, Euler characteristic 1 and one boundary loop.
    closed, handles, holes, nonorientable : (k,) int64
        The islands to cut that have no boundary, that have handles, that have more than
        one boundary loop; and the islands that are not orientable.
    """

    disk: np.ndarray
    closed: np.ndarray
    handles: np.ndarray
    holes: np.ndarray
    nonorientable: np.ndarray

    @classmethod
    def of(cls, Fs, ns, he, face_island, n_islands, orientable) -> _Shapes:
        """The shapes of the islands of ``Fs`` (m, 3) over ``ns`` vertices."""
        chi, n_loops = _island_counts(Fs, ns, he, face_island, n_islands)
        disk = orientable & (chi == 1) & (n_loops == 1)
        cut = ~disk
        return cls(
            disk=disk,
            closed=np.flatnonzero(cut & (n_loops == 0)),
            handles=np.flatnonzero(cut & orientable & (2 - chi - n_loops > 0)),
            holes=np.flatnonzero(cut & (n_loops > 1)),
            nonorientable=np.flatnonzero(~orientable),
        )


def _orientation(Vu, F, Fs, fan0, he: HalfEdges, face_island, n_islands):
    """Faces to turn (m,) bool so that every island is consistently oriented, which
    islands can be (n_islands,) bool, and the face areas (m,) float64 of ``Vu`` (n, 3)
    that orienting weighed (None when every island already is: the fans of validation,
    ``fan0``, were walked because ``F`` was, and the seams kept the faces)."""
    if (Fs is F and fan0 is not None) or he.consistent(Fs):
        return np.zeros(len(F), dtype=bool), np.ones(n_islands, dtype=bool), None
    area = face_areas(Vu, F)
    flip, orientable = orientation(Fs, he, face_island, n_islands, area)
    return flip, orientable, area


def _cut_to_disks(Vu, cut: _Cut, he0: HalfEdges, face_island, to_cut, area, inner, avoid) -> _Cut:
    """``cut`` with the islands flagged in ``to_cut`` (n_islands,) bool cut into disks
    (:func:`.cutgraph.cut_to_disks`), its cuts rooted away from the ``avoid`` vertices
    where they can be; the half-edges are left to be rebuilt once the faces are
    numbered and oriented."""
    n = len(Vu)
    keep = np.zeros(n, dtype=bool)
    if avoid is not None:
        ids = np.asarray(avoid, dtype=np.int64).ravel()
        keep[ids[(ids >= 0) & (ids < n)]] = True
    Fs, vertex_of, flip, cut_edges = cut_to_disks(
        Vu, cut.faces, cut.vertex_of, cut.he, he0, face_island, to_cut, area, inner, cut.flip, keep
    )
    return _Cut(Fs, vertex_of, None, flip, cut_edges)


def _topology(F, fan0, cut: _Cut, face_island, n_islands: int, shapes: _Shapes, defects: Defects) -> Topology:
    """The :class:`Topology` of the ``cut`` mesh: split vertices numbered island by island,
    faces oriented, half-edges and fans (validation's ``fan0`` of ``F`` reused when the
    faces are still ``F``). Islands that were cut are checked to be disks now."""
    Fs, vertex_of, vertex_island, he = _number_by_island(cut.faces, cut.vertex_of, face_island, cut.he)
    ns = len(vertex_of)
    flip = cut.flip
    oriented = np.where(flip[:, None], Fs[:, ::-1], Fs) if flip.any() else Fs
    he_oriented = he if he is not None and oriented is Fs else HalfEdges(oriented, ns)
    if not shapes.disk.all():
        chi, n_loops = _island_counts(oriented, ns, he_oriented, face_island, n_islands)
        still = np.flatnonzero((chi != 1) | (n_loops != 1))
        if still.size:  # pragma: no cover - a bug guard, the cut graph makes disks
            raise SolverError(f"cutting islands {still.tolist()} did not give disks")
    unchanged = fan0 is not None and oriented is F
    fan = fan0 if unchanged else fans(oriented, he_oriented.twin, ns)
    return Topology(
        faces=oriented,
        he=he_oriented,
        fans=fan,
        corner_vertex=Fs,
        vertex_of=vertex_of,
        face_island=face_island,
        vertex_island=vertex_island,
        n_islands=n_islands,
        turned=flip,
        cut_edges=cut.cut_edges,
        cut_islands=np.flatnonzero(~shapes.disk),
        closed_islands=shapes.closed,
        handle_islands=shapes.handles,
        multi_boundary_islands=shapes.holes,
        nonorientable_islands=shapes.nonorientable,
        defects=defects,
    )


def _split_along_seams(F, n: int, he0: HalfEdges, seam: np.ndarray, defects: bool):
    """Faces over split vertices, the mesh vertex of each, and their half-edges: the mesh
    cut along ``seam`` edges, and along the ``defects`` validation found (half-edges with
    no twin: repeated faces, edges of more than two faces, bow-ties). Without either,
    every vertex is one wedge: the split vertices are the used ones, and the half-edges
    of validation are reused."""
    if seam.any() or defects:
        Fs, vertex_of = split(F, n, seam, he0)
        return Fs, vertex_of, HalfEdges(Fs, len(vertex_of))
    used = np.zeros(n, dtype=bool)
    used[F.ravel()] = True
    if used.all():
        return F, np.arange(n, dtype=np.int64), he0
    rank = np.cumsum(used, dtype=np.int64) - 1
    return rank[F], np.flatnonzero(used), he0.relabel(rank)


def _number_by_island(Fs, vertex_of, face_island, he):
    """Split vertices renumbered island by island (each island a contiguous range); the
    half-edges, if given, follow. Returns ``(Fs, vertex_of, vertex_island, he)``."""
    ns = len(vertex_of)
    vertex_island = np.empty(ns, dtype=np.int64)
    vertex_island[Fs.ravel()] = np.repeat(face_island, 3)
    if not np.any(np.diff(vertex_island) < 0):
        return Fs, vertex_of, vertex_island, he
    order = np.argsort(vertex_island, kind="stable")
    rank = np.empty_like(order)
    rank[order] = np.arange(ns)
    return rank[Fs], vertex_of[order], vertex_island[order], None if he is None else he.relabel(rank)
