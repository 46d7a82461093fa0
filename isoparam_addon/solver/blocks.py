"""Per-island small dense algebra over vertices stored island by island.

The solver numbers vertices so that each island is one contiguous block of rows. Then a
per-island Gram matrix ``V_i^T W_i`` is one BLAS call for a large island and one sparse
product for all the small ones together, and a per-island change of basis ``V_i T_i``
is a handful of vector operations. No loop runs over vertices; the loop over large
islands is bounded by n / ``_LARGE``.

The small islands are grouped by size (powers of two) and each group is gathered into a
stack of zero-padded ``(size, p)`` blocks, so that their Gram matrices and changes of
basis are one stacked ``matmul`` per group (at most 11 groups), with at most twice the
rows gathered. An outer product per row (``(n, p * q)``, 87 MB for 9 x 9 columns of
134k rows) summed by a sparse indicator took 2-3x as long (Suzanne subdivided 4 times,
344 Smart UV islands).

``np.dot`` rather than ``@``: in numpy 1.26 (Blender's), ``(100000, 9) @ (9, 2)`` takes
8 ms against 0.7 ms for ``np.dot`` (measured here).
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp

__all__ = ["Islands"]

_LARGE = 1024  # islands with more rows than this get their own BLAS call (and SVD)


class Islands:
    """Contiguous row blocks, one per island.

    Parameters
    ----------
    label : (n,) int64
        Island of each row, non-decreasing.
    n_islands : int
    """

    def __init__(self, label: np.ndarray, n_islands: int):
        self.label = label
        self.n = n_islands
        self.size = np.bincount(label, minlength=n_islands)
        self.start = np.zeros(n_islands + 1, dtype=np.int64)
        self.start[1:] = np.cumsum(self.size)
        if np.any(np.diff(label) < 0):
            raise ValueError("rows must be sorted by island")
        self.large = np.flatnonzero(self.size > _LARGE)
        small_rows = ~np.isin(label, self.large) if self.large.size else np.ones(len(label), dtype=bool)
        self.small_rows = np.flatnonzero(small_rows)
        self.small_indicator = sp.csr_matrix(
            (np.ones(len(self.small_rows)), (label[self.small_rows], np.arange(len(self.small_rows)))),
            shape=(n_islands, len(self.small_rows)),
        )
        self._groups = self._group_small()

    def _group_small(self) -> list:
        """The small islands with rows, by size class (sizes in (2^(c-1), 2^c]): per
        class, the islands (k,), their rows padded to the class's largest (k, s) (the
        padding repeats an island's first row), the padding mask (k, s, 1) float (1 on
        real rows) and which entries are real (k, s) bool."""
        small = np.flatnonzero((self.size > 0) & (self.size <= _LARGE))
        if not small.size:
            return []
        cls = np.ceil(np.log2(self.size[small])).astype(np.int64)
        groups = []
        for c in np.unique(cls):  # at most log2(_LARGE) + 1 classes
            ids = small[cls == c]
            size = self.size[ids]
            t = np.arange(int(size.max()))
            real = t < size[:, None]
            rows = self.start[ids][:, None] + np.where(real, t, 0)
            groups.append((ids, rows, real[:, :, None].astype(np.float64), real))
        return groups

    def subset(self, which: np.ndarray):
        """The islands flagged in ``which`` (n_islands,) bool on their own: their rows
        (k,) int64 and the :class:`Islands` over those rows."""
        rows = np.flatnonzero(which[self.label])
        return rows, Islands(np.cumsum(which)[self.label[rows]] - 1, int(which.sum()))

    def rows(self, i: int) -> slice:
        return slice(int(self.start[i]), int(self.start[i + 1]))

    def sum(self, x: np.ndarray) -> np.ndarray:
        """Per-island sum of rows: (n, ...) -> (n_islands, ...)."""
        flat = x.reshape(len(x), -1)
        out = np.zeros((self.n, flat.shape[1]))
        out += self.small_indicator @ flat[self.small_rows] if self.small_rows.size else 0.0
        for i in self.large:  # a BLAS product: ``sum(axis=0)`` of (100000, 2) rows takes 25x longer
            r = self.rows(i)
            out[i] = np.dot(np.ones(r.stop - r.start), flat[r])
        return out.reshape((self.n,) + x.shape[1:])

    def mean(self, x: np.ndarray) -> np.ndarray:
        s = self.sum(x)
        return s / np.maximum(self.size, 1).reshape((-1,) + (1,) * (x.ndim - 1))

    def gram(self, A: np.ndarray, B: np.ndarray, large: bool = True) -> np.ndarray:
        """Per-island ``A_i^T B_i``: (n, p), (n, q) -> (n_islands, p, q).

        With ``large=False`` the large islands are left at zero.
        """
        p, q = A.shape[1], B.shape[1]
        out = np.zeros((self.n, p, q))
        if self._groups:  # np.take copies a strided source whole on every call
            A, B = np.ascontiguousarray(A), np.ascontiguousarray(B)
        for ids, rows, pad, _ in self._groups:
            Ag = np.take(A, rows, axis=0) * pad  # (k, s, p), zero on the padding
            out[ids] = np.matmul(Ag.transpose(0, 2, 1), np.take(B, rows, axis=0))
        for i in self.large if large else ():
            r = self.rows(i)
            out[i] = np.dot(A[r].T, B[r])
        return out

    def apply(self, V: np.ndarray, T: np.ndarray) -> np.ndarray:
        """Per-island ``V_i T_i``: (n, p), (n_islands, p, q) -> (n, q)."""
        out = np.zeros((len(V), T.shape[2]))
        if self._groups:
            V = np.ascontiguousarray(V)
        for ids, rows, _, real in self._groups:
            out[rows[real]] = np.matmul(np.take(V, rows, axis=0), T[ids])[real]
        for i in self.large:
            r = self.rows(i)
            out[r] = np.dot(V[r], T[i])
        return out

    def expand(self, x: np.ndarray) -> np.ndarray:
        """Per-island values repeated for their rows (a broadcastable view for one island)."""
        if self.n == 1:
            return x[:1]
        return np.repeat(x, self.size, axis=0)
