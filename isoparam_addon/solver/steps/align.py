"""Step 4 of Sun & Hancock: rotation and anisotropic scale fitted to edge lengths,
Eqs. (15)-(18).

With ``A = R^T S^2 R`` the squared 2D length of edge (i, j) is linear in
``(A11, A12, A22)``, Eq. (17), so minimising Eq. (16),
``sum (d_ij^2 - l_ij^2)^2``, is a 3-unknown linear least-squares problem per island.
The eigendecomposition of A gives R and S, and ``y_i = S R y_Ii`` (Eq. 15).
"""

from __future__ import annotations

import numpy as np

from ..geometry import TINY, safe_divide, signed_areas
from ..mesh.islands import Islands

__all__ = ["fit_rotation_scale", "orient"]


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
    floor = 1e-12 * np.maximum(s2[:, 1:], TINY)
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
