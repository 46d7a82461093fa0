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
    collapsed to zero UV area; each island oriented across the edges its faces share in
    UV, so that input winding does not count (:func:`folded`). A face with no 3D area
    (its corners on a line: :attr:`.geometry.Triangles.collapsed`) has no orientation and
    is not counted.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass
from typing import NamedTuple

import numpy as np
import scipy.sparse as sp
from scipy.sparse import csgraph

from .geometry import (
    conformal_parts,
    corner_signed_areas,
    dirichlet_parts,
    edge_lengths,
    frames_of,
    gradient_coefficients,
    next_corner,
    triangle_angles,
    triangles,
)
from .mesh.halfedges import HalfEdges, orientation, unit_of
from .mesh.islands import Islands, Labelled

__all__ = [
    "corner_uvs",
    "uv_edge_lengths",
    "singular_values",
    "residual_variance",
    "one_minus_r2",
    "edge_rms",
    "stretch",
    "symmetric_dirichlet",
    "flipped",
    "folded",
    "island_energy",
    "uv_islands",
    "Distortion",
    "distortion",
    "IslandDistortion",
    "per_island",
    "StretchSummary",
    "face_stretch",
    "combine_stretch",
    "coverage",
    "stretch_colours",
    "self_overlaps",
]


def corner_uvs(F: np.ndarray, uv: np.ndarray) -> np.ndarray:
    """Per-corner UVs (m, 3, 2) from per-vertex (n, 2) or per-corner (m, 3, 2) input."""
    uv = np.asarray(uv, dtype=np.float64)
    if uv.ndim == 3:
        return uv
    return uv[F]


def uv_edge_lengths(V, F, uv):
    """3D and 2D length of every UV edge, once per edge of the UV map (twice across a
    seam): ``(l (e,), d (e,))``."""
    F = np.asarray(F, dtype=np.int64)
    cuv = corner_uvs(F, uv)
    he = HalfEdges(F, len(V))
    h = np.arange(F.size)
    nxt = next_corner(h)
    quv = cuv.reshape(-1, 2)
    flat = F.ravel()
    t = he.twin
    keep = t < 0
    paired = t >= 0
    tn = np.where(paired, next_corner(np.maximum(t, 0)), 0)
    # the twin runs the other way when the faces agree in orientation
    same_dir = paired & (flat[np.maximum(t, 0)] == flat[h])
    ta = np.where(same_dir, t, tn)
    tb = np.where(same_dir, tn, t)
    agree = paired & np.all(quv[ta] == quv[h], axis=1) & np.all(quv[tb] == quv[nxt], axis=1)
    keep |= paired & (~agree | (h < t))
    corners = np.stack([h[keep], nxt[keep]], axis=1)
    return edge_lengths(np.asarray(V, dtype=np.float64), flat[corners]), edge_lengths(quv, corners)


def residual_variance(V, F, uv) -> float:
    """Variance of the 2D-minus-3D edge length (the paper's measure), mesh units."""
    l3, l2 = uv_edge_lengths(V, F, uv)
    return float(np.var(l2 - l3))


def one_minus_r2(V, F, uv) -> float:
    """Isomap-style ``1 - R^2`` between 2D and 3D edge lengths."""
    l3, l2 = uv_edge_lengths(V, F, uv)
    if np.std(l2) == 0 or np.std(l3) == 0:
        return 1.0
    r = np.corrcoef(l2, l3)[0, 1]
    return float(1.0 - r * r)


def edge_rms(V, F, uv) -> float:
    """Relative RMS edge-length error at the best global scale."""
    l3, l2 = uv_edge_lengths(V, F, uv)
    ok = l3 > 0
    r = l2[ok] / l3[ok]
    rr = float((r * r).sum())
    s = float(r.sum()) / rr if rr > 0 else 0.0
    return float(np.sqrt(np.mean((s * r - 1.0) ** 2)))


def _frames(V, F, cuv):
    """3D face areas, which faces have any (m,) bool, and the 2x2 Jacobians ``(a, b, c, d)``
    (each (m,)) of the map from each face to UV, ``J = [[a, b], [c, d]]``, in the frames
    and with the gradient the refinement descends with (:func:`.geometry.frames_of`)."""
    frames = frames_of(triangles(np.asarray(V, dtype=np.float64), F))
    dx, dy = gradient_coefficients(frames)
    u, v = cuv[..., 0], cuv[..., 1]
    J = ((dx * u).sum(axis=1), (dy * u).sum(axis=1), (dx * v).sum(axis=1), (dy * v).sum(axis=1))
    return frames.area, ~frames.flat, J


