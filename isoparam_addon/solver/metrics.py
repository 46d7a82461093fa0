"""Distortion measures of a UV layout against its 3D mesh.

Every function takes ``V (n, 3)``, ``F (m, 3)`` and ``uv``, either per vertex ``(n, 2)``
or per face corner ``(m, 3, 2)`` (a layout with seams). Measures whose value depends
on the layout's overall size are scale-normalised as stated, so a layout packed into
the unit square (Blender) and one in mesh units (isoparam) compare fairly.

Edge measures use every UV edge once: an interior edge whose two faces agree on its
UVs counts once, a seam edge counts once per side. Face measures skip faces of zero
3D area (they carry no weight) and are weighted by 3D area; on a mesh with no face of
positive area they are NaN (there is nothing to weight).

Summary (:func:`distortion` returns all of them):

``residual_variance``
    The paper's measure (Sec. 6): variance of ``d_ij - l_ij`` (2D minus 3D edge length),
    mesh units, no rescaling.
``one_minus_r2``
    Isomap's residual variance ``1 - R^2`` of the 2D against the 3D edge lengths
    (Tenenbaum et al. 2000); scale-free.
``edge_rms``
    Relative RMS edge-length error ``sqrt(mean(((s d - l) / l)^2))`` at the best global
    scale s.
``stretch_l2``, ``stretch_linf``
    Sander et al. (2001) L2 and L-infinity texture stretch of the map from UV to 3D,
    after scaling the layout to the 3D area; both are 1 for an isometry.
``area_distortion``
    Area-weighted mean ``|log(sigma1 sigma2)|`` at the area-matching scale (0 = equiareal).
``angle_distortion``
    Area-weighted mean ``|log(sigma1 / sigma2)|`` (0 = conformal).
``angle_error_deg``
    Mean absolute difference of corner angles, degrees.
``symmetric_dirichlet``
    Area-weighted mean ``sigma1^2 + sigma1^-2 + sigma2^2 + sigma2^-2`` at its optimal
    global scale; 4 for an isometry (Smith & Schaefer 2015).
``flipped``
    Faces whose UV orientation disagrees with their island's area majority, plus faces
    collapsed to zero UV area.
"""

from __future__ import annotations

import numpy as np

from .mesh import HalfEdges

__all__ = [
    "corner_uvs",
    "edge_lengths",
    "singular_values",
    "residual_variance",
    "one_minus_r2",
    "edge_rms",
    "stretch",
    "symmetric_dirichlet",
    "flipped",
    "distortion",
]


def corner_uvs(F: np.ndarray, uv: np.ndarray) -> np.ndarray:
    """Per-corner UVs (m, 3, 2) from per-vertex (n, 2) or per-corner (m, 3, 2) input."""
    uv = np.asarray(uv, dtype=np.float64)
    if uv.ndim == 3:
        return uv
    return uv[F]


