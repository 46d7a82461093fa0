"""Geometric kernels every step shares: corners, areas, angles, lengths, triangle frames.

Conventions: ``X (n, 3)`` positions, ``uv (n, 2)`` a layout, ``faces (m, 3)`` vertex
indices, ``cuv (m, 3, 2)`` per-corner UVs. Corner ``c = 3 f + k`` is corner k of face f;
half-edge ``c`` runs from corner c to the next corner of its face.

Kernels gather from 1-D coordinate columns: numpy's row gather ``X[idx]`` on an (n, 3)
array is several times slower than three gathers from contiguous columns.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

__all__ = [
    "NEXT",
    "PREV",
    "next_corner",
    "prev_corner",
    "rotate_faces",
    "safe_divide",
    "signed_double_areas",
    "signed_areas",
    "corner_signed_areas",
    "Triangles",
    "triangles",
    "face_areas",
    "edge_lengths",
    "corner_angles",
]

NEXT = np.array([1, 2, 0])  # the next corner of a face, by position
PREV = np.array([2, 0, 1])


def next_corner(c: np.ndarray) -> np.ndarray:
    """The next corner of the same face (the end of half-edge ``c``)."""
    return 3 * (c // 3) + NEXT[c % 3]


def prev_corner(c: np.ndarray) -> np.ndarray:
    """The previous corner of the same face."""
    return 3 * (c // 3) + PREV[c % 3]


def rotate_faces(F: np.ndarray, back: bool = False) -> np.ndarray:
    """``F[:, [1, 2, 0]]`` (each corner's next), or ``F[:, [2, 0, 1]]`` with ``back``, by
    column copies (3x faster than fancy indexing)."""
    out = np.empty_like(F)
    if back:
        out[:, 0] = F[:, 2]
        out[:, 1:] = F[:, :2]
    else:
        out[:, :2] = F[:, 1:]
        out[:, 2] = F[:, 0]
    return out


def safe_divide(a, b, fill: float = 0.0):
    """``a / b`` where ``b`` is not zero, ``fill`` where it is (no warning, no inf/NaN)."""
    b = np.asarray(b)
    nonzero = b != 0
    return np.where(nonzero, np.divide(a, np.where(nonzero, b, 1.0)), fill)


def signed_double_areas(uv: np.ndarray, faces: np.ndarray) -> np.ndarray:
    """Twice the signed area of every triangle of a layout, (m,), positive counter-clockwise."""
    u, v = np.ascontiguousarray(uv[:, 0]), np.ascontiguousarray(uv[:, 1])
    a, b, c = (np.ascontiguousarray(faces[:, k]) for k in range(3))
    ua, va = u[a], v[a]
    return (u[b] - ua) * (v[c] - va) - (v[b] - va) * (u[c] - ua)


def signed_areas(uv: np.ndarray, faces: np.ndarray) -> np.ndarray:
    """Signed area of every triangle of a layout, (m,), positive counter-clockwise."""
    return 0.5 * signed_double_areas(uv, faces)


def corner_signed_areas(cuv: np.ndarray) -> np.ndarray:
    """Signed area of every triangle given by its corner UVs (m, 3, 2) -> (m,)."""
    u, v = cuv[..., 0], cuv[..., 1]
    return 0.5 * ((u[:, 1] - u[:, 0]) * (v[:, 2] - v[:, 0]) - (v[:, 1] - v[:, 0]) * (u[:, 2] - u[:, 0]))


COLLAPSED = 1e-6  # a face this flat (height over its longer side) has no area to speak of


class Triangles(NamedTuple):
    """Each face's two edges from its first corner, ``e1 = p1 - p0`` and ``e2 = p2 - p0``,
    as the four numbers that fix the triangle up to a rigid motion: the face maps to its
    own plane as (0, 0), (l1, 0), (dot / l1, cross / l1). All (m,) float64."""

    l1: np.ndarray  # |e1|
    l2: np.ndarray  # |e2|
    dot: np.ndarray  # e1 . e2
    cross: np.ndarray  # |e1 x e2|, twice the area

    @property
    def area(self) -> np.ndarray:
        return 0.5 * self.cross

    @property
    def collapsed(self) -> np.ndarray:
        """Faces with no area to speak of: their height is below ``COLLAPSED`` of their
        longer side from the first corner (a face whose corners sit on one line or one
        point has no orientation, so it cannot fold; the refinement gives it a stand-in)."""
        side = np.maximum(self.l1, self.l2)
        return self.cross <= COLLAPSED * side * side


def triangles(X: np.ndarray, faces: np.ndarray) -> Triangles:
    """The :class:`Triangles` of ``faces`` over positions ``X`` (n, 3)."""
    i0, i1, i2 = (np.ascontiguousarray(faces[:, k]) for k in range(3))
    e1, e2 = [], []
    for c in range(3):  # x, y, z
        col = np.ascontiguousarray(X[:, c])
        base = col[i0]
        e1.append(col[i1] - base)
        e2.append(col[i2] - base)
    cx = e1[1] * e2[2] - e1[2] * e2[1]
    cy = e1[2] * e2[0] - e1[0] * e2[2]
    cz = e1[0] * e2[1] - e1[1] * e2[0]
    return Triangles(
        l1=np.sqrt(e1[0] * e1[0] + e1[1] * e1[1] + e1[2] * e1[2]),
        l2=np.sqrt(e2[0] * e2[0] + e2[1] * e2[1] + e2[2] * e2[2]),
        dot=e1[0] * e2[0] + e1[1] * e2[1] + e1[2] * e2[2],
        cross=np.sqrt(cx * cx + cy * cy + cz * cz),
    )


def face_areas(X: np.ndarray, faces: np.ndarray) -> np.ndarray:
    """3D area of every face, (m,)."""
    return triangles(X, faces).area


def edge_lengths(X: np.ndarray, edges: np.ndarray) -> np.ndarray:
    """Length of every edge ``edges`` (e, 2) over positions ``X`` (n, d), (e,)."""
    a, b = np.ascontiguousarray(edges[:, 0]), np.ascontiguousarray(edges[:, 1])
    total = np.zeros(len(edges))
    for c in range(X.shape[1]):  # coordinates
        col = np.ascontiguousarray(X[:, c])
        d = col[a] - col[b]
        total += d * d
    return np.sqrt(total)


def corner_angles(X: np.ndarray, faces: np.ndarray):
    """Interior angle of every corner and the lengths of its two edges.

    Returns ``(angle, to_next, to_prev)``, each (3m,) float64: the angle at corner
    ``c = 3f + k`` in [0, pi], and the lengths from its vertex to the next and previous
    vertex of face f. ``atan2(|e1 x e2|, e1 . e2)`` is accurate for tiny and obtuse angles
    and gives 0, not NaN, for zero-length edges. Works in chunks of faces that stay in
    cache.
    """
    m = len(faces)
    angle = np.empty((m, 3))
    length = np.empty((m, 3))
    x, y, z = (np.ascontiguousarray(X[:, c]) for c in range(3))
    corner = [np.ascontiguousarray(faces[:, k]) for k in range(3)]
    step = 1 << 16
    for lo in range(0, m, step):  # chunks of 65536 faces
        f = [c[lo : lo + step] for c in corner]
        ex, ey, ez = [], [], []
        for k in range(3):  # edge k runs from corner k to corner k+1
            a, b = f[k], f[(k + 1) % 3]
            ex.append(x[b] - x[a])
            ey.append(y[b] - y[a])
            ez.append(z[b] - z[a])
        nx = ey[0] * ez[1] - ez[0] * ey[1]  # twice the area vector, shared by the corners
        ny = ez[0] * ex[1] - ex[0] * ez[1]
        nz = ex[0] * ey[1] - ey[0] * ex[1]
        double_area = np.sqrt(nx * nx + ny * ny + nz * nz)
        sl = slice(lo, lo + len(f[0]))
        for k in range(3):
            j = (k + 2) % 3  # the edge arriving at corner k
            dot = -(ex[j] * ex[k] + ey[j] * ey[k] + ez[j] * ez[k])
            angle[sl, k] = np.arctan2(double_area, dot)
            length[sl, k] = np.sqrt(ex[k] * ex[k] + ey[k] * ey[k] + ez[k] * ez[k])
    return angle.ravel(), length.ravel(), length[:, PREV].ravel()