def singular_values(V, F, uv):
    """Singular values ``sigma1 >= sigma2`` of the 3D-to-UV Jacobian per face.

    Returns ``(sigma (m, 2), area3d (m,), valid (m,) bool)``; invalid (zero-area 3D)
    faces get sigma = 1.
    """
    F = np.asarray(F, dtype=np.int64)
    area, ok, J = _frames(V, F, corner_uvs(F, uv))
    return _singular_values(J, ok), area, ok


def _singular_values(J, ok: np.ndarray) -> np.ndarray:
    """``sigma1 >= sigma2`` (m, 2) of the Jacobians ``J``; 1 where not ``ok``."""
    q, r = conformal_parts(*J)
    sig = np.stack([q + r, np.abs(q - r)], axis=1)
    sig[~ok] = 1.0
    return sig


def _inverse_stretches(sig: np.ndarray):
    """Per face, from the singular values (m, 2) of its 3D-to-UV map: the largest and
    smallest stretch of the UV-to-3D map, ``Gamma = 1 / sigma2`` and ``gamma = 1 / sigma1``
    (Sander et al. 2001; inf for a collapsed UV triangle), and the larger of the map's own
    stretch and squeeze, ``max(sigma1, 1 / sigma2)``."""
    with np.errstate(divide="ignore", over="ignore"):
        big = np.where(sig[:, 1] > 0, 1.0 / sig[:, 1], np.inf)
        small = 1.0 / sig[:, 0]
    return big, small, np.maximum(sig[:, 0], big)


def _area_scale(V, F, uv) -> float:
    """Factor that makes the UV area equal the 3D area."""
    F = np.asarray(F, dtype=np.int64)
    a2 = np.abs(corner_signed_areas(corner_uvs(F, uv))).sum()
    a3 = triangles(np.asarray(V, dtype=np.float64), F).area.sum()
    return float(np.sqrt(a3 / a2)) if a2 > 0 else 1.0


def stretch(V, F, uv) -> tuple[float, float]:
    """Sander's (L2, Linf) stretch of the UV-to-3D map at equal total area."""
    sig, area, ok = singular_values(V, F, uv)
    big, small, _ = _inverse_stretches(sig * _area_scale(V, F, uv))
    w = area * ok
    l2 = np.sqrt((0.5 * (big**2 + small**2) * w).sum() / w.sum()) if w.sum() > 0 else 1.0
    return float(l2), float(big[ok].max(initial=1.0))


def symmetric_dirichlet(V, F, uv) -> float:
    """Area-weighted symmetric Dirichlet energy at its optimal global scale (>= 4): the
    whole layout as one island (:func:`_at_best_scale`)."""
    F = np.asarray(F, dtype=np.int64)
    area, ok, J = _frames(V, F, corner_uvs(F, uv))
    sd, _ = _at_best_scale(J, area * ok, Labelled(np.zeros(len(F), dtype=np.int64), 1))
    return float(sd[0]) if np.isfinite(sd[0]) else float("inf")


def flipped(V, F, uv, face_island=None) -> int:
    """Faces folded against their island's orientation, or collapsed to zero UV area (not
    counting faces with no 3D area)."""
    F = np.asarray(F, dtype=np.int64)
    cuv = corner_uvs(F, uv)
    if face_island is None:
        face_island = uv_islands(F, cuv)
    return int((folded(F, cuv, face_island) & ~_collapsed(V, F)).sum())


def _collapsed(V, F: np.ndarray) -> np.ndarray:
    """Faces (m,) bool with no 3D area to speak of (:attr:`.geometry.Triangles.collapsed`),
    measured in units of the mesh's size (no overflow at 1e150)."""
    V = np.asarray(V, dtype=np.float64)
    return triangles(V / unit_of(V), F).collapsed


