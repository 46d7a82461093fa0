"""Beyond the paper: how far from isometric a chart will lay out, predicted by linear solves.

A surface with Gaussian curvature K cannot lie flat without strain. To first order, the
in-plane strain ``eps`` (a symmetric 2x2 field) of the least-distorted flat layout is the
one of least ``integral |eps|^2`` that makes the metric flat: its linearized curvature,
``inc(eps) = eps_11,22 + eps_22,11 - 2 eps_12,12``, must cancel K. The minimizer is an
Airy stress field (plane elasticity with the curvature as incompatibility, as in the
theory of thin sheets: Seung & Nelson 1988; Audoly & Pomeau, *Elasticity and Geometry*,
2010, ch. 6),

    eps = [[phi_yy, -phi_xy], [-phi_xy, phi_xx]],    Delta^2 phi = K,

and a free boundary (no traction) clamps it: ``phi = d phi / dn = 0`` there. Three
quantities the charting needs follow, all from one linear solve:

- the **energy**: the symmetric Dirichlet energy per area is ``4 + 4 |eps|^2`` to second
  order, and ``integral |eps|^2 = integral phi K``, so a chart's predicted excess over
  isometric is ``4 sum_v phi_v K_v`` (K_v its angle defects);
- the **area change** ``trace eps = Delta phi``: negative where the layout will squeeze
  the surface (a cap, a bump), positive where it will stretch it;
- the **stress across a cut**: a slit along direction t opens where ``eps_nn = d^2 phi /
  dt^2`` is positive (the layout pulls its banks apart) and folds its banks over each
  other where it is negative.

Discretely, with the cotangent Laplacian ``L`` and the lumped mass ``M``, ``phi`` solves
``L_I^T M^{-1} L_I phi = K_I`` on the interior vertices I (the boundary's rows of L stay
in, which clamps it). Its factor would fill much more than a Laplacian's, so it is
solved by conjugate gradients preconditioned with ``L_II^{-1} M_I L_II^{-1}`` (the
simply supported plate: two solves with the Laplacian's factor), a fixed number of
iterations: 10 reach the clamped energy to about 1e-5, and a fixed count keeps the result
a smooth function of the mesh (no stopping test decides it).

The prediction is linear: it underestimates strongly curved charts and overestimates
those whose slits will open wide; it decides where to cut and when to stop, and the
refined layout is checked afterwards.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp
from scipy.sparse.linalg import splu

from ..geometry import angle_defects, safe_divide
from ..refinement.per_face import FaceFrames

__all__ = ["Prediction", "normal_stress", "predict"]

_ITERATIONS = 10  # conjugate-gradient steps: the clamped energy to about 1e-5 (5: 1e-2)


@dataclass(frozen=True)
class Prediction:
    """The linearized isometric distortion of charts (see the module docstring).

    Attributes
    ----------
    excess : (k,) float
        Per chart, the predicted symmetric Dirichlet energy above isometric,
        ``sum_f A_f (E_f - 4)``.
    area : (k,) float
        Per chart, its 3D area.
    trace : (n,) float
        Per vertex, the predicted area change ``trace eps`` (about the log of UV area
        over 3D area).
    phi : (n,) float
        The Airy stress function (0 on the boundary).
    """

    excess: np.ndarray
    area: np.ndarray
    trace: np.ndarray
    phi: np.ndarray

    def energy(self) -> np.ndarray:
        """Per chart (k,), the predicted symmetric Dirichlet energy per area (4 without area)."""
        return 4.0 + safe_divide(self.excess, self.area)

    def face_trace(self, faces: np.ndarray) -> np.ndarray:
        """Per face (m,), the area change at its corners, averaged."""
        return self.trace[faces].mean(axis=1)


def predict(
    X: np.ndarray, faces: np.ndarray, boundary: np.ndarray, face_chart: np.ndarray, n_charts: int, order=None
) -> Prediction:
    """The :class:`Prediction` of the charts ``face_chart`` (m,) of a mesh ``X`` (n, 3),
    ``faces`` (m, 3) whose ``boundary`` (n,) bool vertices are the charts' boundaries
    (every chart a disk, vertices not shared between charts). ``order`` (n,): a
    fill-reducing vertex order for the Laplacian's factor (SuperLU's COLAMD without).

    A chart with no interior vertex, or a Laplacian SuperLU finds singular (faces with
    no area), is predicted isometric."""
    n = len(X)
    frames = FaceFrames(X, faces)
    L = frames.laplacian()
    mass = np.bincount(faces.ravel(), np.repeat(frames.area / 3.0, 3), minlength=n)
    defect = np.where(boundary, 0.0, angle_defects(X, faces, n=n))
    inner = np.flatnonzero(~boundary & (np.bincount(faces.ravel(), minlength=n) > 0))
    if order is not None:
        rank = np.empty(n, dtype=np.int64)
        rank[order] = np.arange(n)
        inner = inner[np.argsort(rank[inner], kind="stable")]
    phi = np.zeros(n)
    if len(inner):
        try:
            phi[inner] = _clamped(L, mass, defect, inner, order is not None)
        except RuntimeError:  # SuperLU: "Factor is exactly singular"
            phi[:] = 0.0
    vertex_chart = np.zeros(n, dtype=np.int64)
    vertex_chart[faces.ravel()] = np.repeat(face_chart, 3)
    excess = 4.0 * np.bincount(vertex_chart, phi * defect, minlength=n_charts)
    area = np.bincount(face_chart, frames.area, minlength=n_charts)
    trace = -safe_divide(L @ phi, mass)
    return Prediction(np.maximum(excess, 0.0), area, trace, phi)


def _clamped(L: sp.csr_matrix, mass: np.ndarray, defect: np.ndarray, inner: np.ndarray, ordered: bool) -> np.ndarray:
    """``phi`` on the ``inner`` vertices: ``L_I^T M^{-1} L_I phi = K_I`` by
    ``_ITERATIONS`` steps of preconditioned conjugate gradients (see the module docstring)."""
    LI = L[:, inner].tocsc()
    LIt = LI.T.tocsr()
    inverse_mass = 1.0 / mass
    lu = splu(
        L[inner][:, inner].tocsc(),
        permc_spec="NATURAL" if ordered else "COLAMD",
        diag_pivot_thresh=0.0 if ordered else 1.0,
    )
    mass_inner = mass[inner]

    def preconditioned(r):
        return lu.solve(mass_inner * lu.solve(r))

    K = defect[inner]
    x = np.zeros(len(inner))
    r = K.copy()
    z = preconditioned(r)
    p = z.copy()
    rz = float(r @ z)
    for _ in range(_ITERATIONS):
        Ap = LIt @ (inverse_mass * (LI @ p))
        pAp = float(p @ Ap)
        if not pAp > 0.0:  # converged exactly (or nothing to solve)
            break
        alpha = rz / pAp
        x += alpha * p
        r -= alpha * Ap
        z = preconditioned(r)
        rz_next = float(r @ z)
        p = z + (rz_next / rz) * p
        rz = rz_next
    return x


def normal_stress(X: np.ndarray, faces: np.ndarray, phi: np.ndarray, edges: np.ndarray) -> np.ndarray:
    """Per edge (k, 2 vertex pairs), the predicted strain across a cut along it,
    ``d^2 phi / dt^2`` (t its direction): positive where a slit opens, negative where its
    banks would fold over each other. From the vertex gradients of ``phi`` (the
    area-weighted mean of its faces'), differenced along the edge."""
    n = len(X)
    a, b, c = (X[faces[:, k]] for k in range(3))
    normal = np.cross(b - a, c - a)  # twice the area times the unit normal
    double_area = np.linalg.norm(normal, axis=1)
    unit = safe_divide(normal, double_area[:, None])
    # gradient of a linear function on a triangle: sum_k phi_k (n x e_k) / (2 A), e_k the
    # edge opposite corner k
    grad = np.zeros((len(faces), 3))
    for k, (p, q) in enumerate(((b, c), (c, a), (a, b))):
        grad += phi[faces[:, k], None] * np.cross(unit, q - p)
    grad = safe_divide(grad, double_area[:, None])
    weight = 0.5 * double_area
    total = np.bincount(faces.ravel(), np.repeat(weight, 3), minlength=n)
    corner = faces.ravel()
    vertex_grad = np.stack(
        [np.bincount(corner, np.repeat(weight * grad[:, j], 3), minlength=n) for j in range(3)], axis=1
    )
    vertex_grad = safe_divide(vertex_grad, total[:, None])
    d = X[edges[:, 1]] - X[edges[:, 0]]
    return safe_divide(((vertex_grad[edges[:, 1]] - vertex_grad[edges[:, 0]]) * d).sum(axis=1), (d * d).sum(axis=1))
