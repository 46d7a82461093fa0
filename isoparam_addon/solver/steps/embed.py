"""Step 3 of Sun & Hancock: the spectral embedding, Eqs. (12)-(14).

We need, per island, the two non-constant vectors of the near-null space of
``M = (I - W)^T (I - W) = L^T L``. On a developable island that space is exactly
``{1, u, v}`` (three zero eigenvalues), so "drop the lowest eigenvector" is read as
"remove the constant from the null space": we work in the complement of ``1``.

Why not the obvious routes:

* shift-invert ``eigsh`` on M factors M itself: M squares the conditioning of L, has
  2-ring sparsity and fills SuperLU heavily; it stalls beyond ~100k vertices;
* pinning three vertices and solving the normal equations ``M_FF x = b`` loses accuracy
  for the same reason (cond(M_FF) = cond(L_FF)^2);
* a square solve of the free rows ``L_FF x = -L_FP p`` is exact on developable meshes but
  throws away three equations, and folds curved meshes.

What we do instead
------------------
1. Pin three far-apart vertices P per island (the *anchors*; not the user's UV pins)
   and factor one square matrix of the
   sparsity of L, ``A = [L_F  B]``: every row, the free columns, and three random
   border columns per island (1-ring sparsity, conditioning of L, nested-dissection
   order; see :class:`_AnchoredLeastSquares`). Applying ``M_FF^{-1}`` then costs one
   transposed and one plain triangular solve and a 3x3 system per island, never
   forming M.
2. The three *pinned least-squares* functions ``h_k = argmin ||L x||`` with ``x_P = e_k``
   span ``{1, u, v}`` exactly on a developable island. In general they are the
   M-orthogonal complement of the free space, so ``M^+ b = H c + [M_FF^{-1} b_F; 0]`` for
   some c: inverse iteration on M needs only ``M_FF^{-1}``, as long as the search space
   keeps span(H).
3. Block inverse iteration with Rayleigh-Ritz over ``[X_k, H, M_FF^{-1} R_k]``, where
   ``R_k = M X_k - X_k Lambda_k`` is the Ritz residual (the current vectors are kept, as
   in LOBPCG, and the correction is computed from the residual so that it stays
   accurate when it is tiny). The Ritz step evaluates ``||L x||^2`` through L
   itself, so its accuracy follows cond(L), not cond(M), and the *result* is the paper's
   eigenvector pair whatever the anchors: they only change how fast it converges. A
   developable island converges in one step.

The whole mesh is solved at once: islands are independent diagonal blocks, so one
factorization serves all of them, and the per-island Ritz problems are batched.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field

import numpy as np
import scipy.sparse as sp
from scipy.sparse.linalg import splu

from .._parallel import solve_columns
from ..geometry import TINY, safe_divide
from ..mesh.islands import Islands
from ..mesh.ordering import nested_dissection
from ..progress import tick

__all__ = ["Embedding", "EmbeddingTimings", "Plan", "choose_anchors", "plan_elimination", "spectral_embedding"]


@dataclass
class EmbeddingTimings:
    """Seconds spent in Step 3: the elimination order, the factorization, the anchored
    least-squares basis, and the iterations."""

    ordering: float = 0.0
    factorization: float = 0.0
    pinned_basis: float = 0.0
    iterations: float = 0.0


@dataclass
class Embedding:
    """Result of Step 3.

    Attributes
    ----------
    coords : (n, 2) float64
        ``Y_I``, centred (Eq. 13) with ``Y^T Y / N = I`` per island (Eq. 14).
    eigenvalues : (n_islands, 2) float64
        Ritz values of M for the two vectors (``~0`` on developable islands).
    converged : (n_islands,) bool
    change : (n_islands,) float64
        Sine of the angle the subspace moved in the last iteration (the error is about
        this times the convergence rate).
    iterations : int
    timings : EmbeddingTimings
    """

    coords: np.ndarray
    eigenvalues: np.ndarray
    converged: np.ndarray
    change: np.ndarray
    iterations: int
    timings: EmbeddingTimings = field(default_factory=lambda: EmbeddingTimings())


def choose_anchors(X: np.ndarray, islands: Islands) -> np.ndarray:
    """Three far-apart, non-collinear vertices per island, (n_islands, 3) int64.

    p0 is farthest from the island's centroid, p1 farthest from p0, p2 farthest from
    the line p0 p1 (all in 3D). Far-apart anchors keep ``L_FF`` well conditioned.
    """
    n = len(X)
    idx = np.arange(n)
    lab = islands.label

    def argmax(d, exclude=()):
        d = d.copy()
        for e in exclude:
            d[e] = -np.inf
        top = np.full(islands.n, -np.inf)
        np.maximum.at(top, lab, d)
        cand = np.where(d == top[lab], idx, n)
        first = np.full(islands.n, n, dtype=np.int64)
        np.minimum.at(first, lab, cand)
        return first

    c = islands.mean(X)
    p0 = argmax(((X - c[lab]) ** 2).sum(axis=1))
    p1 = argmax(((X - X[p0][lab]) ** 2).sum(axis=1), exclude=(p0,))
    u = X[p1] - X[p0]
    u = safe_divide(u, np.linalg.norm(u, axis=1)[:, None])
    r = X - X[p0][lab]
    r -= (r * u[lab]).sum(axis=1)[:, None] * u[lab]
    p2 = argmax((r**2).sum(axis=1), exclude=(p0, p1))
    return np.stack([p0, p1, p2], axis=1)


@dataclass
class Plan:
    """Where to pin and in which order to eliminate (depends on the mesh graph only).

    Attributes
    ----------
    anchors : (n_islands, 3) int64
    free_order : (n - 3 n_islands,) int64
        The free vertices in elimination order.
    seconds : float
    """

    anchors: np.ndarray
    free_order: np.ndarray
    seconds: float = 0.0


def plan_elimination(X: np.ndarray, edges: np.ndarray, islands: Islands) -> Plan:
    """Pins and a nested-dissection order from positions and mesh edges alone.

    It needs neither Step 1 nor Step 2, so :func:`parametrize` runs it in a second thread
    while they run. The pattern of ``L`` is the mesh's 1-ring graph (plus a few entries
    for the paper's extra vertices, which the order ignores at no measurable cost).

    Parameters
    ----------
    X : (n, 3) float64
    edges : (e, 2) int64
        Undirected mesh edges.
    islands : Islands
    """
    t0 = time.perf_counter()
    anchors = choose_anchors(X, islands)
    n = len(X)
    is_anchor = np.zeros(n, dtype=bool)
    is_anchor[anchors.ravel()] = True
    free = np.flatnonzero(~is_anchor)
    rank = np.cumsum(~is_anchor) - 1
    keep = ~is_anchor[edges[:, 0]] & ~is_anchor[edges[:, 1]]
    e = rank[edges[keep]]
    order = free[nested_dissection(np.take(X, free, axis=0), e)] if len(free) else free
    return Plan(anchors, order, time.perf_counter() - t0)


class _AnchoredLeastSquares:
    """One sparse LU that applies ``M_FF^{-1}`` and gives the pinned least-squares basis.

    ``L_F = L[:, F]`` (all n rows, the free columns) has full column rank, but its square
    part ``L_FF`` can be singular: dropping the pinned *rows* is only safe if the left
    null space of L reaches them, and on meshes with slivers that space concentrates on
    a few sliver rows (measured: cond(L_FF) = 1e15 on a developable cone strip whose
    L is fine). So we keep every row and border ``L_F`` with three seeded random
    columns per island, ``A = [L_F  B]`` (n x n, nonsingular for almost every B, with the
    sparsity of L plus three dense columns that the elimination order puts last).
    To apply ``M_FF^{-1} = (L_F^T L_F)^{-1}`` to b without ever forming M (whose
    conditioning is cond(L)^2): ``y = A^{-T} [b; 0]`` solves ``L_F^T y = b`` (and
    ``B^T y = 0``). The solutions of ``L_F^T y = b`` differ by the left null space of
    ``L_F``, three vectors per island spanned by ``N = A^{-T} E_B`` (E_B: the border
    columns of the identity), and the one orthogonal to N is in the range of ``L_F``:
    ``y - N (N^T N)^{-1} N^T y = L_F w`` with ``L_F^T L_F w = b``. So

        [M_FF^{-1} b; 0] = A^{-1} (y - N (N^T N)^{-1} N^T y),

    one transposed and one plain triangular solve and a 3x3 system per island. (The
    same as the block-inverse identity ``M_FF^{-1} = S_FF - S_FB S_BB^{-1} S_BF`` for
    ``S = (A^T A)^{-1}``, since ``S_BB = N^T N``, without its three extra solves for
    ``S E_B``.)
    """

    def __init__(self, L: sp.csr_matrix, islands: Islands, plan: Plan):
        n = L.shape[0]
        nI = islands.n
        anchors = plan.anchors
        self.n, self.islands, self.anchors, self.L = n, islands, anchors, L.tocsr()
        self.fperm = plan.free_order
        self.nf = nf = len(self.fperm)
        Lc = self.L
        t1 = time.perf_counter()
        # rows: free vertices (elimination order), then the anchors; columns: free, then B
        self.rows = np.concatenate([self.fperm, anchors.ravel()])
        self.label = np.concatenate([islands.label[self.fperm], np.repeat(np.arange(nI), 3)])
        self.B = np.random.default_rng(0x150).standard_normal((n, 3))  # seeded: deterministic
        self.where = np.empty(n, dtype=np.int64)  # row of each vertex
        self.where[self.rows] = np.arange(n)
        bcol = nf + 3 * islands.label[:, None] + np.arange(3)
        border = sp.csr_matrix((self.B.ravel(), (np.repeat(self.where, 3), bcol.ravel())), shape=(n, n))
        A = (sp.hstack([Lc[self.rows][:, self.fperm], sp.csr_matrix((n, 3 * nI))]) + border).tocsc()
        # Threshold partial pivoting: a pivot is kept unless 100x smaller than its column's
        # largest entry. Smooth meshes never pivot; the sliver cylinder does, and pivots less
        # (1M: 115M -> 83M nonzeros, LU 10.7 s -> 6.6 s, 5 -> 7 iterations, edge error
        # 1.0e-9 -> 1.7e-9). No pivoting at all broke the regular S-surface (100k: 38
        # iterations, edge error 0.28).
        self.lu = splu(A, permc_spec="NATURAL", diag_pivot_thresh=0.01)
        t2 = time.perf_counter()
        self.timings = EmbeddingTimings(ordering=plan.seconds, factorization=t2 - t1)
        e3 = np.zeros((n, 3))
        e3[nf + np.arange(3 * nI), np.tile(np.arange(3), nI)] = 1.0  # B columns, k-th of each island
        self.N = solve_columns(self.lu, e3, trans="T")  # A^{-T} E_B: the left null space of L_F
        self.NN = self._gram_rows(self.N, self.N)
        # the pinned least-squares basis: h_k = argmin ||L x|| with x = e_k on the anchors.
        # Its free part is -M_FF^{-1} L_F^T r_k with r_k = L[:, P] e_k, and since
        # [L_F^T r; 0] = A^T r - [0; B^T r], y = A^{-T} [L_F^T r; 0] = r - N (B^T r).
        H = np.zeros((n, 3))
        H[anchors, np.arange(3)] = 1.0
        r = self.L @ H  # L[:, P] e_k for every island at once, (n, 3)
        y = self._to_rows(r) - self._per_island(self.N, islands.gram(self.B, r))
        self.H = H - self._from_rows(self._solve_range(y))

    # Row gathers go through np.take: numpy's fancy row indexing of an (n, p) array is
    # 3-8x slower on a million rows (measured here).
    def _to_rows(self, b: np.ndarray) -> np.ndarray:
        """Vertex order -> row order (free vertices by elimination order, then anchors)."""
        return np.take(b, self.rows, axis=0)

    def _from_rows(self, x: np.ndarray) -> np.ndarray:
        """Row order -> vertex order."""
        return np.take(x, self.where, axis=0)

    def _per_island(self, cols: np.ndarray, coef: np.ndarray) -> np.ndarray:
        """Row-wise ``cols[r] . coef[island(r)]``: (n, 3), (n_islands, 3, p) -> (n, p)."""
        if self.islands.n == 1:
            return np.dot(cols, coef[0])
        return np.einsum("rk,rkp->rp", cols, np.take(coef, self.label, axis=0))

    def _gram_rows(self, P: np.ndarray, Q: np.ndarray) -> np.ndarray:
        """Per-island ``P^T Q`` over rows in row order: (n, p), (n, q) -> (n_islands, p, q)."""
        if self.islands.n == 1:
            return np.dot(P.T, Q)[None]
        nI = self.islands.n
        out = np.empty((nI, P.shape[1], Q.shape[1]))
        for i in range(P.shape[1]):  # a few columns
            for j in range(Q.shape[1]):
                out[:, i, j] = np.bincount(self.label, P[:, i] * Q[:, j], minlength=nI)
        return out

    def _solve_range(self, y: np.ndarray) -> np.ndarray:
        """``[w; 0]`` (row order) with ``L_F w`` the part of y (row order) orthogonal to
        the left null space N of ``L_F``, i.e. ``[M_FF^{-1} b; 0]`` for y = A^{-T} [b; 0]."""
        c = np.linalg.solve(self.NN, self._gram_rows(self.N, y))
        out = solve_columns(self.lu, y - self._per_island(self.N, c))
        out[self.nf :] = 0.0  # the border part is zero up to rounding
        return out

    def solve_mff(self, b: np.ndarray) -> np.ndarray:
        """``[M_FF^{-1} b_F; 0]`` for b (n, p), vertex order."""
        rhs = self._to_rows(b)
        rhs[self.nf :] = 0.0
        return self._from_rows(self._solve_range(solve_columns(self.lu, rhs, trans="T")))


_HANDOVER = 0.25  # once the islands still iterating hold at most this share of the rows: own LU
_LINEAR = 0.1  # largest last step from which the convergence rate is extrapolated
_REMAINDER = 1e-8  # smallest kept part of a column outside the previous blocks (relative)
_NULL = 1e-24  # a Ritz value ||L y||^2 (||y|| = 1) this small is rounding: y is a null vector of L


def _basis(blocks, islands: Islands, drop: float = 1e-10) -> np.ndarray:
    """Per-island orthonormal basis of the blocks' columns, orthogonal to the constant.

    Block classical Gram-Schmidt, twice (CGS2), against everything kept so far, then an
    orthonormalisation inside the block from its Gram matrix (SVQB) that drops
    directions with eigenvalue below ``drop`` relative to the block's largest. The first
    block must have orthonormal columns already or be the only one. Because each block
    is projected before it is normalised, a small but real correction survives down to
    ``_REMAINDER`` of its column (below that the remainder is mostly rounding and would
    not stay orthogonal); directions dependent *within* a block are dropped (set to zero
    on that island). Everything is BLAS-3 on large islands.
    """
    kept = _orthonormal_block(blocks[0], None, islands, drop)
    for B in blocks[1:]:
        kept = np.hstack([kept, _orthonormal_block(B, kept, islands, drop)])
    return kept


def _orthonormal_block(B: np.ndarray, kept: np.ndarray | None, islands: Islands, drop: float) -> np.ndarray:
    """One block of :func:`_basis`: centred, projected off ``kept`` (CGS2), orthonormalised."""
    B = B - islands.expand(islands.mean(B))
    d0 = np.einsum("ijj->ij", islands.gram(B, B))
    if kept is not None:
        for _ in range(2):
            B = B - islands.apply(kept, islands.gram(kept, B))
    g = islands.gram(B, B)
    d = np.einsum("ijj->ij", g)
    # a remainder below 1e-8 of the column is mostly rounding: it would not stay orthogonal
    alive = (d > _REMAINDER**2 * d0) & (d > 0)
    s = np.where(alive, 1.0 / np.sqrt(np.where(alive, d, 1.0)), 0.0)
    lam, U = np.linalg.eigh(s[:, :, None] * g * s[:, None, :])
    ok = lam > drop * np.maximum(lam[:, -1:], TINY)
    T = s[:, :, None] * U * np.where(ok, 1.0 / np.sqrt(np.where(ok, lam, 1.0)), 0.0)[:, None, :]
    return islands.apply(B, T)


def _ritz(L, Q: np.ndarray, islands: Islands, p: int):
    """Rayleigh-Ritz for ``min ||L x|| / ||x||`` over span(Q), Q orthonormal per island.

    Returns the p best vectors (orthonormal per island), L times them, their Ritz values
    (``inf`` where the space is still smaller than p), and per island the size below which
    a Ritz value is rounding (``1e-13 max|K|`` for the eigensolve, ``(1e-12 sigma_max)^2``
    for the SVD: 50-100x their error bounds). On a large island the Ritz
    vectors are the right singular vectors of ``L Q`` (QR, then a 9x9 SVD), so the tiny
    Ritz values keep their relative accuracy (``eps ||L Q||`` on sigma, not
    ``eps ||L Q||^2`` on sigma^2); the many small islands share one batched eigensolve of
    ``(L Q)^T (L Q)``, where the eigenvalues are not that small.
    """
    LQ = L @ Q
    k = Q.shape[1]
    alive = np.einsum("ijj->ij", islands.gram(Q, Q)) > 0.5  # columns _basis dropped are zero
    coef = np.zeros((islands.n, k, p))
    mu = np.full((islands.n, p), np.inf)
    floor = np.zeros(islands.n)
    if islands.small_rows.size:
        K = islands.gram(LQ, LQ, large=False)
        K = 0.5 * (K + K.transpose(0, 2, 1))
        floor = 1e-13 * np.abs(K).max(axis=(1, 2))  # large islands: set below
        dead = 2.0 * np.abs(K).max(axis=(1, 2))[:, None] + TINY
        K[:, np.arange(k), np.arange(k)] += np.where(alive, 0.0, dead)
        w, c = np.linalg.eigh(K)
        q = min(p, k)
        coef[:, :, :q] = c[:, :, :q]
        mu[:, :q] = np.where(alive.sum(axis=1)[:, None] > np.arange(q), w[:, :q], np.inf)
    for i in islands.large:  # one small SVD per large island
        r = islands.rows(i)
        cols = np.flatnonzero(alive[i])
        R = np.linalg.qr(LQ[r][:, cols], mode="r")  # same singular values, 9x9 SVD
        _, sig, vt = np.linalg.svd(R)
        q = min(p, len(cols))  # fewer columns than wanted only before the block has grown
        coef[i] = 0.0
        coef[i][cols, :q] = vt[::-1][:q].T
        mu[i, :q] = sig[::-1][:q] ** 2
        floor[i] = (1e-12 * sig[0]) ** 2 if len(sig) else 0.0
    return islands.apply(Q, coef), islands.apply(LQ, coef), mu, floor


def spectral_embedding(
    L: sp.csr_matrix,
    X: np.ndarray,
    islands: Islands,
    tol: float = 1e-8,
    max_iter: int = 40,
    block: int = 2,
    plan: Plan | None = None,
    start: np.ndarray | None = None,
) -> Embedding:
    """Two lowest non-constant eigenvectors of ``M = L^T L`` per island (Step 3).

    Parameters
    ----------
    L : (n, n) sparse
        ``I - W`` from Step 2, rows and columns ordered island by island.
    X : (n, 3) float64
        Vertex positions (for the anchors and the fill-reducing order).
    islands : Islands
    tol : float
        Stop when the subspace moves, or is predicted from the observed linear rate to
        move next, by less than this (sine of the angle).
    max_iter : int
    block : int
        Ritz vectors carried (2 are wanted; more did not pay off on our meshes).
    plan : Plan, optional
        From :func:`plan_elimination`; computed here if not given.
    start : (n, block) float64, optional
        Vectors to start from, orthonormal and centred per island (else the pinned
        least-squares basis alone).

    Every iteration's solves run over the whole factorization, so islands that have
    converged would keep paying for one that has not (a symmetric island, a box or a
    cylinder, can take 30 iterations where others take 2). Once the islands still
    iterating hold at most ``_HANDOVER`` of the rows, they go on alone: their own
    (small) factorization, started from where they are.

    Returns
    -------
    Embedding
    """
    t0 = time.perf_counter()
    own_plan = plan is None
    if plan is None:
        A0 = L.tocoo()
        plan = plan_elimination(X, np.stack([A0.row, A0.col], axis=1), islands)
    pls = _AnchoredLeastSquares(L, islands, plan)
    t1 = time.perf_counter()
    state = _Iteration.start(L, pls.H, islands, block, start)
    rest = _iterate(L, X, islands, pls, state, tol, max_iter, block)
    t2 = time.perf_counter()
    timings = _timings(pls.timings, plan.seconds if own_plan else 0.0, t1 - t0, t2 - t1, rest)
    return _embedding(state, islands, rest, timings)


@dataclass
class _Iteration:
    """The state of the block inverse iteration of :func:`spectral_embedding`.

    Attributes
    ----------
    Y : (n, block) float64
        The current Ritz vectors, orthonormal and centred per island.
    LY : (n, block) float64
        ``L Y``.
    mu : (n_islands, block) float64
        Their Ritz values.
    previous : (n, block) float64
        ``Y`` before the last step (zero before the first), kept in the search space.
    done : (n_islands,) bool
    change : (n_islands,) float64
        How far the last step moved the subspace (sine of the angle; ``inf`` before it).
    iterations : int
    """

    Y: np.ndarray
    LY: np.ndarray
    mu: np.ndarray
    previous: np.ndarray
    done: np.ndarray
    change: np.ndarray
    iterations: int = 0

    @classmethod
    def start(cls, L, H: np.ndarray, islands: Islands, block: int, start: np.ndarray | None) -> _Iteration:
        """The ``block`` best vectors in the span of the pinned least-squares basis ``H``
        (and of ``start``, if given)."""
        Y, LY, mu, _ = _ritz(L, _basis([H] if start is None else [start, H], islands), islands, block)
        return cls(Y, LY, mu, np.zeros_like(Y), np.zeros(islands.n, dtype=bool), np.full(islands.n, np.inf))


def _iterate(L, X, islands: Islands, pls: _AnchoredLeastSquares, state: _Iteration, tol, max_iter, block):
    """Inverse iterations on ``state`` until every island is done or ``max_iter``; but once
    the islands still iterating hold at most ``_HANDOVER`` of the rows, they go on alone:
    returns that sub-problem (see :func:`_go_on_alone`), or None."""
    for iterations in range(1, max_iter + 1):  # inverse iterations, a handful per mesh
        tick(iterations / (iterations + 4))
        state.iterations = iterations
        _inverse_iteration(L, pls, islands, state, tol, block)
        if state.done.all():
            return None
        if islands.size[~state.done].sum() <= _HANDOVER * len(state.Y) and iterations < max_iter:
            return _go_on_alone(L, X, islands, ~state.done, state.Y, tol, max_iter - iterations, block)
    return None


def _inverse_iteration(L, pls: _AnchoredLeastSquares, islands: Islands, state: _Iteration, tol, block) -> None:
    """One step of block inverse iteration with Rayleigh-Ritz, in place: the islands not yet
    done take the new vectors, and are done once the subspace moved, or is predicted to
    move, by less than ``tol``, or once their pair is ambiguous."""
    Y, LY, mu = state.Y, state.LY, state.mu
    # preconditioned residual with the exact inverse on the free block
    R = L.T @ LY - Y * np.where(np.isfinite(mu), mu, 0.0)[islands.label, : Y.shape[1]]
    W = pls.solve_mff(R)
    Y_new, LY_new, mu_new, floor = _ritz(L, _basis([Y, pls.H, W, state.previous], islands), islands, block + 1)
    # a null space of more than two non-constant dimensions (measured: two Smart UV
    # islands of a subdivided Suzanne, four zero singular values of L each) makes the
    # pair ambiguous; the iteration would wander inside it to max_iter. The Ritz values
    # bound the eigenvalues from above, so a third one at rounding level proves it.
    ambiguous = np.all(mu_new <= np.maximum(floor, _NULL)[:, None], axis=1)
    Y_new, LY_new, mu_new = Y_new[:, :block], LY_new[:, :block], mu_new[:, :block]
    step = _moved(Y, Y_new, islands)
    predicted = _predicted(step, state.change)
    live = ~state.done
    state.change[live] = step[live]
    keep_old = islands.expand(state.done)[:, None]
    state.previous = Y
    state.Y = np.where(keep_old, Y, Y_new)
    state.LY = np.where(keep_old, LY, LY_new)
    state.mu[live] = mu_new[live]
    state.done |= (step < tol) | (predicted < tol) | ambiguous


def _moved(Y: np.ndarray, Y_new: np.ndarray, islands: Islands) -> np.ndarray:
    """How far the pair moved, per island (n_islands,): the norm of the part of
    ``Y_new[:, :2]`` outside the span of ``Y[:, :2]`` (both orthonormal per island), the
    sine of the angle between the two subspaces."""
    cross = islands.gram(Y[:, :2], Y_new[:, :2])
    moved = Y_new[:, :2] - islands.apply(Y[:, :2], cross)
    return np.sqrt(islands.sum(moved**2).sum(axis=1))


def _predicted(step: np.ndarray, change: np.ndarray) -> np.ndarray:
    """The next step (n_islands,) predicted from this ``step`` and the last (``change``,
    ``inf`` before the first), where the iteration converges linearly; else ``step``."""
    # linear convergence: the next step would move about step * (step / last step),
    # once the iteration is in its linear regime: a rate measured from a large last
    # step is not trusted (200k-vertex developable strips: steps 0.63 then 2e-5
    # "predicted" 6e-10 and stopped at an edge error of 4e-8; one more step: 6e-10)
    last = np.where(np.isfinite(change), change, 1.0)
    linear = np.isfinite(change) & (step < change) & (last < _LINEAR)  # (so last > step >= 0)
    rate = np.where(linear, step / np.where(linear, last, 1.0), 1.0)
    return step * rate


def _embedding(state: _Iteration, islands: Islands, rest, timings: EmbeddingTimings) -> Embedding:
    """The :class:`Embedding` of the iteration's ``state``, with the islands that went on
    alone (``rest``, from :func:`_go_on_alone`) taken from their sub-problem."""
    coords = state.Y[:, :2] * np.sqrt(islands.expand(islands.size.astype(np.float64)))[:, None]
    mu, done, change, iterations = state.mu, state.done, state.change, state.iterations
    if rest is not None:
        live, rows, emb = rest
        coords[rows] = emb.coords
        mu[live, :2], done[live], change[live] = emb.eigenvalues, emb.converged, emb.change
        iterations += emb.iterations
    return Embedding(coords, mu[:, :2], done, change, iterations, timings)


def _timings(timings: EmbeddingTimings, planning: float, setup: float, iterating: float, rest) -> EmbeddingTimings:
    """``timings`` (the factorization's) completed: the pinned basis took the ``setup``
    seconds that neither ``planning`` (the order, when computed here) nor the factorization
    did; the islands that went on alone (``rest``) count their ordering and LU as such,
    not as iterations."""
    before_basis = timings.factorization + planning
    timings.pinned_basis, timings.iterations = setup - before_basis, iterating
    if rest is not None:
        sub = rest[2].timings
        timings.ordering += sub.ordering
        timings.factorization += sub.factorization
        timings.iterations -= sub.ordering + sub.factorization
    return timings


def _go_on_alone(L, X, islands: Islands, live: np.ndarray, Y: np.ndarray, tol, max_iter, block):
    """Step 3 for the ``live`` islands alone (their rows and columns of L: islands are
    diagonal blocks), from their current vectors ``Y``. Returns the islands, their rows
    and the :class:`Embedding` of that sub-problem."""
    rows, sub = islands.subset(live)
    L_sub = L[rows][:, rows]
    return np.flatnonzero(live), rows, spectral_embedding(L_sub, X[rows], sub, tol, max_iter, block, start=Y[rows])
