"""Per-face stretch as a colour attribute, so the viewport shows where textures distort.

A face's distortion is ``max(sigma1, 1 / sigma2)`` of its 3D-to-UV map, after the global
scale that gives the UVs the mesh's area: 1 where the texture lands at true shape and
scale (up to that scale), 2 where it is stretched or squeezed twice over. Colours run
from white (1) through yellow to red (2 and more), on a log scale.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from ..solver import metrics

__all__ = ["ATTRIBUTE", "Summary", "colours", "combine", "measure", "summary"]

ATTRIBUTE = "isoparam_stretch"


def _distortion(V, F, corner_uv):
    """(distortion (t,), 3D area (t,), measurable (t,) bool): one singular-value pass."""
    sig, area, ok = metrics.singular_values(V, F, corner_uv)
    q1, q2 = corner_uv[:, 1] - corner_uv[:, 0], corner_uv[:, 2] - corner_uv[:, 0]
    a2 = 0.5 * np.abs(q1[:, 0] * q2[:, 1] - q1[:, 1] * q2[:, 0]).sum()
    k = np.sqrt(area.sum() / a2) if a2 > 0 else 1.0
    sig = sig * k
    with np.errstate(divide="ignore"):
        d = np.maximum(sig[:, 0], np.where(sig[:, 1] > 0, 1.0 / sig[:, 1], np.inf))
    return np.where(ok, d, 1.0), area, ok


def colours(distortion: np.ndarray) -> np.ndarray:
    """RGBA (k, 4) float32: white at 1, yellow at sqrt(2), red from 2 on."""
    x = np.clip(np.log2(np.where(np.isfinite(distortion), distortion, 4.0)), 0.0, 1.0)
    rgba = np.ones((len(x), 4), dtype=np.float32)
    rgba[:, 1] = np.clip(2.0 * (1.0 - x), 0.0, 1.0)
    rgba[:, 2] = np.clip(1.0 - 2.0 * x, 0.0, 1.0)
    return rgba


class Summary(NamedTuple):
    worst: float
    mean: float  # weighted by 3D area
    area: float  # the 3D area the mean is over (to combine meshes)


def measure(V, F, corner_uv) -> tuple[np.ndarray, Summary]:
    """Distortion of every triangle, (t,) (inf for a collapsed UV triangle), and its
    summary, from one singular-value pass."""
    d, area, ok = _distortion(V, F, corner_uv)
    w = area * ok
    finite = np.isfinite(d)
    total = float(w[finite].sum())
    return d, Summary(float(d.max()), float((d[finite] * w[finite]).sum() / max(total, 1e-300)), total)


def summary(V, F, corner_uv) -> Summary:
    """Worst and area-weighted mean distortion of a layout."""
    return measure(V, F, corner_uv)[1]


def combine(parts: list) -> Summary:
    """One summary for several meshes."""
    area = sum(p.area for p in parts)
    mean = sum(p.mean * p.area for p in parts) / area if area > 0 else float(np.mean([p.mean for p in parts]))
    return Summary(max(p.worst for p in parts), mean, area)
