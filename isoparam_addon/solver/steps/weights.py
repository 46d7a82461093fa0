"""Step 2 of Sun & Hancock: minimum-norm affine reconstructing weights, Eqs. (6)-(11).

Eq. (11), ``W_i = Z_j (Z_j^T Z_j)^{-1} z_i`` with ``Z_j = [Y_Lj 1]``, has a short closed
form. Put the centre at the origin, let ``p`` be the neighbours' mean and ``Q_j = y_j - p``
their centred positions with scatter ``C = sum_j Q_j Q_j^T``. Then

    W_ij = 1/m - Q_j^T C^{-1} p,

which satisfies both constraints of Eq. (9) and lies in the row space of ``Z_j^T``, so it
is the minimum-norm solution. Only a 2x2 matrix is inverted per vertex, and the weights
are invariant to any affine map of the local coordinates.

Degenerate vertices
-------------------
``C`` is singular when the neighbours are collinear: always for a boundary vertex with
two neighbours, occasionally otherwise. Following the paper, such a vertex borrows one
more vertex k, a neighbour of a neighbour: the far corner of a face across one of its
fan's rim edges (j_t, j_t+1). We place k where the *local flattening* puts it, by
unfolding that face across the rim edge with its 3D edge lengths, on the side away from
the centre. On a developable mesh this is the true developed position, so the weights
stay exact. Where the next face beyond k exists, its far corner is borrowed as well (see
``_extra_vertex``: with k alone, a flap's rows repeat one another and M gains spurious
null vectors; measured on Suzanne's Smart UV Project islands, Step 3 then needed its 40
iterations and did not converge on 3 islands, against 6 iterations with both). A vertex
with no such face (an island of one triangle) falls back to Tikhonov-regularised
weights, which stay finite.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
import scipy.sparse as sp

from ..geometry import NEXT, PREV, TINY, det2
from .local import Patch

__all__ = ["Flagged", "reconstruction_weights"]


class Flagged(NamedTuple):
    """Vertices of Step 2 whose weights needed help, (k,) int64 each."""

    extra_vertex: np.ndarray  # borrowed a neighbour's neighbour (collinear neighbours)
    regularized: np.ndarray  # no face to borrow from: regularised weights


_DEGENERATE = 1e-10  # det(C) / (tr C / 2)^2 below this: neighbours (nearly) collinear


def _affine_weights(P: np.ndarray, reg: float = 0.0):
    """Minimum-norm affine weights reconstructing the origin from points P (G, m, 2).

    Returns ``(W (G, m), degenerate (G,) bool)``.
    """
    x, y = P[:, :, 0], P[:, :, 1]
    m = P.shape[1]
    scale = np.sqrt((x * x + y * y).mean(axis=1))
    inv = 1.0 / np.where(scale > 0, scale, 1.0)
    x, y = x * inv[:, None], y * inv[:, None]
    px, py = x.mean(axis=1), y.mean(axis=1)
    qx, qy = x - px[:, None], y - py[:, None]
    cxx = (qx * qx).sum(axis=1)
    cyy = (qy * qy).sum(axis=1)
    cxy = (qx * qy).sum(axis=1)
    half_trace = 0.5 * (cxx + cyy)
    det = det2(cxx, cxy, cxy, cyy)
    degenerate = ~(det > _DEGENERATE * half_trace**2)
    if reg:
        delta = reg * np.maximum(half_trace, TINY)
        cxx, cyy = cxx + delta, cyy + delta
        det = det2(cxx, cxy, cxy, cyy)
    # an unregularized degenerate row is replaced by the caller; a regularized one can
    # still be singular when all points coincide (C = 0): it gets uniform weights
    good = (det > 0) & ~(degenerate & (reg == 0))
    safe = np.where(good, det, 1.0)
    ux = np.where(good, (cyy * px - cxy * py) / safe, 0.0)  # u = C^{-1} p
    uy = np.where(good, (cxx * py - cxy * px) / safe, 0.0)
    W = 1.0 / m - (qx * ux[:, None] + qy * uy[:, None])
    return W, degenerate


def _unfold(X, Pa, Pb, P_away, ka, kb, k):
    """Position of vertex k beyond edge (ka, kb), placed in the plane by its 3D distances
    to ka and kb, on the side of the edge away from ``P_away``. All (r, 2) / (r,)."""
    base_vec = Pb - Pa
    base = np.linalg.norm(base_vec, axis=1)
    base = np.where(base > 0, base, 1.0)
    e = base_vec / base[:, None]
    nrm = np.stack([-e[:, 1], e[:, 0]], axis=1)
    la2 = ((X[k] - X[ka]) ** 2).sum(axis=1)
    lb2 = ((X[k] - X[kb]) ** 2).sum(axis=1)
    along = (la2 - lb2 + base**2) / (2 * base)
    height = np.sqrt(np.maximum(la2 - along**2, 0.0))
    side = np.where(((P_away - Pa) * nrm).sum(axis=1) > 0, -1.0, 1.0)
    return Pa + along[:, None] * e + (side * height)[:, None] * nrm


def _extra_vertex(X, faces, twin, patch: Patch, rows: np.ndarray):
    """The paper's extra vertices for degenerate centres ``patch.vertex[rows]``.

    The first is the far corner k1 of a face across a rim edge (j_t, j_t+1) of the fan.
    Alone it can leave two rows saying the same thing: on a *flap* (two triangles hanging
    off the mesh by one edge) the ear's row and its neighbour's row are then the one
    affine relation of the same four points, and L gains a spurious null vector (measured:
    8 of them on one Smart-UV-Project island of Suzanne). So a second vertex k2, the far
    corner of the next face across an edge (j, k1), joins when there is one. Both are
    unfolded into the centre's flattening with their 3D edge lengths, so a developable
    mesh stays exact.

    Returns ``(count (r,) int in {0, 1, 2}, k (r, 2) int64, y_k (r, 2, 2) float64)``.
    """
    C = patch.corners[rows]  # (r, K)
    Y = patch.coords[rows]  # (r, m+1, 2)
    nb = patch.neighbours[rows]
    m = nb.shape[1]
    flat = faces.ravel()
    rim = 3 * (C // 3) + NEXT[C % 3]  # half-edge j_t -> j_t+1 in face t
    tw = twin[rim]
    has = tw >= 0
    far = np.where(has, flat[3 * (tw // 3) + PREV[tw % 3]], -1)
    centre = patch.vertex[rows]
    known = (far[:, :, None] == nb[:, None, :]).any(axis=2) | (far == centre[:, None])
    ok_t = has & ~known
    ok = ok_t.any(axis=1)
    t = np.argmax(ok_t, axis=1)
    r = np.arange(len(rows))
    ka, kb = nb[r, t], nb[r, (t + 1) % m]
    k1 = far[r, t]
    Pa, Pb, P0 = Y[r, 1 + t], Y[r, 1 + (t + 1) % m], Y[r, 0]
    y1 = _unfold(X, Pa, Pb, P0, ka, kb, k1)
    # the next face: across (kb, k1) or (k1, ka) of face f1 = (kb, ka, k1) (twin of ka -> kb)
    t_he = tw[r, t]
    f1 = np.maximum(t_he, 0) // 3
    e_next = 3 * f1 + NEXT[np.maximum(t_he, 0) % 3]  # half-edge ka -> k1 ... in f1's order
    cand_he = np.stack([e_next, 3 * f1 + PREV[np.maximum(t_he, 0) % 3]], axis=1)  # the two other edges
    tw2 = twin[cand_he]
    far2 = np.where(tw2 >= 0, flat[3 * (np.maximum(tw2, 0) // 3) + PREV[np.maximum(tw2, 0) % 3]], -1)
    taken = (far2[:, :, None] == nb[:, None, :]).any(axis=2) | (far2 == centre[:, None]) | (far2 == k1[:, None])
    ok2_c = ok[:, None] & (tw2 >= 0) & ~taken
    ok2 = ok2_c.any(axis=1)
    c = np.argmax(ok2_c, axis=1)
    he = cand_he[r, c]
    u_from, u_to = flat[he], flat[3 * (he // 3) + NEXT[he % 3]]  # the shared edge of f1 and f2
    pos = {"a": Pa, "b": Pb, "k": y1}

    def where_is(v):  # the shared edge's ends are among ka, kb, k1
        return np.where((v == ka)[:, None], pos["a"], np.where((v == kb)[:, None], pos["b"], pos["k"]))

    third = flat[3 * (he // 3) + PREV[he % 3]]  # f1's corner off the shared edge
    y2 = _unfold(X, where_is(u_from), where_is(u_to), where_is(third), u_from, u_to, far2[r, c])
    count = ok.astype(np.int64) + (ok & ok2)
    k = np.stack([k1, far2[r, c]], axis=1)
    return count, k, np.stack([y1, y2], axis=1)


def reconstruction_weights(X, faces, twin, patches: list[Patch], n: int):
    """Assemble ``L = I - W`` from the local flattenings (Step 2).

    Parameters
    ----------
    X : (n, 3) float64
    faces : (m, 3) int64
        Oriented faces (needed to find the extra vertex of degenerate centres).
    twin : (3m,) int64
        Twin half-edge of each half-edge of ``faces`` (-1 on the boundary).
    patches : list of Patch
    n : int

    Returns
    -------
    L : (n, n) scipy.sparse.csr_matrix
        ``I - W``; every row sums to zero.
    flagged : Flagged
        The centres that borrowed a vertex, and those left with regularised weights.
    """
    rows, cols, vals = [np.arange(n)], [np.arange(n)], [np.ones(n)]

    def emit(centre, nb, W):
        rows.append(np.repeat(centre, nb.shape[1]))
        cols.append(nb.ravel())
        vals.append(-W.ravel())

    borrowed, regularized = [np.zeros(0, dtype=np.int64)], [np.zeros(0, dtype=np.int64)]
    for patch in patches:
        P = patch.coords[:, 1:] - patch.coords[:, :1]
        W, bad = _affine_weights(P)
        emit(patch.vertex[~bad], patch.neighbours[~bad], W[~bad])
        if not bad.any():
            continue
        idx = np.flatnonzero(bad)
        count, k, yk = _extra_vertex(X, faces, twin, patch, idx)
        rel = yk - patch.coords[idx, :1]
        for extra in (2, 1, 0):  # borrowed vertices: two, one or none
            sub = np.flatnonzero(count == extra)
            if not sub.size:
                continue
            P_aug = np.concatenate([P[idx[sub]], rel[sub, :extra]], axis=1)
            nb_aug = np.concatenate([patch.neighbours[idx[sub]], k[sub, :extra]], axis=1)
            W_aug, still = _affine_weights(P_aug)
            good = ~still if extra else np.zeros(len(sub), dtype=bool)
            emit(patch.vertex[idx[sub[good]]], nb_aug[good], W_aug[good])
            borrowed.append(patch.vertex[idx[sub[good]]])
            W_reg, _ = _affine_weights(P_aug[~good], reg=1e-8)
            emit(patch.vertex[idx[sub[~good]]], nb_aug[~good], W_reg)
            regularized.append(patch.vertex[idx[sub[~good]]])
    L = sp.csr_matrix((np.concatenate(vals), (np.concatenate(rows), np.concatenate(cols))), shape=(n, n))
    return L, Flagged(np.concatenate(borrowed), np.concatenate(regularized))
