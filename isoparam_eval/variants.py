"""Mesh variants for property and fuzz tests: shapes of any genus, and the ways real meshes
differ from clean ones (holes, noise, renumbering, copies, coarse clustering, quads).

Every function takes and returns plain arrays, ``V (n, 3) float64`` and ``F (m, 3) int64``,
and draws its randomness from the ``numpy.random.Generator`` it is given.
"""

from __future__ import annotations

import numpy as np

__all__ = [
    "cluster",
    "copies",
    "edge_flips",
    "noisy",
    "punched",
    "renumbered",
    "voxel_blob",
    "voxels",
]

# the four corners of a voxel's face across each axis, counter-clockwise seen from outside
# the + side (offsets of the unit cube's corners)
_QUAD = {
    0: np.array([[1, 0, 0], [1, 1, 0], [1, 1, 1], [1, 0, 1]]),
    1: np.array([[0, 1, 0], [0, 1, 1], [1, 1, 1], [1, 1, 0]]),
    2: np.array([[0, 0, 1], [1, 0, 1], [1, 1, 1], [0, 1, 1]]),
}


def voxels(occupied: np.ndarray, quads: bool = False):
    """The closed surface of a union of unit voxels, ``occupied`` (a, b, c) bool: every side
    between a full and an empty voxel is a square of two triangles, facing out.

    Its genus is the voxel set's (a plate with two holes through it: 2); voxels that touch
    along an edge or at a corner only give non-manifold edges or vertices, as coarse real
    meshes do. Returns ``(V, F)``, or with ``quads`` also the squares' diagonals (k, 2).
    """
    full = np.pad(np.asarray(occupied, dtype=bool), 1)
    corners: list[np.ndarray] = []
    triangles: list[np.ndarray] = []
    diagonals: list[np.ndarray] = []
    for axis in range(3):
        step = np.roll(full, -1, axis=axis)
        for outwards in (True, False):  # from full to empty along +axis, or the reverse
            at = np.argwhere(full & ~step if outwards else ~full & step)
            quad = _QUAD[axis] if outwards else _QUAD[axis][::-1]
            base = int(sum(len(c) for c in corners))
            corners.append((at[:, None, :] + quad[None]).reshape(-1, 3))
            k = base + 4 * np.arange(len(at))[:, None]
            triangles.append(np.concatenate([k + [0, 1, 2], k + [0, 2, 3]]))
            diagonals.append(np.concatenate([k + [0], k + [2]], axis=1))
    P = np.concatenate(corners).astype(np.float64)
    _, first, weld = np.unique(P, axis=0, return_index=True, return_inverse=True)
    weld = weld.ravel()
    V, F = P[first], weld[np.concatenate(triangles)]
    return (V, F, weld[np.concatenate(diagonals)]) if quads else (V, F)


def voxel_blob(rng: np.random.Generator, size: int = 4, fill: float = 0.6) -> np.ndarray:
    """A random voxel set (size, size, size) bool: each voxel full with probability
    ``fill``, and never empty (one voxel at least)."""
    occupied = rng.random((size, size, size)) < fill
    occupied.flat[rng.integers(occupied.size)] = True
    return occupied


def punched(V: np.ndarray, F: np.ndarray, rng: np.random.Generator, holes: int = 3, rings: int = 1):
    """``F`` less ``holes`` holes: the faces within ``rings`` rings of random vertices.
    Unused vertices are kept (the solver ignores them)."""
    around = rng.choice(len(V), size=min(holes, len(V)), replace=False)
    gone = np.zeros(len(V), dtype=bool)
    gone[around] = True
    for _ in range(rings - 1):  # grow the set by one ring of vertices
        gone[F[gone[F].any(axis=1)].ravel()] = True
    keep = ~gone[F].any(axis=1)
    if not keep.any():
        keep[0] = True
    return V, F[keep]


def noisy(V: np.ndarray, F: np.ndarray, rng: np.random.Generator, scale: float = 0.1):
    """``V`` moved at random by up to ``scale`` times the mean edge length along each axis."""
    e = np.concatenate([F[:, [0, 1]], F[:, [1, 2]], F[:, [2, 0]]])
    mean = float(np.linalg.norm(V[e[:, 0]] - V[e[:, 1]], axis=1).mean())
    return V + rng.uniform(-scale * mean, scale * mean, V.shape), F


