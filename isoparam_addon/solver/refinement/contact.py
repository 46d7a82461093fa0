"""Beyond the paper: an island's boundary never crosses itself while it is refined.

A layout without folds covers every point of the plane once exactly when its boundary is
a simple curve (see :mod:`.overlap`). The symmetric Dirichlet energy does not see the
boundary: where a slit's banks are pressed together, or a flap is pulled over the rest,
its minimum lies where the layout overlaps itself. Smith & Schaefer ("Bijective
parameterization with free boundaries", 2015) add a barrier between the boundary's
vertices and edges to the energy; here it is the log barrier of incremental potential
contact (Li et al., "Incremental potential contact", 2020),

    b(d) = -(d - g)^2 ln(d / g)    for d < g,    0 beyond,

of the distance d between a boundary vertex and a boundary edge of its island that does
not hold it, with g (the gap) half the edge's length: smooth, zero until two parts of the
boundary come that close, infinite at contact. The barrier is scaled to about the energy
of a face on the edge, so that it is a wall, not a force felt across the island (gap and
scale follow each edge: a part with long and short edges, a CAD part, is no different).
Every step stops short of the first time a vertex would meet an edge (continuous
collision detection); one that moves the boundary farther than the pairs followed is
tested for crossings at its end instead.

Banks of a cut laid out as one (a layout cut further goes on from where it was) start in
contact: they are pushed a thousandth of an edge apart first (:meth:`Contact.separate`).

The refinement watches contact only where it is likely or met (see :mod:`.watch`).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Self

import numpy as np

from ..geometry import safe_divide, sum_products
from ..mesh.halfedges import HalfEdges, unique_sorted
from ..overlap import box_pairs, crossings
from .per_face import block_matrix

__all__ = ["Boundary", "Contact", "Near"]

_GAP = 0.5  # the barrier starts this share of its edge's length away
_STIFFNESS = 1.0  # the barrier's scale, in the energies of a face on its edge (an equilateral one)
_APART = 1e-3  # banks that start in contact are pushed this share of an edge apart
_FOLLOWED = 4.0  # contact is followed along a step within this many gaps of every vertex
_SKIN = 0.5  # pairs are listed this many gaps beyond a step's reach, and the list kept while it covers the steps
_CLOSER = 0.9  # a pair acts once it is this much nearer than on the surface ...
_SAME = 1e-3  # ... unless it is this near on the surface (as a share of the gap): copies of a vertex
_TOUCHING = 0.1  # an island with a pair this near (share of the gap) at the start is watched from there


def _distances(x: np.ndarray, v: np.ndarray, a: np.ndarray, b: np.ndarray):
    """Distances (p,) from points ``x[v]`` to segments ``x[a]``-``x[b]`` (rows of any
    dimension), where along each segment the nearest point lies (p,), and the vectors
    from it to the point (p, d)."""
    columns = [x[:, c] for c in range(x.shape[1])]  # (a coordinate at a time: numpy is slow along short rows)
    pa = [c[v] - c[a] for c in columns]
    ab = [c[b] - c[a] for c in columns]
    s = np.clip(safe_divide(sum_products(pa, ab), sum_products(ab, ab)), 0.0, 1.0)
    diff = [p - s * q for p, q in zip(pa, ab)]
    return np.sqrt(sum_products(diff, diff)), s, np.stack(diff, axis=1)


def _log_barrier(d: np.ndarray, g: np.ndarray):
    """The barrier ``b(d) = -(d - g)^2 ln(d / g)`` (p,) of pairs at distances ``d`` (p,)
    below their gaps ``g`` (p,), scaled to a face's energy (the area of an equilateral face
    on the edge, 2 gaps), and its slope ``db / dd`` (p,)."""
    w = _STIFFNESS * np.sqrt(3.0)
    with np.errstate(divide="ignore", invalid="ignore"):
        log = np.log(d / g)
        value = -w * (d - g) ** 2 * log
        slope = -w * (2.0 * (d - g) * log + (d - g) ** 2 / d)  # d value / d d
    return value, slope


def _log_barrier_curvature(d: np.ndarray, g: np.ndarray) -> np.ndarray:
    """The barrier's second derivative ``d^2 b / d d^2`` (p,) at distances ``d`` below the
    gaps ``g`` (positive: the barrier is convex in the distance)."""
    w = _STIFFNESS * np.sqrt(3.0)
    with np.errstate(divide="ignore", invalid="ignore"):
        return -w * (2.0 * np.log(d / g) + 4.0 * (d - g) / d - (d - g) ** 2 / (d * d))


def _first_meeting(e0: np.ndarray, e1: np.ndarray, r0: np.ndarray, r1: np.ndarray) -> np.ndarray:
    """Per pair (p,), the first step t > 0 at which a vertex meets an edge as both move (inf
    if it never does): ``e0 + t e1`` (p, 2) is the edge (its end from its start), ``r0 + t r1``
    (p, 2) the vertex from the edge's start. The positive roots of their orientation, a
    quadratic in t, where the vertex then lies within the edge."""
    e0u, e0w, e1u, e1w = e0[:, 0], e0[:, 1], e1[:, 0], e1[:, 1]  # (a coordinate at a time)
    r0u, r0w, r1u, r1w = r0[:, 0], r0[:, 1], r1[:, 0], r1[:, 1]
    c2 = e1u * r1w - e1w * r1u
    c1 = e0u * r1w - e0w * r1u + e1u * r0w - e1w * r0u
    c0 = e0u * r0w - e0w * r0u
    with np.errstate(divide="ignore", invalid="ignore"):
        disc = np.sqrt(np.maximum(c1 * c1 - 4.0 * c2 * c0, 0.0))
        q = -0.5 * (c1 + np.where(c1 >= 0, disc, -disc))  # (the stable form of the roots)
        roots = [q / c2, c0 / q, -c0 / c1]
    linear = np.abs(c2) <= 1e-14 * (np.abs(c1) + np.abs(c0))
    real = (c1 * c1 - 4.0 * c2 * c0 >= 0) | linear
    first = np.full(len(c0), np.inf)
    for k, root in enumerate(roots):  # (the quadratic's two, or the linear one)
        root = np.where(linear, np.inf, root) if k < 2 else np.where(linear, root, np.inf)
        root = np.where(np.isfinite(root) & (root > 0) & real, root, np.inf)
        # the meeting counts only where the vertex lies on the edge then
        t = np.where(np.isfinite(root), root, 0.0)
        et_u, et_w, rt_u, rt_w = e0u + t * e1u, e0w + t * e1w, r0u + t * r1u, r0w + t * r1w
        along = safe_divide(et_u * rt_u + et_w * rt_w, et_u * et_u + et_w * et_w, -1.0)
        first = np.minimum(first, np.where(np.isfinite(root) & (along >= 0.0) & (along <= 1.0), root, np.inf))
    return first


def _inward_normals(x: np.ndarray, edges: np.ndarray) -> np.ndarray:
    """Per vertex (n, 2), the unit inward normal of the boundary ``edges`` (k, 2) in ``x``
    (n, 2): the sum of its two edges' unit normals, turned left (the island is on the left),
    normalised; 0 off the boundary."""
    a, b = edges[:, 0], edges[:, 1]
    t = x[b] - x[a]
    normal = np.stack([-t[:, 1], t[:, 0]], axis=1)
    normal = safe_divide(normal, np.hypot(normal[:, 0], normal[:, 1])[:, None])
    n = len(x)
    out = np.stack(
        [np.bincount(a, normal[:, c], minlength=n) + np.bincount(b, normal[:, c], minlength=n) for c in range(2)],
        axis=1,
    )
    return safe_divide(out, np.hypot(out[:, 0], out[:, 1])[:, None])


@dataclass(frozen=True)
class Near:
    """Parts of a boundary that may touch in a step: (vertex, edge) pairs (``vertex``,
    ``edge``: an index into :attr:`Boundary.edges`), and the distance below which each
    pair's barrier acts (``gap``)."""

    vertex: np.ndarray
    edge: np.ndarray
    gap: np.ndarray

    @classmethod
    def none(cls) -> Near:
        empty = np.zeros(0, dtype=np.int64)
        return cls(empty, empty, np.zeros(0))


