"""Cuts that open every island that is not a topological disk (closed, with handles, with
several boundary loops, non-orientable) into one.
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp
from scipy.sparse import csgraph
from scipy.sparse.linalg import splu

from ..errors import SolverError
from ..geometry import TINY, edge_lengths, face_areas
from .halfedges import HalfEdges, orientation, pair_keys, split

__all__ = ["cut_to_disks"]


def cut_to_disks(Vu, Fs, vertex_of, he, he0, face_island, todo, area, inner, flip, keep):
    """Cut the islands in ``todo`` into disks, working on their faces alone.

    The cut graph, the orientation along it and the split run on the sub-mesh of the
    faces to cut (often a few islands of many); the other islands keep their vertices.
    Split vertices keep the order of :func:`.halfedges.split` on the whole mesh: by old split
    vertex, then by first corner, both increasing in the sub-mesh's numbering. Lengths
    are compared within the sub-mesh only, so the disks beside an island never break a
    tie between two of its equally short cuts.

    Returns ``(Fs, vertex_of, flip, cut_edges)`` for the whole mesh; ``cut_edges`` are
    input-vertex pairs, sorted like the undirected edges they were.
    """
    ns, m = len(vertex_of), len(Fs)
    sub = np.flatnonzero(todo[face_island])
    whole = len(sub) == m
    used = np.zeros(ns, dtype=bool)
    used[Fs[sub].ravel()] = True
    sv = np.arange(ns) if whole else np.flatnonzero(used)
    rank = np.cumsum(used, dtype=np.int64) - 1
    Fsub = Fs if whole else rank[Fs[sub]]
    hsub = he if whole else HalfEdges(Fsub, len(sv))
    isl_sub = face_island[sub]
    keys = np.flatnonzero(inner)
    inner_sub = np.zeros(hsub.n_edges, dtype=bool)
    if keys.size:  # the same edges over the sub-mesh's vertices
        n = len(Vu)
        ev0 = he0.edge_vertices[keys]
        ev = np.sort(vertex_of[sv[hsub.edge_vertices]], axis=1)
        inner_sub = np.isin(pair_keys(ev[:, 0], ev[:, 1], n), pair_keys(ev0[:, 0], ev0[:, 1], n))
    n_islands = len(todo)
    X = Vu[vertex_of[sv]]
    cut = _cut_graph(X, Fsub, hsub, isl_sub, todo, inner_sub, keep[vertex_of[sv]])
    area = face_areas(X, Fsub) if area is None else area[sub]
    flip = flip.copy()
    flip[sub] = _orient_cut(Fsub, hsub, isl_sub, n_islands, area, cut, flip[sub], todo)
    F2, of2 = split(Fsub, len(sv), cut, hsub)
    cut_edges = np.sort(vertex_of[sv[hsub.edge_vertices[cut]]], axis=1)
    if whole:
        return F2, vertex_of[of2], flip, cut_edges
    keep = np.flatnonzero(~used)  # the other islands' vertices, first and in order
    new_id = np.empty(ns, dtype=np.int64)
    new_id[keep] = np.arange(len(keep))
    out = new_id[Fs]
    out[sub] = F2 + len(keep)
    return out, np.concatenate([vertex_of[keep], vertex_of[sv[of2]]]), flip, cut_edges


def _two_core(ns: int, edges: np.ndarray) -> np.ndarray:
    """Which edges belong to the 2-core of a graph (what pruning degree-1 vertices leaves).

    A spanning forest is rooted at a virtual vertex; a tree edge survives iff both sides
    of it hold an endpoint of a non-tree edge, and every non-tree edge survives. Subtree
    sums come from one sparse unit-triangular solve in breadth-first order, so no loop
    runs over vertices.

    Parameters
    ----------
    ns : int
        Number of vertices.
    edges : (k, 2) int64
        Distinct undirected edges.

    Returns
    -------
    (k,) bool
    """
    k = len(edges)
    if k == 0:
        return np.zeros(0, dtype=bool)
    r = ns  # the virtual root
    a, b = edges[:, 0], edges[:, 1]
    graph = sp.coo_matrix((np.ones(k), (a, b)), shape=(ns + 1, ns + 1)).tocsr()
    graph = graph + graph.T
    involved = np.zeros(ns + 1, dtype=bool)
    involved[edges.ravel()] = True
    _, comp = csgraph.connected_components(graph, directed=False)
    members = np.flatnonzero(involved)
    roots = members[np.unique(comp[members], return_index=True)[1]]
    link = sp.coo_matrix((np.ones(len(roots)), (np.full(len(roots), r), roots)), shape=(ns + 1, ns + 1))
    order, pred = csgraph.breadth_first_order(
        (graph + link + link.T).tocsr(), r, directed=False, return_predecessors=True
    )
    tree_a = pred[a] == b
    tree_b = pred[b] == a
    is_tree = tree_a | tree_b
    child = np.where(tree_a, a, b)
    ends = np.bincount(edges[~is_tree].ravel(), minlength=ns + 1).astype(np.float64)
    # subtree sums s solve (I - C) s = ends, C[parent, child] = 1: upper triangular in BFS order
    pos = np.empty(ns + 1, dtype=np.int64)
    pos[order] = np.arange(len(order))
    nn = len(order)
    kids = order[1:]
    U = sp.coo_matrix(
        (
            np.concatenate([np.ones(nn), -np.ones(nn - 1)]),
            (np.concatenate([np.arange(nn), pos[pred[kids]]]), np.concatenate([np.arange(nn), pos[kids]])),
        ),
        shape=(nn, nn),
    ).tocsc()
    sub = np.zeros(ns + 1)
    sub[order] = splu(U, permc_spec="NATURAL", diag_pivot_thresh=0.0).solve(ends[order])
    comp_total = np.zeros(comp.max() + 1)
    comp_total[comp[roots]] = sub[roots]
    inside = sub[child]
    outside = comp_total[comp[child]] - inside
    return ~is_tree | ((inside > 0.5) & (outside > 0.5))


def _cut_graph(X, Fs, he, face_island, todo, inner, keep):
    """Edges to cut so that every island in ``todo`` becomes a topological disk.

    Tree-cotree with shortest paths, after Erickson & Whittlesey (2005), "Greedy optimal
    homotopy and homology generators":

    1. T: a shortest-path forest grown from every boundary vertex of the island (from
       one far-away root if it is closed);
    2. D: a maximum spanning tree of the dual graph over the edges not in T, weighted by
       the length of the loop an edge closes through T;
    3. the faces glued along D form a disk bounded by every edge D does not cross;
       zipping back dangling edges leaves the 2-core of those edges: the boundary plus
       the short loops (one per handle) and paths (one per extra boundary loop) to cut.

    A closed island of genus 0 has an empty cut graph; it is cut along the shortest path
    from the root to the vertex farthest from it, at least two edges long.

    Edges flagged ``inner`` (polygon diagonals) cost more than any path without them in
    T and in the genus-0 path, and join D first, so they are cut only when nothing else
    opens the island. A closed island's root is a vertex not flagged in ``keep`` (ns,)
    bool if it has one (every loop of its cut graph passes through the root).

    Returns a boolean mask over the undirected edges of ``he``.
    """
    g = _EdgeGraph(X, Fs, he, face_island, inner)
    boundary_edge = he.edge_count == 1
    on_bnd = np.zeros(g.ns, dtype=bool)
    on_bnd[g.ev[boundary_edge].ravel()] = True
    sources = np.flatnonzero(on_bnd & todo[g.v_isl])
    closed = np.flatnonzero(todo & (np.bincount(g.e_isl[boundary_edge], minlength=len(todo)) == 0))
    roots = _roots(g, closed, keep, len(todo))
    cut = _tree_cotree(g, he, face_island, todo, inner, np.concatenate([sources, roots])) & ~boundary_edge
    # closed genus-0 islands: nothing to cut yet; open them from the root to the farthest vertex
    has_cut = np.bincount(g.e_isl[cut], minlength=len(todo)) > 0
    sphere = ~has_cut[closed]
    if sphere.any():
        cut[_farthest_paths(g, closed[sphere], roots[sphere], keep)] = True
    return cut


class _EdgeGraph:
    """The mesh's edges as a weighted graph for the cuts: 3D lengths, plus ``tiny`` (csgraph
    ignores zero weights), and polygon diagonals longer than any simple path of other
    edges; the island of every edge and vertex (-1 for vertices of no face)."""

    def __init__(self, X, Fs, he, face_island, inner):
        self.ns = ns = len(X)
        self.ev = ev = he.edge_vertices
        self.length = edge_lengths(X, ev)
        self.tiny = 1e-12 * max(float(self.length.max()), TINY)
        w = self.length + self.tiny
        w[inner] += w.sum()
        self.w = w
        self.graph = sp.coo_matrix((w, (ev[:, 0], ev[:, 1])), shape=(ns, ns)).tocsr()
        self.e_isl = np.empty(he.n_edges, dtype=np.int64)
        self.e_isl[he.edge] = np.repeat(face_island, 3)
        self.v_isl = np.full(ns, -1, dtype=np.int64)
        self.v_isl[Fs.ravel()] = np.repeat(face_island, 3)
        self.key = pair_keys(ev[:, 0], ev[:, 1], ns, ordered=True)  # sorted: edges are numbered by key

    def edges(self, a: np.ndarray, b: np.ndarray) -> np.ndarray:
        """The edge numbers of the vertex pairs (a, b) (each an edge)."""
        return np.searchsorted(self.key, pair_keys(a, b, self.ns))


def _roots(g: _EdgeGraph, closed: np.ndarray, keep: np.ndarray, n_islands: int) -> np.ndarray:
    """Per closed island, the vertex farthest from its lowest-numbered vertex (the lowest
    numbered of the farthest), avoiding ``keep`` vertices where another can be."""
    if not closed.size:
        return np.zeros(0, dtype=np.int64)
    ns, v_isl = g.ns, g.v_isl
    used = v_isl >= 0
    first_v = np.full(n_islands, ns, dtype=np.int64)
    np.minimum.at(first_v, v_isl[used], np.flatnonzero(used))
    d0 = csgraph.dijkstra(g.graph, directed=False, indices=first_v[closed], min_only=True)
    far = np.where(np.isfinite(d0), d0, -1.0)
    far = np.where(keep & (far >= 0), -0.5, far)  # vertices to keep whole root it only if nothing else can
    best = np.full(n_islands, -np.inf)
    np.maximum.at(best, v_isl[used], far[used])
    hit = (far == best[np.maximum(v_isl, 0)]) & used & np.isin(v_isl, closed)
    root_of = np.full(n_islands, ns, dtype=np.int64)
    np.minimum.at(root_of, v_isl[used], np.where(hit, np.arange(ns), ns)[used])
    return root_of[closed]


def _tree_cotree(g: _EdgeGraph, he, face_island, todo, inner, sources) -> np.ndarray:
    """Steps 1-3 of :func:`_cut_graph`: the cut graph of the islands in ``todo`` from the
    shortest-path forest grown from ``sources`` (k,), as a mask over the edges."""
    m = len(face_island)
    ev = g.ev
    dist, pred, _ = csgraph.dijkstra(g.graph, directed=False, indices=sources, min_only=True, return_predecessors=True)
    # T: the edge from every reached non-source vertex to its predecessor
    child = np.flatnonzero(pred >= 0)
    in_T = np.zeros(he.n_edges, dtype=bool)
    in_T[g.edges(child, pred[child])] = True
    # D: maximum spanning tree of the dual over interior edges outside T
    h = np.flatnonzero((he.twin > np.arange(3 * m)) & todo[face_island[np.arange(3 * m) // 3]])
    h = h[~in_T[he.edge[h]]]
    e = he.edge[h]
    reach = np.where(np.isfinite(dist), dist, 0.0)
    loop = reach[ev[e, 0]] + reach[ev[e, 1]] + g.length[e]
    weight = (loop.max(initial=0.0) - loop) + g.tiny + TINY  # minimum of this = maximum loop
    weight[inner[e]] = 0.5 * g.tiny + TINY  # below every other: diagonals are crossed, not cut
    dual = sp.coo_matrix((weight, (h // 3, he.twin[h] // 3)), shape=(m, m)).tocsr()
    tree = csgraph.minimum_spanning_tree(dual).tocoo()
    fkey = np.sort(pair_keys(tree.row, tree.col, m))  # (scipy's rows are int32)
    hkey = pair_keys(h // 3, he.twin[h] // 3, m)
    crossed = np.zeros(he.n_edges, dtype=bool)
    if fkey.size:
        pos = np.minimum(np.searchsorted(fkey, hkey), fkey.size - 1)
        crossed[e[fkey[pos] == hkey]] = True
    candidate = np.flatnonzero(todo[g.e_isl] & ~crossed)
    cut = np.zeros(he.n_edges, dtype=bool)
    cut[candidate[_two_core(g.ns, ev[candidate])]] = True
    return cut


def _farthest_paths(g: _EdgeGraph, islands: np.ndarray, roots: np.ndarray, keep: np.ndarray) -> np.ndarray:
    """For closed genus-0 ``islands`` (k,), the edges of the shortest path from each one's
    root (k,) to its farthest vertex (not a ``keep`` vertex if another can be), at least
    two edges long: one edge would open nothing (its two sides join the same two
    vertices). All islands at once: they are disconnected, so one Dijkstra from every
    root gives each vertex its own island's distance."""
    ns, v_isl = g.ns, g.v_isl
    dist, pred, _ = csgraph.dijkstra(g.graph, directed=False, indices=roots, min_only=True, return_predecessors=True)
    slot = np.full(int(v_isl.max()) + 1, -1, dtype=np.int64)
    slot[islands] = np.arange(len(islands))
    mine = slot[np.maximum(v_isl, 0)]
    mine[v_isl < 0] = -1
    inside = mine >= 0
    is_root = np.zeros(ns, dtype=bool)
    is_root[roots] = True
    other = ~keep & ~is_root
    has_other = np.bincount(mine[inside & other], minlength=len(islands)) > 0
    far = np.where(np.isfinite(dist), dist, -1.0)
    far = np.where(has_other[np.maximum(mine, 0)] & ~other, -1.0, far)  # the far end: not kept if avoidable
    best = np.full(len(islands), -np.inf)
    np.maximum.at(best, mine[inside], far[inside])
    hit = inside & (far == best[np.maximum(mine, 0)])
    end = np.full(len(islands), ns, dtype=np.int64)
    np.minimum.at(end, mine[inside], np.where(hit, np.arange(ns), ns)[inside])
    # a path of one edge goes on to the end's cheapest neighbour that is not the root
    short = pred[end] == roots
    if short.any():
        at = np.flatnonzero(np.isin(g.ev[:, 0], end[short]) | np.isin(g.ev[:, 1], end[short]))
        a, b = g.ev[at, 0], g.ev[at, 1]
        pos = np.full(ns, -1, dtype=np.int64)
        pos[end[short]] = np.flatnonzero(short)
        owner = np.where(pos[a] >= 0, pos[a], pos[b])  # which short path's end this edge is at
        nb = np.where(pos[a] >= 0, b, a)
        ok = nb != roots[owner]
        order = np.lexsort((at[ok], g.w[at[ok]], owner[ok]))  # cheapest, then lowest edge number
        first = order[np.unique(owner[ok][order], return_index=True)[1]]
        extra_a, extra_b = nb[ok][first], end[owner[ok][first]]
    else:
        extra_a = extra_b = np.zeros(0, dtype=np.int64)
    pieces = [g.edges(extra_a, extra_b)]
    cur, stop = end, roots
    while cur.size:  # one step along every path at once; as many rounds as the longest path
        prev = pred[cur]
        pieces.append(g.edges(cur, prev))
        going = prev != stop
        cur, stop = prev[going], stop[going]
    return np.concatenate(pieces)


def _orient_cut(Fs, he, face_island, n_islands, area, cut, flip, todo):
    """Orient the islands being cut along their uncut edges (a spanning tree suffices)."""
    m = len(Fs)
    h = np.flatnonzero((he.twin > np.arange(3 * m)) & ~cut[he.edge])
    f2, orientable = orientation(Fs, he, face_island, n_islands, area, tree_only=h)
    if not orientable[todo].all():  # pragma: no cover - the cut removes every orientation reversal
        raise SolverError("cut islands are still non-orientable")
    return np.where(todo[face_island], f2, flip)