def folded(F: np.ndarray, cuv: np.ndarray, face_island: np.ndarray) -> np.ndarray:
    """Per face (m,) bool: folded against its island's orientation, or collapsed to zero
    UV area. The island is oriented across the edges its faces share in UV (both sides,
    same UVs), so a face the input winds against its neighbours, but laid out alongside
    them, is not folded (input winding is not the layout's business); of the island's two
    orientations, the one most of its UV area agrees with."""
    F = np.asarray(F, dtype=np.int64)
    m = len(F)
    signed = corner_signed_areas(cuv)
    if not m:
        return np.zeros(0, dtype=bool)
    he, h, agree = _uv_joins(F, cuv)
    k = int(face_island.max()) + 1
    reverse, _ = orientation(F, he, face_island, k, np.ones(m), tree_only=h[agree])
    signed = np.where(reverse, -signed, signed)
    major = np.bincount(face_island, signed, minlength=k) >= 0
    return ~np.where(major[face_island], signed > 0, signed < 0)


def _uv_joins(F: np.ndarray, cuv: np.ndarray):
    """The half-edges of ``F`` (:class:`.halfedges.HalfEdges`), those with a twin of higher
    number, ``h`` (k,), and which of them join their two faces in UV, ``agree`` (k,) bool:
    the same UVs at both ends on both sides."""
    he = HalfEdges(F, int(F.max()) + 1)
    h = np.flatnonzero(he.twin > np.arange(F.size))
    t = he.twin[h]
    quv = cuv.reshape(-1, 2)
    flat = F.ravel()
    same_dir = flat[t] == flat[h]
    ta = np.where(same_dir, t, next_corner(t))
    tb = np.where(same_dir, next_corner(t), t)
    agree = np.all(quv[ta] == quv[h], axis=1) & np.all(quv[tb] == quv[next_corner(h)], axis=1)
    return he, h, agree


