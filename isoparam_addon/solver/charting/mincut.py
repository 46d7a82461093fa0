"""Seams as minimum cuts: the faces' adjacency graph, what cutting each edge costs, and the
cheapest set of edges that separates two sets of faces.

Both searches that cut islands apart (:mod:`.untangle`, :mod:`.charts`) ask the same
question: which edges, as short and as little in sight as possible, separate these faces
from those? That is a minimum cut of the dual graph (faces joined across the edges that
are neither seams nor cuts), solved as a maximum flow (Ford & Fulkerson; scipy's Dinic,
integer capacities).

An edge's cost is its 3D length, less where the surface folds sharply across it: a seam
along a crease follows a line the eye already sees, where a texture's break hides
(xatlas and D-Charts prefer such edges for the same reason). A polygon's diagonal is
never cut: a face corner would need two UVs.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp
from scipy.sparse import csgraph

from ..geometry import TINY, safe_divide
from ..mesh.halfedges import HalfEdges, pair_keys
from ..mesh.islands import first_rows

__all__ = ["FaceGraph", "face_graph", "minimum_cut", "source_side", "without_chips"]

_CREASE = np.pi / 2  # a crease this sharp (angle between the face normals) or sharper ...
_CREASE_COST = 0.25  # ... costs this much of its length to cut
_NEVER = 1 << 24  # capacity of an edge that is never cut
_UNITS = 1000  # capacity of an edge of typical length and no crease
_REGION_FROM = 4000  # faces: a smaller graph flows whole at once
_REACH = 1.5  # the first region around the sources and sinks (see source_side)
_COARSE_FROM = 200_000  # joins (edges) in a flow: from here it runs coarse, then in a band (_banded_side)
_CLUSTER = 8.0  # ... clusters of about this many faces across (face spacings)
_RINGS = 2  # ... the band: the clusters along the cut and this many rings of neighbours
_ROUNDS = 4  # ... moved along with the cut at most this many times


@dataclass(frozen=True)
class FaceGraph:
    """The faces of a mesh joined across its edges that are neither seams nor cuts.

    Attributes
    ----------
    f, g : (k,) int64
        The two faces of each joining edge.
    edges : (k, 2) int64
        The joining edges as sorted mesh vertex pairs.
    cost : (k,) float64
        What cutting each edge costs: its 3D length, less along creases; inf for an edge
        never to cut (a polygon's diagonal).
    centroids : (m, 3) float64
        Face centroids (the graph's distances are between them).
    """

    f: np.ndarray
    g: np.ndarray
    edges: np.ndarray
    cost: np.ndarray
    centroids: np.ndarray

    @property
    def n_faces(self) -> int:
        return len(self.centroids)

    def among(self, faces: np.ndarray) -> FaceGraph:
        """The graph with only the edges between two of ``faces`` (m,) bool."""
        keep = faces[self.f] & faces[self.g]
        return FaceGraph(self.f[keep], self.g[keep], self.edges[keep], self.cost[keep], self.centroids)

    def among_edges(self, keep: np.ndarray) -> FaceGraph:
        """The graph with only the edges ``keep`` (k,) bool."""
        return FaceGraph(self.f[keep], self.g[keep], self.edges[keep], self.cost[keep], self.centroids)

    def polygons(self) -> np.ndarray | None:
        """The polygon of every face (m,): faces joined across edges never to cut (a
        polygon's diagonals) share one, numbered by its lowest face; None if there are
        no such edges."""
        never = ~np.isfinite(self.cost)
        if not never.any():
            return None
        m = self.n_faces
        joined = sp.coo_matrix((np.ones(int(never.sum())), (self.f[never], self.g[never])), shape=(m, m))
        _, label = csgraph.connected_components(joined, directed=False)
        return first_rows(label)[label]

    def distances(self) -> sp.csr_matrix:
        """The graph weighted by the distance between face centroids (symmetric)."""
        m = self.n_faces
        d = np.linalg.norm(self.centroids[self.f] - self.centroids[self.g], axis=1)
        d += 1e-12 * max(float(d.max(initial=0.0)), TINY)  # csgraph drops zero weights
        graph = sp.coo_matrix((d, (self.f, self.g)), shape=(m, m))
        return (graph + graph.T).tocsr()


def face_graph(V: np.ndarray, F: np.ndarray, face_island: np.ndarray, cut, inner_edges=None, faces=None) -> FaceGraph:
    """The :class:`FaceGraph` of mesh ``V`` (n, 3), ``F`` (m, 3): faces of one island
    (``face_island`` (m,)) joined across the edges that are not among ``cut`` (k, 2 vertex
    pairs: seams and cuts so far) and are shared by exactly two faces. ``inner_edges``
    (vertex pairs) are never to be cut. ``faces`` (k,) int, if given: whole islands, the
    only faces joined (the graph of the others is not built; faces keep their numbers)."""
    centroids = V[F].mean(axis=1)
    if faces is not None:
        sub = face_graph(V, F[faces], face_island[faces], cut, inner_edges)
        return FaceGraph(faces[sub.f], faces[sub.g], sub.edges, sub.cost, centroids)
    n, m = len(V), len(F)
    # the faces of each island over vertices of their own: an edge two faces of an island
    # share is theirs alone, whatever faces of other islands also hold it (a face given
    # twice is an island of its own, and must not make its copy's edges look non-manifold)
    own, Fi = np.unique(pair_keys(np.repeat(face_island, 3), F.ravel(), n, ordered=True), return_inverse=True)
    Fi = Fi.reshape(-1, 3)
    vertex = own % n  # the mesh vertex of each island's own copy
    he = HalfEdges(Fi, len(own))
    h = np.flatnonzero(he.twin > np.arange(3 * m))
    f, g = h // 3, he.twin[h] // 3
    e = he.edge[h]
    edges = np.sort(vertex[he.edge_vertices[e]], axis=1)
    keep = ~np.isin(pair_keys(edges[:, 0], edges[:, 1], n), _keys(cut, n)) & (he.edge_count[e] == 2)
    f, g, e, edges = f[keep], g[keep], e[keep], edges[keep]
    length = np.linalg.norm(V[edges[:, 0]] - V[edges[:, 1]], axis=1)
    normal = np.cross(V[F[:, 1]] - V[F[:, 0]], V[F[:, 2]] - V[F[:, 0]])
    normal = safe_divide(normal, np.linalg.norm(normal, axis=1, keepdims=True))
    # (a mesh not consistently oriented reads some flat edges as creases: only a cost)
    angle = np.arccos(np.clip((normal[f] * normal[g]).sum(axis=1), -1.0, 1.0))
    cost = length * (1.0 - (1.0 - _CREASE_COST) * np.minimum(angle / _CREASE, 1.0))
    cost[np.isin(pair_keys(edges[:, 0], edges[:, 1], n), _keys(inner_edges, n))] = np.inf
    return FaceGraph(f, g, edges, cost, centroids)


def _keys(pairs, n: int) -> np.ndarray:
    """The :func:`.halfedges.pair_keys` of vertex pairs ``pairs`` (k, 2, or None: none)."""
    if pairs is None:
        return np.zeros(0, dtype=np.int64)
    P = np.asarray(pairs, dtype=np.int64).reshape(-1, 2)
    return pair_keys(P[:, 0], P[:, 1], n)


def minimum_cut(graph: FaceGraph, source: np.ndarray, sink: np.ndarray) -> np.ndarray:
    """The edges (k, 2 sorted vertex pairs) of a cheapest cut of ``graph`` between the
    ``source`` and the ``sink`` faces (m,) bool (disjoint). Components with faces of only
    one side, or none, are not cut."""
    side = source_side(graph, source, sink)
    return np.unique(graph.edges[side[graph.f] != side[graph.g]], axis=0)


def source_side(graph: FaceGraph, source: np.ndarray, sink: np.ndarray) -> np.ndarray:
    """The faces (m,) bool on the ``source`` side of a cheapest cut of ``graph`` between the
    ``source`` and the ``sink`` faces (m,) bool (disjoint): those still joined to a source
    face once the cut edges are removed.

    On a large graph the flow first runs in a region around the two sets (the faces whose
    distances to both add up to at most ``_REACH`` times the most any source or sink face
    of their component has), which holds the short cuts between sets that are close; the
    region doubles until its cut separates every source face from every sink face (at
    worst, the whole component). Each component of the graph (an island) is done when its
    own cut separates: the next flows run over the components still joined (the flows'
    capacities are still scaled by the costs of all the components in them).
    """
    polygon = graph.polygons()
    if polygon is not None:  # a polygon is on one side whole: its source faces claim it
        source = np.bincount(polygon, source, minlength=graph.n_faces)[polygon] > 0
        sink = (np.bincount(polygon, sink, minlength=graph.n_faces)[polygon] > 0) & ~source
    if graph.n_faces < _REGION_FROM or not source.any() or not sink.any():
        return _flow_side(graph, source, sink)
    G = graph.distances()
    to_source = csgraph.dijkstra(G, directed=False, indices=np.flatnonzero(source), min_only=True)
    to_sink = csgraph.dijkstra(G, directed=False, indices=np.flatnonzero(sink), min_only=True)
    n_parts, part = csgraph.connected_components(G, directed=False)
    total = to_source + to_sink
    ends = (source | sink) & np.isfinite(total)
    spread = np.zeros(n_parts)
    np.maximum.at(spread, part[ends], total[ends])
    reach = _REACH
    side = np.zeros(graph.n_faces, dtype=bool)
    todo = np.ones(n_parts, dtype=bool)  # the components whose cut does not separate yet
    while todo.any():
        mine = todo[part]
        region = ((total <= reach * spread[part]) | source | sink) & mine
        cut = _flow_side(graph.among(region), source & mine, sink & mine)
        inside = mine[graph.f]  # (an edge's two faces are of one component)
        crossed = region[graph.f] & region[graph.g] & (cut[graph.f] != cut[graph.g])
        joined = _joined(graph, inside & ~crossed, source & mine)
        whole = np.bincount(part[mine & ~region], minlength=n_parts) == 0
        done = todo & (whole | (np.bincount(part[joined & sink], minlength=n_parts) == 0))
        side |= joined & done[part]
        todo &= ~done
        reach *= 2.0
    return side


def _joined(graph: FaceGraph, keep: np.ndarray, source: np.ndarray) -> np.ndarray:
    """The faces (m,) bool joined to a ``source`` face over the edges ``keep`` (k,) bool."""
    m = graph.n_faces
    G = sp.coo_matrix((np.ones(int(keep.sum()), dtype=np.int8), (graph.f[keep], graph.g[keep])), shape=(m, m))
    _, label = csgraph.connected_components(G, directed=False)
    return np.isin(label, label[source])


def _flow_side(graph: FaceGraph, source: np.ndarray, sink: np.ndarray) -> np.ndarray:
    """:func:`source_side` by one maximum flow over all of ``graph``: the faces reachable
    from the source in the residual graph (coarse, then in a band, on a large graph:
    :func:`_banded_side`)."""
    if len(graph.f) >= _COARSE_FROM:
        banded = _banded_side(graph, source, sink)
        if banded is not None:
            return banded
    return _exact_side(graph, source, sink)


def _banded_side(graph: FaceGraph, source: np.ndarray, sink: np.ndarray) -> np.ndarray | None:
    """:func:`_flow_side` on a large graph, coarse to fine (a banded graph cut, Lombaert
    et al., "A multilevel banded graph cuts method for fast image segmentation", ICCV
    2005): the faces are grouped into clusters (the pieces of each cell of a grid about
    ``_CLUSTER`` face spacings wide), the cut is found between clusters, and then between
    faces again in the band of clusters along it and their neighbours, the faces beyond
    the band held on their side. Dinic's flow takes about the square of the faces' count
    on these graphs (figures in docs/benchmarks.md); the two small flows take a fraction.
    None where a cluster holds both source and sink faces (the flow then runs whole)."""
    m = graph.n_faces
    d = np.linalg.norm(graph.centroids[graph.f] - graph.centroids[graph.g], axis=1)
    spacing = float(np.median(d)) if len(d) else 0.0
    if not spacing > 0.0:
        return None
    grid = np.floor(graph.centroids / (_CLUSTER * spacing)).astype(np.int64)
    grid -= grid.min(axis=0)
    dims = grid.max(axis=0) + 1
    if float(np.prod(dims.astype(np.float64))) >= 2.0**62:  # (cells too many to number: none)
        return None
    _, cell = np.unique(np.ravel_multi_index(grid.T, dims), return_inverse=True)
    cell = cell.ravel()
    inside = cell[graph.f] == cell[graph.g]  # the pieces of each cell: joined within it
    G = sp.coo_matrix((np.ones(int(inside.sum()), dtype=np.int8), (graph.f[inside], graph.g[inside])), shape=(m, m))
    n_clusters, cluster = csgraph.connected_components(G, directed=False)
    c_source = np.bincount(cluster, source, minlength=n_clusters) > 0
    c_sink = np.bincount(cluster, sink, minlength=n_clusters) > 0
    if (c_source & c_sink).any():
        return None
    # the clusters' graph: what cutting between two clusters costs, summed
    a, b = cluster[graph.f[~inside]], cluster[graph.g[~inside]]
    pair, which = np.unique(pair_keys(np.minimum(a, b), np.maximum(a, b), n_clusters), return_inverse=True)
    cost = np.bincount(which.ravel(), graph.cost[~inside], minlength=len(pair))
    coarse = FaceGraph(
        pair // n_clusters, pair % n_clusters, np.zeros((len(pair), 2), np.int64), cost, np.zeros((n_clusters, 3))
    )
    c_side = _exact_side(coarse, c_source, c_sink)
    side = c_side[cluster]
    best = np.inf
    for _ in range(_ROUNDS):  # the band follows the cut until it stops shortening
        crossing = side[graph.f] != side[graph.g]
        band = np.zeros(n_clusters, dtype=bool)
        band[cluster[graph.f[crossing]]] = band[cluster[graph.g[crossing]]] = True
        for _ in range(_RINGS):
            near = band[coarse.f] | band[coarse.g]
            band[coarse.f[near]] = band[coarse.g[near]] = True
        free = band[cluster]
        keep = free[graph.f] | free[graph.g]  # the edges the fine flow can cut
        held = np.zeros(m, dtype=bool)
        held[graph.f[keep]] = held[graph.g[keep]] = True
        held &= ~free  # faces beyond the band that touch it: on the side they are
        fine = _exact_side(graph.among_edges(keep), source | (held & side), sink | (held & ~side))
        fine = np.where(free | held, fine, side)
        length = float(graph.cost[fine[graph.f] != fine[graph.g]].sum())
        if not length < best * (1.0 - 1e-9):
            break
        best, side = length, fine
    node = np.zeros(m, dtype=bool)  # (as the whole flow: faces it does not hold are on neither side)
    node[graph.f] = node[graph.g] = True
    return side & (node | source | sink)


def _exact_side(graph: FaceGraph, source: np.ndarray, sink: np.ndarray) -> np.ndarray:
    """:func:`_flow_side` by one maximum flow over all of ``graph``.

    Only the faces the edges touch take part in the flow: a source or sink face with no
    edge carries none, and is on its own side whatever the flow (the source side is the
    faces the source reaches in the residual graph, the same for every maximum flow). A
    graph narrowed to a band or a region (:func:`_banded_side`, :func:`source_side`)
    keeps every face, so a flow over all of them would spend each of Dinic's phases on
    the faces beyond it."""
    m = graph.n_faces
    finite = np.isfinite(graph.cost)
    positive = finite & (graph.cost > 0)
    typical = float(np.median(graph.cost[positive])) if positive.any() else 1.0
    scaled = np.minimum(np.round(_UNITS * np.where(finite, graph.cost, 0.0) / typical), 1e6)
    capacity = np.where(finite, 1 + scaled.astype(np.int64), _NEVER)
    big = int(min(capacity.sum() + 1, 1 << 30))
    # an edge between two source faces, or two sink faces, is never cut: every minimum cut
    # holds both on their side, so without it the cuts, and the faces the source reaches,
    # are the same; only the faces between the two sets are left to flow through (the
    # cores of cells, the balls of a cut: most of the graph)
    between = ~((source[graph.f] & source[graph.g]) | (sink[graph.f] & sink[graph.g]))
    graph_f, graph_g, capacity = graph.f[between], graph.g[between], capacity[between]
    # only the faces the edges touch take part, numbered 0..k-1
    node = np.zeros(m, dtype=bool)
    node[graph_f] = node[graph_g] = True
    alone = source & ~node  # (on the source side; a sink face alone is not)
    source, sink = source & node, sink & node
    index = np.cumsum(node) - 1
    k = int(node.sum())
    f, g = index[graph_f], index[graph_g]
    S, T = k, k + 1
    rows = np.concatenate([f, g, np.full(source.sum(), S), index[sink]])
    cols = np.concatenate([g, f, index[source], np.full(sink.sum(), T)])
    caps = np.concatenate([capacity, capacity, np.full(source.sum(), big), np.full(sink.sum(), big)])
    flow_graph = sp.csr_matrix((caps.astype(np.int32), (rows, cols)), shape=(k + 2, k + 2))
    flow = csgraph.maximum_flow(flow_graph, S, T).flow
    residual = (flow_graph - flow).tocsr()
    residual.data = (residual.data > 0).astype(np.int8)
    residual.eliminate_zeros()
    reach = csgraph.breadth_first_order(residual, S, directed=True, return_predecessors=False)
    side = np.zeros(k + 2, dtype=bool)
    side[reach] = True
    return (node & side[index]) | alone


def without_chips(graph: FaceGraph, cut: np.ndarray, seeds: np.ndarray | None = None, fewest=0) -> np.ndarray:
    """``cut`` (k, 2 vertex pairs) less the edges of ``graph`` that only bound chips:
    pieces of the cut graph that hold none of the ``seeds`` faces (what the cut is to
    part) and fewer than ``fewest`` faces (a number, or per face (m,): a piece's is the
    most of its faces'). Each chip joins the piece it shares most cut
    length with (a chip beside a chip joins it first), so that a cut parts its island
    into the pieces it is for, and nothing else. Edges of ``cut`` that are not in
    ``graph`` stay."""
    m = graph.n_faces
    if not len(cut) or not len(graph.f):
        return cut
    n = int(max(graph.edges.max(), cut.max())) + 1
    keys = pair_keys(cut[:, 0], cut[:, 1], n)
    edge_keys = pair_keys(graph.edges[:, 0], graph.edges[:, 1], n)
    crossed = np.isin(edge_keys, keys)
    outside = cut[~np.isin(keys, edge_keys)]
    for _ in range(4):  # a chip beside a chip joins it, then the pair joins a piece
        joined = ~crossed
        G = sp.coo_matrix((np.ones(int(joined.sum())), (graph.f[joined], graph.g[joined])), shape=(m, m))
        _, piece = csgraph.connected_components(G, directed=False)
        least = np.zeros(m)
        np.maximum.at(least, piece, np.broadcast_to(np.asarray(fewest, dtype=np.float64), (m,)))
        held = np.bincount(piece, minlength=m) >= np.maximum(least, 1.0)
        if seeds is not None:
            held &= least > 0
            held[piece[seeds]] = True
        chip = ~held[piece[graph.f]] | ~held[piece[graph.g]]
        chip &= crossed & (piece[graph.f] != piece[graph.g])
        if not chip.any():
            break
        # each chip's longest cut boundary with another piece is opened
        small = np.where(~held[piece[graph.f]], piece[graph.f], piece[graph.g])
        other = np.where(~held[piece[graph.f]], piece[graph.g], piece[graph.f])
        e = np.flatnonzero(chip)
        key = pair_keys(small[e], other[e], m, ordered=True)
        pair, inverse = np.unique(key, return_inverse=True)
        length = np.bincount(inverse.ravel(), graph.cost[e], minlength=len(pair))
        owner = pair // m
        order = np.lexsort((pair, -length, owner))
        first = order[np.unique(owner[order], return_index=True)[1]]  # per chip, its longest boundary
        crossed[e[np.isin(key, pair[first])]] = False
    return np.vstack([outside, np.unique(graph.edges[crossed], axis=0).reshape(-1, 2)])
