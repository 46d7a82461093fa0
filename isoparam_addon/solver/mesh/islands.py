"""Per-island reductions: the one vocabulary for sums, means, minima, dots and small dense
algebra over islands.

Islands are independent problems, and every step treats them so in one pass over the
whole mesh: a per-island quantity is a reduction over rows labelled by island, never a
Python loop over islands.

Two layouts of the rows:

* **contiguous** (:class:`Islands`, the solver's vertices): rows are numbered island by
  island, each island one block. A per-island Gram matrix ``V_i^T W_i`` is then one BLAS
  call for a large island and one stacked ``matmul`` per size class for the small ones,
  and a per-island change of basis ``V_i T_i`` a handful of vector operations. The
  small islands are grouped by size (powers of two); each group is gathered into a
  stack of zero-padded ``(size, p)`` blocks, with at most twice the rows gathered. The
  loop over large islands is bounded by ``n / _LARGE``.
* **labelled** (:class:`Labelled`, from :meth:`Islands.labelled`: faces, edges, corners
  in any order): sums are ``bincount``, minima a sort-and-``reduceat``, and the dense
  algebra is not offered. :class:`Islands` is a :class:`Labelled` whose rows are in
  order, with faster reductions and the dense algebra.

``np.dot`` rather than ``@`` on large blocks: in numpy 1.26 (Blender's) ``(100000, 9) @
(9, 2)`` is an order of magnitude slower than ``np.dot`` (see docs/benchmarks.md).
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp

__all__ = ["Islands", "Labelled", "first_rows"]

_LARGE = 1024  # islands with more rows than this get their own BLAS call (and SVD)


class Labelled:
    """Rows labelled by island, in any order (faces, edges, corners): reductions only.

    Parameters
    ----------
    label : (n,) int64
        Island of each row.
    n_islands : int

    Attributes
    ----------
    label : (n,) int64
    n : int
        Number of islands.
    size : (n_islands,) int64
        Rows per island.
    """

    def __init__(self, label: np.ndarray, n_islands: int):
        self.label = label
        self.n = n_islands
        self.size = np.bincount(label, minlength=n_islands)
        self._order: np.ndarray | None = None

    def sum(self, x: np.ndarray) -> np.ndarray:
        """Per-island sum of rows: (n, ...) -> (n_islands, ...)."""
        if x.ndim == 1:
            return np.array([x.sum()], dtype=np.float64) if self.n == 1 else self._bincount(x)
        flat = x.reshape(len(x), -1)
        out = np.stack([self._bincount(flat[:, j]) for j in range(flat.shape[1])], axis=1)
        return out.reshape((self.n,) + x.shape[1:])

    def _bincount(self, x: np.ndarray) -> np.ndarray:
        return np.bincount(self.label, x, minlength=self.n)

    def mean(self, x: np.ndarray) -> np.ndarray:
        s = self.sum(x)
        return s / np.maximum(self.size, 1).reshape((-1,) + (1,) * (x.ndim - 1))

    def expand(self, per_island: np.ndarray) -> np.ndarray:
        """Per-island values repeated for their rows (a broadcastable view for one island)."""
        if self.n == 1:
            return per_island[:1]
        return per_island[self.label]

    def min(self, x: np.ndarray) -> np.ndarray:
        """Per-island minimum of (n,) values, ``inf`` for islands without rows."""
        out = np.full(self.n, np.inf)
        if not len(x):
            return out
        if self.n == 1:
            out[0] = x.min()
            return out
        has = self.size > 0
        out[has] = self._reduce_min(x, has)
        return out

    def _reduce_min(self, x: np.ndarray, has: np.ndarray) -> np.ndarray:
        order, start = self._sorted()
        return np.minimum.reduceat(x[order], start[has])

    def max(self, x: np.ndarray) -> np.ndarray:
        """Per-island maximum of (n,) values, ``-inf`` for islands without rows."""
        return -self.min(-x)

    def _sorted(self) -> tuple[np.ndarray, np.ndarray]:
        """The rows sorted by island (stable) and where each island starts in that order."""
        if self._order is None:
            self._order = np.argsort(self.label, kind="stable")
        return self._order, np.searchsorted(self.label[self._order], np.arange(self.n))

    def members(self, which: np.ndarray) -> np.ndarray:
        """The rows of the islands flagged in ``which`` (n_islands,) bool, island by island."""
        order, start = self._sorted()
        end = np.append(start[1:], len(self.label))
        counts = np.where(which, end - start, 0)
        if not counts.any():
            return np.zeros(0, dtype=np.int64)
        first = np.repeat(start - np.cumsum(counts) + counts, counts)  # each island's run of the order
        return order[first + np.arange(counts.sum())]

    def dot(self, a: np.ndarray, b: np.ndarray) -> np.ndarray:
        """Per-island inner product of rows, (n_islands,)."""
        if self.n == 1:  # one island: a BLAS dot; ``(a * b).sum(axis=1)`` is 4x slower
            return np.array([np.dot(a.ravel(), b.ravel())])
        ab = a * b
        return self._bincount(ab if ab.ndim == 1 else ab.reshape(len(ab), -1).sum(axis=1))


class Islands(Labelled):
    """Rows grouped by island, numbered island by island: the reductions of
    :class:`Labelled`, faster, and per-island dense algebra.

    Parameters
    ----------
    label : (n,) int64
        Island of each row, non-decreasing (use :meth:`labelled` for rows in any order).
    n_islands : int

    Attributes
    ----------
    start : (n_islands + 1,) int64
        Island i holds rows ``start[i]:start[i + 1]``.
    """

    def __init__(self, label: np.ndarray, n_islands: int):
        super().__init__(label, n_islands)
        if np.any(np.diff(label) < 0):
            raise ValueError("rows must be sorted by island")
        self.start = np.zeros(n_islands + 1, dtype=np.int64)
        self.start[1:] = np.cumsum(self.size)
        self.large = np.flatnonzero(self.size > _LARGE)
        small_rows = ~np.isin(label, self.large) if self.large.size else np.ones(len(label), dtype=bool)
        self.small_rows = np.flatnonzero(small_rows)
        self.small_indicator = sp.csr_matrix(
            (np.ones(len(self.small_rows)), (label[self.small_rows], np.arange(len(self.small_rows)))),
            shape=(n_islands, len(self.small_rows)),
        )
        self._groups = _group_small(self.size, self.start)

    @staticmethod
    def labelled(label: np.ndarray, n_islands: int) -> Labelled:
        """Islands over rows in any order (faces, edges, corners): reductions only."""
        return Labelled(label, n_islands)

    def sum(self, x: np.ndarray) -> np.ndarray:
        """Per-island sum of rows: (n, ...) -> (n_islands, ...)."""
        flat = x.reshape(len(x), -1)
        out = np.zeros((self.n, flat.shape[1]))
        out += self.small_indicator @ flat[self.small_rows] if self.small_rows.size else 0.0
        for i in self.large:  # a BLAS product: ``sum(axis=0)`` of (100000, 2) rows takes 25x longer
            r = self.rows(i)
            out[i] = np.dot(np.ones(r.stop - r.start), flat[r])
        return out.reshape((self.n,) + x.shape[1:])

    def expand(self, per_island: np.ndarray) -> np.ndarray:
        """Per-island values repeated for their rows (a broadcastable view for one island)."""
        if self.n == 1:
            return per_island[:1]
        return np.repeat(per_island, self.size, axis=0)

    def _reduce_min(self, x: np.ndarray, has: np.ndarray) -> np.ndarray:
        return np.minimum.reduceat(x, self.start[:-1][has])

    def members(self, which: np.ndarray) -> np.ndarray:
        """The rows of the islands flagged in ``which`` (n_islands,) bool, island by island."""
        return np.flatnonzero(which[self.label])

    def rows(self, i: int) -> slice:
        return slice(int(self.start[i]), int(self.start[i + 1]))

    def subset(self, which: np.ndarray):
        """The islands flagged in ``which`` (n_islands,) bool on their own: their rows
        (k,) int64 and the :class:`Islands` over those rows."""
        rows = np.flatnonzero(which[self.label])
        return rows, Islands(np.cumsum(which)[self.label[rows]] - 1, int(which.sum()))

    def first(self, mask: np.ndarray) -> np.ndarray:
        """Per island, its first row where ``mask`` (n,) holds, or n where none does."""
        n = len(mask)
        out = np.full(self.n, n, dtype=np.int64)
        has = self.size > 0
        if n:
            out[has] = np.minimum.reduceat(np.where(mask, np.arange(n), n), self.start[:-1][has])
        return out

    def spread(self, per_island: np.ndarray) -> np.ndarray:
        """Per-island scalars over (n, 2) rows: (k,) -> (n, 2), or (1, 1) for one island.

        One ``np.repeat``: an (n, 1) column broadcast against (n, 2) rows makes every
        product with it several times slower."""
        if self.n == 1:
            return per_island.reshape(1, 1)
        return np.repeat(per_island, 2 * self.size).reshape(-1, 2)

    def dot(self, a: np.ndarray, b: np.ndarray) -> np.ndarray:
        """Per-island inner product of (n, 2) rows, (n_islands,).

        One BLAS dot per large island and one ``bincount`` over the rows of the small
        ones (a ``bincount`` over every row is several times slower beside a large island)."""
        if self.n == 1:  # one island: a BLAS dot; ``(a * b).sum(axis=1)`` is 4x slower
            return np.array([np.dot(a.ravel(), b.ravel())])
        out = np.zeros(self.n)
        if self.small_rows.size:
            r = self.small_rows
            a_s, b_s = np.take(a, r, axis=0), np.take(b, r, axis=0)
            out += np.bincount(self.label[r], a_s[:, 0] * b_s[:, 0] + a_s[:, 1] * b_s[:, 1], minlength=self.n)
        for i in self.large:  # bounded by n / _LARGE
            rows = self.rows(i)
            out[i] = np.dot(a[rows].ravel(), b[rows].ravel())
        return out

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


def _group_small(size: np.ndarray, start: np.ndarray) -> list:
    """The small islands with rows, by size class (sizes in (2^(c-1), 2^c]): per class, the
    islands (k,), their rows padded to the class's largest (k, s) (the padding repeats an
    island's first row), the padding mask (k, s, 1) float (1 on real rows) and which
    entries are real (k, s) bool."""
    small = np.flatnonzero((size > 0) & (size <= _LARGE))
    if not small.size:
        return []
    cls = np.ceil(np.log2(size[small])).astype(np.int64)
    groups = []
    for c in np.unique(cls):  # at most log2(_LARGE) + 1 classes
        ids = small[cls == c]
        sz = size[ids]
        t = np.arange(int(sz.max()))
        real = t < sz[:, None]
        rows = start[ids][:, None] + np.where(real, t, 0)
        groups.append((ids, rows, real[:, :, None].astype(np.float64), real))
    return groups


def first_rows(label: np.ndarray, n: int | None = None) -> np.ndarray:
    """The lowest-numbered row of every label (n,) (``len(label)`` for a label with none):
    e.g. the first face of every island, its representative."""
    first = np.full(int(label.max(initial=-1)) + 1 if n is None else n, len(label), dtype=np.int64)
    np.minimum.at(first, label, np.arange(len(label)))
    return first
