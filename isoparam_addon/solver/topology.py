"""Topology: islands, their orientation, and cuts that make every island a disk.

:func:`build_topology` validates the mesh (:func:`.mesh.check`), splits it along seams,
finds the islands, orients each consistently, opens every island that is not a disk
(:mod:`.cutgraph`) and walks the ordered 1-rings (fans) that Step 1 flattens.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import scipy.sparse as sp
from scipy.sparse import csgraph

from .cutgraph import cut_to_disks
from .errors import SolverError
from .geometry import face_areas
from .mesh import Fans, HalfEdges, check, edge_mask, face_components, fans, orientation, split, unit_of

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
    flipped : (m,) bool
        Faces whose corner order was reversed to orient their island.
    cut_edges : (k, 2) int64
        Input-vertex pairs of the edges cut automatically to make islands disks.
    cut_islands : (j,) int64
        Islands that were not disks and got cut.
    closed_islands, handle_islands, multi_boundary_islands, nonorientable_islands : (j,) int64
        Why they were cut (an island can appear in several).
    """

    faces: np.ndarray
    he: HalfEdges
    fans: Fans
    corner_vertex: np.ndarray
    vertex_of: np.ndarray
    face_island: np.ndarray
    vertex_island: np.ndarray
    n_islands: int
    flipped: np.ndarray
    cut_edges: np.ndarray
    cut_islands: np.ndarray
    closed_islands: np.ndarray = field(default_factory=lambda: np.zeros(0, np.int64))
    handle_islands: np.ndarray = field(default_factory=lambda: np.zeros(0, np.int64))
    multi_boundary_islands: np.ndarray = field(default_factory=lambda: np.zeros(0, np.int64))
    nonorientable_islands: np.ndarray = field(default_factory=lambda: np.zeros(0, np.int64))


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
    loops = np.unique(lab[on_bnd])
    loop_island = np.full(lab.max() + 1, -1, dtype=np.int64)
    loop_island[lab[on_bnd]] = v_isl[on_bnd]
    n_loops = np.bincount(loop_island[loops], minlength=n_islands)
    return chi, n_loops


def build_topology(vertices, faces, seams=None, split_bowties: bool = False, inner_edges=None, avoid=None):
    """Validate, split along seams, find islands, orient them, cut non-disks into disks.

    Parameters
    ----------
    vertices : (n, 3) array_like of float
    faces : (m, 3) array_like of int
    seams : (k, 2) int, optional
        Vertex pairs of edges to cut along (Blender's UV seams).
    split_bowties : bool
        Give a vertex whose faces form several fans one copy per fan (faces that share
        only a vertex end up in different islands, as in Blender's unwrap) instead of
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
    V, F, he0, fan0 = check(vertices, faces, split_bowties)
    n, m = len(V), len(F)
    seam = edge_mask(he0, n, seams)
    inner = edge_mask(he0, n, inner_edges, "inner_edges")
    if seam.any() or (split_bowties and fan0 is None):
        Fs, vertex_of = split(F, n, seam, he0)
        he = HalfEdges(Fs, len(vertex_of))
    else:  # validation guarantees one wedge per vertex: split vertices are the used ones
        used = np.zeros(n, dtype=bool)
        used[F.ravel()] = True
        if used.all():
            Fs, vertex_of, he = F, np.arange(n, dtype=np.int64), he0
        else:
            vertex_of = np.flatnonzero(used)
            rank = np.cumsum(used, dtype=np.int64) - 1
            Fs, he = rank[F], he0.relabel(rank)
    ns = len(vertex_of)
    face_island = face_components(m, he, np.zeros(he.n_edges, dtype=bool))
    n_islands = int(face_island.max()) + 1
    Vu = V / unit_of(V)  # areas and lengths below only compare with each other
    area = None  # only for orienting
    # the fans of validation were walked because F was consistently oriented
    if (Fs is F and fan0 is not None) or he.consistent(Fs):
        flip, orientable = np.zeros(m, dtype=bool), np.ones(n_islands, dtype=bool)
    else:  # pragma: no branch
        area = face_areas(Vu, F)
        flip, orientable = orientation(Fs, he, face_island, n_islands, area)
    chi, n_loops = _island_counts(Fs, ns, he, face_island, n_islands)
    disk = orientable & (chi == 1) & (n_loops == 1)
    empty = np.zeros(0, dtype=np.int64)
    cut_edges, cut_islands = np.zeros((0, 2), dtype=np.int64), empty
    reasons = dict(closed=empty, handle=empty, multi=empty, nonorientable=empty)
    if not disk.all():
        cut_islands = np.flatnonzero(~disk)
        reasons = dict(
            closed=np.flatnonzero(~disk & (n_loops == 0)),
            handle=np.flatnonzero(~disk & orientable & (2 - chi - n_loops > 0)),
            multi=np.flatnonzero(~disk & (n_loops > 1)),
            nonorientable=np.flatnonzero(~orientable),
        )
        keep = np.zeros(n, dtype=bool)
        if avoid is not None:
            ids = np.asarray(avoid, dtype=np.int64).ravel()
            keep[ids[(ids >= 0) & (ids < n)]] = True
        Fs, vertex_of, flip, cut_edges = cut_to_disks(
            Vu, Fs, vertex_of, he, he0, face_island, ~disk, area, inner, flip, keep
        )
        ns = len(vertex_of)
        he = None  # rebuilt below, once the faces are numbered and oriented
    # number the split vertices island by island
    vertex_island = np.empty(ns, dtype=np.int64)
    vertex_island[Fs.ravel()] = np.repeat(face_island, 3)
    if np.any(np.diff(vertex_island) < 0):
        order = np.argsort(vertex_island, kind="stable")
        rank = np.empty_like(order)
        rank[order] = np.arange(ns)
        Fs, vertex_of, vertex_island = rank[Fs], vertex_of[order], vertex_island[order]
        he = None if he is None else he.relabel(rank)
    oriented = np.where(flip[:, None], Fs[:, ::-1], Fs) if flip.any() else Fs
    he_oriented = he if he is not None and oriented is Fs else HalfEdges(oriented, ns)
    if cut_islands.size:
        chi, n_loops = _island_counts(oriented, ns, he_oriented, face_island, n_islands)
        still = np.flatnonzero((chi != 1) | (n_loops != 1))
        if still.size:  # pragma: no cover - a bug guard, the cut graph makes disks
            raise SolverError(f"cutting islands {still.tolist()} did not give disks")
    unchanged = fan0 is not None and oriented is F
    fan = fan0 if unchanged else fans(oriented, he_oriented.twin, ns)
    return (
        V,
        F,
        Topology(
            faces=oriented,
            he=he_oriented,
            fans=fan,
            corner_vertex=Fs,
            vertex_of=vertex_of,
            face_island=face_island,
            vertex_island=vertex_island,
            n_islands=n_islands,
            flipped=flip,
            cut_edges=cut_edges,
            cut_islands=cut_islands,
            closed_islands=reasons["closed"],
            handle_islands=reasons["handle"],
            multi_boundary_islands=reasons["multi"],
            nonorientable_islands=reasons["nonorientable"],
        ),
    )
