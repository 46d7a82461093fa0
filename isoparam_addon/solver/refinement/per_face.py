"""Per-face quantities of a piecewise-linear map from a triangle mesh to the plane: each
face's reference frame and the gradient operators (:class:`FaceFrames`), the Jacobians,
the symmetric Dirichlet energy and its derivative, the first step at which a face
collapses, and SLIM's per-face proxy weights: the kernels the refinement descends with.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp

from ..geometry import conformal_parts, det2, dirichlet_parts, frames_of, gradient_coefficients, triangles
from ..mesh.islands import Labelled

__all__ = [
    "BlockPattern",
    "FaceFrames",
    "block_matrix",
    "dirichlet_hessians",
    "layout_energy",
    "max_step",
    "slim_weights",
    "symmetric_dirichlet",
]


class FaceFrames:
    """Per-face reference triangles and the gradient operators of piecewise-linear maps.

    Face f maps to its own plane as (0, 0), (x1, 0), (x2, y2), y2 > 0 (its
    :class:`~isoparam_addon.solver.geometry.Frames`). For a function with values
    (f0, f1, f2) at the corners, ``grad f = (Dx f, Dy f)``: the gradient coefficients as
    sparse operators over the vertices.

    Attributes
    ----------
    area : (m,) float64
        3D area (degenerate faces get a tiny positive stand-in, see ``degenerate``).
    Dx, Dy : (m, n) sparse
    dx, dy : (m, 3) float64
        The same coefficients per corner of each face.
    degenerate : (m,) bool
    faces : (m, 3) int64
    """

    def __init__(self, X: np.ndarray, faces: np.ndarray):
        m, n = len(faces), len(X)
        self.faces = faces
        frames = frames_of(triangles(X, faces))
        # (a face collapsed to a point takes a stand-in size: a zero area would make its
        # gradient 0/0, the whole island's energy NaN)
        self.degenerate = frames.flat
        self.area = frames.area
        dx, dy = gradient_coefficients(frames)
        self.dx, self.dy = dx, dy  # (m, 3): the coefficients per corner
        rows = np.repeat(np.arange(m), 3)
        idx = faces.ravel()
        self.Dx = sp.csr_matrix((dx.ravel(), (rows, idx)), shape=(m, n))
        self.Dy = sp.csr_matrix((dy.ravel(), (rows, idx)), shape=(m, n))
        self.DxT, self.DyT = self.Dx.T.tocsr(), self.Dy.T.tocsr()
        self._assembled = False  # (whether :meth:`laplacian` ran once)
        self._pattern: BlockPattern | None = None

    def jacobians(self, uv: np.ndarray):
        """(a, b, c, d) per face: J = [[a, b], [c, d]] = [[u_x, u_y], [v_x, v_y]]."""
        u, v = uv[:, 0], uv[:, 1]
        return self.Dx @ u, self.Dy @ u, self.Dx @ v, self.Dy @ v

    def laplacian(self, weights: np.ndarray | None = None) -> sp.csr_matrix:
        """The cotangent Laplacian ``sum_f w_f A_f (Dx^T Dx + Dy^T Dy)`` (n, n), with
        per-face ``weights`` (m,) (1 without).

        The first is two sparse products; from the second on (a proxy re-weighted again
        and again) the faces' 3x3 blocks are summed into a :class:`BlockPattern` kept
        from then: one ``bincount`` each, a third of the products' time on large meshes
        once its sort is paid."""
        wa = self.area if weights is None else self.area * weights
        if not self._assembled:
            self._assembled = True
            A = sp.diags(wa)
            return (self.DxT @ A @ self.Dx + self.DyT @ A @ self.Dy).tocsr()
        if self._pattern is None:
            self._pattern = BlockPattern.of(self.faces, self.Dx.shape[1])
        dx, dy = self.dx, self.dy
        blocks = dx[:, :, None] * dx[:, None, :] + dy[:, :, None] * dy[:, None, :]
        return self._pattern.matrix(blocks * wa[:, None, None])


def symmetric_dirichlet(a, b, c, d, area):
    """Symmetric Dirichlet per face and its derivative with respect to J."""
    fro, inv, det = dirichlet_parts(a, b, c, d)
    e = area * (fro + inv)
    # d/dJ ||J^{-1}||^2 = (2 / det^2) J - (2 ||J||^2 / det^3) cof(J), cof(J) = [[d, -c], [-b, a]]
    k1 = 2.0 * area * (1.0 + 1.0 / (det * det))
    k2 = -2.0 * area * fro / (det * det * det)
    return e, (k1 * a + k2 * d, k1 * b - k2 * c, k1 * c - k2 * b, k1 * d + k2 * a)


def dirichlet_hessians(J, area) -> np.ndarray:
    """Per face (m, 4, 4), the Hessian of its symmetric Dirichlet energy ``A (|J|^2 +
    |J|^2 / det^2)`` in the Jacobian's entries (a, b, c, d), made positive semi-definite
    (negative eigenvalues set to 0): the second-order proxy's blocks (Teran et al. 2005).

    With F = |J|^2 and D = det J: the Hessian of F is 2 I, of D the constant ``HD``, and
    that of F / D^2 is ``2 I / D^2 - 2 (gF gD^T + gD gF^T) / D^3 + 6 F gD gD^T / D^4 -
    2 F HD / D^3`` (gF = 2 J, gD = (d, -c, -b, a)).

    The projection is closed-form (Smith, De Goes and Kim 2019, analytic eigensystems):
    in the singular values s1, s2 the energy is ``f = s1^2 + s2^2 + s1^-2 + s2^-2``, whose
    Hessian has the eigenvalues ``f_ii = 2 + 6 / s_i^4`` on the two scalings, ``(f_1 -
    f_2) / (s1 - s2) = 2 + 2 (s1^2 + s1 s2 + s2^2) / (s1 s2)^3`` on the flip, and ``(f_1 +
    f_2) / (s1 + s2) = 2 - 2 (s1^2 - s1 s2 + s2^2) / (s1 s2)^3`` on the twist, the one
    that can be negative. The twist is the turn ``R90 U V^T`` of the nearest rotation
    ``U V^T``; with the conformal parts q, r (s = q +- r) its eigenvalue is ``2 - 2 (q^2 +
    3 r^2) / (q^2 - r^2)^3``. Faces that fold (no such frame) are projected numerically."""
    a, b, c, d = J
    Jv = np.stack([a, b, c, d], axis=1)
    F = (Jv * Jv).sum(axis=1)
    D = det2(a, b, c, d)
    gF, gD = 2.0 * Jv, np.stack([d, -c, -b, a], axis=1)
    HD = np.zeros((4, 4))
    HD[0, 3] = HD[3, 0] = 1.0
    HD[1, 2] = HD[2, 1] = -1.0
    q, r = conformal_parts(a, b, c, d)
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        inv = 1.0 / D
        H = (2.0 * (1.0 + inv * inv))[:, None, None] * np.eye(4)
        H -= (2.0 * inv**3)[:, None, None] * (gF[:, :, None] * gD[:, None, :] + gD[:, :, None] * gF[:, None, :])
        H += (6.0 * F * inv**4)[:, None, None] * (gD[:, :, None] * gD[:, None, :])
        H -= (2.0 * F * inv**3)[:, None, None] * HD
        twist = np.stack([-(c - b), -(a + d), a + d, -(c - b)], axis=1) / (2.0 * np.sqrt(2.0) * q)[:, None]
        negative = np.minimum(2.0 - 2.0 * (q * q + 3.0 * r * r) / (q * q - r * r) ** 3, 0.0)
        H -= negative[:, None, None] * (twist[:, :, None] * twist[:, None, :])
    H = np.where(np.isfinite(H).all(axis=(1, 2))[:, None, None], H, 0.0)
    folded = np.flatnonzero(~(D > 0))
    if len(folded):
        w, V = np.linalg.eigh(H[folded])
        H[folded] = (V * np.maximum(w, 0.0)[:, None, :]) @ V.transpose(0, 2, 1)
    return H * area[:, None, None]


@dataclass(frozen=True)
class BlockPattern:
    """Where dense blocks, block i over the rows and columns ``at[i]``, land in the
    (size, size) CSR matrix that sums them: built once for a set of faces, it turns each
    new set of their blocks into a matrix by one ``bincount`` (no sort of the entries)."""

    indptr: np.ndarray
    indices: np.ndarray
    slot: np.ndarray  # (p k^2,) each block entry's place in the matrix's data
    size: int

    @classmethod
    def of(cls, at: np.ndarray, size: int, width: int = 1) -> BlockPattern:
        """The pattern of blocks over the rows and columns ``at`` (p, k) of ``size``.

        With ``width`` > 1, ``at`` numbers vertices of ``width`` coordinates each
        (coordinate ``width * v + c`` of ``width * size``), and a block (k width, k width)
        runs over its vertices' coordinates in that order (vertex, then coordinate): the
        pattern is found among the p k^2 vertex pairs and spread to their coordinates by
        arithmetic, a sort of ``width^2`` times fewer keys. The matrix is the one the
        coordinates' own pattern gives, entry for entry."""
        k = at.shape[1]
        rows, cols = np.repeat(at, k, axis=1).ravel(), np.tile(at, (1, k)).ravel()
        key = rows.astype(np.int64) * size + cols
        order = np.argsort(key, kind="stable")
        ranked = key[order]
        first = np.ones(len(ranked), dtype=bool)
        first[1:] = ranked[1:] != ranked[:-1]
        slot = np.empty(len(key), dtype=np.int64)
        slot[order] = np.cumsum(first) - 1
        distinct = ranked[first]
        indptr = np.searchsorted(distinct // size, np.arange(size + 1))
        if width == 1:
            return cls(indptr, distinct % size, slot, size)
        w = width
        deg = np.diff(indptr)
        # coordinate row w v + c holds the w deg(v) columns w u + d of v's pairs (u, d
        # ascending), from here on
        row_start = (w * w * indptr[:-1])[:, None] + np.arange(w) * (w * deg)[:, None]  # (size, w)
        columns = (w * (distinct % size)[:, None] + np.arange(w)).ravel()
        owner = np.repeat(np.arange(size), w * deg)
        within = np.arange(len(columns)) - w * indptr[owner]
        indices = np.empty(w * len(columns), dtype=np.int64)
        for c in range(w):
            indices[row_start[owner, c] + within] = columns
        # a block's entry (a, c; b, d): row w at[a] + c, at the pair (a, b)'s place in it
        # (the columns (b, d) made one axis first: numpy's loops are slow over axes of 2)
        offset = slot.reshape(-1, k, k) - indptr[at][:, :, None]
        columns_of = (w * offset[:, :, :, None] + np.arange(w)).reshape(-1, k, 1, k * w)
        full = row_start[at][:, :, :, None] + columns_of
        return cls(np.append(row_start.ravel(), w * w * indptr[-1]), indices, full.ravel(), w * size)

    def matrix(self, blocks: np.ndarray) -> sp.csr_matrix:
        """The sum of ``blocks`` (p, k, k) as a sparse (size, size) matrix."""
        data = np.bincount(self.slot, blocks.ravel(), minlength=len(self.indices))
        return sp.csr_matrix((data, self.indices, self.indptr), shape=(self.size, self.size))


def block_matrix(at: np.ndarray, blocks: np.ndarray, size: int) -> sp.csr_matrix:
    """The sparse (size, size) matrix that sums dense blocks ``blocks`` (p, k, k), block i
    over the rows and columns ``at[i]`` (p, k): an assembled Hessian."""
    return BlockPattern.of(at, size).matrix(blocks)


def max_step(J, dJ, limit: float = np.inf):
    """Per face, the first t in (0, ``limit``] with det(J + t dJ) = 0 (det J > 0), inf
    where there is none: (m,).

    det(J + t dJ) = qa t^2 + qb t + qc with qc = det J > 0. With a finite ``limit`` only
    the faces whose determinant can reach zero by then get their roots computed: those
    with det <= 0 at ``limit``, or with a minimum inside (0, limit) that is not positive
    (a few percent of the faces in a descent).
    """
    a, b, c, d = J
    da, db, dc, dd = dJ
    qa = det2(da, db, dc, dd)
    qb = a * dd + d * da - b * dc - c * db
    qc = det2(a, b, c, d)
    # (scaled by the largest, which leaves the roots: qb^2 and qa qc would overflow beyond 1e154)
    big = np.maximum(np.maximum(np.abs(qa), np.abs(qb)), np.abs(qc))
    big = np.where(np.isfinite(big) & (big > 0), big, 1.0)
    qa, qb, qc = qa / big, qb / big, qc / big
    t = np.full(len(a), np.inf)
    if np.isfinite(limit):
        with np.errstate(invalid="ignore"):
            dips = (qa > 0) & (qb < 0) & (qb > -2.0 * limit * qa) & (qb * qb >= 4.0 * qa * qc)
            rows = np.flatnonzero(((qa * limit + qb) * limit + qc <= 0) | dips)
        t[rows] = max_step((a[rows], b[rows], c[rows], d[rows]), tuple(x[rows] for x in dJ))
        return t
    # the roots as q / qa and qc / q with q = -(qb + sign(qb) sqrt(disc)) / 2: the textbook
    # (-qb -+ sqrt(disc)) / (2 qa) cancels where det is nearly linear in t (|qa qc| << qb^2:
    # a short step, or banks pushed apart evenly) and loses the root; qa = 0 needs no case
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        disc = qb * qb - 4.0 * qa * qc
        sq = np.sqrt(np.maximum(disc, 0.0))
        q = -0.5 * (qb + np.where(qb < 0, -sq, sq))
        real = disc >= 0
        r1 = np.where(real & (q / qa > 0), q / qa, np.inf)
        r2 = np.where(real & (qc / q > 0), qc / q, np.inf)
    return np.minimum(t, np.minimum(r1, r2))


def slim_weights(J) -> np.ndarray:
    """Per face, the scalar weight of SLIM's re-weighted proxy for the symmetric Dirichlet
    energy, 1 for an isometric face (m,).

    SLIM (Rabinovich et al. 2017, Sec. 4) weighs each singular direction by
    ``w(s)^2 = f'(s) / (2 (s - 1))``, here with f(s) = s^2 + s^-2:
    ``w^2 = (s + 1)(s^2 + 1) / s^3``, 4 at s = 1, growing as ``s^-3`` for a crushed
    direction. One proxy serves u and v only if the weight is the same in both
    directions: the mean of the two, divided by its isometric value.
    """
    a, b, c, d = J
    q, r = conformal_parts(a, b, c, d)
    s1 = np.maximum(q + r, 1e-50)  # a collapsed face weighs as much as a float allows
    s2 = np.maximum(q - r, 1e-50)  # (fold-free: q > r)
    w = sum((s + 1.0) * (s * s + 1.0) / (s * s * s) for s in (s1, s2)) / 8.0
    # on a grid of 2^(1/8) steps: the proxy, and with it the descent, must not follow
    # rounding (a layout that differs by 1e-9 would otherwise descend to points 1e-4
    # apart); a face's weight is off by 4% at most, which the quasi-Newton pairs absorb
    return np.exp2(np.round(8.0 * np.log2(np.minimum(w, 1e150))) / 8.0)


def layout_energy(frames: FaceFrames, per_face: Labelled, uv: np.ndarray) -> np.ndarray:
    """Per island, the symmetric Dirichlet energy of a layout as it is scaled (``sum_f A_f
    E_f``; :func:`.metrics.island_energy` gives it per area at the best scale), inf where
    a face folds."""
    a, b, c, d = frames.jacobians(uv)
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        e, _ = symmetric_dirichlet(a, b, c, d, frames.area)
    return per_face.sum(np.where(det2(a, b, c, d) > 0, e, np.inf))
