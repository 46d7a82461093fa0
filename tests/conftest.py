"""Shared helpers for the solver tests (no bpy)."""

import numpy as np
import pytest


def procrustes_error(A: np.ndarray, B: np.ndarray) -> float:
    """Largest distance between A and the best rigid motion (rotation or reflection) of B,
    relative to A's extent."""
    A0, B0 = A - A.mean(axis=0), B - B.mean(axis=0)
    U, _, Vt = np.linalg.svd(B0.T @ A0)
    R = U @ Vt
    return float(np.abs(B0 @ R - A0).max() / np.ptp(A0, axis=0).max())


def edge_length_error(V, F, uv) -> float:
    """Relative RMS difference of 2D and 3D edge lengths, no rescaling."""
    from isoparam_addon.solver.metrics import uv_edge_lengths

    l3, l2 = uv_edge_lengths(V, F, uv)
    return float(np.sqrt(np.mean(((l2 - l3) / l3) ** 2)))


@pytest.fixture
def rng():
    return np.random.default_rng(12345)
