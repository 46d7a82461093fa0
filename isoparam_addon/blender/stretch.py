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
    u, v = corner_uv[..., 0], corner_uv[..., 1]  # 1-D columns: (t, 2) rows are slower
    a2 = 0.5 * np.abs((u[:, 1] - u[:, 0]) * (v[:, 2] - v[:, 0]) - (v[:, 1] - v[:, 0]) * (u[:, 2] - u[:, 0])).sum()
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
    finite = np.isfinite(d)
    w = np.where(finite & ok, area, 0.0)
    total = float(w.sum())
    return d, Summary(float(d.max()), float(np.dot(np.where(finite, d, 0.0), w)) / max(total, 1e-300), total)


def summary(V, F, corner_uv) -> Summary:
    """Worst and area-weighted mean distortion of a layout."""
    return measure(V, F, corner_uv)[1]


def combine(parts: list) -> Summary:
    """One summary for several meshes."""
    area = sum(p.area for p in parts)
    mean = sum(p.mean * p.area for p in parts) / area if area > 0 else float(np.mean([p.mean for p in parts]))
    return Summary(max(p.worst for p in parts), mean, area)
