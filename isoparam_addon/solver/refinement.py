"""Beyond the paper: isometric refinement of the four-step layout, without folds.

The four-step layout is exact on developable surfaces, but on curved ones it shrinks the
curved regions and grows the flat ones, and on non-developable random triangulations
it can fold. Here it seeds the minimisation of the *symmetric Dirichlet* energy
(Smith & Schaefer 2015),

    E = sum_f A_f (||J_f||^2 + ||J_f^{-1}||^2),        E >= 4 sum_f A_f, equality iff isometric,

over the UVs, J_f being the Jacobian of face f's map from its 3D triangle to UV. E is
infinite for a collapsed triangle, so a descent that starts without folds never creates
one: every step is capped below the first time any triangle would degenerate (the root
of det J_f(t), a quadratic in the step t).

The descent is L-BFGS whose initial inverse Hessian is the cotangent Laplacian (the
Hessian of the Dirichlet part, the "quadratic proxy" of Kovalsky et al. 2016), factored
once in nested-dissection order and reused by every iteration; the quasi-Newton pairs
add the curvature of the ||J^{-1}|| part. An iteration costs one pair of triangular
solves, a dozen sparse products and the line search (measured with ``tol=1e-7``: 40
iterations on peaks 41x41, ~190 on a 100k-vertex peaks, against ~100 and 300+ for the
momentum-only AQP; the default ``tol=1e-5`` stops after 15 and 16, with the symmetric
Dirichlet energy within 1e-4 of the 1e-7 result).

Islands are independent problems and are treated as such: each has its own ARAP
acceptance, step length, line search, L-BFGS memory and stopping test (per-island dot
products are one ``bincount``), so a hard island neither holds back nor stops the rest.

A seed that folds (slivers on a random Delaunay S-surface, strongly curved islands such
as a band around a sphere) cannot be repaired by a barrier energy; that island restarts
from a conformal map, or a Tutte embedding where that folds too (see :mod:`.seeds`).
Measured on Suzanne subdivided twice with Smart UV Project seams (112 islands, 9 of
them folded): symmetric Dirichlet 4.0037 after 34 iterations, against 6.93 when every
island restarted from a Tutte embedding and shared one line search.

Pins are Dirichlet constraints: pinned vertices keep their UV and the others adapt.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field

import numpy as np
import scipy.sparse as sp
from scipy.sparse.linalg import splu

from ._parallel import solve_columns
from .geometry import signed_double_areas
from .islands import Islands
from .mesh import unique_edges
from .ordering import nested_dissection
from .seeds import lscm, tutte

__all__ = ["Refinement", "refine", "FaceFrames"]

_MEMORY = 8  # L-BFGS pairs
_HANDOVER = 0.25  # once the islands still descending hold at most this share of the rows: own factor
_COLLAPSED = 1e-6  # a seed face with less UV area than this times its 3D area: restart


class FaceFrames:
    """Per-face reference triangles and the gradient operators of piecewise-linear maps.

    Face f maps to its own plane as (0, 0), (x1, 0), (x2, y2), y2 > 0. For a function
    with values (f0, f1, f2) at the corners, ``grad f = (Dx f, Dy f)``.

    Attributes
    ----------
    area : (m,) float64
        3D area (degenerate faces get a tiny positive stand-in, see ``degenerate``).
    Dx, Dy : (m, n) sparse
    degenerate : (m,) bool
    """

    def __init__(self, X: np.ndarray, faces: np.ndarray):
        m, n = len(faces), len(X)
        cols = [np.ascontiguousarray(X[:, c]) for c in range(3)]
        i0, i1, i2 = (np.ascontiguousarray(faces[:, k]) for k in range(3))
        e1 = np.stack([c[i1] - c[i0] for c in cols], axis=1)
        e2 = np.stack([c[i2] - c[i0] for c in cols], axis=1)
        x1 = np.sqrt((e1 * e1).sum(axis=1))
        cross = np.cross(e1, e2)
        twice = np.sqrt((cross * cross).sum(axis=1))
        scale = np.maximum(x1, np.sqrt((e2 * e2).sum(axis=1)))
        # a face collapsed to a point takes a stand-in size from the mesh: 1e-300 made its
        # area underflow to 0 and its gradient 0/0 (NaN energy for the whole island)
        size = float(scale.max(initial=0.0))
        scale = np.maximum(scale, 1e-9 * (size if size > 0 else 1.0))
        floor = 1e-6 * scale
        x1 = np.maximum(x1, floor)
        x2 = (e1 * e2).sum(axis=1) / x1
        y2 = twice / x1
        self.degenerate = y2 < floor
        y2 = np.maximum(y2, floor)
        self.area = 0.5 * x1 * y2
        dx = np.stack([-1.0 / x1, 1.0 / x1, np.zeros(m)], axis=1)
        dy = np.stack([(x2 / x1 - 1.0) / y2, -x2 / (x1 * y2), 1.0 / y2], axis=1)
        rows = np.repeat(np.arange(m), 3)
        idx = faces.ravel()
        self.Dx = sp.csr_matrix((dx.ravel(), (rows, idx)), shape=(m, n))
        self.Dy = sp.csr_matrix((dy.ravel(), (rows, idx)), shape=(m, n))
        self.DxT, self.DyT = self.Dx.T.tocsr(), self.Dy.T.tocsr()

    def jacobians(self, uv: np.ndarray):
        """(a, b, c, d) per face: J = [[a, b], [c, d]] = [[u_x, u_y], [v_x, v_y]]."""
        u, v = uv[:, 0], uv[:, 1]
        return self.Dx @ u, self.Dy @ u, self.Dx @ v, self.Dy @ v

    def laplacian(self) -> sp.csr_matrix:
        """The cotangent Laplacian ``sum_f A_f (Dx^T Dx + Dy^T Dy)`` (n, n)."""
        A = sp.diags(self.area)
        return (self.DxT @ A @ self.Dx + self.DyT @ A @ self.Dy).tocsr()


def _energy_terms(a, b, c, d, area):
    """Symmetric Dirichlet per face and its derivative with respect to J."""
    det = a * d - b * c
    fro = a * a + b * b + c * c + d * d
    inv = fro / (det * det)  # ||J^{-1}||_F^2 = ||J||_F^2 / det^2 in 2D
    e = area * (fro + inv)
    # d/dJ ||J^{-1}||^2 = (2 / det^2) J - (2 ||J||^2 / det^3) cof(J), cof(J) = [[d, -c], [-b, a]]
    k1 = 2.0 * area * (1.0 + 1.0 / (det * det))
    k2 = -2.0 * area * fro / (det * det * det)
    return e, (k1 * a + k2 * d, k1 * b - k2 * c, k1 * c - k2 * b, k1 * d + k2 * a)


def _max_step(J, dJ, limit: float = np.inf):
    """Per face, the first t in (0, ``limit``] with det(J + t dJ) = 0 (det J > 0), inf
    where there is none: (m,).

    det(J + t dJ) = qa t^2 + qb t + qc with qc = det J > 0. With a finite ``limit`` only
    the faces whose determinant can reach zero by then get their roots computed: those
    with det <= 0 at ``limit``, or with a minimum inside (0, limit) that is not positive
    (a few percent of the faces in a descent).
    """
    a, b, c, d = J
    da, db, dc, dd = dJ
    qa = da * dd - db * dc
    qb = a * dd + d * da - b * dc - c * db
    qc = a * d - b * c
    t = np.full(len(a), np.inf)
    if np.isfinite(limit):
        with np.errstate(invalid="ignore"):
            dips = (qa > 0) & (qb < 0) & (qb > -2.0 * limit * qa) & (qb * qb >= 4.0 * qa * qc)
            rows = np.flatnonzero(((qa * limit + qb) * limit + qc <= 0) | dips)
        t[rows] = _max_step((a[rows], b[rows], c[rows], d[rows]), tuple(x[rows] for x in dJ))
        return t
    lin = np.abs(qa) < 1e-30 * np.maximum(np.abs(qb), 1e-300)
    with np.errstate(divide="ignore", invalid="ignore"):
        tl = -qc / qb
        t = np.where(lin & (tl > 0), tl, t)
        disc = qb * qb - 4.0 * qa * qc
        sq = np.sqrt(np.maximum(disc, 0.0))
        r1 = (-qb - sq) / (2.0 * qa)
        r2 = (-qb + sq) / (2.0 * qa)
        quad = ~lin & (disc >= 0)
        r1 = np.where(quad & (r1 > 0), r1, np.inf)
        r2 = np.where(quad & (r2 > 0), r2, np.inf)
    return np.minimum(t, np.minimum(r1, r2))


@dataclass
class Refinement:
    """What :func:`refine` did.

    Attributes
    ----------
    uv : (n, 2) float64
    energy : list of float
        Symmetric Dirichlet per unit area (4 = isometric) after each iteration, the
        seed's first; then, if islands were scaled onto their pins after the last
        iteration (:meth:`rescale`), the layout's as returned (which can be higher).
    iterations : int
        Descent iterations.
    arap_iterations : int
    restarted_conformal, restarted_tutte : (n_islands,) bool
        Islands whose seed folded, by the layout that replaced it: a conformal map, or a
        Tutte embedding where that folded too.
    folded : int
        Faces still folded at the end: 0 unless an island's seed folded and could not be
        replaced (it has pins, or even its Tutte embedding folded).
    island_energy, island_area : (n_islands,) float64
        At the end, per island: the energy (``sum_f A_f E_f``) and the 3D area of its
        faces that were refined (0 for islands left alone), so that the last ``energy``
        is ``island_energy.sum() / island_area.sum()``.
    island_parts : ((n_islands,), (n_islands,)) float64
        ``island_energy`` split into its ``sum_f A_f ||J_f||^2`` and
        ``sum_f A_f ||J_f^{-1}||^2`` parts, which a uniform scale of the layout changes
        by ``s^2`` and ``1 / s^2`` (see :meth:`rescale`).
    seconds : float
    """

    uv: np.ndarray
    restarted_conformal: np.ndarray
    restarted_tutte: np.ndarray
    island_energy: np.ndarray
    island_area: np.ndarray
    island_parts: tuple[np.ndarray, np.ndarray]
    energy: list[float] = field(default_factory=list)
    iterations: int = 0
    arap_iterations: int = 0
    folded: int = 0
    seconds: float = 0.0

    def rescale(self, which: np.ndarray, scale: np.ndarray) -> None:
        """Account for islands ``which`` (k,) bool of ``uv`` having been scaled by
        ``scale`` (k,) (and turned and moved, which change nothing) after the last
        iteration: their energies become those of the layout as it now is, and ``energy``
        gets one more entry, the whole layout's."""
        s2 = np.where(which, scale, 1.0) ** 2
        d, i = self.island_parts[0] * s2, self.island_parts[1] / s2
        self.island_parts = (d, i)
        self.island_energy = np.where(which, d + i, self.island_energy)
        self.energy.append(float(self.island_energy.sum()) / max(float(self.island_area.sum()), 1e-300))