def edge_lengths(V, F, uv):
    """3D and 2D length of every UV edge: ``(l (e,), d (e,))``."""
    F = np.asarray(F, dtype=np.int64)
    cuv = corner_uvs(F, uv)
    he = HalfEdges(F, len(V))
    h = np.arange(F.size)
    nxt = 3 * (h // 3) + np.array([1, 2, 0])[h % 3]
    quv = cuv.reshape(-1, 2)
    flat = F.ravel()
    t = he.twin
    keep = t < 0
    paired = t >= 0
    tn = np.where(paired, 3 * (t // 3) + np.array([1, 2, 0])[np.maximum(t, 0) % 3], 0)
    # the twin runs the other way when the faces agree in orientation
    same_dir = paired & (flat[np.maximum(t, 0)] == flat[h])
    ta = np.where(same_dir, t, tn)
    tb = np.where(same_dir, tn, t)
    agree = paired & np.all(quv[ta] == quv[h], axis=1) & np.all(quv[tb] == quv[nxt], axis=1)
    keep |= paired & (~agree | (h < t))
    a, b = flat[h[keep]], flat[nxt[keep]]
    l3 = np.linalg.norm(np.asarray(V, dtype=np.float64)[a] - np.asarray(V, dtype=np.float64)[b], axis=1)
    l2 = np.linalg.norm(quv[h[keep]] - quv[nxt[keep]], axis=1)
    return l3, l2


def residual_variance(V, F, uv) -> float:
    """Variance of the 2D-minus-3D edge length (the paper's measure), mesh units."""
    l3, l2 = edge_lengths(V, F, uv)
    return float(np.var(l2 - l3))


def one_minus_r2(V, F, uv) -> float:
    """Isomap-style ``1 - R^2`` between 2D and 3D edge lengths."""
    l3, l2 = edge_lengths(V, F, uv)
    if np.std(l2) == 0 or np.std(l3) == 0:
        return 1.0
    r = np.corrcoef(l2, l3)[0, 1]
    return float(1.0 - r * r)


def edge_rms(V, F, uv) -> float:
    """Relative RMS edge-length error at the best global scale."""
    l3, l2 = edge_lengths(V, F, uv)
    ok = l3 > 0
    r = l2[ok] / l3[ok]
    rr = float((r * r).sum())
    s = float(r.sum()) / rr if rr > 0 else 0.0
    return float(np.sqrt(np.mean((s * r - 1.0) ** 2)))


def _frames(V, F, cuv):
    """3D face areas, and the 2x2 Jacobians ``(a, b, c, d)`` (each (m,)) of the map from
    each face to UV: ``J = [[a, b], [c, d]]``.

    Column by column: 1-D gathers and arithmetic on (m,) arrays are several times faster
    than on (m, 3) and (m, 2) rows (200k faces: 14 ms against 48 ms here).
    """
    V = np.asarray(V, dtype=np.float64)
    i0, i1, i2 = (np.ascontiguousarray(F[:, k]) for k in range(3))
    e1, e2 = [], []
    for c in range(3):  # x, y, z
        col = np.ascontiguousarray(V[:, c])
        base = col[i0]
        e1.append(col[i1] - base)
        e2.append(col[i2] - base)
    n1 = np.sqrt(e1[0] * e1[0] + e1[1] * e1[1] + e1[2] * e1[2])
    cx = e1[1] * e2[2] - e1[2] * e2[1]
    cy = e1[2] * e2[0] - e1[0] * e2[2]
    cz = e1[0] * e2[1] - e1[1] * e2[0]
    cross = np.sqrt(cx * cx + cy * cy + cz * cz)
    area = 0.5 * cross
    ok = (cross > 1e-14 * np.maximum(n1, 1e-300) ** 2) & (n1 > 0)
    x1 = np.where(ok, n1, 1.0)
    x2 = np.where(ok, (e1[0] * e2[0] + e1[1] * e2[1] + e1[2] * e2[2]) / x1, 0.0)
    y2 = np.where(ok, cross / x1, 1.0)
    # J [x1 x2; 0 y2] = [q1 q2], q1 and q2 the UV edges from corner 0
    r = x2 / x1
    J = []
    for c in range(2):  # u, v
        base = cuv[:, 0, c]
        q1, q2 = cuv[:, 1, c] - base, cuv[:, 2, c] - base
        J += [q1 / x1, (q2 - q1 * r) / y2]
    return area, ok, tuple(J)


def singular_values(V, F, uv):
    """Singular values ``sigma1 >= sigma2`` of the 3D-to-UV Jacobian per face.

    Returns ``(sigma (m, 2), area3d (m,), valid (m,) bool)``; invalid (zero-area 3D)
    faces get sigma = 1.
    """
    F = np.asarray(F, dtype=np.int64)
    area, ok, (a, b, c, d) = _frames(V, F, corner_uvs(F, uv))
    # closed form without cancellation: sigma = |q +- r| with q, r the conformal and
    # anti-conformal parts of J
    q = 0.5 * np.hypot(a + d, c - b)
    r = 0.5 * np.hypot(a - d, c + b)
    sig = np.stack([q + r, np.abs(q - r)], axis=1)
    sig[~ok] = 1.0
    return sig, area, ok


def _area_scale(V, F, uv) -> float:
    """Factor that makes the UV area equal the 3D area."""
    F = np.asarray(F, dtype=np.int64)
    cuv = corner_uvs(F, uv)
    q1, q2 = cuv[:, 1] - cuv[:, 0], cuv[:, 2] - cuv[:, 0]
    a2 = 0.5 * np.abs(q1[:, 0] * q2[:, 1] - q1[:, 1] * q2[:, 0]).sum()
    p = np.asarray(V, dtype=np.float64)[F]
    a3 = 0.5 * np.linalg.norm(np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0]), axis=1).sum()
    return float(np.sqrt(a3 / a2)) if a2 > 0 else 1.0


def stretch(V, F, uv) -> tuple[float, float]:
    """Sander's (L2, Linf) stretch of the UV-to-3D map at equal total area."""
    sig, area, ok = singular_values(V, F, uv)
    sig = sig * _area_scale(V, F, uv)
    with np.errstate(divide="ignore"):
        big = np.where(sig[:, 1] > 0, 1.0 / sig[:, 1], np.inf)  # Gamma of the inverse map
        small = 1.0 / sig[:, 0]
    w = area * ok
    l2 = np.sqrt((0.5 * (big**2 + small**2) * w).sum() / w.sum())
    return float(l2), float(big[ok].max(initial=1.0))


def symmetric_dirichlet(V, F, uv) -> float:
    """Area-weighted symmetric Dirichlet energy at its optimal global scale (>= 4)."""
    sig, area, ok = singular_values(V, F, uv)
    w = area * ok
    with np.errstate(divide="ignore"):
        pos = ((sig**2).sum(axis=1) * w).sum()
        neg = ((1.0 / sig**2).sum(axis=1) * w).sum()
    if not np.isfinite(neg):
        return float("inf")
    s2 = np.sqrt(neg / pos)
    return float((s2 * pos + neg / s2) / w.sum())


def flipped(V, F, uv, face_island=None) -> int:
    """Faces folded against their island's orientation, or collapsed to zero UV area."""
    F = np.asarray(F, dtype=np.int64)
    cuv = corner_uvs(F, uv)
    q1, q2 = cuv[:, 1] - cuv[:, 0], cuv[:, 2] - cuv[:, 0]
    signed = 0.5 * (q1[:, 0] * q2[:, 1] - q1[:, 1] * q2[:, 0])
    if face_island is None:
        face_island = uv_islands(F, cuv)
    major = np.bincount(face_island, signed) >= 0
    sign_ok = np.where(major[face_island], signed > 0, signed < 0)
    return int((~sign_ok).sum())


def uv_islands(F: np.ndarray, cuv: np.ndarray) -> np.ndarray:
    """Faces connected across edges whose UVs agree on both sides, (m,) labels."""
    import scipy.sparse as sp
    from scipy.sparse import csgraph

    F = np.asarray(F, dtype=np.int64)
    he = HalfEdges(F, int(F.max()) + 1)
    h = np.flatnonzero(he.twin > np.arange(F.size))
    t = he.twin[h]
    quv = cuv.reshape(-1, 2)
    flat = F.ravel()
    nxt = lambda x: 3 * (x // 3) + np.array([1, 2, 0])[x % 3]  # noqa: E731
    same_dir = flat[t] == flat[h]
    ta = np.where(same_dir, t, nxt(t))
    tb = np.where(same_dir, nxt(t), t)
    agree = np.all(quv[ta] == quv[h], axis=1) & np.all(quv[tb] == quv[nxt(h)], axis=1)
    m = len(F)
    g = sp.coo_matrix((np.ones(agree.sum()), (h[agree] // 3, t[agree] // 3)), shape=(m, m))
    return csgraph.connected_components(g, directed=False)[1]


def distortion(V, F, uv, face_island=None) -> dict:
    """Every measure of this module in one dict (see the module docstring)."""
    F = np.asarray(F, dtype=np.int64)
    cuv = corner_uvs(F, uv)
    l3, l2 = edge_lengths(V, F, cuv)
    sig, area, ok = singular_values(V, F, cuv)
    w = area * ok
    k = _area_scale(V, F, cuv)
    with np.errstate(divide="ignore", invalid="ignore"):
        logdet = np.abs(np.log(sig[:, 0] * sig[:, 1] * k * k))
        logratio = np.abs(np.log(sig[:, 0] / sig[:, 1]))
    p = np.asarray(V, dtype=np.float64)[F]
    ang3 = _angles(p)
    ang2 = _angles(cuv)
    l2s, linf = stretch(V, F, cuv)
    r = l2[l3 > 0] / l3[l3 > 0]
    return {
        "residual_variance": float(np.var(l2 - l3)),
        "one_minus_r2": one_minus_r2(V, F, cuv),
        "edge_rms": edge_rms(V, F, cuv),
        "stretch_l2": l2s,
        "stretch_linf": linf,
        "area_distortion": float((logdet * w).sum() / w.sum()),
        "angle_distortion": float((logratio * w).sum() / w.sum()),
        "angle_error_deg": float(np.degrees(np.abs(ang2 - ang3)[ok].mean())) if ok.any() else 0.0,
        "symmetric_dirichlet": symmetric_dirichlet(V, F, cuv),
        "flipped": flipped(V, F, cuv, face_island),
        "max_edge_ratio": float(r.max() / r.min()) if r.size and r.min() > 0 else float("inf"),
    }


def _angles(p: np.ndarray) -> np.ndarray:
    """Corner angles (m, 3) of triangles p (m, 3, d)."""
    e1 = p[:, [1, 2, 0]] - p
    e2 = p[:, [2, 0, 1]] - p
    if p.shape[2] == 2:
        cross = np.abs(e1[..., 0] * e2[..., 1] - e1[..., 1] * e2[..., 0])
    else:
        cross = np.linalg.norm(np.cross(e1, e2), axis=2)
    return np.arctan2(cross, (e1 * e2).sum(axis=2))
