"""The refinement's quadratic proxy: the cotangent Laplacian of the layout's faces, per
face re-weighted as SLIM weighs them (Rabinovich et al. 2017) where an island is far from
isometric, factored per group of islands in a fill-reducing order.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp
from scipy.sparse.linalg import splu

from .._parallel import solve_columns
from ..geometry import safe_divide
from ..mesh.islands import Islands, Labelled
from .per_face import FaceFrames

__all__ = ["Proxy", "quadratic_proxy"]

_BLOCKS = 8  # the proxy's factors are kept for at most this many groups of islands


@dataclass
class _Block:
    """A factor of the proxy's rows of some islands (islands are independent blocks of H)."""

    islands: np.ndarray  # (n_islands,) bool
    rows: np.ndarray  # their free rows, in elimination order
    lu: object


@dataclass
class Proxy:
    """The descent's quadratic proxy ``H = 2 (K_w + diag(whisper))``, factored.

    ``K_w`` is the cotangent Laplacian with per-face ``weights`` (1: the cotangent
    Laplacian itself, which depends on the mesh and the pins only, so :func:`.solve`
    factors it in a worker thread while Step 3 runs), and the whisper, a tiny multiple of
    the lumped mass per island, fixes the translation of islands without pins.

    The factors are kept per group of islands (``blocks``): re-weighting some islands
    factors their rows again, not every island's (at most ``_BLOCKS`` groups; beyond, one).
    """

    frames: FaceFrames
    weights: np.ndarray  # (m,)
    H: sp.csr_matrix
    whisper: np.ndarray  # (n,)
    pinned: np.ndarray  # (n,) bool
    perm: np.ndarray  # the free vertices in elimination order
    blocks: list[_Block]

    def solve(self, g: np.ndarray) -> np.ndarray:
        """``H^{-1} g`` on the free rows (n, 2), zero on the pinned ones."""
        out = np.zeros_like(g)
        for block in self.blocks:  # a few groups of islands
            if block.lu is not None:
                out[block.rows] = solve_columns(block.lu, np.take(g, block.rows, axis=0))
        return out

    def curvature(self, islands: Islands, per_face: Labelled, s: np.ndarray, t: np.ndarray, dJ) -> np.ndarray:
        """Per island, ``s^T H s`` of a step ``s = t p`` (n, 2) (``t`` per island), where
        ``dJ`` are the Jacobians of ``p``: ``s^T K_w s = t^2 sum_f w_f A_f |dJ_f|^2``."""
        wa = self.frames.area * self.weights
        sKs = t * t * per_face.sum(wa * (dJ[0] * dJ[0] + dJ[1] * dJ[1] + dJ[2] * dJ[2] + dJ[3] * dJ[3]))
        whisper = np.repeat(self.whisper, 2).reshape(-1, 2)
        return 2.0 * (sKs + islands.dot(s, s * whisper))

    def reweighted(self, islands: Islands, weights: np.ndarray, which: np.ndarray) -> Proxy:
        """The proxy with other face weights (m,), which differ on the islands ``which``
        (n_islands,) bool only: their rows are factored again, in the same order."""
        proxy = _factor(self.frames, islands, self.pinned, self.perm, weights, factor=False)
        blocks: list[_Block] = []
        for block in self.blocks:
            if not (block.islands & which).any():
                blocks.append(block)
                continue
            blocks += [
                _block(proxy.H, islands, self.perm, part)
                for part in (block.islands & which, block.islands & ~which)
                if part.any()
            ]
        if len(blocks) > _BLOCKS:  # scattered re-weighting: one factor again
            blocks = [_block(proxy.H, islands, self.perm, np.ones(islands.n, dtype=bool))]
        proxy.blocks = blocks
        return proxy


def quadratic_proxy(X, faces, islands: Islands, pinned=None, order=None, weights=None) -> Proxy:
    """Build and factor the proxy (see :class:`Proxy`) for ``pinned`` (n,) bool vertices,
    with per-face ``weights`` (m,) (1: the cotangent Laplacian), eliminating in ``order``
    (n,) (e.g. Step 3's nested dissection) when given."""
    n = len(X)
    pinned = np.zeros(n, dtype=bool) if pinned is None else pinned
    frames = FaceFrames(X, faces)
    perm = order[~pinned[order]] if order is not None else np.flatnonzero(~pinned)
    return _factor(frames, islands, pinned, perm, np.ones(len(faces)) if weights is None else weights)


def _block(H: sp.csr_matrix, islands: Islands, perm: np.ndarray, which: np.ndarray) -> _Block:
    """The factor of ``H``'s free rows (``perm``, in elimination order) of the islands
    ``which`` (n_islands,) bool."""
    rows = perm[which[islands.label[perm]]]
    lu = splu(H[rows][:, rows].tocsc(), permc_spec="NATURAL") if len(rows) else None
    return _Block(which, rows, lu)


def _factor(frames: FaceFrames, islands: Islands, pinned, perm, weights, factor: bool = True) -> Proxy:
    K = frames.laplacian(weights)
    n = K.shape[0]
    # a whisper of the mass matrix pins the translations of islands without pins, scaled
    # per island so that each island's block of H is what it would be alone
    mass = np.bincount(frames.faces.ravel(), np.repeat(frames.area / 3, 3), minlength=n)
    size = np.maximum(islands.size, 1)
    reg = 1e-9 * np.bincount(islands.label, K.diagonal(), minlength=islands.n) / size
    mean_mass = np.bincount(islands.label, mass, minlength=islands.n) / size
    whisper = safe_divide(reg, mean_mass)[islands.label] * mass
    H = (2.0 * (K + sp.diags(whisper))).tocsr()
    every = np.ones(islands.n, dtype=bool)
    return Proxy(frames, weights, H, whisper, pinned, perm, [_block(H, islands, perm, every)] if factor else [])