def renumbered(V: np.ndarray, F: np.ndarray, rng: np.random.Generator):
    """The same mesh with its vertices and faces in a random order, each face's corners
    turned by a random amount (orientation kept)."""
    p = rng.permutation(len(V))
    new = np.empty_like(p)
    new[p] = np.arange(len(p))
    G = new[F][rng.permutation(len(F))]
    turn = rng.integers(3, size=len(G))
    rows = np.arange(len(G))[:, None]
    return V[p], G[rows, (np.arange(3) + turn[:, None]) % 3]


def copies(V: np.ndarray, F: np.ndarray, count: int = 2):
    """``count`` copies of the mesh side by side (one part each)."""
    width = float(np.ptp(V[:, 0])) * 1.5 + 1.0
    Vs = [V + [k * width, 0.0, 0.0] for k in range(count)]
    Fs = [F + k * len(V) for k in range(count)]
    return np.concatenate(Vs), np.concatenate(Fs)


def cluster(V: np.ndarray, F: np.ndarray, cell: float):
    """Vertex clustering (a coarse decimation, as scan pipelines do): vertices in the same
    cube of side ``cell`` merge at their mean; faces that lose a corner go. What is left
    can hold edges of three faces, bow-ties and faces given twice."""
    key = np.floor(V / cell).astype(np.int64)
    _, label = np.unique(key, axis=0, return_inverse=True)
    label = label.ravel()
    count = np.bincount(label)
    W = np.stack([np.bincount(label, V[:, k]) for k in range(3)], axis=1) / count[:, None]
    G = label[F]
    keep = (G[:, 0] != G[:, 1]) & (G[:, 1] != G[:, 2]) & (G[:, 2] != G[:, 0])
    return W, G[keep]


def edge_flips(V: np.ndarray, F: np.ndarray, rng: np.random.Generator, share: float = 0.3):
    """``F`` with about ``share`` of its faces' edges flipped (an irregular remeshing of
    the same surface: slivers, high and low valences). Each face takes part in one flip
    at most: every face picks one of its interior edges at random, and an edge whose two
    faces picked it is flipped, unless its flip would repeat an edge."""
    F = np.asarray(F, dtype=np.int64).copy()
    m = len(F)
    a, b = F.ravel(), F[:, [1, 2, 0]].ravel()
    key = np.minimum(a, b) * len(V) + np.maximum(a, b)
    order = np.argsort(key, kind="stable")
    ks = key[order]
    twin = np.full(3 * m, -1, dtype=np.int64)
    pair = np.flatnonzero(ks[1:] == ks[:-1])
    lone = np.ones(len(pair), dtype=bool)  # edges of exactly two faces
    lone[1:] &= pair[1:] != pair[:-1] + 1
    lone[:-1] &= pair[:-1] + 1 != pair[1:]
    pair = pair[lone]
    twin[order[pair]], twin[order[pair + 1]] = order[pair + 1], order[pair]
    priority = np.where(twin >= 0, rng.random(3 * m), np.inf).reshape(m, 3)
    pick = 3 * np.arange(m) + np.argmin(priority, axis=1)
    pick = pick[np.isfinite(priority.min(axis=1)) & (rng.random(m) < share)]
    chosen = np.zeros(3 * m, dtype=bool)
    chosen[pick] = True
    h = pick[chosen[twin[pick]] & (pick < twin[pick])]  # both faces picked this edge
    t = twin[h]
    f, g = h // 3, t // 3
    ea, eb = F.ravel()[h], F.ravel()[3 * f + (h % 3 + 1) % 3]  # h runs ea -> eb
    c = F.ravel()[3 * f + (h % 3 + 2) % 3]  # opposite ea -> eb in f
    d = F.ravel()[3 * g + (t % 3 + 2) % 3]  # opposite in g
    new_key = np.minimum(c, d) * len(V) + np.maximum(c, d)
    uniq, count = np.unique(new_key, return_counts=True)
    ok = (c != d) & ~np.isin(new_key, key) & ~np.isin(new_key, uniq[count > 1])  # (two flips to one edge)
    f, g, ea, eb, c, d = f[ok], g[ok], ea[ok], eb[ok], c[ok], d[ok]
    F[f] = np.stack([c, ea, d], axis=1)  # (ea, eb, c) and (eb, ea, d) become two faces across c-d
    F[g] = np.stack([d, eb, c], axis=1)
    return V, F
