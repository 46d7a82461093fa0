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
    "dirichlet_parts",
    "Frames",
    "frames_of",
    "gradient_coefficients",
    "det2",
    "NEXT",
    "TINY",
    "PREV",
    "next_corner",
    "prev_corner",
    "rotate_faces",
    "safe_divide",
    "triangle_angles",
    "conformal_parts",
    "signed_double_areas",
    "signed_areas",
    "corner_signed_areas",
    "Triangles",
    "triangles",
    "face_areas",
    "edge_lengths",
    "corner_angles",
    "angle_defects",
]

# the floor of a scale that must stay positive (a relative threshold of a zero scale would
# be zero): the smallest normal double, so it changes no scale that is not zero
TINY = 1e-300
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


def det2(a, b, c, d):
    """The determinant of 2x2 matrices ``[[a, b], [c, d]]``, element by element: a Jacobian's,
    or twice the signed area of a triangle with edges ``(a, c)`` and ``(b, d)``."""
    return a * d - b * c


def dirichlet_parts(a, b, c, d):
    """The two parts of the symmetric Dirichlet energy density of 2x2 Jacobians
    ``[[a, b], [c, d]]`` (Smith & Schaefer 2015), and their determinant:
    ``(||J||_F^2, ||J^-1||_F^2, det J)``, with ``||J^-1||_F^2 = ||J||_F^2 / det^2`` in 2D
    (inf where det is 0). A uniform scale s of the map scales them by s^2 and 1 / s^2."""
    det = det2(a, b, c, d)
    fro = a * a + b * b + c * c + d * d
    return fro, fro / (det * det), det


def signed_double_areas(uv: np.ndarray, faces: np.ndarray) -> np.ndarray:
    """Twice the signed area of every triangle of a layout, (m,), positive counter-clockwise."""
    u, v = np.ascontiguousarray(uv[:, 0]), np.ascontiguousarray(uv[:, 1])
    a, b, c = (np.ascontiguousarray(faces[:, k]) for k in range(3))
    ua, va = u[a], v[a]
    return det2(u[b] - ua, u[c] - ua, v[b] - va, v[c] - va)


def signed_areas(uv: np.ndarray, faces: np.ndarray) -> np.ndarray:
    """Signed area of every triangle of a layout, (m,), positive counter-clockwise."""
    return 0.5 * signed_double_areas(uv, faces)


def corner_signed_areas(cuv: np.ndarray) -> np.ndarray:
    """Signed area of every triangle given by its corner UVs (m, 3, 2) -> (m,)."""
    u, v = cuv[..., 0], cuv[..., 1]
    return 0.5 * det2(u[:, 1] - u[:, 0], u[:, 2] - u[:, 0], v[:, 1] - v[:, 0], v[:, 2] - v[:, 0])


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
        """Faces with no area to speak of (:attr:`Frames.flat`): a face whose corners sit
        on one line or one point has no orientation, so it cannot fold; the refinement
        gives it a stand-in."""
        return frames_of(self).flat


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


class Frames(NamedTuple):
    """Each face in its own plane, the frame the Jacobians of maps from it are taken in:
    corners (0, 0), (x1, 0), (x2, y2), y2 > 0. One rule for faces with no area to speak
    of (``flat``: twice the area at most ``COLLAPSED`` times the square of the longer side
    from the first corner, the same for every choice of first corner up to which two sides
    that measures): they keep a stand-in height of ``COLLAPSED`` times that side, and a
    face collapsed to a point (or below 1e-9 of the mesh's largest face) a stand-in size,
    so that a gradient on them is large but finite. All (m,)."""

    x1: np.ndarray
    x2: np.ndarray
    y2: np.ndarray
    flat: np.ndarray  # bool

    @property
    def area(self) -> np.ndarray:
        """The area (the stand-in's on flat faces)."""
        return 0.5 * self.x1 * self.y2


def frames_of(tri: Triangles) -> Frames:
    """The :class:`Frames` of triangles."""
    scale = np.maximum(tri.l1, tri.l2)
    size = float(scale.max(initial=0.0))
    scale = np.maximum(scale, 1e-9 * (size if size > 0 else 1.0))
    floor = COLLAPSED * scale
    x1 = np.maximum(tri.l1, floor)
    x2 = tri.dot / x1
    y2 = tri.cross / x1
    # flat: twice the area below COLLAPSED of the longer side squared, whichever corner is
    # first (a face whose first side is shorter than the floor is flat by this rule too,
    # so no face that is not flat has its frame taken from a stand-in side)
    return Frames(x1, x2, np.maximum(y2, floor), tri.cross <= floor * scale)


def gradient_coefficients(frames: Frames) -> tuple[np.ndarray, np.ndarray]:
    """Per face the weights (m, 3) of its corners' values in the gradient of the linear
    function over it: ``grad f = (dx . f, dy . f)`` for values ``f`` (m, 3) at the corners,
    so the Jacobian of a map ``(u, v)`` is ``[[dx . u, dy . u], [dx . v, dy . v]]``."""
    x1, x2, y2 = frames.x1, frames.x2, frames.y2
    zero = np.zeros(len(x1))
    dx = np.stack([-1.0 / x1, 1.0 / x1, zero], axis=1)
    dy = np.stack([(x2 / x1 - 1.0) / y2, -x2 / (x1 * y2), 1.0 / y2], axis=1)
    return dx, dy


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


