"""Fill-reducing ordering for the sparse LU of Step 3: geometric nested dissection.

SciPy's SuperLU orders columns with COLAMD or MMD, which on a 2D mesh leave roughly
twice the fill of nested dissection and take about twice as long to factor (measured:
1.2 s against 0.47 s on a 100k-vertex grid). A surface mesh is two-dimensional, so
cutting it recursively with planes gives small separators: each domain is split by a
plane through its centroid, the vertices along the cut on the side that has fewer of
them form the separator, and separators are numbered after the two halves they
separate.

Which plane: a curved surface can cross a plane several times (a C-shaped strip cut
across its mouth leaves two separators where one cut across the strip would do), so
on every level with a domain larger than ``_COMPARE_ABOVE`` each domain tries the planes
normal to the three coordinate axes and to its principal axis of largest variance, and
keeps the one that cuts the fewest edges for its balance ((cut + 1) / smaller share, a
share of at least ``_BALANCE`` unless it is the widest axis). Deeper levels take the axis
of largest variance. Against the axis of largest variance alone (nnz of the LU of
the Step-3 matrix at 100k vertices): peaks 9.59M -> 9.03M, random S-surface 9.64M ->
8.72M, a 3/4-cylinder strip 12.2M -> 9.60M; at 1M vertices that strip factors in
26 s instead of 34 s. Medians instead of centroids gave 1-8% more fill.

Which vertices: a plane only sees geometry, and on irregular meshes the graph has
shortcuts it cannot see (a vertex of a long sliver touches many vertices across it). So
every domain larger than ``_FLOW_ABOVE`` then looks for the smallest vertex separator
among the vertices within ``_FLOW_HOPS`` edges of the plane's: a minimum cut between the
two rims of that band, one maximum flow (SciPy's Dinic) for all domains of the level, on
the band with every vertex split into an in- and an out-node joined by a unit arc. The
plane's separator is one of the cuts, so the flow never makes a separator larger. On the
irregular cylinder of the benchmark (1M vertices) the first separator shrinks from 984 to
500 vertices, the LU's fill from 159M to 115M and its time from 24 s to 11 s (its
ordering from 3.4 s to 5.4 s). On regular grids (peaks) the planes' cuts are already
minimal: once the cuts have saved less than ``_FLOW_GAIN`` of the planes' separator
vertices, the deeper levels skip them (peaks: after the first level).

All domains of one level are split together with array operations, so the cost is a
few passes over the edges per candidate and level, about 20 levels for a million
vertices, plus one flow per level with a domain larger than ``_FLOW_ABOVE``.
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp
from scipy.sparse.csgraph import breadth_first_order, maximum_flow

__all__ = ["nested_dissection"]

_COMPARE_ABOVE = 256  # levels with a domain larger than this compare four planes (fill: 1024 +2%, 4096 +4%)
_BALANCE = 0.25  # smallest share of a domain on either side of a plane other than the widest axis
_FLOW_ABOVE = 2000  # domains larger than this get the smallest separator near their plane's
_FLOW_HOPS = 2  # how near: within this many edges (3: 4% smaller separators, flow twice as slow)
_FLOW_GAIN = 0.05  # the cuts stop, planes alone go on, once they have saved less than this share


def _postorder(level: np.ndarray, node: np.ndarray, depth: int) -> np.ndarray:
    """Post-order position of node ``node`` on ``level`` in a perfect binary tree.

    The subtree of a node on level k holds ``2^(depth-k+1) - 1`` nodes; before node d
    come d such subtrees and, interleaved, the ``d - popcount(d)`` ancestors
    ``sum_j floor(d / 2^j)`` that close them.
    """
    size = (np.int64(2) << (depth - level)) - 1
    before = np.zeros_like(node)
    for j in range(1, depth + 1):  # one pass per tree level, not per vertex
        before += node >> j
    return node * size + before + size - 1


def _planes(q: tuple, d: np.ndarray, n_dom: int, cnt: np.ndarray, compare: bool) -> tuple[list, np.ndarray]:
    """Signed distances of the vertices being split to candidate cutting planes through
    their domain's centroid: a list of (a,) arrays, and per domain (n_dom,) which candidate
    is the plane across the axis of largest variance.

    ``q`` holds three (a,) columns, the coordinates relative to the centroid; ``d`` (a,)
    the domain of each vertex; ``cnt`` (n_dom,) the domain sizes. ``compare``: the planes
    normal to the three axes and to the principal axis of largest variance; otherwise
    only the one across the axis of largest variance."""
    var = np.stack([np.bincount(d, c * c, minlength=n_dom) for c in q])
    widest = np.argmax(var, axis=0)
    if not compare:
        return [np.choose(widest[d], q)], np.zeros(n_dom, dtype=np.int64)
    cov = np.empty((n_dom, 3, 3))
    for i in range(3):
        cov[:, i, i] = var[i]
        for j in range(i + 1, 3):
            cov[:, i, j] = cov[:, j, i] = np.bincount(d, q[i] * q[j], minlength=n_dom)
    axis = np.linalg.eigh(cov / cnt[:, None, None])[1][:, :, 2]
    return [*q, sum(c * axis[d, i] for i, c in enumerate(q))], widest


def _best_cut(bits: np.ndarray, k: int, widest, dom, act, ea, eb, size):
    """Per domain, the candidate plane that cuts the fewest edges relative to its balance.

    A plane that leaves less than ``_BALANCE`` of the domain on one side only counts if it
    is the one across the axis of largest variance (candidate ``widest``), so the tree is
    never less balanced than with that plane alone.

    ``bits`` (n,) holds, per vertex, which side of each of the ``k`` candidate planes it is
    on (bit j for plane j), so all candidates are counted with one gather and one
    ``bincount``. ``widest`` (n_dom,), ``dom`` (n,) the domain of every vertex, ``act``
    (a,) the vertices being split, ``ea``/``eb`` (e,) the edges inside them, ``size``
    (n_dom,) the number of vertices being split per domain. Returns the chosen side of
    every vertex (n,), the separator (n,) (the endpoints of cut edges on whichever side
    has fewer of them) and which edges were cut (e,).
    """
    n_dom = len(size)
    has = (np.arange(1 << k)[:, None] >> np.arange(k)) & 1  # (patterns, k): bit j set
    d = dom[act]
    n1 = np.bincount(d * (1 << k) + bits[act], minlength=n_dom << k).reshape(n_dom, -1) @ has
    balance = np.minimum(n1, size[:, None] - n1) / np.maximum(size, 1)[:, None]  # (n_dom, k)
    if k == 1:
        best = np.zeros(n_dom, dtype=np.uint8)
    else:  # the edge cut stands in for the separator size
        cut = np.bincount(dom[ea] * (1 << k) + (bits[ea] ^ bits[eb]), minlength=n_dom << k)
        cut = cut.reshape(n_dom, -1) @ has
        ok = (balance >= _BALANCE) | (np.arange(k) == widest[:, None])
        ok &= balance > 0  # a plane with everything on one side does not cut
        best = np.argmin(np.where(ok, (cut + 1) / np.where(ok, balance, 1.0), np.inf), axis=1).astype(np.uint8)
    side = ((bits >> best[dom]) & 1).astype(bool)
    flat = balance[np.arange(n_dom), best] == 0  # every candidate left one side empty
    if flat[d].any():  # coincident points: halve the domain by index instead
        grab = act[flat[d]]
        order = grab[np.argsort(dom[grab], kind="stable")]
        rank = np.arange(len(order)) - np.searchsorted(dom[order], dom[order])
        side[order] = rank >= size[dom[order]] // 2
    sa, sb = side[ea], side[eb]
    cross = sa != sb
    ca, cb, csa = ea[cross], eb[cross], sa[cross]
    n = len(dom)
    in1 = np.zeros(n, dtype=bool)
    in0 = np.zeros(n, dtype=bool)
    in1[np.where(csa, ca, cb)] = True
    in0[np.where(csa, cb, ca)] = True
    use1 = np.bincount(dom[in1], minlength=n_dom) <= np.bincount(dom[in0], minlength=n_dom)
    return side, np.where(use1[dom], in1, in0), cross


def _min_separator(side, sep, dom, big, ea, eb, hops):
    """The smallest vertex separator within ``hops`` edges of each big domain's plane separator.

    ``side``/``sep`` (n,) bool are the plane's split, ``dom`` (n,) the domain of every
    vertex, ``big`` (n_dom,) the domains to improve, ``ea``/``eb`` (e,) the edges inside
    the domains being split. Returns the new ``(side, sep)``; vertices outside the bands
    keep their side.

    In the band, every vertex is an in-node and an out-node joined by an arc of capacity 1;
    every edge is two arcs of unlimited capacity from out- to in-nodes; a source feeds the
    band's outermost vertices on side 0 and its outermost vertices on side 1 drain into a
    sink. A minimum cut then crosses only unit arcs: its vertices separate side 0 from
    side 1, and the plane's separator is one such cut. Unlimited is ``nb + 1``, more than
    any cut of unit arcs.
    """
    n, n_dom = len(dom), len(big)
    dist = np.full(n, hops + 1, dtype=np.int16)
    front = sep & big[dom]
    dist[front] = 0
    for k in range(1, hops + 1):
        reach = np.zeros(n, dtype=bool)
        reach[eb[front[ea]]] = True
        reach[ea[front[eb]]] = True
        front = reach & (dist > hops)
        dist[front] = k
    band = dist <= hops
    rim = dist == hops  # its neighbours outside the band are on its own side
    both = (np.bincount(dom[rim & ~side], minlength=n_dom) > 0) & (np.bincount(dom[rim & side], minlength=n_dom) > 0)
    band &= both[dom]  # a domain with no rim on one side has nothing to cut between
    B = np.flatnonzero(band)
    nb = len(B)
    if nb == 0:
        return side, sep
    loc = np.zeros(n, dtype=np.int32)
    loc[B] = np.arange(nb, dtype=np.int32)
    inside = band[ea] & band[eb]
    a, b = loc[ea[inside]], loc[eb[inside]]
    src, snk = loc[band & rim & ~side], loc[band & rim & side]
    S, T = 2 * nb, 2 * nb + 1
    rows = np.concatenate([np.arange(nb), nb + a, nb + b, np.full(len(src), S), nb + snk])
    cols = np.concatenate([nb + np.arange(nb), b, a, src, np.full(len(snk), T)])
    cap = np.full(len(rows), nb + 1, dtype=np.int32)
    cap[:nb] = 1
    C = sp.csr_matrix((cap, (rows, cols)), shape=(2 * nb + 2, 2 * nb + 2))
    R = (C - maximum_flow(C, S, T).flow).tocsr()  # residual capacities (the flow is antisymmetric)
    R.data[R.data < 0] = 0
    R.eliminate_zeros()
    reached = np.zeros(2 * nb + 2, dtype=bool)
    reached[breadth_first_order(R, S, directed=True, return_predecessors=False)] = True
    r_in, r_out = reached[:nb], reached[nb : 2 * nb]
    side, sep = side.copy(), sep.copy()
    sep[B] = r_in & ~r_out  # the cut's unit arcs
    side[B] = ~r_in
    return side, sep


def nested_dissection(points: np.ndarray, edges: np.ndarray, leaf: int = 32) -> np.ndarray:
    """Order vertices so that the LU of a mesh matrix fills in little.

    Parameters
    ----------
    points : (n, 3) float64
        Vertex positions (only used to choose cutting planes).
    edges : (e, 2) int
        The symmetric sparsity pattern, each undirected pair once (either direction).
    leaf : int
        Domains at most this large (at least 1) are not split further.

    Returns
    -------
    (n,) int64
        The elimination order: ``order[k]`` is the vertex eliminated k-th.
    """
    if leaf < 1:
        raise ValueError(f"leaf must be at least 1, got {leaf}")  # a one-vertex domain cannot be halved
    n = len(points)
    if n <= leaf:
        return np.arange(n)
    dom = np.zeros(n, dtype=np.int64)
    level_of = np.full(n, -1, dtype=np.int64)
    node_of = np.zeros(n, dtype=np.int64)
    active = np.ones(n, dtype=bool)
    P = np.asarray(points, dtype=np.float64)
    P = P - P.mean(axis=0)
    scale = np.abs(P).max()
    if np.isfinite(scale) and scale > 0:  # the planes do not depend on scale; squares must not overflow
        P /= scale
    xyz = [np.ascontiguousarray(P[:, c]) for c in range(3)]  # 1-D gathers
    e = np.asarray(edges)
    e = e[e[:, 0] != e[:, 1]]
    ea, eb = e[:, 0].astype(np.int32), e[:, 1].astype(np.int32)  # edges inside live, split domains
    bits = np.zeros(n, dtype=np.uint8)
    depth = 0
    flow, planes_sep, cut_sep = True, 0, 0
    while True:
        n_dom = 1 << depth
        size = np.bincount(dom[active], minlength=n_dom)
        split = size > leaf
        if not split.any():
            break
        act = np.flatnonzero(active & split[dom])
        d = dom[act]
        cnt = np.maximum(size, 1)
        q = []
        for c in xyz:
            c = c[act]
            q.append(c - (np.bincount(d, c, minlength=n_dom) / cnt)[d])
        planes, widest = _planes(tuple(q), d, n_dom, cnt, compare=size.max() > _COMPARE_ABOVE)
        packed = np.zeros(len(act), dtype=np.uint8)
        for j, c in enumerate(planes):
            packed |= (c > 0.0).view(np.uint8) << j
        bits[:] = 0
        bits[act] = packed
        side, sep, cross = _best_cut(bits, len(planes), widest, dom, act, ea, eb, size)
        if flow and size.max() > _FLOW_ABOVE:
            planes_sep += int(sep.sum())
            side, sep = _min_separator(side, sep, dom, size > _FLOW_ABOVE, ea, eb, _FLOW_HOPS)
            cross = side[ea] != side[eb]
            cut_sep += int(sep.sum())
            flow = cut_sep < (1.0 - _FLOW_GAIN) * planes_sep  # worth its time on this mesh?
        level_of[sep] = depth
        node_of[sep] = dom[sep]
        active &= ~sep
        dom = 2 * dom + side
        depth += 1
        # keep the edges that stay inside one live domain that will be split again
        next_split = np.bincount(dom[active], minlength=2 * n_dom) > leaf
        keep = ~cross
        keep &= active[ea]
        keep &= active[eb]
        keep &= next_split[dom[ea]]
        ea, eb = ea[keep], eb[keep]
    level_of[active] = depth
    node_of[active] = dom[active]
    key = _postorder(level_of, node_of, depth)
    return np.argsort(key, kind="stable")