@dataclass
class Boundary:
    """The boundary of every island of a layout: its edges, how far a step moves them, and
    whether it crosses itself.

    Attributes
    ----------
    edges : (k, 2) int64
        Boundary edges (vertex pairs, in the order of their face: the island to the left).
    edge_island : (k,) int64
    gap : (k,) float
        Per edge, the distance below which its barrier acts (half its length on the
        surface).
    n_islands : int
    opposite : (k,) int64
        Per edge, the third vertex of its face (-1: none given). No barrier acts between
        the two: the face's own determinant keeps that vertex off the edge (every step
        stops before a face collapses), at the face's own shape, where a barrier would
        hold a sliver's apex at half the edge's length.
    """

    edges: np.ndarray
    edge_island: np.ndarray
    gap: np.ndarray
    n_islands: int
    after: np.ndarray  # (n,) the next vertex along the boundary (-1 off it)
    before: np.ndarray  # (n,) the previous one
    X: np.ndarray  # (n, 3) the vertices on the surface
    starting: np.ndarray  # (n,) the boundary edge each boundary vertex starts (-1 off it)
    opposite: np.ndarray  # (k,) see above

    @classmethod
    def of(cls, X: np.ndarray, faces: np.ndarray, vertex_island: np.ndarray, n_islands: int) -> Self:
        """The boundary of the islands of ``faces`` (m, 3) over ``X`` (n, 3), each of whose
        vertices is in island ``vertex_island`` (n,)."""
        he = HalfEdges(faces, len(X))
        h = np.flatnonzero(he.edge_count[he.edge] == 1)
        f, k = h // 3, h % 3
        edges = np.stack([faces[f, k], faces[f, (k + 1) % 3]], axis=1)
        gap = _GAP * np.linalg.norm(X[edges[:, 0]] - X[edges[:, 1]], axis=1)
        after = np.full(len(X), -1, dtype=np.int64)
        before = np.full(len(X), -1, dtype=np.int64)
        after[edges[:, 0]], before[edges[:, 1]] = edges[:, 1], edges[:, 0]
        starting = np.full(len(X), -1, dtype=np.int64)
        starting[edges[:, 0]] = np.arange(len(edges))
        opposite = faces[f, (k + 2) % 3]
        return cls(edges, vertex_island[edges[:, 0]], gap, n_islands, after, before, X, starting, opposite)

    def n_vertices(self, which: np.ndarray) -> int:
        """How many boundary vertices the islands ``which`` (n_islands,) bool have."""
        return int(which[self.edge_island].sum())

    def _vertex_gap(self) -> np.ndarray:
        """Per vertex (n,), the larger gap of its two boundary edges (0 off the boundary)."""
        out = np.zeros(len(self.after))
        np.maximum.at(out, self.edges[:, 0], self.gap)
        np.maximum.at(out, self.edges[:, 1], self.gap)
        return out

    def _usable(self, x: np.ndarray) -> np.ndarray:
        """Per boundary edge, whether contact can be followed there: its island has a size
        (a part collapsed to a point has none) and its layout numbers a grid can hold (a
        layout left as it is may hold none)."""
        return (self.gap > 0) & (np.abs(x[self.edges]) < 1e150).all(axis=(1, 2))

    def motion(self, p: np.ndarray, t: np.ndarray) -> np.ndarray:
        """Per vertex (n,), how far it moves along ``p`` (n, 2) with its island's step
        ``t`` (per island; boundary vertices only, 0 elsewhere)."""
        out = np.zeros(len(p))
        v = self.edges[:, 0]
        out[v] = np.hypot(p[v, 0], p[v, 1]) * t[self.edge_island]
        return out

    def followed(self, motion: np.ndarray, n_islands: int) -> np.ndarray:
        """Per island (n_islands,) bool: whether contact is followed along the whole of a
        step that moves each vertex by ``motion`` (n,) (else its end is tested for
        crossings)."""
        v = self.edges[:, 0]
        beyond = motion[v] > _FOLLOWED * self.gap
        return np.bincount(self.edge_island[beyond], minlength=n_islands) == 0

    def allowance(self, motion: np.ndarray) -> np.ndarray:
        """Per vertex (n,) (0 off the boundary), how far it may move before the pairs listed
        for it are found again: a step's ``motion`` (n,) and a margin (the skin), so that
        the next steps can use the list too, up to the reach :meth:`Contact.near` lists."""
        gap = self._vertex_gap()
        return np.minimum(motion + _SKIN * gap, (_FOLLOWED + _SKIN) * gap)

    def crossing(self, x: np.ndarray, which: np.ndarray | None = None) -> np.ndarray:
        """Per island bool: islands (of ``which``, all by default) whose boundary crosses
        itself in ``x`` (n, 2)."""
        out = np.zeros(self.n_islands, dtype=bool)
        finite = self._usable(x)
        if which is not None:
            finite &= which[self.edge_island]
        i, _ = crossings(x, self.edges[finite], self.edge_island[finite])
        out[self.edge_island[finite][i]] = True
        return out