def _reseed(X, faces, x, he_twin, islands, frames, per_face, pinned, order=None):
    """Replace the seed of islands that fold or collapse (and have no pins) by a
    conformal map, or by a Tutte embedding where that folds too.

    Collapsed means a face whose UV area is below ``_COLLAPSED`` times its 3D area: a
    descent from there spends its iterations on the energy's singularity.

    Returns the new seed, the islands still folded, and those restarted from a
    conformal map and from a Tutte embedding, (n_islands,) bool each.
    """
    det = signed_double_areas(x, faces) / (2.0 * frames.area)
    poor = per_face.sum(det <= _COLLAPSED) > 0
    bad = poor & (np.bincount(islands.label, pinned, minlength=islands.n) == 0)
    restarted = []
    for seed, floor in ((lscm, _COLLAPSED), (tutte, 0.0)):
        ok = np.zeros(islands.n, dtype=bool)
        if bad.any():
            try:
                if seed is lscm:
                    y = lscm(X, faces, islands, frames, bad, order)
                else:
                    y = tutte(X, faces, he_twin, islands, frames, bad, order)
            except RuntimeError:  # SuperLU: "Factor is exactly singular"; they stay as they are
                y = None
            if y is not None:
                ok = bad & (per_face.sum(signed_double_areas(y, faces) <= floor * 2.0 * frames.area) == 0)
                x = np.where(ok[islands.label][:, None], y, x)
                bad &= ~ok
        restarted.append(ok)
    return x, per_face.sum(signed_double_areas(x, faces) <= 0) > 0, restarted[0], restarted[1]