def uv_islands(F: np.ndarray, cuv: np.ndarray) -> np.ndarray:
    """Faces connected across edges whose UVs agree on both sides, (m,) labels."""
    F = np.asarray(F, dtype=np.int64)
    he, h, agree = _uv_joins(F, cuv)
    t = he.twin[h]
    m = len(F)
    g = sp.coo_matrix((np.ones(agree.sum()), (h[agree] // 3, t[agree] // 3)), shape=(m, m))
    return csgraph.connected_components(g, directed=False)[1]


@dataclass(frozen=True)
class Distortion:
    """Every measure of this module for one layout (see the module docstring); measures
    that depend on scale use one global scale over the whole layout (see
    :func:`per_island` for each island at its own best scale)."""

    residual_variance: float
    one_minus_r2: float
    edge_rms: float
    stretch_l2: float
    stretch_linf: float
    area_distortion: float
    angle_distortion: float
    angle_error_deg: float
    symmetric_dirichlet: float
    flipped: int
    max_edge_ratio: float

    def asdict(self) -> dict:
        return asdict(self)


def distortion(V, F, uv, face_island=None) -> Distortion:
    """Every measure of this module (see the module docstring)."""
    F = np.asarray(F, dtype=np.int64)
    cuv = corner_uvs(F, uv)
    l3, l2 = uv_edge_lengths(V, F, cuv)
    sig, area, ok = singular_values(V, F, cuv)
    w = area * ok
    k = _area_scale(V, F, cuv)
    with np.errstate(divide="ignore", invalid="ignore"):
        logdet = np.abs(np.log(sig[:, 0] * sig[:, 1] * k * k))
        logratio = np.abs(np.log(sig[:, 0] / sig[:, 1]))
    p = np.asarray(V, dtype=np.float64)[F]
    ang3 = triangle_angles(p)
    ang2 = triangle_angles(cuv)
    l2s, linf = stretch(V, F, cuv)
    r = l2[l3 > 0] / l3[l3 > 0]
    return Distortion(
        residual_variance=float(np.var(l2 - l3)),
        one_minus_r2=one_minus_r2(V, F, cuv),
        edge_rms=edge_rms(V, F, cuv),
        stretch_l2=l2s,
        stretch_linf=linf,
        area_distortion=float((logdet * w).sum() / w.sum()),
        angle_distortion=float((logratio * w).sum() / w.sum()),
        angle_error_deg=float(np.degrees(np.abs(ang2 - ang3)[ok].mean())) if ok.any() else 0.0,
        symmetric_dirichlet=symmetric_dirichlet(V, F, cuv),
        flipped=flipped(V, F, cuv, face_island),
        max_edge_ratio=float(r.max() / r.min()) if r.size and r.min() > 0 else float("inf"),
    )


@dataclass(frozen=True)
class IslandDistortion:
    """Distortion of a layout measured island by island, each island at its own best
    scale, so that no layout is judged on how its islands were scaled against each other
    (a packer scales islands to fill the square; texel density is reported apart).

    Per island (n_islands,): ``area`` (3D), ``symmetric_dirichlet`` at the island's best
    scale, ``stretch_l2`` and ``stretch_linf`` (Sander et al. 2001) and ``stretch`` (the
    area-weighted mean of ``max(sigma1, 1 / sigma2)``, as :func:`face_stretch` has it per
    face) at the scale that gives the island its 3D area, ``flipped`` faces, and ``scale``: the factor that gives the
    island its 3D area (its texel density, up to a constant). Overall: ``mean_*`` weighted
    by 3D area, ``worst_stretch`` the largest Linf, ``scale_spread`` the largest over the
    smallest ``scale`` among islands with area.
    """

    area: np.ndarray
    symmetric_dirichlet: np.ndarray
    stretch_l2: np.ndarray
    stretch_linf: np.ndarray
    stretch: np.ndarray
    flipped: np.ndarray
    scale: np.ndarray
    mean_symmetric_dirichlet: float
    mean_stretch_l2: float
    worst_stretch: float
    scale_spread: float

    @property
    def n_islands(self) -> int:
        return len(self.area)


def island_energy(V, F, uv, face_island: np.ndarray, k: int) -> tuple[np.ndarray, np.ndarray]:
    """Per island (k,): the symmetric Dirichlet energy per area at the island's best scale
    (as :func:`per_island` has it, nan without area), and its 3D area; the part of
    :func:`per_island` a caller that only weighs distortion needs."""
    F = np.asarray(F, dtype=np.int64)
    area, ok, J = _frames(V, F, corner_uvs(F, uv))
    return _at_best_scale(J, area * ok, Islands.labelled(np.asarray(face_island, dtype=np.int64), k))


def _at_best_scale(J, w: np.ndarray, groups: Labelled) -> tuple[np.ndarray, np.ndarray]:
    """Per island: symmetric Dirichlet at its best scale from the Jacobians ``J`` and face
    weights (3D areas) ``w`` (m,), and the islands' weights."""
    A3 = groups.sum(w)
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        fro, inv, _ = dirichlet_parts(*J)
        pos = groups.sum(np.where(w > 0, fro * w, 0.0))
        neg = groups.sum(np.where(w > 0, inv * w, 0.0))
        sd = np.where(A3 > 0, 2.0 * np.sqrt(pos * neg) / A3, np.nan)  # min over s of (s2 pos + neg / s2) / A3
    return sd, A3


def per_island(V, F, uv, face_island=None) -> IslandDistortion:
    """:class:`IslandDistortion` of a layout; islands are ``face_island`` (m,) or, if not
    given, the faces connected in UV space (:func:`uv_islands`)."""
    F = np.asarray(F, dtype=np.int64)
    cuv = corner_uvs(F, uv)
    label = uv_islands(F, cuv) if face_island is None else np.asarray(face_island, dtype=np.int64)
    k = int(label.max()) + 1 if len(label) else 0
    groups = Islands.labelled(label, k)
    area, ok, J = _frames(V, F, cuv)
    sig = _singular_values(J, ok)
    w = area * ok
    A2 = groups.sum(np.abs(corner_signed_areas(cuv)) * ok)
    sd, A3 = _at_best_scale(J, w, groups)
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        scale = np.where(A2 > 0, np.sqrt(A3 / A2), np.inf)  # UV -> 3D area
        s = groups.expand(np.where(np.isfinite(scale), scale, 1.0)) * np.ones(len(F))
        big_inv, small_inv, worse = _inverse_stretches(sig * s[:, None])  # of the scaled map
        l2 = np.sqrt(groups.sum(0.5 * (big_inv**2 + small_inv**2) * w) / A3)
        linf = groups.max(np.where(ok, big_inv, -np.inf))
        stretch = groups.sum(np.where(w > 0, worse * w, 0.0)) / A3
    flips = np.bincount(label[folded(F, cuv, label) & ~_collapsed(V, F)], minlength=k)
    has = A3 > 0
    total = float(A3[has].sum())
    finite = has & np.isfinite(scale) & (scale > 0)
    return IslandDistortion(
        area=A3,
        symmetric_dirichlet=sd,
        stretch_l2=l2,
        stretch_linf=linf,
        stretch=stretch,
        flipped=flips,
        scale=scale,
        mean_symmetric_dirichlet=float((sd[has] * A3[has]).sum() / total) if total > 0 else float("nan"),
        mean_stretch_l2=float(np.sqrt((l2[has] ** 2 * A3[has]).sum() / total)) if total > 0 else float("nan"),
        worst_stretch=float(linf[has].max(initial=1.0)),
        scale_spread=float(scale[finite].max() / scale[finite].min()) if finite.any() else 1.0,
    )


# ---------------------------------------------------------------------------- per-face stretch


class StretchSummary(NamedTuple):
    worst: float
    mean: float  # weighted by 3D area
    area: float  # the 3D area the mean is over (to combine meshes)


def face_stretch(V, F, corner_uv) -> tuple[np.ndarray, StretchSummary]:
    """Per face ``max(sigma1, 1 / sigma2)`` of its 3D-to-UV map after the global scale that
    gives the UVs the mesh's area (t,): 1 where a texture lands at true shape and scale
    (up to that scale), 2 where it is stretched or squeezed twice over, inf for a
    collapsed UV triangle; and its worst and area-weighted mean. One singular-value pass.
    """
    sig, area, ok = singular_values(V, F, corner_uv)
    a2 = np.abs(corner_signed_areas(corner_uv)).sum()
    _, _, worse = _inverse_stretches(sig * (np.sqrt(area.sum() / a2) if a2 > 0 else 1.0))
    d = np.where(ok, worse, 1.0)
    finite = np.isfinite(d)
    w = np.where(finite & ok, area, 0.0)
    total = float(w.sum())
    mean = float(np.dot(np.where(finite, d, 0.0), w)) / total if total > 0 else 0.0
    return d, StretchSummary(float(d.max(initial=1.0)), mean, total)


def coverage(*corner_uvs: np.ndarray) -> float:
    """The share of the texture the faces cover: the UV area of every face of the layouts
    ``corner_uvs`` (each (t, 3, 2)) over the area of the smallest axis-aligned square that
    holds them all (the unit square of a packed layout); 0 for no area. Overlapping faces
    count twice."""
    points = [np.asarray(c, dtype=np.float64).reshape(-1, 3, 2) for c in corner_uvs]
    points = [p[np.isfinite(p).all(axis=(1, 2))] for p in points]
    if not sum(len(p) for p in points):
        return 0.0
    area = sum(float(np.abs(corner_signed_areas(p)).sum()) for p in points)
    lo = np.min([p.reshape(-1, 2).min(axis=0) for p in points if len(p)], axis=0)
    hi = np.max([p.reshape(-1, 2).max(axis=0) for p in points if len(p)], axis=0)
    side = float((hi - lo).max())
    return area / (side * side) if side > 0 else 0.0


def combine_stretch(parts: list[StretchSummary]) -> StretchSummary:
    """One summary for several meshes."""
    area = sum(p.area for p in parts)
    mean = sum(p.mean * p.area for p in parts) / area if area > 0 else float(np.mean([p.mean for p in parts]))
    return StretchSummary(max(p.worst for p in parts), mean, area)


def stretch_colours(distortion: np.ndarray) -> np.ndarray:
    """RGBA (k, 4) float32 for per-face stretch (:func:`face_stretch`): white at 1, yellow
    at sqrt(2), red from 2 on (log scale)."""
    x = np.clip(np.log2(np.where(np.isfinite(distortion), distortion, 4.0)), 0.0, 1.0)
    rgba = np.ones((len(x), 4), dtype=np.float32)
    rgba[:, 1] = np.clip(2.0 * (1.0 - x), 0.0, 1.0)
    rgba[:, 2] = np.clip(1.0 - 2.0 * x, 0.0, 1.0)
    return rgba


def self_overlaps(V, F, uv, face_island=None):
    """How the islands of any layout (per vertex or per corner, e.g. read back from
    Blender) overlap themselves: an :class:`.overlap.Overlaps` (boundary crossings and UV
    area covered twice per island); islands are ``face_island`` (m,), or the faces
    connected in UV space (:func:`uv_islands`)."""
    from .overlap import self_overlaps as found

    F = np.asarray(F, dtype=np.int64)
    cuv = corner_uvs(F, uv)
    label = uv_islands(F, cuv) if face_island is None else np.asarray(face_island, dtype=np.int64)
    return found(F, cuv, label, int(label.max()) + 1 if len(label) else 0)