class Contact(Boundary):
    """Where the boundary of every island may touch itself (module docstring): its vertices
    and edges near each other, their barrier, the first step at which they meet, and banks
    that start in contact pushed apart."""

    def near(
        self, x: np.ndarray, which: np.ndarray, motion: np.ndarray | None = None, moved: np.ndarray | None = None
    ) -> Near:
        """The (vertex, edge) pairs of the boundaries of the islands ``which``
        (n_islands,) bool that are within their gap of each other in ``x`` (n, 2), or may
        come so while each vertex moves by at most ``motion`` (n,) (one grid pass over
        boxes grown by the gap and the motion, then the distances: a step's trials look
        at these alone). With ``moved`` (n,) bool, only the pairs that hold such a vertex
        (as the vertex or an end of the edge)."""
        on = np.flatnonzero(which[self.edge_island] & self._usable(x))
        if not len(on):
            return Near.none()
        E = self.edges
        edges, island = E[on], self.edge_island[on]
        # (a step that moves the boundary far is followed within a few gaps: beyond, the
        # test of its end for crossings refuses it, see :meth:`crossing`)
        move = np.zeros(len(x)) if motion is None else np.minimum(motion, (_FOLLOWED + _SKIN) * self._vertex_gap())
        # vertex points and edge boxes grown by the edge's gap and the motion: pairs of a
        # vertex with an edge whose box holds it (one pass of box_pairs, boxes of every size,
        # no pair of two vertices or two edges)
        vertices = edges[:, 0]  # (each boundary vertex starts one edge)
        a, b = x[edges[:, 0]], x[edges[:, 1]]
        pad = (self.gap[on] + np.maximum(move[edges[:, 0]], move[edges[:, 1]]))[:, None]
        k = len(on)
        box_lo = np.vstack([x[vertices] - move[vertices, None], np.minimum(a, b) - pad])
        box_hi = np.vstack([x[vertices] + move[vertices, None], np.maximum(a, b) + pad])
        cell = float(max(2.0 * np.median(box_hi[k:] - box_lo[k:]), 1e-300))
        query = None if moved is None else np.concatenate([moved[vertices], moved[edges].any(axis=1)])
        is_edge = np.arange(2 * k) >= k
        i, j = box_pairs(box_lo, box_hi, np.concatenate([island, island]), cell, query, across=is_edge)
        v, e = vertices[i], on[j - k]
        # not an edge of the vertex's own, nor of its face's
        a_, b_ = E[e, 0], E[e, 1]
        keep = (a_ != v) & (b_ != v) & (self.opposite[e] != v)
        v, e = v[keep], e[keep]
        gap = self.gap[e]
        d = _distances(x, v, E[e, 0], E[e, 1])[0]
        can = d < gap + move[v] + np.maximum(move[E[e, 0]], move[E[e, 1]])
        v, e, gap = v[can], e[can], gap[can]
        # a pair as near on the surface keeps its distance (an exact layout of a developable
        # island, or a sharp corner of its boundary, is left as it is); copies of one
        # vertex (the banks of a cut) are apart
        on_surface = _distances(self.X, v, E[e, 0], E[e, 1])[0]
        gap = np.where(on_surface > _SAME * gap, np.minimum(gap, _CLOSER * on_surface), gap)
        return Near(v, e, gap)

    def within(self, x: np.ndarray, near: Near, motion: np.ndarray) -> tuple[Near, Near]:
        """Of the pairs ``near``, those whose barrier can act on a step that moves each
        vertex by at most ``motion`` (n,) from ``x`` (n, 2), and those that can meet on it."""
        E = self.edges
        v, e = near.vertex, near.edge
        d = _distances(x, v, E[e, 0], E[e, 1])[0]
        reach = motion[v] + np.maximum(motion[E[e, 0]], motion[E[e, 1]])
        act, meet = d < near.gap + reach, d <= reach
        return Near(v[act], e[act], near.gap[act]), Near(v[meet], e[meet], near.gap[meet])

    def touching(self, x: np.ndarray, which: np.ndarray) -> np.ndarray:
        """Islands (n_islands,) bool of ``which`` with a boundary vertex within ``_TOUCHING``
        of its gap from an edge in ``x`` (n, 2): the banks of a cut laid out as one, a
        boundary pressed against itself; where contact is followed from the start."""
        near = self.near(x, which)
        d = _distances(x, near.vertex, self.edges[near.edge, 0], self.edges[near.edge, 1])[0]
        touching = near.edge[d < _TOUCHING * near.gap]
        return np.bincount(self.edge_island[touching], minlength=self.n_islands) > 0

    def energy(self, x: np.ndarray, near: Near, n_islands: int):
        """Per island (n_islands,) the barrier in ``x`` (n, 2) of the pairs ``near`` (0
        elsewhere), and its gradient (n, 2)."""
        grad = np.zeros_like(x)
        if not len(near.vertex):
            return np.zeros(n_islands), grad
        v, e = near.vertex, near.edge
        d, s, diff = _distances(x, v, self.edges[e, 0], self.edges[e, 1])
        island = self.edge_island[e]
        close = d < near.gap
        if not close.any():
            return np.zeros(n_islands), grad
        v, e, s, d, island = v[close], e[close], s[close], d[close], island[close]
        u = safe_divide(diff[close], d[:, None])
        value, slope = _log_barrier(d, near.gap[close])
        a, b = self.edges[e, 0], self.edges[e, 1]
        n = len(x)
        force = slope[:, None] * u
        for c in range(2):
            grad[:, c] = (
                np.bincount(v, force[:, c], minlength=n)
                - np.bincount(a, (1.0 - s) * force[:, c], minlength=n)
                - np.bincount(b, s * force[:, c], minlength=n)
            )
        return np.bincount(island, value, minlength=n_islands), grad

    def normal_curvature(self, x: np.ndarray, near: Near):
        """The barrier's curvature along each close pair's normal, ``b''(d) grad d grad d^T``
        over the 2n coordinates (u, v of each vertex, interleaved), as a sparse (2n, 2n)
        matrix: the part of the barrier's Hessian that is positive semi-definite (the
        distance's own curvature, which lets a vertex slide along an edge, is left out).
        None when no pair is within its gap."""
        v, e = near.vertex, near.edge
        d, s, diff = _distances(x, v, self.edges[e, 0], self.edges[e, 1])
        close = (d < near.gap) & (d > 0)
        if not close.any():
            return None
        v, e, s, d, diff = v[close], e[close], s[close], d[close], diff[close]
        k = _log_barrier_curvature(d, near.gap[close])
        u = diff / d[:, None]
        a, b = self.edges[e, 0], self.edges[e, 1]
        at = np.stack([2 * v, 2 * v + 1, 2 * a, 2 * a + 1, 2 * b, 2 * b + 1], axis=1)
        grad = np.concatenate([u, -(1.0 - s)[:, None] * u, -s[:, None] * u], axis=1)  # of d, over at
        return block_matrix(at, k[:, None, None] * grad[:, :, None] * grad[:, None, :], 2 * len(x))

    def first_contact(self, x: np.ndarray, p: np.ndarray, near: Near, n_islands: int) -> np.ndarray:
        """Per island (n_islands,), the first step t > 0 along ``p`` (n, 2) from ``x`` at
        which a boundary vertex of the pairs ``near`` meets its edge (inf if none does; see
        :func:`_first_meeting`)."""
        out = np.full(n_islands, np.inf)
        if not len(near.vertex):
            return out
        v, a, b = near.vertex, self.edges[near.edge, 0], self.edges[near.edge, 1]
        hit = _first_meeting(x[b] - x[a], p[b] - p[a], x[v] - x[a], p[v] - p[a])
        np.minimum.at(out, self.edge_island[near.edge], hit)
        return out

    def separate(self, x: np.ndarray, which: np.ndarray) -> np.ndarray:
        """``x`` (n, 2) with the boundary vertices of islands ``which`` that lie on another
        part of their boundary (in contact: the banks of a cut laid out as one) pushed
        ``_APART`` of an edge into their island, away from the part they touch."""
        near = self.near(x, which)
        v, e = near.vertex, near.edge
        d = _distances(x, v, self.edges[e, 0], self.edges[e, 1])[0]
        touching = unique_sorted(v[d < _APART * self.gap[e] / _GAP])
        if not len(touching):
            return x
        step = np.zeros(len(x))
        step[touching] = _APART * self._vertex_gap()[touching] / _GAP
        return x + step[:, None] * _inward_normals(x, self.edges)
