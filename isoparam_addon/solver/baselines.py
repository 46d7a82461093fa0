"""Reference methods the paper compares against, for evaluation only.

* :func:`isomap`: Tenenbaum et al. (2000) on the mesh graph: Dijkstra geodesics along
  edges, then classical MDS of the full distance matrix (O(n^2) memory).
* :func:`floater`: Floater's mean-value parametrization (Floater 2003) with the boundary
  fixed on a circle by chord length; the paper cites it ([3]) as the fixed-boundary
  alternative.
* :func:`dense_paper`: Sun & Hancock's Steps 3-4 with the eigenvectors of M computed by
  a dense eigensolver: the reference our sparse Step 3 must match on small meshes.
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp
from scipy.sparse import csgraph
from scipy.sparse.linalg import splu

from .align import fit_rotation_scale
from .islands import Islands
from .local import local_flattening
from .mesh import HalfEdges, unique_edges
from .topology import build_topology
from .weights import reconstruction_weights

__all__ = ["isomap", "floater", "dense_paper", "reconstruction_matrix"]


def isomap(V: np.ndarray, F: np.ndarray) -> np.ndarray:
    """Isomap layout (n, 2) of a connected mesh, in mesh units."""
    E = unique_edges(np.asarray(F))
    w = np.linalg.norm(V[E[:, 0]] - V[E[:, 1]], axis=1)
    n = len(V)
    g = sp.coo_matrix((w, (E[:, 0], E[:, 1])), shape=(n, n)).tocsr()
    D = csgraph.shortest_path(g, method="D", directed=False)
    D2 = D * D
    B = -0.5 * (D2 - D2.mean(axis=0) - D2.mean(axis=1)[:, None] + D2.mean())
    lam, Q = np.linalg.eigh(B)
    return Q[:, -2:][:, ::-1] * np.sqrt(np.maximum(lam[-2:][::-1], 0.0))


def floater(V: np.ndarray, F: np.ndarray) -> np.ndarray:
    """Mean-value coordinates with the boundary on a circle (chord length), (n, 2).

    The mesh must be a topological disk.
    """
    F = np.asarray(F, dtype=np.int64)
    n = len(V)
    he = HalfEdges(F, n)
    bnd_e = he.edge_vertices[he.edge_count == 1]
    # walk the boundary loop in face order: boundary half-edges a -> b
    h = np.flatnonzero(he.twin < 0)
    a, b = F.ravel()[h], F[:, [1, 2, 0]].ravel()[h]
    nxt = np.full(n, -1, dtype=np.int64)
    nxt[a] = b
    loop = [int(a[0])]
    for _ in range(len(bnd_e) - 1):  # boundary length, evaluation code
        loop.append(int(nxt[loop[-1]]))
    loop = np.asarray(loop)
    seg = np.linalg.norm(V[np.roll(loop, -1)] - V[loop], axis=1)
    t = 2 * np.pi * np.concatenate([[0.0], np.cumsum(seg)[:-1]]) / seg.sum()
    uv = np.zeros((n, 2))
    uv[loop] = np.stack([np.cos(t), np.sin(t)], axis=1)
    # mean-value weights: w_ij = (tan(a1/2) + tan(a2/2)) / |x_i - x_j| over the faces at edge ij
    rows, cols, vals = [], [], []
    for k in range(3):  # the three corners of every face
        i, j, o = F[:, k], F[:, (k + 1) % 3], F[:, (k + 2) % 3]
        e1, e2 = V[j] - V[i], V[o] - V[i]
        n1, n2 = np.linalg.norm(e1, axis=1), np.linalg.norm(e2, axis=1)
        ang = np.arctan2(np.linalg.norm(np.cross(e1, e2), axis=1), (e1 * e2).sum(axis=1))
        tn = np.tan(ang / 2)
        rows += [i, i]
        cols += [j, o]
        vals += [tn / n1, tn / n2]
    W = sp.csr_matrix((np.concatenate(vals), (np.concatenate(rows), np.concatenate(cols))), shape=(n, n))
    interior = np.setdiff1d(np.arange(n), loop)
    Lm = sp.diags(np.asarray(W.sum(axis=1)).ravel()) - W
    A = Lm[interior][:, interior].tocsc()
    rhs = -(Lm[interior][:, loop] @ uv[loop])
    uv[interior] = splu(A).solve(np.ascontiguousarray(rhs))
    # scale to the mesh's area for comparisons in mesh units
    p = V[F]
    a3 = 0.5 * np.linalg.norm(np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0]), axis=1).sum()
    q = uv[F]
    a2 = 0.5 * np.abs(np.cross(q[:, 1] - q[:, 0], q[:, 2] - q[:, 0])).sum()
    return uv * np.sqrt(a3 / a2)


def reconstruction_matrix(V: np.ndarray, F: np.ndarray):
    """Steps 1-2 on a connected disk mesh: ``(L = I - W, X, faces)`` in our vertex order."""
    V, F, topo = build_topology(V, F)
    if topo.n_islands != 1 or topo.cut_islands.size:
        raise ValueError("reconstruction_matrix expects one disk-shaped island")
    X = V[topo.vertex_of]
    faces = topo.faces
    patches = local_flattening(X, faces, topo.fans)
    L, _ = reconstruction_weights(X, faces, topo.he.twin, patches, len(X))
    return L, X, faces, topo.vertex_of


def dense_paper(V: np.ndarray, F: np.ndarray):
    """The paper's parametrization with Step 3 done by dense ``eigh`` of M (small meshes).

    The constant vector is projected out of the eigenvectors (on a curved mesh dense
    ``eigh`` mixes it in at the level of its rounding error over the tiny gap).
    Returns ``(uv (n, 2) per input vertex, eigenvalues (3,))``.
    """
    L, X, faces, vertex_of = reconstruction_matrix(V, F)
    M = (L.T @ L).toarray()
    lam, Q = np.linalg.eigh(M)
    Y = Q[:, 1:3] - Q[:, 1:3].mean(axis=0)
    Y, _ = np.linalg.qr(Y)
    Y *= np.sqrt(len(X))
    edges = HalfEdges(faces, len(X)).edge_vertices
    length = np.linalg.norm(X[edges[:, 0]] - X[edges[:, 1]], axis=1)
    isl = Islands(np.zeros(len(X), dtype=np.int64), 1)
    Yf, _, _ = fit_rotation_scale(Y, edges, length, np.zeros(len(edges), dtype=np.int64), isl)
    uv = np.zeros((len(V), 2))
    uv[vertex_of] = Yf
    return uv, lam[:3]
