"""Islands that overlap themselves in UV space: exact detection, the faces involved, and
the area covered twice.

A layout without folds maps each island, a topological disk, one-to-one exactly when its
boundary is a simple closed curve (the number of times a point is covered is the winding
number of the boundary around it). So an island overlaps itself iff two of its boundary
edges cross, which :func:`crossings` tests exactly (orientation signs) after a uniform
grid has paired the edges whose boxes meet. The faces that overlap, and the area they
share, come from the same grid over triangles and a separating-axis test
(:func:`overlapping_faces`), then clipping one triangle by the other (:func:`shared_area`).

Everything runs on whole arrays: the grids pair items cell by cell with ``np.repeat``;
no loop runs over faces, edges or islands (only over a few size classes).
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from .geometry import TINY, corner_signed_areas, det2
from .mesh.halfedges import pair_keys, unique_sorted

__all__ = [
    "Overlaps",
    "boundary_crossings",
    "box_pairs",
    "crossings",
    "overlapping_faces",
    "self_overlaps",
    "shared_area",
    "uv_points",
]


_SWEPT = 64  # the sweep is kept while it tests at most this many pairs per item; else the grid


def box_pairs(
    lo: np.ndarray,
    hi: np.ndarray,
    group: np.ndarray,
    cell: float,
    query: np.ndarray | None = None,
    across: np.ndarray | None = None,
):
    """Pairs (i < j) of items whose boxes ``lo``/``hi`` (k, 2) meet and that belong to the
    same ``group`` (k,): (p,) and (p,) int64, sorted, each pair once. With ``query`` (k,)
    bool, only the pairs that hold a query item. With ``across`` (k,) bool, only the pairs
    of an item not ``across`` (i) with one that is (j): points against segments, say, with
    no pair of two points or two segments made at all.

    First a sweep along u (:func:`_swept`): a few whole-array passes, which is what a
    boundary of a few hundred edges needs. Where boxes stack along u (a straight boundary
    running along v, a layout with many islands side by side) the sweep would test too
    many pairs, and a grid of cells about ``cell`` wide pairs them instead
    (:func:`_pairs_in_cells`).
    """
    k = len(lo)
    empty = np.zeros(0, dtype=np.int64)
    if k < 2 or (query is not None and not query.any()):
        return empty, empty
    swept = _swept(lo[:, 0], hi[:, 0], group, across, _SWEPT * k)
    if swept is None:
        return _pairs_in_cells(lo, hi, group, cell, query, across)
    i, j = swept
    if query is not None:
        asked = query[i] | query[j]
        i, j = i[asked], j[asked]
    lo_v, hi_v = lo[:, 1], hi[:, 1]
    meet = (lo_v[i] <= hi_v[j]) & (lo_v[j] <= hi_v[i])
    i, j = i[meet], j[meet]
    pair = np.sort(pair_keys(i, j, k, ordered=across is not None))
    return pair // k, pair % k


def _swept(lo_u: np.ndarray, hi_u: np.ndarray, group: np.ndarray, across: np.ndarray | None, limit: int):
    """The pairs of items of one ``group`` whose intervals ``lo_u``..``hi_u`` (k,) meet, by a
    sweep: the ends of every interval sorted (by group, then u, starts before ends), the
    pair of i and j is made once, from the one whose start comes first, as the other's
    start lies between its start and its end. With ``across``, only pairs of an item not
    across with one that is, in that order. None if they would be more than ``limit``."""
    k = len(lo_u)
    ends = np.repeat(np.array([False, True]), k)
    order = np.lexsort((ends, np.concatenate([lo_u, hi_u]), np.concatenate([group, group])))
    start, item = ~ends[order], order % k
    sides = [None] if across is None else [False, True]
    side = np.zeros(len(order), dtype=bool) if across is None else across[item]
    made = []
    for this in sides:
        # the starts of the items it pairs with, in order, and how many come before each event
        other = start if this is None else start & (side != this)
        passed = np.cumsum(other)
        mine = ~side if this is None else side == this
        first, last = np.empty(k, dtype=np.int64), np.empty(k, dtype=np.int64)
        first[item[start & mine]] = passed[start & mine]
        last[item[~start & mine]] = passed[~start & mine]
        held = item[start & mine]
        count = last[held] - first[held]
        made.append((held, count, item[other], first[held]))
    if sum(int(count.sum()) for _, count, _, _ in made) > limit:
        return None
    pairs = [(np.repeat(held, count), starts[_ranges(at, count)]) for held, count, starts, at in made]
    if across is None:
        return pairs[0]
    (i0, j0), (j1, i1) = pairs  # (the second pass holds items across: turned back)
    return np.concatenate([i0, i1]), np.concatenate([j0, j1])


def _pairs_in_cells(
    lo: np.ndarray,
    hi: np.ndarray,
    group: np.ndarray,
    cell: float,
    query: np.ndarray | None = None,
    across: np.ndarray | None = None,
):
    """:func:`box_pairs` by a grid (cells without a query item are not paired at all).

    A grid per size class (a loose quadtree, flattened): an item whose box is wider than
    ``cell`` goes to the grid whose cells are the smallest power of two times ``cell`` at
    least as wide, so that it spans two by two cells at most; each grid pairs its own items
    with each other and with the smaller items, which it holds too. Two items whose boxes
    meet share a cell of the grid of the larger. A sliver as long as the layout thus costs
    a few cells, not a row of thousands, and is tested against the items near it only.
    """
    k = len(lo)
    empty = np.zeros(0, dtype=np.int64)
    base = lo.min(axis=0)
    extent = np.max(hi - lo, axis=1)
    level = np.ceil(np.log2(np.maximum(extent / cell, 1.0))).astype(np.int64)
    lo_, hi_ = np.ascontiguousarray(lo.T), np.ascontiguousarray(hi.T)
    found = []
    for top in unique_sorted(level):  # a few size classes, each one whole-array pass
        key, item = _grid_cells(lo, hi, group, np.flatnonzero(level <= top), base, cell * 2.0 ** float(top))
        if query is not None:  # only the cells that hold a query item
            asked = unique_sorted(key[query[item]])
            if not len(asked):
                continue
            held = asked[np.minimum(np.searchsorted(asked, key), len(asked) - 1)] == key
            key, item = key[held], item[held]
        own = level[item] == top
        i, j = _cell_pairs(key, item, own) if across is None else _cell_pairs_across(key, item, own, across)
        if query is not None:
            asked = query[i] | query[j]
            i, j = i[asked], j[asked]
        meet = np.ones(len(i), dtype=bool)  # (one coordinate array at a time, as numpy is fastest)
        for c in range(2):
            meet &= (lo_[c][i] <= hi_[c][j]) & (lo_[c][j] <= hi_[c][i])
        found.append(np.stack([i[meet], j[meet]]))
    if not found:
        return empty, empty
    i, j = np.concatenate(found, axis=1)
    keep = i != j
    pair = unique_sorted(pair_keys(i[keep], j[keep], k, ordered=across is not None))
    return pair // k, pair % k


def _grid_cells(lo, hi, group, held, base, size):
    """The cells of size ``size`` (from ``base``) that the boxes of the items ``held`` cover,
    as keys (one per group and cell) and the item in each, one row per item and cell."""
    c0 = np.floor((lo[held] - base) / size).astype(np.int64)
    c1 = np.floor((hi[held] - base) / size).astype(np.int64)
    span = c1 - c0 + 1
    count = span[:, 0] * span[:, 1]
    slot = np.repeat(np.arange(len(held)), count)
    offset = _ranges(np.zeros_like(count), count)
    cx = c0[slot, 0] + offset % span[slot, 0]
    cy = c0[slot, 1] + offset // span[slot, 0]
    width = int(c1[:, 0].max()) + 1
    return (group[held[slot]] * (int(c1[:, 1].max()) + 1) + cy) * width + cx, held[slot]


def _ranges(start: np.ndarray, count: np.ndarray) -> np.ndarray:
    """``start[r] + 0 .. count[r] - 1`` for every row r, one after the other."""
    return np.repeat(start - np.cumsum(count) + count, count) + np.arange(int(count.sum()))


def _cell_pairs(key, item, own):
    """Per cell (equal ``key``), every own item with every later item of the cell: sorted
    own first, every pair of the cell is made once and a pair of two items held from finer
    grids is left to those."""
    order = np.lexsort((~own, key))
    key, item, own = key[order], item[order], own[order]
    start = np.flatnonzero(np.r_[True, key[1:] != key[:-1]])
    size = np.diff(np.r_[start, len(key)])
    pos = np.arange(len(key))
    later = np.where(own, np.repeat(start + size, size) - pos - 1, 0)
    return item[np.repeat(pos, later)], item[_ranges(pos + 1, later)]


def _cell_pairs_across(key, item, own, across):
    """Per cell (equal ``key``), every item not ``across`` with the items across it: all of
    them where it is own, else the own ones (sorted first within the cell)."""
    side = across[item]
    order = np.lexsort((2 * side + ~own, key))  # per cell: one side, then the other, own first
    key, item, own, side = key[order], item[order], own[order], side[order]
    first = np.r_[True, key[1:] != key[:-1]]
    start = np.flatnonzero(first)
    cell = np.cumsum(first) - 1
    n_other = np.add.reduceat(side.astype(np.int64), start)
    n_this = np.diff(np.r_[start, len(key)]) - n_other
    n_own = np.add.reduceat((side & own).astype(np.int64), start)
    pos = np.flatnonzero(~side)
    cell = cell[pos]
    count = np.where(own[pos], n_other[cell], n_own[cell])
    return item[np.repeat(pos, count)], item[_ranges(start[cell] + n_this[cell], count)]


def _cell(lo: np.ndarray, hi: np.ndarray) -> float:
    """A grid cell about twice the typical item: few cells per item, few items per cell."""
    extent = np.median(np.max(hi - lo, axis=1)) if len(lo) else 1.0
    return float(max(2.0 * extent, TINY))


def _orient(p, q, r):
    """Twice the signed area of (p, q, r), rows of (k, 2)."""
    return (q[:, 0] - p[:, 0]) * (r[:, 1] - p[:, 1]) - (q[:, 1] - p[:, 1]) * (r[:, 0] - p[:, 0])


def crossings(uv: np.ndarray, edges: np.ndarray, group: np.ndarray):
    """Pairs of segments ``edges`` (k, 2) over points ``uv`` (n, 2), of the same ``group``
    (k,), that cross: each strictly separates the other's ends. Segments sharing an end
    point are not tested (they meet there). Returns (p,) and (p,) indices into ``edges``."""
    P, Q = uv[edges[:, 0]], uv[edges[:, 1]]
    lo, hi = np.minimum(P, Q), np.maximum(P, Q)
    i, j = box_pairs(lo, hi, group, _cell(lo, hi))
    shared = (edges[i, 0] == edges[j, 0]) | (edges[i, 0] == edges[j, 1]) | (edges[i, 1] == edges[j, 0])
    shared |= edges[i, 1] == edges[j, 1]
    i, j = i[~shared], j[~shared]
    a, b, c, d = P[i], Q[i], P[j], Q[j]
    cross = (np.sign(_orient(a, b, c)) * np.sign(_orient(a, b, d)) < 0) & (
        np.sign(_orient(c, d, a)) * np.sign(_orient(c, d, b)) < 0
    )
    return i[cross], j[cross]


def overlapping_faces(cuv: np.ndarray, faces: np.ndarray, group: np.ndarray):
    """Pairs of triangles (corner UVs ``cuv`` (m, 3, 2), vertex ids ``faces`` (m, 3)) of
    the same ``group`` (m,) that overlap with positive area, by separating axes (the six
    edge normals; a gap or a touch below 1e-12 of the triangles' size separates).
    Triangles sharing an edge are not tested (in a layout without folds they lie on its two
    sides); two that share one vertex are, as they can lie one over the other from there
    (two flaps hinged at a vertex). Returns (p,) and (p,) face indices."""
    if not len(cuv):
        empty = np.zeros(0, dtype=np.int64)
        return empty, empty
    lo, hi = cuv.min(axis=1), cuv.max(axis=1)
    i, j = box_pairs(lo, hi, group, _cell(lo, hi))
    meet = ((lo[i] <= hi[j]) & (lo[j] <= hi[i])).all(axis=1)  # boxes apart: triangles apart
    i, j = i[meet], j[meet]
    shared = (faces[i][:, :, None] == faces[j][:, None, :]).sum(axis=(1, 2)) >= 2
    i, j = i[~shared], j[~shared]
    # corner coordinates as columns (p,): reductions over axes of length 3 are slow in numpy;
    # each pair taken from its first triangle's first corner, so that what rounds is the
    # triangles' size, not where they lie (a vertex two faces share then projects the same,
    # exactly, whichever face's edge it is projected along)
    ox, oy = cuv[i, 0, 0], cuv[i, 0, 1]
    ax = [cuv[i, k, 0] - ox for k in range(3)]
    ay = [cuv[i, k, 1] - oy for k in range(3)]
    bx = [cuv[j, k, 0] - ox for k in range(3)]
    by = [cuv[j, k, 1] - oy for k in range(3)]
    size = np.maximum(
        np.maximum(np.maximum(*ax[:2]), ax[2]) - np.minimum(np.minimum(*ax[:2]), ax[2]),
        np.maximum(np.maximum(*ay[:2]), ay[2]) - np.minimum(np.minimum(*ay[:2]), ay[2]),
    )
    apart = np.zeros(len(i), dtype=bool)
    for tx, ty in ((ax, ay), (bx, by)):  # the edge normals of each triangle
        for k in range(3):
            nx, ny = -(ty[(k + 1) % 3] - ty[k]), tx[(k + 1) % 3] - tx[k]
            pa = [ax[c] * nx + ay[c] * ny for c in range(3)]
            pb = [bx[c] * nx + by[c] * ny for c in range(3)]
            tol = 1e-12 * size * np.hypot(nx, ny)
            a_lo, a_hi = np.minimum(np.minimum(*pa[:2]), pa[2]), np.maximum(np.maximum(*pa[:2]), pa[2])
            b_lo, b_hi = np.minimum(np.minimum(*pb[:2]), pb[2]), np.maximum(np.maximum(*pb[:2]), pb[2])
            apart |= (a_hi <= b_lo + tol) | (b_hi <= a_lo + tol)
    return i[~apart], j[~apart]


def shared_area(A: np.ndarray, B: np.ndarray) -> np.ndarray:
    """Area of the intersection of triangles ``A`` and ``B`` (p, 3, 2) each, (p,): A clipped
    by the three half-planes of B (Sutherland-Hodgman), at most six corners throughout."""
    p = len(A)
    if not p:
        return np.zeros(0)
    ccw = np.where(corner_signed_areas(B) < 0, -1.0, 1.0)  # B's inside is to the left of its edges
    poly = np.zeros((p, 9, 2))
    poly[:, :3] = A
    count = np.full(p, 3)
    for k in range(3):
        a, b = B[:, k], B[:, (k + 1) % 3]
        side = ccw[:, None] * (
            (b[:, None, 0] - a[:, None, 0]) * (poly[:, :, 1] - a[:, None, 1])
            - (b[:, None, 1] - a[:, None, 1]) * (poly[:, :, 0] - a[:, None, 0])
        )
        valid = np.arange(9)[None, :] < count[:, None]
        nxt = np.where(np.arange(9)[None, :] + 1 < count[:, None], np.arange(9)[None, :] + 1, 0)
        s_here, s_next = side, np.take_along_axis(side, nxt, axis=1)
        q_next = np.take_along_axis(poly, nxt[:, :, None], axis=1)
        inside = valid & (s_here >= 0)
        crossing = valid & ((s_here >= 0) != (s_next >= 0))
        with np.errstate(divide="ignore", invalid="ignore"):
            t = np.where(crossing, s_here / (s_here - s_next), 0.0)
        hit = poly + t[:, :, None] * (q_next - poly)
        # each corner emits itself (if inside) then the crossing point (if any): two slots
        out = np.zeros((p, 18, 2))
        keep = np.zeros((p, 18), dtype=bool)
        out[:, 0::2], keep[:, 0::2] = poly, inside
        out[:, 1::2], keep[:, 1::2] = hit, crossing
        rank = np.cumsum(keep, axis=1) - 1
        count = keep.sum(axis=1)
        poly = np.zeros((p, 9, 2))
        r, c = np.nonzero(keep & (rank < 9))
        poly[r, rank[r, c]] = out[r, c]
        count = np.minimum(count, 9)
    x, y = poly[:, :, 0], poly[:, :, 1]
    nxt = np.where(np.arange(9)[None, :] + 1 < count[:, None], np.arange(9)[None, :] + 1, 0)
    xn, yn = np.take_along_axis(x, nxt, axis=1), np.take_along_axis(y, nxt, axis=1)
    valid = np.arange(9)[None, :] < count[:, None]
    return 0.5 * np.abs(np.where(valid, det2(x, xn, y, yn), 0.0).sum(axis=1))


def boundary_crossings(uv: np.ndarray, topo) -> np.ndarray:
    """Per island of a :class:`.topology.Topology`, the pairs of its boundary edges that
    cross in the layout ``uv`` (n, 2) over its split vertices (n_islands,): positive
    where the island overlaps itself. The cheap test every solve runs."""
    h = np.flatnonzero(topo.he.twin < 0)  # the boundary, edge by edge
    f, k = h // 3, h % 3
    edges = np.stack([topo.faces[f, k], topo.faces[f, (k + 1) % 3]], axis=1)
    a, _ = crossings(uv, edges, topo.face_island[f])
    return np.bincount(topo.face_island[f[a]], minlength=topo.n_islands)


class Overlaps(NamedTuple):
    """How the islands of a layout overlap themselves."""

    crossings: np.ndarray  # (n_islands,) pairs of boundary edges that cross
    area: np.ndarray  # (n_islands,) UV area covered twice
    pairs: tuple[np.ndarray, np.ndarray]  # faces of one island that overlap (or, if none
    # share area, the faces of its first crossing boundary edges), (p,) each
    pair_area: np.ndarray  # (p,) the UV area each pair shares (0 for a crossing's faces)

    @property
    def islands(self) -> int:
        return int((self.crossings > 0).sum())

    def share(self, uv_area: float) -> float:
        """The area covered twice as a share of ``uv_area``."""
        return float(self.area.sum() / uv_area) if uv_area > 0 else 0.0


def uv_points(F: np.ndarray, cuv: np.ndarray) -> np.ndarray:
    """One id per (mesh vertex, UV) point, for every face corner (m * 3,): corners that
    share one meet there in UV space (the same UV to the bit, -0.0 as 0.0), numbered in
    the order of (vertex, u bits, v bits).

    A sort on three keys: ``np.unique(..., axis=0)`` on the same rows is 3x slower."""
    bits = np.ascontiguousarray(np.asarray(cuv, dtype=np.float64).reshape(-1, 2) + 0.0).view(np.int64)
    vertex = np.asarray(F, dtype=np.int64).ravel()
    order = np.lexsort((bits[:, 1], bits[:, 0], vertex))
    v, b = vertex[order], bits[order]
    new = np.ones(len(order), dtype=bool)
    new[1:] = (v[1:] != v[:-1]) | (b[1:] != b[:-1]).any(axis=1)
    point = np.empty(len(order), dtype=np.int64)
    point[order] = np.cumsum(new) - 1
    return point


def self_overlaps(F: np.ndarray, cuv: np.ndarray, face_island: np.ndarray, n_islands: int) -> Overlaps:
    """:class:`Overlaps` of any layout given per face corner, ``cuv`` (m, 3, 2) of mesh
    faces ``F`` (m, 3), islands ``face_island`` (m,): an island's boundary is where its
    corner UVs disagree across an edge, or the mesh's boundary."""
    from .mesh.halfedges import HalfEdges

    m = len(F)
    if not m:
        empty = np.zeros(0, dtype=np.int64)
        return Overlaps(np.zeros(n_islands, dtype=np.int64), np.zeros(n_islands), (empty, empty), np.zeros(0))
    quv = np.ascontiguousarray(cuv.reshape(-1, 2), dtype=np.float64)
    point = uv_points(F, cuv)
    he = HalfEdges(F, int(F.max()) + 1)
    h, t = np.arange(F.size), he.twin
    paired = t >= 0
    tt = np.maximum(t, 0)
    # across an edge the two faces agree if their corners meet at both of its ends
    nxt = 3 * (h // 3) + (h % 3 + 1) % 3
    tnxt = 3 * (tt // 3) + (tt % 3 + 1) % 3
    same_dir = paired & (F.ravel()[tt] == F.ravel()[h])
    ta, tb = np.where(same_dir, tt, tnxt), np.where(same_dir, tnxt, tt)
    agree = paired & (point[ta] == point[h]) & (point[tb] == point[nxt])
    agree &= face_island[h // 3] == face_island[tt // 3]
    b = np.flatnonzero(~agree)  # boundary half-edges of the islands
    ends = np.stack([point[b], point[3 * (b // 3) + (b % 3 + 1) % 3]], axis=1)
    points = np.zeros((int(point.max()) + 1, 2))
    points[point] = quv
    a, c = crossings(points, ends, face_island[b // 3])
    per = np.bincount(face_island[b[a] // 3], minlength=n_islands)
    on = np.flatnonzero(per[face_island] > 0)
    fi, fj = overlapping_faces(cuv[on], point.reshape(-1, 3)[on], face_island[on])
    fi, fj = on[fi], on[fj]
    shared = shared_area(cuv[fi], cuv[fj])
    area = np.bincount(face_island[fi], shared, minlength=n_islands)
    # an island whose boundary crosses where no two faces share area (they only touch
    # there): the faces of its first crossing stand for the overlap
    bare = np.flatnonzero(per > 0)
    bare = bare[~np.isin(bare, face_island[fi])]
    first = np.unique(face_island[b[a] // 3], return_index=True)[1]
    pick = first[np.isin(face_island[b[a[first]] // 3], bare)]
    return Overlaps(
        per, area, (np.r_[fi, b[a[pick]] // 3], np.r_[fj, b[c[pick]] // 3]), np.r_[shared, np.zeros(len(pick))]
    )
