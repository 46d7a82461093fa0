"""Cuts that open every island that is not a topological disk (closed, with handles, with
several boundary loops, non-orientable) into one.
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp
from scipy.sparse import csgraph
from scipy.sparse.linalg import splu

from .errors import SolverError
from .geometry import face_areas
from .mesh import HalfEdges, orientation, split

__all__ = ["cut_to_disks"]


def cut_to_disks(Vu, Fs, vertex_of, he, he0, face_island, todo, area, inner, flip, keep):
    """Cut the islands in ``todo`` into disks, working on their faces alone.

    The cut graph, the orientation along it and the split run on the sub-mesh of the
    faces to cut (often a few islands of many); the other islands keep their vertices.
    Split vertices keep the order of :func:`.mesh.split` on the whole mesh: by old split
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
        inner_sub = np.isin(ev[:, 0] * np.int64(n) + ev[:, 1], ev0[:, 0] * np.int64(n) + ev0[:, 1])
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
    ns = len(X)
    m = len(Fs)
    ev = he.edge_vertices
    length = np.linalg.norm(X[ev[:, 0]] - X[ev[:, 1]], axis=1)
    tiny = 1e-12 * max(float(length.max()), 1e-300)
    w = length + tiny  # csgraph ignores zero weights
    w[inner] += w.sum()  # longer than any simple path of other edges
    graph = sp.coo_matrix((w, (ev[:, 0], ev[:, 1])), shape=(ns, ns)).tocsr()
    e_isl = np.empty(he.n_edges, dtype=np.int64)
    e_isl[he.edge] = np.repeat(face_island, 3)
    v_isl = np.full(ns, -1, dtype=np.int64)
    v_isl[Fs.ravel()] = np.repeat(face_island, 3)
    boundary_edge = he.edge_count == 1
    on_bnd = np.zeros(ns, dtype=bool)
    on_bnd[ev[boundary_edge].ravel()] = True
    sources = np.flatnonzero(on_bnd & todo[v_isl])
    closed = np.flatnonzero(todo & (np.bincount(e_isl[boundary_edge], minlength=len(todo)) == 0))
    roots = np.zeros(0, dtype=np.int64)
    if closed.size:
        first_v = np.full(len(todo), ns, dtype=np.int64)
        np.minimum.at(first_v, v_isl[v_isl >= 0], np.flatnonzero(v_isl >= 0))
        d0 = csgraph.dijkstra(graph, directed=False, indices=first_v[closed], min_only=True)
        far = np.where(np.isfinite(d0), d0, -1.0)
        far = np.where(keep & (far >= 0), -0.5, far)  # vertices to keep whole root it only if nothing else can
        roots = np.full(len(todo), -1, dtype=np.int64)
        best = np.full(len(todo), -np.inf)
        np.maximum.at(best, v_isl[v_isl >= 0], far[v_isl >= 0])
        hit = (far == best[np.maximum(v_isl, 0)]) & (v_isl >= 0) & np.isin(v_isl, closed)
        cand = np.where(hit, np.arange(ns), ns)
        root_of = np.full(len(todo), ns, dtype=np.int64)
        np.minimum.at(root_of, v_isl[v_isl >= 0], cand[v_isl >= 0])
        roots = root_of[closed]
    dist, pred, _ = csgraph.dijkstra(
        graph, directed=False, indices=np.concatenate([sources, roots]), min_only=True, return_predecessors=True
    )
    # T: the edge from every reached non-source vertex to its predecessor
    child = np.flatnonzero(pred >= 0)
    tkey = np.sort(np.minimum(child, pred[child]) * np.int64(ns) + np.maximum(child, pred[child]))
    ekey = ev[:, 0] * np.int64(ns) + ev[:, 1]
    in_T = np.zeros(he.n_edges, dtype=bool)
    in_T[np.searchsorted(ekey, tkey)] = True
    # D: maximum spanning tree of the dual over interior edges outside T
    h = np.flatnonzero((he.twin > np.arange(3 * m)) & todo[face_island[np.arange(3 * m) // 3]])
    h = h[~in_T[he.edge[h]]]
    e = he.edge[h]
    loop = (
        np.where(np.isfinite(dist[ev[e, 0]]), dist[ev[e, 0]], 0)
        + np.where(np.isfinite(dist[ev[e, 1]]), dist[ev[e, 1]], 0)
        + length[e]
    )
    weight = (loop.max(initial=0.0) - loop) + tiny + 1e-300  # minimum of this = maximum loop
    weight[inner[e]] = 0.5 * tiny + 1e-300  # below every other: diagonals are crossed, not cut
    dual = sp.coo_matrix((weight, (h // 3, he.twin[h] // 3)), shape=(m, m)).tocsr()
    tree = csgraph.minimum_spanning_tree(dual).tocoo()
    # int64 before the product: scipy's rows are int32, and numpy 1.26 (Blender's) keeps
    # int32 * np.int64(m) in int32 when m fits; past 46,341 faces the keys wrapped around
    r, c = tree.row.astype(np.int64), tree.col.astype(np.int64)
    fkey = np.sort(np.minimum(r, c) * m + np.maximum(r, c))
    f, g = h // 3, he.twin[h] // 3
    hkey = np.minimum(f, g) * np.int64(m) + np.maximum(f, g)
    crossed = np.zeros(he.n_edges, dtype=bool)
    if fkey.size:
        pos = np.minimum(np.searchsorted(fkey, hkey), fkey.size - 1)
        crossed[e[fkey[pos] == hkey]] = True
    cand_idx = np.flatnonzero(todo[e_isl] & ~crossed)
    core = _two_core(ns, ev[cand_idx])
    cut = np.zeros(he.n_edges, dtype=bool)
    cut[cand_idx[core]] = True
    cut &= ~boundary_edge
    # closed genus-0 islands: nothing to cut yet; open them from the root to the farthest vertex
    has_cut = np.bincount(e_isl[cut], minlength=len(todo)) > 0
    sphere = np.intersect1d(closed, np.flatnonzero(~has_cut))
    for isl in sphere:  # one iteration per closed genus-0 island, not per vertex
        inside = np.flatnonzero(v_isl == isl)
        r = int(roots[np.searchsorted(closed, isl)])
        d1, p1 = csgraph.dijkstra(graph, directed=False, indices=r, return_predecessors=True)
        far1 = d1[inside]
        other = ~keep[inside] & (inside != r)  # the far end: not a vertex to keep whole if another can be
        if other.any():
            far1 = np.where(other, far1, -1.0)
        b = int(inside[np.argmax(far1)])  # never r: every other vertex is farther
        path = [b]
        while path[-1] != r:  # walks one path, O(sqrt(n)) steps on a typical mesh
            path.append(int(p1[path[-1]]))
        if len(path) == 2:
            # one edge opens nothing (its two sides join the same two vertices, which
            # is still one edge): go on to the neighbour of b costing least that is not
            # r (from the edge list: ``graph`` holds each edge once, at its lower vertex;
            # reading b's row alone found none, or only r, on small closed meshes)
            at = np.flatnonzero((ev[:, 0] == b) | (ev[:, 1] == b))
            nb = np.where(ev[at, 0] == b, ev[at, 1], ev[at, 0])
            path.insert(0, int(nb[np.argmin(np.where(nb == r, np.inf, w[at]))]))
        p = np.asarray(path, dtype=np.int64)
        pk = np.minimum(p[:-1], p[1:]) * np.int64(ns) + np.maximum(p[:-1], p[1:])
        cut[np.searchsorted(ekey, pk)] = True
    return cut


def _orient_cut(Fs, he, face_island, n_islands, area, cut, flip, todo):
    """Orient the islands being cut along their uncut edges (a spanning tree suffices)."""
    m = len(Fs)
    h = np.flatnonzero((he.twin > np.arange(3 * m)) & ~cut[he.edge])
    f2, orientable = orientation(Fs, he, face_island, n_islands, area, tree_only=h)
    if not orientable[todo].all():  # pragma: no cover - the cut removes every orientation reversal
        raise SolverError("cut islands are still non-orientable")
    return np.where(todo[face_island], f2, flip)