@dataclass
class Proxy:
    """The descent's fixed quadratic proxy ``H = 2 (K + eps M)``, factored once.

    K is the cotangent Laplacian, M the lumped mass matrix with a whisper ``eps`` that
    fixes the translation of islands without pins. It depends on the mesh and the pins
    only, not on the layout, so :func:`parametrize` builds it in its worker thread while
    Step 3 runs (SuperLU releases the GIL; measured: two 100k factorizations take 0.55 s
    side by side, 1.08 s one after the other).
    """

    frames: FaceFrames
    H: sp.csr_matrix
    whisper: np.ndarray  # (n,): H = 2 (K + diag(whisper))
    pinned: np.ndarray
    perm: np.ndarray
    lu: object


def quadratic_proxy(X, faces, islands: Islands, pinned=None, order=None) -> Proxy:
    """Build and factor the proxy (see :class:`Proxy`) for ``pinned`` (n,) bool vertices,
    eliminating in ``order`` (n,) (e.g. Step 3's nested dissection) when given."""
    n = len(X)
    pinned = np.zeros(n, dtype=bool) if pinned is None else pinned
    frames = FaceFrames(X, faces)
    K = frames.laplacian()
    # a whisper of the mass matrix pins the translations of islands without pins, scaled
    # per island so that each island's block of H is what it would be alone
    mass = np.bincount(faces.ravel(), np.repeat(frames.area / 3, 3), minlength=n)
    size = np.maximum(islands.size, 1)
    reg = 1e-9 * np.bincount(islands.label, K.diagonal(), minlength=islands.n) / size
    mean_mass = np.bincount(islands.label, mass, minlength=islands.n) / size
    whisper = (reg / np.maximum(mean_mass, 1e-300))[islands.label] * mass
    H = 2.0 * (K + sp.diags(whisper))
    perm = order[~pinned[order]] if order is not None else np.flatnonzero(~pinned)
    lu = splu(H[perm][:, perm].tocsc(), permc_spec="NATURAL") if len(perm) else None
    return Proxy(frames=frames, H=H.tocsr(), whisper=whisper, pinned=pinned, perm=perm, lu=lu)


