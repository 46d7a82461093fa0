"""Beyond the paper: islands that overlap themselves are cut where their overlapping parts
are least apart.

An island laid out near-isometrically can fold over its own boundary (a strip that winds
more than a turn, an island with a hole opened by a slit): two places of the model then
share texels. No flip shows it; :mod:`.overlap` finds it exactly. Here every such island
is cut in two by the shortest seam that separates its overlapping layers: a minimum cut
of its faces' adjacency graph, edge capacities the 3D edge lengths (polygon diagonals
never cut), between the faces on either side of its largest overlap (Ford & Fulkerson's
max-flow/min-cut, scipy's Dinic). The two parts are solved again, alone
(:func:`.resolve.solve_islands`), and put back (:func:`.resolve.combine`); parts that
still overlap are cut again, a few rounds at most. All overlapping islands are cut in
one flow problem: they are disconnected, so one flow separates each.
"""

from __future__ import annotations

import time
from dataclasses import replace

import numpy as np
import scipy.sparse as sp
from scipy.sparse import csgraph

from .options import Options, Problem
from .overlap import shared_area
from .resolve import combine, pairs, solve_islands
from .result import Parametrization
from .topology import Topology, build_topology

__all__ = ["without_overlaps"]

_ROUNDS = 6  # cut, solve again, check: at most this many times


def without_overlaps(first: Parametrization, problem: Problem, options: Options) -> Parametrization:
    """``first`` with every island that overlaps itself cut in two and solved again, until
    none does or ``_ROUNDS`` rounds have been tried (what is left is warned about)."""
    result = first
    t0 = time.perf_counter()
    cuts = first.cut_edges
    for _ in range(_ROUNDS):  # a handful of rounds, each one solve of the islands cut
        bad = np.flatnonzero(result.islands.crossings > 0)
        if not bad.size:
            break
        seams = np.vstack([pairs(problem.seams), cuts])
        _, _, topo = build_topology(
            result.vertices, result.faces, seams, options.split_nonmanifold, problem.inner_edges
        )
        new = _separating_cuts(result, topo, problem.inner_edges)
        if not len(new):
            break
        cuts = np.vstack([cuts, new])
        # the parts go on from the island's layout (fold-free, overlapping only across the cut)
        start = result.corner_uv if options.refine else None
        trying = replace(
            problem, vertices=result.vertices, faces=result.faces, seams=np.vstack([seams, new]), start=start
        )
        part = solve_islands(trying, np.flatnonzero(np.isin(result.face_island, bad)), options)
        # the parts' own automatic cuts (a part that is an annulus is cut open) are seams too
        cuts = np.vstack([cuts, part.cut_edges])
        result = combine(
            result, [part], replace(trying, seams=np.vstack([pairs(problem.seams), cuts]), start=None), options
        )
        result.cut_edges, result.cut_islands = cuts, first.cut_islands
        result.stats.overlap_cuts += len(new)
    result.timings.untangle = first.timings.untangle + time.perf_counter() - t0
    result.timings.total = first.timings.total + result.timings.untangle
    return result


def _separating_cuts(result: Parametrization, topo: Topology, inner_edges) -> np.ndarray:
    """For every island of ``result`` that overlaps itself, the mesh edges (k, 2 vertex
    pairs) of the shortest cut between the two layers of its largest overlap."""
    i, j = result.overlaps().pairs
    if not len(i):
        return np.zeros((0, 2), dtype=np.int64)
    m = len(result.faces)
    he = topo.he
    h = np.flatnonzero(he.twin > np.arange(3 * m))  # interior, uncut: the faces' adjacency
    f, g = h // 3, he.twin[h] // 3
    # the two faces of an overlap lie in different layers of the island: colour the faces
    # of every group of overlaps (the pairs linked through shared faces) by the parity of
    # their distance from the group's largest overlap, and cut between the two colours
    area = shared_area(result.corner_uv[i], result.corner_uv[j])
    pair_graph = sp.coo_matrix((np.ones(len(i)), (i, j)), shape=(m, m)).tocsr()
    group = csgraph.connected_components(pair_graph, directed=False)[1][i]
    order = np.lexsort((-area, group))
    best = order[np.unique(group[order], return_index=True)[1]]  # each group's largest overlap
    hops = csgraph.dijkstra(pair_graph, directed=False, unweighted=True, indices=i[best], min_only=True)
    reached = np.isfinite(hops)
    parity = np.where(reached, hops, 0).astype(np.int64) % 2
    source = reached & (parity == 0)
    sink = reached & (parity == 1)
    return _minimum_cut(result, topo, f, g, h, source, sink, inner_edges)


def _minimum_cut(result, topo: Topology, f, g, h, source, sink, inner_edges) -> np.ndarray:
    """The mesh edges crossed by a minimum cut between the ``source`` and ``sink`` faces
    (m,) bool over the adjacency (f, g) across half-edges ``h``."""
    m = len(result.faces)
    V = result.vertices
    ev = topo.he.edge_vertices[topo.he.edge[h]]  # split vertices of the edges crossed
    a, b = topo.vertex_of[ev[:, 0]], topo.vertex_of[ev[:, 1]]
    length = np.linalg.norm(V[a] - V[b], axis=1)
    typical = float(np.median(length[length > 0])) if (length > 0).any() else 1.0
    capacity = 1 + np.minimum(np.round(1000.0 * length / typical), 1e6).astype(np.int64)
    inner = _mesh_edge_mask(a, b, len(V), inner_edges)
    capacity[inner] = 1 << 24  # a polygon's diagonal is never cut (a corner would need two UVs)
    S, T = m, m + 1
    big = int(min(capacity.sum() + 1, 1 << 30))
    rows = np.concatenate([f, g, np.full(source.sum(), S), np.flatnonzero(sink)])
    cols = np.concatenate([g, f, np.flatnonzero(source), np.full(sink.sum(), T)])
    caps = np.concatenate([capacity, capacity, np.full(source.sum(), big), np.full(sink.sum(), big)])
    graph = sp.csr_matrix((caps.astype(np.int32), (rows, cols)), shape=(m + 2, m + 2))
    flow = csgraph.maximum_flow(graph, S, T).flow
    residual = (graph - flow).tocsr()
    residual.data = (residual.data > 0).astype(np.int8)
    residual.eliminate_zeros()
    reach = csgraph.breadth_first_order(residual, S, directed=True, return_predecessors=False)
    side = np.zeros(m + 2, dtype=bool)
    side[reach] = True
    crossed = side[f] != side[g]
    return np.unique(np.sort(np.stack([a[crossed], b[crossed]], axis=1), axis=1), axis=0)


def _mesh_edge_mask(a: np.ndarray, b: np.ndarray, n: int, inner_edges) -> np.ndarray:
    """Which mesh vertex pairs (a, b) are among ``inner_edges``."""
    inner = pairs(inner_edges)
    if not len(inner):
        return np.zeros(len(a), dtype=bool)
    key = np.minimum(a, b) * np.int64(n) + np.maximum(a, b)
    ikey = np.minimum(inner[:, 0], inner[:, 1]) * np.int64(n) + np.maximum(inner[:, 0], inner[:, 1])
    return np.isin(key, ikey)
