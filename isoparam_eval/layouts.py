"""Checks on packed layouts, for tests and benchmarks: how close islands come, and whether
any overlap."""

from __future__ import annotations

import numpy as np
from scipy.spatial import cKDTree

from isoparam_addon.solver.overlap import overlapping_faces

__all__ = ["islands_overlapping", "least_gap"]


def least_gap(uv, island, spacing: float) -> float:
    """The least distance between points of two different islands, sampled along the
    islands' boundary edges (edges of one triangle of their island) at ``spacing`` or
    closer: an upper bound on the true least distance."""
    a, b = uv.reshape(-1, 2), np.roll(uv, -1, axis=1).reshape(-1, 2)
    lab = np.repeat(island, 3)
    ends = np.sort(np.stack([a[:, 0] + 1j * a[:, 1], b[:, 0] + 1j * b[:, 1]], axis=1), axis=1)
    key = np.column_stack([lab, ends.real, ends.imag])
    _, inverse, count = np.unique(key, axis=0, return_inverse=True, return_counts=True)
    edge = count[inverse.ravel()] == 1
    a, b, lab = a[edge], b[edge], lab[edge]
    steps = np.ceil(np.linalg.norm(b - a, axis=1) / spacing).astype(np.int64) + 1
    which = np.repeat(np.arange(len(a)), steps)
    s = (np.arange(len(which)) - np.repeat(np.cumsum(steps) - steps, steps)) / np.repeat(steps - 1, steps)
    pts = a[which] + s[:, None] * (b - a)[which]
    d, j = cKDTree(pts).query(pts, k=24)
    other = lab[which][j] != lab[which][:, None]
    return float(d[other].min()) if other.any() else np.inf


def islands_overlapping(uv, island) -> int:
    """Pairs of faces of two different islands that overlap with positive area."""
    ids = np.arange(3 * len(uv)).reshape(-1, 3)
    i, j = overlapping_faces(uv, ids, np.zeros(len(uv), dtype=np.int64))
    return int((island[i] != island[j]).sum())