def refine(
    X: np.ndarray,
    faces: np.ndarray,
    uv: np.ndarray,
    islands: Islands,
    he_twin: np.ndarray,
    *,
    iterations: int = 100,
    tol: float = 1e-5,
    arap: int = 10,
    pinned: np.ndarray | None = None,
    order: np.ndarray | None = None,
    proxy: Proxy | None = None,
    carry: tuple | None = None,
) -> Refinement:
    """Lower the symmetric Dirichlet energy of a layout without folding it.

    Every island is its own problem: it has its own step lengths and L-BFGS memory and
    stops on its own, so one hard island neither slows nor stops the others. Each
    iteration still costs a pass over every island, so once the islands still descending
    hold at most ``_HANDOVER`` of the rows they go on alone, with their own factored
    proxy (measured: Suzanne with no seams, closed and cut open, takes all 100 iterations;
    beside a 100k-vertex peaks, done after 16, the refinement took 14 s, ~1.8 s for
    peaks alone).

    Parameters
    ----------
    X : (n, 3) float64
    faces : (m, 3) int64
        Oriented faces (counter-clockwise in a good layout).
    uv : (n, 2) float64
        The seed, in mesh units, islands counter-clockwise.
    islands : Islands
    he_twin : (3m,) int64
        Twin half-edges of ``faces`` (boundary loops for the Tutte fallback).
    iterations : int
        At most this many descent steps.
    tol : float
        An island stops when an iteration lowers its energy by less than this, relative.
    arap : int
        ARAP local/global steps before the descent (an island stops taking them when one
        would fold it or not lower its symmetric Dirichlet energy): measured on a
        100k-vertex peaks, 10 of them cut the descent from ~190 to ~32 iterations.
    pinned : (n,) bool, optional
        Vertices that keep their UV.
    order : (n,) int64, optional
        Fill-reducing order for the factorization (e.g. the nested dissection of Step 3).
    proxy : Proxy, optional
        A proxy built beforehand by :func:`quadratic_proxy`; used if its pins are ours.
    carry : (memory, gamma), optional
        The L-BFGS state of the refinement these islands are handed over from (see
        ``_go_on_alone``): the descent goes on where it was, with no restart from a
        conformal map (``he_twin`` is not used) and no ARAP.

    Returns
    -------
    Refinement
    """
    t0 = time.perf_counter()
    n = len(X)
    pinned = np.zeros(n, dtype=bool) if pinned is None else pinned
    if proxy is None or not np.array_equal(proxy.pinned, pinned):
        proxy = quadratic_proxy(X, faces, islands, pinned, order)
    frames, H, perm, lu = proxy.frames, proxy.H, proxy.perm, proxy.lu
    area = frames.area
    per_face = Islands.labelled(islands.label[faces[:, 0]], islands.n)
    none = np.zeros(islands.n, dtype=bool)
    out = Refinement(
        np.array(uv, dtype=np.float64, copy=True),
        none,
        none,
        np.zeros(islands.n),
        np.zeros(islands.n),
        (np.zeros(islands.n), np.zeros(islands.n)),
    )
    if carry is None:
        x, stuck, out.restarted_conformal, out.restarted_tutte = _reseed(
            X, faces, out.uv, he_twin, islands, frames, per_face, pinned, order
        )
    else:
        x, stuck = out.uv, np.zeros(islands.n, dtype=bool)
    # islands that still fold, and islands with nothing free, are left as they are
    free_count = np.bincount(islands.label, ~pinned, minlength=islands.n)
    active = ~stuck & (free_count > 0)
    live_face = active[per_face.label]
    live_area = float(area[live_face].sum())
    every_face_live = bool(live_face.all())
    fixed = np.flatnonzero(pinned)

    def energies(J):
        """Per-island energy (0 for islands left alone: they may hold folds) and the
        per-face derivatives dE/dJ, which :func:`gradient` turns into dE/duv."""
        with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
            e, G = _energy_terms(*J, area)
        return per_face.sum(e if every_face_live else np.where(live_face, e, 0.0)), G

    def gradient(G):
        if not every_face_live:
            G = [np.where(live_face, Gk, 0.0) for Gk in G]
        g = np.stack([frames.DxT @ G[0] + frames.DyT @ G[1], frames.DxT @ G[2] + frames.DyT @ G[3]], axis=1)
        g[pinned] = 0.0
        return g

    # row gathers through np.take (fancy indexing of (n, 2) rows is 8x slower); pinned
    # vertices read the zero row appended to the solution
    slot = np.full(n, len(perm), dtype=np.int64)
    slot[perm] = np.arange(len(perm))

    def precondition(g):  # H^{-1} g; H is block diagonal, so islands stay independent
        if lu is None:
            return np.zeros_like(g)
        y = solve_columns(lu, np.take(g, perm, axis=0))
        return np.take(np.vstack([y, np.zeros((1, y.shape[1]))]), slot, axis=0)

    J = frames.jacobians(x)
    E, G = energies(J)
    history = [E]  # per island, the seed's and each ARAP step's
    # ARAP first (Liu et al. 2008): large, cheap moves with the same factorization
    stepping = active.copy()
    for _ in range(arap):  # local/global steps
        a, b, c, d = J
        # the rotation closest to each Jacobian: (cos, sin) along (a + d, c - b), no
        # trigonometry (arctan2, cos and sin took 11 ms per step at 200k faces)
        cs, sn = a + d, c - b
        h = np.hypot(cs, sn)
        flat = h == 0  # arctan2(0, 0) = 0: the identity
        h = area / np.where(flat, 1.0, h)
        cs = np.where(flat, area, cs * h)
        sn *= h
        rhs = 2.0 * np.stack([frames.DxT @ cs - frames.DyT @ sn, frames.DxT @ sn + frames.DyT @ cs], axis=1)
        if fixed.size:
            rhs -= H[:, fixed] @ x[fixed]
        y = precondition(rhs)
        y[pinned] = x[pinned]
        Jy = frames.jacobians(y)
        folds = per_face.sum((Jy[0] * Jy[3] - Jy[1] * Jy[2]) <= 0) > 0
        Ey, Gy = energies(Jy)
        take = stepping & ~folds & (Ey < E)
        if not take.any():
            break
        x = np.where(islands.spread(take), y, x)
        J = tuple(np.where(per_face.expand(take), jy, j) for jy, j in zip(Jy, J))
        G = [np.where(per_face.expand(take), gy, gk) for gy, gk in zip(Gy, G)]
        E = np.where(take, Ey, E)
        stepping = take  # an island that declines once has reached ARAP's reach
        history.append(E)
        out.arap_iterations += 1
    # an island whose energy is still infinite (a face whose det J squared underflows, and
    # ARAP found no better: fuzzing, every vertex on one point and pins apart) is left as
    # it is: the descent's inf - inf made its UVs NaN
    endless = active & ~np.isfinite(E)
    if endless.any():
        active &= ~endless
        live_face = active[per_face.label]
        live_area = float(area[live_face].sum())
        every_face_live = bool(live_face.all())
        E, G = energies(J)
        history = [np.where(endless, 0.0, h) for h in history]
    out.energy += [float(h.sum()) / max(live_area, 1e-300) for h in history]
    g = gradient(G)
    memory = []  # L-BFGS pairs (s, y, rho per island); an island's rho is 0 where unused
    whisper = np.repeat(proxy.whisper, 2).reshape(-1, 2)  # per row and column: no (n, 1) broadcast
    gamma = np.ones(islands.n)  # per-island scale of the proxy, from the last good pair
    if carry is not None:
        memory, gamma = carry
    for it in range(1, iterations + 1):  # quasi-Newton steps, each one factored solve
        q = np.where(islands.spread(active), g, 0.0)
        alphas = []
        for s_k, y_k, rho in reversed(memory):
            a_k = rho * islands.dot(s_k, q)
            alphas.append(a_k)
            q -= islands.spread(a_k) * y_k
        r = precondition(q) * islands.spread(gamma)
        for a_k, (s_k, y_k, rho) in zip(reversed(alphas), memory):
            r += islands.spread(a_k - rho * islands.dot(y_k, r)) * s_k
        p = -r
        slope = islands.dot(g, p)
        lost = active & (slope >= 0)
        if lost.any():  # not a descent direction: those islands forget and use the proxy
            memory = [(s_k, y_k, np.where(lost, 0.0, rho)) for s_k, y_k, rho in memory]
            gamma[lost] = 1.0
            p = np.where(islands.spread(lost), -precondition(np.where(islands.spread(lost), g, 0.0)), p)
            slope = islands.dot(g, p)
        p = np.where(islands.spread(active), p, 0.0)
        dJ = frames.jacobians(p)
        t = np.where(active, np.minimum(1.0, 0.9 * per_face.min(_max_step(J, dJ, 1.0 / 0.9))), 0.0)
        searching = active.copy()
        Jt = None
        while searching.any():  # backtracking (Armijo), island by island
            f = None if Jt is None else per_face.members(searching)
            if f is None or 2 * len(f) > len(area):
                Jt = tuple(j + per_face.expand(t) * dj for j, dj in zip(J, dJ))
                Et, Gt = energies(Jt)
                Gt = list(Gt)
            else:  # few faces still searching: evaluate only theirs, the rest stands
                tf = t[per_face.label[f]]
                Jf = [np.take(j, f) + tf * np.take(dj, f) for j, dj in zip(J, dJ)]
                with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
                    ef, Gf = _energy_terms(*Jf, np.take(area, f))
                for k in range(4):
                    Jt[k][f], Gt[k][f] = Jf[k], Gf[k]
                Et = np.where(searching, np.bincount(per_face.label[f], ef, minlength=islands.n), Et)
            searching &= ~(Et <= E + 1e-4 * t * slope)
            t[searching] *= 0.5
            gone = searching & (t < 1e-12)
            t[gone] = 0.0
            active &= ~gone  # no decrease along a descent direction: as far as it goes
            searching &= ~gone
        if not (t > 0).any():
            break
        # every island that moved was last evaluated at its final step; the others stay
        still = per_face.expand(t == 0)
        Jt = tuple(np.where(still, j, jt) for j, jt in zip(J, Jt))
        Et = np.where(t == 0, E, Et)
        x_new = x + islands.spread(t) * p
        g_new = gradient(Gt)  # rows of islands that did not move are not used again
        s_k, y_k = x_new - x, g_new - g
        sy, ss = islands.dot(s_k, y_k), islands.dot(s_k, s_k)
        good = (t > 0) & (sy > 1e-12 * ss)
        if good.any():
            s_k, y_k = np.where(islands.spread(good), s_k, 0.0), np.where(islands.spread(good), y_k, 0.0)
            rho = np.where(good, 1.0 / np.where(good, sy, 1.0), 0.0)
            memory.append((s_k, y_k, rho))
            memory = memory[-_MEMORY:]
            # scale the proxy to the curvature seen along the step, s^T H s / s^T y, with
            # s^T K s = t^2 sum_f A_f |dJ_f|^2 from the Jacobians at hand (no product with H)
            sKs = t * t * per_face.sum(area * (dJ[0] * dJ[0] + dJ[1] * dJ[1] + dJ[2] * dJ[2] + dJ[3] * dJ[3]))
            sHs = 2.0 * (sKs + islands.dot(s_k, s_k * whisper))
            gamma = np.where(good, sHs / np.where(good, sy, 1.0), gamma)
        active &= ~(E - Et < tol * Et)
        x, J, E, g = x_new, Jt, Et, g_new
        out.energy.append(float(E.sum()) / live_area)
        out.iterations = it
        if not active.any():
            break
        if it < iterations and islands.size[active].sum() <= _HANDOVER * n:
            rows, sub, sub_area = _go_on_alone(
                X, faces, x, islands, active, per_face, pinned, iterations - it, tol, (memory, gamma), area
            )
            x = x.copy()
            x[rows] = sub.uv
            E = E.copy()
            E[active] = sub.island_energy
            # the energy over every live face: the islands handed over, the others as they stopped
            rest = float(E[~active].sum())
            out.energy += [(rest + e * sub_area) / live_area for e in sub.energy[1:]]
            out.iterations = it + sub.iterations
            break
    out.uv = x
    out.island_energy, out.island_area = E, per_face.sum(np.where(live_face, area, 0.0))
    a, b, c, d = frames.jacobians(x)  # from x: a hand-over leaves J behind
    fro, det = a * a + b * b + c * c + d * d, a * d - b * c
    with np.errstate(divide="ignore", invalid="ignore"):
        inv = fro / (det * det)
    out.island_parts = tuple(per_face.sum(np.where(live_face, area * t, 0.0)) for t in (fro, inv))
    out.folded = int((signed_double_areas(x, faces) <= 0).sum())
    out.seconds = time.perf_counter() - t0
    return out


def _go_on_alone(X, faces, x, islands: Islands, active, per_face: Islands, pinned, iterations, tol, state, area):
    """:func:`refine` for the ``active`` islands alone, from their layout in ``x`` and
    their part of the L-BFGS ``state`` (memory, gamma): their rows and faces, and a
    nested-dissection order and proxy of their own (the proxy's blocks are what they
    are in the whole, so the descent goes on as it would have). Returns their rows, the
    :class:`Refinement` and the 3D area of their faces."""
    rows, sub = islands.subset(active)
    index = np.full(len(X), -1, dtype=np.int64)
    index[rows] = np.arange(len(rows))
    f = per_face.members(active)
    F_sub = index[faces[f]]
    X_sub = np.take(X, rows, axis=0)
    order = nested_dissection(X_sub, unique_edges(F_sub))
    result = refine(
        X_sub,
        F_sub,
        x[rows],
        sub,
        None,
        iterations=iterations,
        tol=tol,
        arap=0,
        pinned=pinned[rows],
        order=order,
        carry=([(s_k[rows], y_k[rows], rho[active]) for s_k, y_k, rho in state[0]], state[1][active]),
    )
    return rows, result, float(area[f].sum())
