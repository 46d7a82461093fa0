"""Reference methods the paper compares against, for evaluation only.

* :func:`isomap`: Tenenbaum et al. (2000) on the mesh graph: Dijkstra geodesics along
  edges, then classical MDS of the full distance matrix (O(n^2) memory).
* :func:`floater`: Floater's mean-value parametrization (Floater 2003) with the boundary
  fixed on a circle by chord length (the solver's Tutte seed); the paper cites it ([3])
  as the fixed-boundary alternative.
* :func:`dense_paper`: Sun & Hancock's Steps 3-4 with the eigenvectors of M computed by
  a dense eigensolver: the reference our sparse Step 3 must match on small meshes.
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp
from scipy.sparse import csgraph

from isoparam_addon.solver.mesh.halfedges import HalfEdges, unique_edges
from isoparam_addon.solver.mesh.islands import Islands
from isoparam_addon.solver.mesh.topology import build_topology
from isoparam_addon.solver.refinement.per_face import FaceFrames
from isoparam_addon.solver.refinement.seeds import tutte
from isoparam_addon.solver.steps.align import fit_rotation_scale
from isoparam_addon.solver.steps.local import local_flattening
from isoparam_addon.solver.steps.weights import reconstruction_weights

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
    """Mean-value coordinates with the boundary on a circle (chord length), scaled to the
    mesh's area, (n, 2): the solver's Tutte seed
    (:func:`isoparam_addon.solver.refinement.seeds.tutte`) of the whole mesh, which must be
    one topological disk."""
    V, F, topo = build_topology(V, F)
    if topo.n_islands != 1 or topo.cut_islands.size:
        raise ValueError("floater expects one disk-shaped island")
    X = V[topo.vertex_of]
    islands = Islands(topo.vertex_island, 1)
    uv_split = tutte(X, topo.faces, topo.he.twin, islands, FaceFrames(X, topo.faces), np.array([True]))
    uv = np.zeros((len(V), 2))
    uv[topo.vertex_of] = uv_split
    return uv


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
