"""Fold-free starting layouts for islands whose four-step layout folds.

On a strongly curved island (a Smart UV Project island wrapping the back of Suzanne's
head folds 729 of its 1351 triangles) the two smallest eigenvectors of M describe a
folded sheet, and no barrier descent can repair a layout that starts folded. Such islands restart from

1. a *least-squares conformal map* (Levy et al. 2002) with two pinned vertices: free
   boundary, low distortion on near-developable islands, fold-free in practice though
   not by theorem; and where that folds too,
2. a *Tutte embedding* with mean-value weights (Floater 2003) and the boundary on a circle
   by chord length: fold-free by Tutte's and Floater's theorems, but far from isometric.

Both are scaled per island to the island's 3D area. Each solve covers only the chosen
islands' vertices, so its cost follows the islands that need it.
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp
from scipy.sparse.linalg import splu

from ..geometry import signed_double_areas
from ..mesh.islands import Islands

__all__ = ["lscm", "tutte"]


def _scale_to_area(uv, faces, islands: Islands, area3d, which):
    fi = islands.label[faces[:, 0]]
    a2 = np.bincount(fi, np.abs(signed_double_areas(uv, faces)) / 2, minlength=islands.n)
    a3 = np.bincount(fi, area3d, minlength=islands.n)
    s = np.where(which, np.sqrt(a3 / np.where(a2 > 0, a2, 1.0)), 1.0)
    return uv * s[islands.label][:, None]


def _solve_free(K, rhs, free, order=None):
    """Solve ``K[free][:, free] x = rhs[free]`` (K (n, n) real or complex, rhs (n, k)); zeros
    elsewhere.

    ``order`` (n,): a fill-reducing vertex order (Step 3's nested dissection); the free
    unknowns are eliminated in that order, and without it SuperLU orders them with
    COLAMD. Measured on Suzanne subdivided 4 times with Smart UV seams, the conformal map
    of its 11 folded islands (60k vertices, then solved as 2n real unknowns): 1.08 s with
    COLAMD against 0.77 s in this order (medians of 5; the same solution to 7e-9 relative).
    """
    out = np.zeros_like(rhs)
    if not free.size:
        return out
    if order is None:
        out[free] = splu(K[free][:, free].tocsc()).solve(np.ascontiguousarray(rhs[free]))
        return out
    rank = np.empty(len(order), dtype=np.int64)
    rank[order] = np.arange(len(order))
    free = free[np.argsort(rank[free], kind="stable")]
    A = K[free][:, free].tocsc()
    # threshold pivoting as in Step 3: a diagonal pivot is kept unless 100x below its column's largest
    out[free] = splu(A, permc_spec="NATURAL", diag_pivot_thresh=0.01).solve(np.ascontiguousarray(rhs[free]))
    return out


def lscm(X, faces, islands: Islands, frames, which: np.ndarray, order=None) -> np.ndarray:
    """Least-squares conformal map of the islands flagged in ``which`` (n_islands,) bool.

    Minimises ``sum_f A_f |grad u - rot90(grad v)|^2`` (the Cauchy-Riemann residual, whose
    solutions preserve orientation) with two vertices pinned per island: the extremes
    along the island's longest coordinate axis, at their 3D distance apart. Rows of other
    islands are zero. ``order`` (n,): a fill-reducing vertex order for the solve. Returns
    (n, 2).

    The residual ``(u_x - v_y, u_y + v_x)`` is ``(Dx + i Dy) z`` for ``z = u + i v``, so the
    normal equations are one Hermitian system in n complex unknowns rather than a real
    one in 2n: a quarter of the structural nonzeros for SuperLU, whose time follows its
    symbolic work more than its arithmetic: about half the time of the real system, for
    the same map to rounding.
    """
    n = len(X)
    sel_v = which[islands.label]
    sel_f = np.flatnonzero(which[islands.label[faces[:, 0]]])
    # pins: rows are sorted by island, so per-island extremes are reduceat / sorted runs
    starts = islands.start[:-1]
    extent = np.maximum.reduceat(X, starts, axis=0) - np.minimum.reduceat(X, starts, axis=0)
    axis = np.argmax(extent, axis=1)
    coord = X[np.arange(n), axis[islands.label]]
    along = np.lexsort((coord, islands.label))
    pin_a, pin_b = along[starts], along[islands.start[1:] - 1]
    pin_a, pin_b = pin_a[which], pin_b[which]
    z = np.zeros(n, dtype=np.complex128)  # u + i v
    z[pin_b] = np.linalg.norm(X[pin_b] - X[pin_a], axis=1)
    w = sp.diags(np.sqrt(frames.area[sel_f]))
    A = (w @ frames.Dx[sel_f] + 1j * (w @ frames.Dy[sel_f])).tocsr()  # (Dx + i Dy) z, per face
    K = (A.conj().T @ A).tocsr()
    pinned = np.zeros(n, dtype=bool)
    pinned[pin_a] = pinned[pin_b] = True
    fixed = np.concatenate([pin_a, pin_b])
    rhs = -(K[:, fixed] @ z[fixed])
    z = z + _solve_free(K, rhs[:, None], np.flatnonzero(sel_v & ~pinned), order)[:, 0]
    uv = np.stack([z.real, z.imag], axis=1)
    return _scale_to_area(uv, faces, islands, frames.area, which)


def tutte(X, faces, he_twin, islands: Islands, frames, which: np.ndarray, order=None) -> np.ndarray:
    """Mean-value Tutte embedding of the islands flagged in ``which``, boundary on a
    circle by chord length. Each island must have one boundary loop. ``order`` (n,): a
    fill-reducing vertex order for the solve. Returns (n, 2)."""
    n = len(X)
    sel_v = which[islands.label]
    # boundary loops: half-edge a -> b on the boundary; each island has one loop
    h = np.flatnonzero(he_twin < 0)
    flat = faces.ravel()
    a, b = flat[h], faces[:, [1, 2, 0]].ravel()[h]
    nxt = np.full(n, -1, dtype=np.int64)
    nxt[a] = b
    on_loop = np.zeros(n, dtype=bool)
    on_loop[a] = True
    # rank each loop's vertices by pointer jumping (list ranking) from its lowest vertex
    start = np.full(islands.n, n, dtype=np.int64)
    np.minimum.at(start, islands.label[a], a)
    prev = np.full(n, -1, dtype=np.int64)
    prev[b] = a
    dist = on_loop.astype(np.int64)
    pp = np.where(on_loop, prev, -1)
    dist[start] = 0
    pp[start] = -1
    while np.any(pp >= 0):  # log2(loop length) rounds
        live = pp >= 0
        dist = np.where(live, dist + dist[np.maximum(pp, 0)], dist)
        pp = np.where(live, pp[np.maximum(pp, 0)], -1)
    # chord-length parameter along the loop, each step at least 1e-3 of the loop's mean:
    # coincident boundary vertices (a face collapsed to a point, found by fuzzing) took
    # one point of the circle, and the faces between them no area
    chord = np.linalg.norm(X[b] - X[a], axis=1)  # from a to its successor
    count = np.bincount(islands.label[a], minlength=islands.n)
    mean = np.bincount(islands.label[a], chord, minlength=islands.n) / np.maximum(count, 1)
    seg = np.zeros(n)
    seg[a] = np.maximum(chord, np.where(mean > 0, 1e-3 * mean, 1.0)[islands.label[a]])
    loop_vertices = np.flatnonzero(on_loop)
    loop = loop_vertices[np.lexsort((dist[loop_vertices], islands.label[loop_vertices]))]
    isl = islands.label[loop]
    cum = np.cumsum(seg[loop])
    first = np.searchsorted(isl, np.arange(islands.n))
    offset = np.concatenate([[0.0], cum])[first]
    total = np.bincount(isl, seg[loop], minlength=islands.n)
    s_before = np.concatenate([[0.0], cum[:-1]]) - offset[isl]
    angle = 2 * np.pi * s_before / np.where(total[isl] > 0, total[isl], 1.0)
    uv = np.zeros((n, 2))
    uv[loop, 0], uv[loop, 1] = np.cos(angle), np.sin(angle)
    # mean-value weights w_ij = (tan(a1/2) + tan(a2/2)) / |x_i - x_j|, all positive and
    # bounded: coincident vertices (a zero-length edge, no angle) took 1e-300 lengths and
    # gave weights of 1e287 beside ones of 1, and SuperLU "Factor is exactly singular"
    # (found by fuzzing); such an edge now weighs about as much as a normal one
    rows, cols, vals = [], [], []
    P = X[faces]
    size = float(np.abs(P).max(initial=0.0)) or 1.0
    for k in range(3):  # the three corners of every face
        i, o = faces[:, k], faces[:, (k + 2) % 3]
        j = faces[:, (k + 1) % 3]
        e1, e2 = P[:, (k + 1) % 3] - P[:, k], P[:, (k + 2) % 3] - P[:, k]
        n1 = np.maximum(np.linalg.norm(e1, axis=1), 1e-6 * size)
        n2 = np.maximum(np.linalg.norm(e2, axis=1), 1e-6 * size)
        # (the angle as :func:`.geometry.triangle_angles` gives it up to rounding; computed
        # here from this corner's own edges, which the Tutte starts were tuned with: the
        # shared-normal form moves charting's rounding-sensitive choices, e.g. peaks)
        ang = np.arctan2(np.linalg.norm(np.cross(e1, e2), axis=1), (e1 * e2).sum(axis=1))
        tn = np.tan(np.clip(ang, 1e-6, np.pi - 1e-6) / 2)
        rows += [i, i]
        cols += [j, o]
        vals += [tn / n1, tn / n2]
    Wm = sp.csr_matrix((np.concatenate(vals), (np.concatenate(rows), np.concatenate(cols))), shape=(n, n))
    Lm = (sp.diags(np.asarray(Wm.sum(axis=1)).ravel()) - Wm).tocsr()
    fixed = np.flatnonzero(on_loop)
    rhs = -(Lm[:, fixed] @ uv[fixed])
    uv = uv + _solve_free(Lm, rhs, np.flatnonzero(sel_v & ~on_loop), order)
    uv[~sel_v] = 0.0
    return _scale_to_area(uv, faces, islands, frames.area, which)