def triangle_angles(p: np.ndarray) -> np.ndarray:
    """Corner angles (m, 3) in [0, pi] of triangles given by their corners ``p`` (m, 3, d),
    d = 2 or 3 (the kernel of :func:`corner_angles`, for triangles apart)."""
    angle, _ = _angles_and_lengths([p[:, k] for k in range(3)])
    return angle


def conformal_parts(a, b, c, d) -> tuple[np.ndarray, np.ndarray]:
    """The conformal and anti-conformal parts ``(q, r)`` of 2x2 Jacobians
    ``J = [[a, b], [c, d]]`` (each (m,)): the singular values are ``q + r`` and ``|q - r|``
    (closed form, without the cancellation of an eigenvalue formula), and ``q > r`` where
    J keeps orientation."""
    return 0.5 * np.hypot(a + d, c - b), 0.5 * np.hypot(a - d, c + b)


def corner_angles(X: np.ndarray, faces: np.ndarray):
    """Interior angle of every corner and the lengths of its two edges.

    Returns ``(angle, to_next, to_prev)``, each (3m,) float64: the angle at corner
    ``c = 3f + k`` in [0, pi], and the lengths from its vertex to the next and previous
    vertex of face f. Works in chunks of faces that stay in cache.
    """
    m = len(faces)
    angle = np.empty((m, 3))
    length = np.empty((m, 3))
    X = np.asarray(X)
    columns = [np.ascontiguousarray(X[:, c]) for c in range(X.shape[1])]
    corner = [np.ascontiguousarray(faces[:, k]) for k in range(3)]
    step = 1 << 16
    for lo in range(0, m, step):  # chunks of 65536 faces
        sl = slice(lo, min(lo + step, m))
        points = [np.stack([x[c[sl]] for x in columns], axis=1) for c in corner]
        angle[sl], length[sl] = _angles_and_lengths(points)
    return angle.ravel(), length.ravel(), length[:, PREV].ravel()


def angle_defects(X: np.ndarray, faces: np.ndarray, vertex: np.ndarray | None = None, n: int | None = None):
    """Per vertex (n,), its angle defect ``2 pi - sum of its corners' angles`` (the
    discrete Gaussian curvature of an interior vertex) over the triangles ``faces`` (m, 3)
    of ``X``. ``vertex`` (len(X),): the vertex each row of ``X`` is a copy of (split
    vertices summed at their mesh vertex; default: each its own), ``n`` the vertices
    counted (default: as many as rows of ``X``, or ``vertex.max() + 1``)."""
    angle, _, _ = corner_angles(X, faces)
    corner = faces.ravel() if vertex is None else vertex[faces.ravel()]
    if n is None:
        n = len(X) if vertex is None else int(vertex.max(initial=-1)) + 1
    return 2.0 * np.pi - np.bincount(corner, angle, minlength=n)


def _angles_and_lengths(points: list[np.ndarray]) -> tuple[np.ndarray, np.ndarray]:
    """The one corner-angle kernel: for triangles with corners ``points`` (three (m, d),
    d = 2 or 3), the angle at each corner (m, 3) in [0, pi] and the length of the edge
    from each corner to the next (m, 3). ``atan2(2 area, e1 . e2)`` is accurate for tiny
    and obtuse angles and gives 0, not NaN, for zero-length edges."""
    d = points[0].shape[1]
    edges = [[points[(k + 1) % 3][:, c] - points[k][:, c] for c in range(d)] for k in range(3)]
    e0, e1 = edges[0], edges[1]  # edge k runs from corner k to corner k+1
    if d == 2:
        double_area = np.abs(det2(e0[0], e0[1], e1[0], e1[1]))
    else:  # twice the area vector, shared by the corners
        nx = e0[1] * e1[2] - e0[2] * e1[1]
        ny = e0[2] * e1[0] - e0[0] * e1[2]
        nz = e0[0] * e1[1] - e0[1] * e1[0]
        double_area = np.sqrt(nx * nx + ny * ny + nz * nz)
    angle = np.empty((len(points[0]), 3))
    length = np.empty((len(points[0]), 3))
    for k in range(3):
        j = (k + 2) % 3  # the edge arriving at corner k
        dot = -sum_products(edges[j], edges[k])
        angle[:, k] = np.arctan2(double_area, dot)
        length[:, k] = np.sqrt(sum_products(edges[k], edges[k]))
    return angle, length


def sum_products(a: list[np.ndarray], b: list[np.ndarray]) -> np.ndarray:
    """``a . b`` for vectors given as lists of coordinate arrays, summed in order."""
    out = a[0] * b[0]
    for x, y in zip(a[1:], b[1:]):
        out = out + x * y
    return out
