"""Step 4 of Sun & Hancock: rotation and anisotropic scale fitted to edge lengths,
Eqs. (15)-(18), then the placement of the islands in one layout.

With ``A = R^T S^2 R`` the squared 2D length of edge (i, j) is linear in
``(A11, A12, A22)``, Eq. (17), so minimising Eq. (16),
``sum (d_ij^2 - l_ij^2)^2``, is a 3-unknown linear least-squares problem per island.
The eigendecomposition of A gives R and S, and ``y_i = S R y_Ii`` (Eq. 15).
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from .geometry import safe_divide, signed_areas
from .islands import Islands

__all__ = ["Turn", "canonical_turn", "fit_rotation_scale", "orient", "place", "signed_areas"]


def fit_rotation_scale(Y_I, edges, length, edge_island, islands: Islands):
    """Fit ``A`` per island and apply ``y = S R y_I`` (Step 4).

    Parameters
    ----------
    Y_I : (n, 2) float64
        Coordinates from Step 3.
    edges : (e, 2) int64
        Undirected edges.
    length : (e,) float64
        3D edge lengths ``l_ij``.
    edge_island : (e,) int64
    islands : Islands

    Returns
    -------
    Y : (n, 2) float64
    A : (n_islands, 2, 2) float64
    clipped : (n_islands,) bool
        Islands whose fitted A was not positive definite and was clipped.
    """
    u, v = np.ascontiguousarray(Y_I[:, 0]), np.ascontiguousarray(Y_I[:, 1])
    a, b = np.ascontiguousarray(edges[:, 0]), np.ascontiguousarray(edges[:, 1])
    du, dv = u[a] - u[b], v[a] - v[b]  # 1-D gathers: row gathers of (n, 2) arrays are slow
    rows = np.stack([du * du, 2.0 * du * dv, dv * dv], axis=1)  # Eq. (17)
    coef = _least_squares(rows, length**2, edge_island, islands.n)
    A = np.stack([coef[:, [0, 1]], coef[:, [1, 2]]], axis=1)  # Eq. (18)
    s2, U = np.linalg.eigh(A)  # A = U diag(s^2) U^T, so R = U^T and S = diag(s)
    floor = 1e-12 * np.maximum(s2[:, 1:], 1e-300)
    clipped = s2[:, 0] < floor[:, 0]
    s2 = np.maximum(s2, floor)
    T = U * np.sqrt(s2)[:, None, :]  # rows: y = y_I U S
    return islands.apply(Y_I, T), A, clipped


def _least_squares(rows: np.ndarray, target: np.ndarray, label: np.ndarray, n: int) -> np.ndarray:
    """``argmin ||rows c - target||`` per group of rows, (n, 3): a QR of the (r, 3) rows by
    classical Gram-Schmidt done twice, with per-group inner products from ``bincount``.

    Not the normal equations: they square the conditioning of the rows, which on a
    long thin island is large (a flat 5001 x 2 strip: relative edge error 0.07 through
    the normal equations, 1e-10 through this QR). A column that is dependent on the
    previous ones inside its group (a collinear island) gets coefficient 0.
    """
    groups = Islands.labelled(label, n)
    R = np.zeros((n, 3, 3))
    Q: list[np.ndarray] = []
    for j in range(3):
        q = rows[:, j].copy()
        start = np.sqrt(groups.dot(q, q))
        for _ in range(2):  # twice is enough (CGS2)
            for i, qi in enumerate(Q):
                c = groups.dot(qi, q)
                R[:, i, j] += c
                q -= groups.expand(c) * qi
        norm = np.sqrt(groups.dot(q, q))
        ok = norm > 1e-12 * start
        R[:, j, j] = np.where(ok, norm, 0.0)
        q *= groups.expand(safe_divide(1.0, np.where(ok, norm, 0.0)))
        Q.append(q)
    qt = np.stack([groups.dot(q, target) for q in Q], axis=1)
    coef = np.zeros((n, 3))
    for j in (2, 1, 0):  # back substitution
        rest = qt[:, j] - sum(R[:, j, k] * coef[:, k] for k in range(j + 1, 3))
        d = R[:, j, j]
        coef[:, j] = safe_divide(rest, d)
    return coef


def orient(Y, faces, face_island, islands: Islands):
    """Mirror every island whose faces are mostly clockwise (the eigenvectors leave the
    reflection free). Returns Y (n, 2); which faces fold is read from the layout as
    returned (see :func:`.parametrize`)."""
    mirror = np.bincount(face_island, signed_areas(Y, faces), minlength=islands.n) < 0
    Y = Y.copy()
    Y[mirror[islands.label], 0] *= -1.0
    return Y


def place(Y, islands: Islands, pack: bool = True, margin: float = 0.02, fixed=None):
    """Turn each island into its canonical frame (:func:`canonical_turn`) and put the
    islands side by side.

    The turn makes the layout deterministic and compact. With ``pack`` the islands go on
    shelves in mesh units (true scale, no overlap), ``margin`` being a fraction of the
    square root of their total area; otherwise each island is centred at the origin.
    Islands in ``fixed`` (n_islands,) bool keep their frame (pinned islands); packed
    islands go to the right of them.
    """
    nI = islands.n
    fixed = np.zeros(nI, dtype=bool) if fixed is None else fixed
    Yc = Y - islands.expand(islands.mean(Y))
    Yr = islands.apply(Yc, canonical_turn(Yc, islands).rotation)
    if fixed.any():
        Yr = np.where(fixed[islands.label][:, None], Y, Yr)
    return pack_islands(Yr, islands, margin, fixed) if pack else Yr


_TIE = 1e-3  # moments below this fraction of their scale are ties (symmetric islands)


class Turn(NamedTuple):
    """What :func:`canonical_turn` decided, per island."""

    rotation: np.ndarray  # (n_islands, 2, 2): ``Yc @ rotation`` is the turned island
    by_anchor: np.ndarray  # (n_islands,) bool: symmetric (rules 1-2 tied): the numbering decided


def canonical_turn(Yc: np.ndarray, islands: Islands) -> Turn:
    """Per island, the rotation that puts its centred rows ``Yc`` (n, 2) in a canonical
    frame.

    A turn has to be decided from the layout alone, and must not change when the layout
    changes by rounding (another BLAS kernel, thread count or summation order), also on
    symmetric islands, where every geometric rule ties. With ``z = u + i v`` per vertex
    (centred), the rules, in order:

    1. Principal axes: ``M2 = sum z^2`` gives the major axis (angle ``arg(M2) / 2``) when
       ``|M2| > _TIE sum |z|^2``. Else (as round as it is long), ``M4 = sum z^4`` gives a
       four-fold frame (angle ``arg(M4) / 4``, a square's sides) when ``|M4| > _TIE sum |z|^4``.
       Else the frame is free.
    2. Which of the ``k`` turns left (2 for an axis, 4 for a four-fold frame, any for a
       free one): for an axis, the one with positive skewness ``sum u^3`` along it, when
       ``|sum u^3| > _TIE sum |u|^3``. Else the *anchor*, the island's lowest-numbered
       vertex among those more than half the island's radius from its centre (and, with
       ``k > 1``, more than a tenth of a sector away from the sectors' edges), is turned
       into the sector around +u (onto +u for a free frame).

    Every decision is a comparison with a margin of ``_TIE`` or more, so rounding
    (relative 1e-16 to 1e-10 of the layout) never flips one. The anchor rule depends on
    the vertex numbering (the input's order): a symmetric island relabelled may come out
    turned by one of its symmetries. Asymmetric islands are decided by rules 1-2 alone,
    whatever the numbering.
    """
    n_rows = len(Yc)
    x, y = np.ascontiguousarray(Yc[:, 0]), np.ascontiguousarray(Yc[:, 1])
    # in units of the island's radius: powers of raw coordinates overflow beyond ~1e77
    # (pins far from a mesh collapsed to a point)
    radius = np.hypot(x, y)
    top = islands.max(radius)
    unit = islands.expand(np.where(top > 0, top, 1.0))
    x, y, radius = x / unit, y / unit, radius / unit
    r2 = x * x + y * y
    z2 = np.stack([x * x - y * y, 2.0 * x * y], axis=1)  # z^2 as (re, im)
    z4 = np.stack([z2[:, 0] ** 2 - z2[:, 1] ** 2, 2.0 * z2[:, 0] * z2[:, 1]], axis=1)
    s = islands.sum(np.column_stack([z2, z4, r2, r2 * r2]))
    m2, m4 = s[:, 0] + 1j * s[:, 1], s[:, 2] + 1j * s[:, 3]
    axis = np.abs(m2) > _TIE * s[:, 4]
    square = ~axis & (np.abs(m4) > _TIE * s[:, 5])
    k = np.where(axis, 2, np.where(square, 4, 1))
    theta = np.where(axis, np.angle(m2) / 2, np.where(square, np.angle(m4) / 4, 0.0))
    # rule 2 for an axis: skewness along it
    c, sn = np.cos(theta), np.sin(theta)
    u = x * islands.expand(c) + y * islands.expand(sn)
    s3 = islands.sum(np.column_stack([u**3, np.abs(u) ** 3]))
    skewed = axis & (np.abs(s3[:, 0]) > _TIE * s3[:, 1])
    turn = np.where(skewed & (s3[:, 0] < 0), np.pi, 0.0)
    # rule 2 otherwise: the anchor
    sector = 2.0 * np.pi / k
    alpha = np.arctan2(y, x) - islands.expand(theta)
    step = alpha / islands.expand(sector)
    off_edge = (k[islands.label] == 1) | (np.abs(step - np.round(step)) < 0.4)
    far = radius > 0.5 * islands.expand(np.where(top > 0, 1.0, np.inf))
    anchor = islands.first(far & off_edge)
    anchor = np.where(anchor < n_rows, anchor, islands.first(far))
    has = anchor < n_rows  # islands that are not one point
    a = np.minimum(anchor, max(n_rows - 1, 0))
    to_anchor = np.where(k == 1, alpha[a] if n_rows else 0.0, np.round(step[a] if n_rows else 0.0) * sector)
    turn = np.where(skewed | ~has, turn, to_anchor)
    angle = theta + turn
    c, sn = np.cos(angle), np.sin(angle)
    # y = Yc @ R turns by -angle: the chosen direction goes onto +u
    R = np.stack([np.stack([c, -sn], axis=1), np.stack([sn, c], axis=1)], axis=1)
    return Turn(R, ~skewed & has)


def pack_islands(Y, islands: Islands, margin: float = 0.02, fixed=None):
    """Shift the islands of ``Y`` (n, 2) onto shelves, without turning them (the packing
    step of :func:`place`). Islands in ``fixed`` (n_islands,) bool stay where they are."""
    nI = islands.n
    fixed = np.zeros(nI, dtype=bool) if fixed is None else fixed
    if fixed.all():
        return Y
    lo = np.minimum.reduceat(Y, islands.start[:-1], axis=0)  # islands are contiguous row blocks
    hi = np.maximum.reduceat(Y, islands.start[:-1], axis=0)
    size = hi - lo
    gap = margin * np.sqrt(max(float(np.prod(size, axis=1).sum()), 1e-300))
    free = np.flatnonzero(~fixed)
    corner = np.zeros((nI, 2))
    corner[free] = _shelves(size[free], gap)
    if fixed.any():  # the free islands go to the right of the pinned ones
        corner[free] += [hi[fixed, 0].max() + gap, lo[fixed, 1].min()]
    shift = np.where(fixed[:, None], 0.0, corner - lo)
    return Y + islands.expand(shift)


def _shelves(size: np.ndarray, gap: float) -> np.ndarray:
    """Lower-left corners for boxes (k, 2) on shelves, tallest first, rows ~ square."""
    k = len(size)
    if k == 1:
        return np.zeros((1, 2))
    # tallest first; heights within 1e-6 of the tallest's count as equal (islands alike up to
    # rounding), so that rounding never reorders them: then by island number
    height = np.round(size[:, 1] / max(float(size[:, 1].max()) * 1e-6, 1e-300))
    order = np.lexsort((np.arange(k), -height))
    width = max(float(size[:, 0].max()), float(np.sqrt(((size[:, 0] + gap) * (size[:, 1] + gap)).sum())))
    out = np.zeros((k, 2))
    x = y = row_h = 0.0
    for i in order:  # one step per island
        w, h = size[i]
        if x > 0 and x + w > width:
            x, y, row_h = 0.0, y + row_h + gap, 0.0
        out[i] = (x, y)
        x += w + gap
        row_h = max(row_h, h)
    return out
