"""Meshes for tests, benchmarks and the demo: the paper's test surfaces, exactly
developable meshes, OBJ files, and the real meshes of ``../shared/meshes``.

Every generator returns ``(V (n, 3) float64, F (m, 3) int64)``; the developable ones
also return their exact planar development ``U (n, 2)``. All randomness is seeded.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
from scipy.spatial import Delaunay

__all__ = [
    "grid_faces",
    "peaks",
    "s_surface",
    "s_surface_random",
    "plane_random",
    "cylinder_strips",
    "cone_strips",
    "saddle",
    "spherical_cap",
    "sphere",
    "sphere_band",
    "torus",
    "annulus",
    "box",
    "load_obj",
    "real_mesh",
    "suzanne_closed",
    "REAL",
    "SPOT",
    "SHARED",
]


def grid_faces(nu: int, nv: int) -> np.ndarray:
    """Two triangles per cell of an ``nu x nv`` vertex grid (row-major, u fastest)."""
    i, j = np.meshgrid(np.arange(nu - 1), np.arange(nv - 1), indexing="xy")
    a = (j * nu + i).ravel()
    b, c, d = a + 1, a + nu, a + nu + 1
    return np.concatenate([np.stack([a, b, d], 1), np.stack([a, d, c], 1)]).astype(np.int64)


def peaks(n: int = 41, z_scale: float = 1.0 / 3.0):
    """MATLAB's ``peaks`` on an n x n grid over [-3, 3]^2, z scaled (the paper uses 1/3).

    With n = 41: 1681 vertices and 4880 edges, as in the paper's Section 6.
    """
    x, y = np.meshgrid(np.linspace(-3, 3, n), np.linspace(-3, 3, n), indexing="xy")
    z = (
        3 * (1 - x) ** 2 * np.exp(-(x**2) - (y + 1) ** 2)
        - 10 * (x / 5 - x**3 - y**5) * np.exp(-(x**2) - y**2)
        - 1 / 3 * np.exp(-((x + 1) ** 2) - y**2)
    )
    V = np.stack([x.ravel(), y.ravel(), z_scale * z.ravel()], axis=1)
    return V, grid_faces(n, n)


def _s_map(t: np.ndarray, w: np.ndarray) -> np.ndarray:
    """The S-shaped manifold of Saul & Roweis, parametrised by arc length t and width w."""
    return np.stack([np.sin(t), w, np.sign(t) * (np.cos(t) - 1)], axis=1)


_S_T = 1.5 * np.pi  # t in [-3pi/2, 3pi/2]: arc length 3 pi
_S_W = 5.0  # the height of Roweis & Saul's scurve.m (sklearn's make_s_curve uses 2)


def s_surface(nt: int = 50, nw: int = 12):
    """Regular S-surface: an ``nt x nw`` grid in (arc length, width), 600 vertices by default.

    The grid cells are planar rectangles in 3D, so the mesh is exactly developable; its
    development U unrolls the polygonal profile (chord lengths along t, width along w).
    Returns ``(V, F, U)``.
    """
    t, w = np.meshgrid(np.linspace(-_S_T, _S_T, nt), np.linspace(0, _S_W, nw), indexing="xy")
    V = _s_map(t.ravel(), w.ravel())
    # the development unrolls the polygonal profile: chord lengths, not arc lengths
    profile = _s_map(t[0], np.zeros(nt))
    s = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(profile, axis=0), axis=1))])
    U = np.stack([np.tile(s, nw), w.ravel()], axis=1)
    return V, grid_faces(nt, nw), U


def s_surface_random(n: int = 600, seed: int = 0):
    """S-surface sampled uniformly at random, Delaunay-triangulated in its parameter plane.

    Not exactly developable (triangles spanning three arc-length values bend the
    surface slightly), and the hull of a random Delaunay triangulation has slivers.
    Returns ``(V, F, U)`` with U the parameter-plane positions.
    """
    rng = np.random.default_rng(seed)
    U = np.stack([rng.uniform(-_S_T, _S_T, n), rng.uniform(0, _S_W, n)], axis=1)
    F = Delaunay(U).simplices.astype(np.int64)
    F = _ccw(U, F)
    return _s_map(U[:, 0], U[:, 1]), F, U


def _ccw(U, F):
    a, b, c = U[F[:, 0]], U[F[:, 1]], U[F[:, 2]]
    cw = (b[:, 0] - a[:, 0]) * (c[:, 1] - a[:, 1]) - (b[:, 1] - a[:, 1]) * (c[:, 0] - a[:, 0]) < 0
    F = F.copy()
    F[cw] = F[cw][:, [0, 2, 1]]
    return F


def plane_random(n: int = 500, seed: int = 0):
    """A random Delaunay triangulation of the unit square, rigidly moved into 3D.

    Returns ``(V, F, U)``.
    """
    rng = np.random.default_rng(seed)
    U = rng.uniform(0, 1, (n, 2))
    F = _ccw(U, Delaunay(U).simplices.astype(np.int64))
    q, _ = np.linalg.qr(rng.standard_normal((3, 3)))
    V = np.column_stack([U, np.zeros(n)]) @ q.T + rng.standard_normal(3)
    return V, F, U


def _ladder(h0: np.ndarray, h1: np.ndarray, base0: int, base1: int) -> np.ndarray:
    """Triangulate the strip between two sorted chains of heights (indices offset)."""
    n0, n1 = len(h0), len(h1)
    # merge the two chains by height; each step advances one chain and emits a triangle
    key = np.concatenate([h0[1:], h1[1:]])
    side = np.concatenate([np.zeros(n0 - 1, dtype=np.int64), np.ones(n1 - 1, dtype=np.int64)])
    order = np.lexsort((side, key))
    side = side[order]
    i0 = np.concatenate([[0], np.cumsum(side == 0)])
    i1 = np.concatenate([[0], np.cumsum(side == 1)])
    a0, a1 = base0 + i0[:-1], base1 + i1[:-1]
    tri = np.where(
        (side == 0)[:, None],
        np.stack([a0, a0 + 1, a1], 1),
        np.stack([a0, a1 + 1, a1], 1),
    )
    return tri


def _strips(profile3d, ruling_dir, heights_list, offset_list=None):
    """Planar strips between consecutive rulings: an exactly developable mesh."""
    n_r = len(heights_list)
    sizes = np.array([len(h) for h in heights_list])
    base = np.concatenate([[0], np.cumsum(sizes)])
    V = np.concatenate(
        [profile3d[k] + np.outer(heights_list[k], ruling_dir[k]) for k in range(n_r)]
    )  # one block per ruling (tens of rulings), not per vertex
    F = np.concatenate([_ladder(heights_list[k], heights_list[k + 1], base[k], base[k + 1]) for k in range(n_r - 1)])
    return V, F.astype(np.int64)


def cylinder_strips(
    n_rulings: int = 40,
    per_ruling: tuple = (8, 20),
    radius: float = 1.0,
    angle: float = 1.5 * np.pi,
    height: float = 2.0,
    seed: int = 0,
):
    """An irregular, exactly developable piece of a prism (a cylinder made of planar strips).

    Rulings stand at random angles, with a random number of vertices at random heights
    on each; consecutive rulings are joined by a ladder triangulation, so every triangle
    lies in the plane of its strip. Returns ``(V, F, U)`` with the exact development U.
    """
    rng = np.random.default_rng(seed)
    th = np.sort(np.concatenate([[0.0, angle], rng.uniform(0, angle, n_rulings - 2)]))
    heights = [
        np.sort(np.concatenate([[0.0, height], rng.uniform(0, height, rng.integers(*per_ruling) - 2)]))
        for _ in range(n_rulings)
    ]  # one array per ruling
    prof = np.stack([radius * np.cos(th), radius * np.sin(th), np.zeros(n_rulings)], 1)
    V, F = _strips(prof, np.tile([0.0, 0.0, 1.0], (n_rulings, 1)), heights)
    chord = np.linalg.norm(np.diff(prof, axis=0), axis=1)
    s = np.concatenate([[0.0], np.cumsum(chord)])
    U = np.concatenate([np.column_stack([np.full(len(h), s[k]), h]) for k, h in enumerate(heights)])
    return V, _ccw(U, F), U


def cone_strips(
    n_rulings: int = 40,
    per_ruling: tuple = (8, 20),
    r0: float = 0.5,
    r1: float = 2.0,
    half_angle: float = 0.5,
    sweep: float = 1.5 * np.pi,
    seed: int = 0,
):
    """An irregular, exactly developable cone frustum piece (planar strips through the apex).

    Returns ``(V, F, U)`` with the exact development U.
    """
    rng = np.random.default_rng(seed)
    th = np.sort(np.concatenate([[0.0, sweep], rng.uniform(0, sweep, n_rulings - 2)]))
    radii = [
        np.sort(np.concatenate([[r0, r1], rng.uniform(r0, r1, rng.integers(*per_ruling) - 2)]))
        for _ in range(n_rulings)
    ]  # one array per ruling
    d = np.stack(
        [np.sin(half_angle) * np.cos(th), np.sin(half_angle) * np.sin(th), np.full(n_rulings, np.cos(half_angle))], 1
    )
    V, F = _strips(np.zeros((n_rulings, 3)), d, radii)
    # development: angle between consecutive rulings, accumulated
    gap = np.arccos(np.clip((d[1:] * d[:-1]).sum(axis=1), -1, 1))
    phi = np.concatenate([[0.0], np.cumsum(gap)])
    U = np.concatenate([np.column_stack([r * np.cos(phi[k]), r * np.sin(phi[k])]) for k, r in enumerate(radii)])
    return V, _ccw(U, F), U


def saddle(n: int = 41, k: float = 0.5):
    """The hyperbolic paraboloid ``z = k (x^2 - y^2)`` on a grid over [-1, 1]^2."""
    x, y = np.meshgrid(np.linspace(-1, 1, n), np.linspace(-1, 1, n), indexing="xy")
    V = np.stack([x.ravel(), y.ravel(), k * (x**2 - y**2).ravel()], axis=1)
    return V, grid_faces(n, n)


def spherical_cap(n: int = 40, max_polar: float = np.pi / 3, radius: float = 1.0):
    """A spherical cap (positive curvature) from a polar grid of n rings, apex at the pole."""
    rings = []
    for k in range(1, n + 1):  # one ring per latitude (n rings)
        m = 6 * k
        phi = np.arange(m) * 2 * np.pi / m
        rings.append(np.stack([np.full(m, k * max_polar / n), phi], 1))
    P = np.concatenate([np.zeros((1, 2))] + rings)
    U = np.column_stack([P[:, 0] * np.cos(P[:, 1]), P[:, 0] * np.sin(P[:, 1])])
    F = _ccw(U, Delaunay(U).simplices.astype(np.int64))
    th, ph = P[:, 0], P[:, 1]
    V = radius * np.stack([np.sin(th) * np.cos(ph), np.sin(th) * np.sin(ph), np.cos(th)], 1)
    return V, F


def sphere(subdivisions: int = 3):
    """A closed icosphere (genus 0, no boundary)."""
    t = (1 + 5**0.5) / 2
    V = np.array(
        [
            [-1, t, 0],
            [1, t, 0],
            [-1, -t, 0],
            [1, -t, 0],
            [0, -1, t],
            [0, 1, t],
            [0, -1, -t],
            [0, 1, -t],
            [t, 0, -1],
            [t, 0, 1],
            [-t, 0, -1],
            [-t, 0, 1],
        ],
        dtype=np.float64,
    )
    F = np.array(
        [
            [0, 11, 5],
            [0, 5, 1],
            [0, 1, 7],
            [0, 7, 10],
            [0, 10, 11],
            [1, 5, 9],
            [5, 11, 4],
            [11, 10, 2],
            [10, 7, 6],
            [7, 1, 8],
            [3, 9, 4],
            [3, 4, 2],
            [3, 2, 6],
            [3, 6, 8],
            [3, 8, 9],
            [4, 9, 5],
            [2, 4, 11],
            [6, 2, 10],
            [8, 6, 7],
            [9, 8, 1],
        ],
        dtype=np.int64,
    )
    for _ in range(subdivisions):  # a few rounds of 4-to-1 subdivision
        e = np.sort(np.concatenate([F[:, [0, 1]], F[:, [1, 2]], F[:, [2, 0]]]), axis=1)
        uniq, inv = np.unique(e, axis=0, return_inverse=True)
        mid = len(V) + inv.reshape(3, -1).T
        V = np.concatenate([V, 0.5 * (V[uniq[:, 0]] + V[uniq[:, 1]])])
        a, b, c = F.T
        ab, bc, ca = mid.T
        F = np.concatenate([np.stack(x, 1) for x in ((a, ab, ca), (b, bc, ab), (c, ca, bc), (ab, bc, ca))])
    V /= np.linalg.norm(V, axis=1, keepdims=True)
    return V, F


def sphere_band(subdivisions: int = 4, half_width: float = 0.3, gap: float = 0.2):
    """A band around the unit icosphere's equator (face centroids with |z| < half_width),
    opened into a disk by dropping the faces near +x with |y| < gap.

    Strongly curved and long: its four-step layout folds (measured: 725 of 1,497
    triangles at the defaults), the case the refinement's conformal restart is for.
    """
    V, F = sphere(subdivisions)
    c = V[F].mean(axis=1)
    keep = (np.abs(c[:, 2]) < half_width) & ~((c[:, 0] > 0) & (np.abs(c[:, 1]) < gap))
    used, inv = np.unique(F[keep], return_inverse=True)
    return V[used], inv.reshape(-1, 3).astype(np.int64)


def torus(nu: int = 40, nv: int = 16, R: float = 2.0, r: float = 0.6):
    """A closed torus (genus 1) on a periodic grid."""
    u, v = np.meshgrid(np.arange(nu) * 2 * np.pi / nu, np.arange(nv) * 2 * np.pi / nv, indexing="xy")
    V = np.stack([(R + r * np.cos(v)) * np.cos(u), (R + r * np.cos(v)) * np.sin(u), r * np.sin(v)], -1)
    i, j = np.meshgrid(np.arange(nu), np.arange(nv), indexing="xy")
    a = j * nu + i
    b = j * nu + (i + 1) % nu
    c = ((j + 1) % nv) * nu + i
    d = ((j + 1) % nv) * nu + (i + 1) % nu
    F = np.concatenate([np.stack([a.ravel(), b.ravel(), d.ravel()], 1), np.stack([a.ravel(), d.ravel(), c.ravel()], 1)])
    return V.reshape(-1, 3), F.astype(np.int64)


def annulus(n_radial: int = 8, n_around: int = 48, r0: float = 0.5, r1: float = 1.5):
    """A flat annulus (two boundary loops), developable but not a disk."""
    r, a = np.meshgrid(np.linspace(r0, r1, n_radial), np.arange(n_around) * 2 * np.pi / n_around, indexing="ij")
    V = np.stack([r * np.cos(a), r * np.sin(a), np.zeros_like(r)], -1).reshape(-1, 3)
    i, j = np.meshgrid(np.arange(n_radial - 1), np.arange(n_around), indexing="ij")
    p = i * n_around + j
    q = i * n_around + (j + 1) % n_around
    s, t = p + n_around, q + n_around
    F = np.concatenate([np.stack([p.ravel(), q.ravel(), t.ravel()], 1), np.stack([p.ravel(), t.ravel(), s.ravel()], 1)])
    return V, F.astype(np.int64)


def box(k: int = 8):
    """The closed surface of the cube [-1, 1]^3 with k x k quads per side, each split along
    its diagonal from its first corner; also returns those diagonals (d, 2).

    Developable except at its eight corners, so a layout cut open only by a short path
    squeezes the faces around the corners; one cut per corner makes it nearly exact.
    """
    g = np.linspace(-1.0, 1.0, k + 1)
    u, v = (c.ravel() for c in np.meshgrid(g, g, indexing="ij"))
    idx = np.arange((k + 1) ** 2).reshape(k + 1, k + 1)
    a, b, c, d = idx[:-1, :-1].ravel(), idx[1:, :-1].ravel(), idx[1:, 1:].ravel(), idx[:-1, 1:].ravel()
    quad = np.concatenate([np.stack([a, b, c], 1), np.stack([a, c, d], 1)])
    sides: list[np.ndarray] = []
    Fs, D = [], []
    for axis in range(3):
        rest = [x for x in range(3) if x != axis]
        for sign in (-1.0, 1.0):  # the six sides, faces turned outwards
            pts = np.zeros((len(u), 3))
            pts[:, axis], pts[:, rest[0]], pts[:, rest[1]] = sign, u, v
            base = sum(len(p) for p in sides)
            outwards = (sign > 0) == (axis != 1)  # (rest[0], rest[1]) x-products to +/-axis
            Fs.append(base + (quad if outwards else quad[:, ::-1]))
            D.append(base + np.stack([a, c], 1))
            sides.append(pts)
    P = np.concatenate(sides)
    _, first, weld = np.unique(np.round(P * 1e9).astype(np.int64), axis=0, return_index=True, return_inverse=True)
    weld = weld.ravel()
    return P[first], weld[np.concatenate(Fs)], weld[np.concatenate(D)]


def load_obj(path) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """A Wavefront OBJ file as ``(V (n, 3) float64, F (m, 3) int64, seams (k, 2) int64)``.

    Polygons are split into triangle fans. ``seams`` are the vertex pairs of the edges
    across which the file's texture coordinates (``vt``) differ, i.e. the seams of its
    UV map (none when it has no ``vt``). Lines are grouped by their number of corners
    and parsed a group at a time.
    """
    from isoparam_addon.solver.mesh.halfedges import HalfEdges

    text = open(path, encoding="utf-8", errors="replace").read()
    lines = text.splitlines()
    vert = [ln.split()[1:4] for ln in lines if ln.startswith("v ")]
    V = np.array(vert, dtype=np.float64).reshape(-1, 3)
    face_lines = [ln.split()[1:] for ln in lines if ln.startswith("f ")]
    counts = np.array([len(f) for f in face_lines], dtype=np.int64)
    F_parts, T_parts, order = [], [], []
    for k in np.unique(counts):  # one group per polygon size
        rows = np.flatnonzero(counts == k)
        tokens = [t.split("/") for r in rows for t in face_lines[r]]
        v = np.array([int(t[0]) for t in tokens], dtype=np.int64).reshape(len(rows), k)
        vt = np.array([int(t[1]) if len(t) > 1 and t[1] else 0 for t in tokens], dtype=np.int64).reshape(len(rows), k)
        fan = np.stack([np.zeros(k - 2, dtype=np.int64), np.arange(1, k - 1), np.arange(2, k)], axis=1)
        F_parts.append(v[:, fan].reshape(-1, 3))
        T_parts.append(vt[:, fan].reshape(-1, 3))
        order.append(np.repeat(rows, k - 2) * 64 + np.tile(np.arange(k - 2), len(rows)))
    o = np.argsort(np.concatenate(order), kind="stable")  # the file's face order
    F, T = np.concatenate(F_parts)[o], np.concatenate(T_parts)[o]
    F = np.where(F > 0, F - 1, len(V) + F)  # 1-based, or negative from the end
    seams = np.zeros((0, 2), dtype=np.int64)
    if (T != 0).all():
        he = HalfEdges(F, len(V))
        h = np.flatnonzero(he.twin >= 0)
        t = he.twin[h]
        nxt = np.array([1, 2, 0])
        flat_t = T.ravel()
        # h runs a -> b, its twin b -> a: the texture corners must agree at a and at b
        same = (flat_t[h] == flat_t[3 * (t // 3) + nxt[t % 3]]) & (flat_t[3 * (h // 3) + nxt[h % 3]] == flat_t[t])
        seams = np.unique(he.edge_vertices[he.edge[h[~same]]], axis=0)
    return V, F.astype(np.int64), seams


ROOT = Path(__file__).resolve().parent.parent
SPOT = ROOT / "tests" / "data" / "spot.obj"  # public domain (Keenan Crane): vendored
SHARED = ROOT.parent / "shared" / "meshes"  # research-use models, read in place, never copied
REAL = ("spot", "stanford-bunny", "fandisk", "rocker-arm", "homer", "beetle", "teapot")


def real_mesh(name: str) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """One of the real meshes (:data:`REAL`) as :func:`load_obj` reads it."""
    path = SPOT if name == "spot" else SHARED / f"{name}.obj"
    return load_obj(path)


SUZANNE = ROOT / "tests" / "data" / "suzanne.npz"  # Blender's monkey, triangulated (bpy.ops.mesh.primitive_monkey_add)


def suzanne_closed() -> tuple[np.ndarray, np.ndarray]:
    """Suzanne as Blender adds it, triangulated, no seams: 507 vertices, a head with holes
    and two closed eyes. Returns (V, F)."""
    with np.load(SUZANNE) as data:
        return data["V"].astype(np.float64), data["F"].astype(np.int64)


def helical_ribbon(
    turns: float = 1.6, nt: int = 160, nw: int = 6, r0: float = 1.0, r1: float = 1.25, rise: float = 0.15
):
    """A ribbon winding ``turns`` times up a helix, radii r0..r1: nearly developable, and
    its near-isometric layout, an annulus sector of more than a turn, overlaps itself."""
    t = np.linspace(0.0, 2.0 * np.pi * turns, nt)
    w = np.linspace(r0, r1, nw)
    T, W = np.meshgrid(t, w, indexing="ij")
    V = np.stack([W * np.cos(T), W * np.sin(T), rise * T], axis=-1).reshape(-1, 3)
    return V, grid_faces(nw, nt)


def saddle_c(nt: int = 120, nw: int = 5, gap: float = 0.15, r0: float = 1.0, r1: float = 1.12, k: float = 0.5):
    """A thin C-shaped band (an annulus with a gap of ``gap`` radians) on the saddle
    z = k (x^2 - y^2): the saddle's negative curvature opens its development by more than
    the gap, so its near-isometric layout closes on itself and overlaps."""
    t = np.linspace(gap / 2, 2.0 * np.pi - gap / 2, nt)
    w = np.linspace(r0, r1, nw)
    T, W = np.meshgrid(t, w, indexing="ij")
    x, y = W * np.cos(T), W * np.sin(T)
    V = np.stack([x, y, k * (x * x - y * y)], axis=-1).reshape(-1, 3)
    return V, grid_faces(nw, nt)
