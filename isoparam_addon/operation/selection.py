"""One mesh's part in an unwrap as arrays (:class:`Selection`), as :mod:`isoparam_addon.blender.mesh_io`
reads it from Blender, and what the operation does to it without Blender: the sides of
its triangles inside their faces, and its quads split the other way."""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from ..solver.mesh.halfedges import pair_keys

__all__ = ["Selection", "inner_sides", "other_diagonals"]


@dataclass
class Selection:
    """What one mesh contributes to an unwrap, as arrays.

    Attributes
    ----------
    name : str
        The object's name (for reports).
    V : (n, 3) float64
        Positions of the vertices used by the selected faces (object space, or world space
        without the location).
    F : (t, 3) int64
        Triangles of the selected faces over ``V``.
    tri_loops : (t, 3) int64
        Mesh corner (loop) of every triangle corner.
    tri_poly : (t,) int64
        Mesh face of every triangle.
    vert_ids : (n,) int64
        Mesh vertex of every row of ``V``.
    seams : (k, 2) int64
        Seam edges as pairs of rows of ``V``.
    diagonals : (d, 2) int64
        Triangle edges inside a quad or n-gon (no mesh edge), as pairs of rows of ``V``.
    uv : (corners, 2) float32
        The current UVs of every corner of the mesh (all faces).
    locked : (corners,) bool
        Corners whose UV must not move: pinned, or (UV editor, sync off) not UV-selected.
    pinned : (corners,) bool
        The pinned ones among them.
    face_material : (t,) int64
    uv_name : str
    """

    name: str
    V: np.ndarray
    F: np.ndarray
    tri_loops: np.ndarray
    tri_poly: np.ndarray
    vert_ids: np.ndarray
    seams: np.ndarray
    diagonals: np.ndarray
    uv: np.ndarray
    locked: np.ndarray
    pinned: np.ndarray
    face_material: np.ndarray
    uv_name: str

    @property
    def empty(self) -> bool:
        return len(self.F) == 0


def inner_sides(tri_loops, tri_poly, loop_total):
    """Triangle sides inside their face (t, 3) bool: the corners are not neighbours.
    ``loop_total[tri_poly]`` is each triangle's face's corner count."""
    k = loop_total[tri_poly][:, None]
    step = (tri_loops[:, [1, 2, 0]] - tri_loops) % k
    return (step != 1) & (step != k - 1)


def other_diagonals(sel: Selection) -> Selection | None:
    """``sel`` with its quads split along their other diagonal where theirs lies on another
    triangle's side or another face's diagonal; None if there is no such quad.

    There two faces share three vertices and Blender's triangles overlap: the same triangle
    twice, or three triangles on one side (found by fuzzing: a quad with a triangle along
    its diagonal; coarse meshes after Limited Dissolve), which the solver refuses. Blender's
    own unwrap takes such meshes; the other diagonal makes them manifold (not for a concave
    quad, whose other diagonal runs outside it). Only tried when the solver refuses (it
    costs a few sorts of the corners).
    """
    tri_loops, tri_poly, F = sel.tri_loops, sel.tri_poly, sel.F
    polys, per_poly = np.unique(tri_poly, return_inverse=True)
    loop_total = np.bincount(per_poly) + 2  # a face of k corners has k - 2 triangles
    total = loop_total[per_poly]
    inner = inner_sides(tri_loops, np.arange(len(tri_poly)), total)
    n = len(sel.V)
    key = pair_keys(F, F[:, [1, 2, 0]], n)  # (t, 3) sides
    diag = np.unique(np.stack([key[inner], per_poly[np.nonzero(inner)[0]]], axis=1), axis=0)  # once per face
    shared, count = np.unique(diag[:, 0], return_counts=True)
    clash = np.isin(diag[:, 0], np.concatenate([key[~inner], shared[count > 1]]))
    quads = np.unique(diag[clash, 1])
    quads = quads[loop_total[quads] == 4]
    if not quads.size:
        return None
    rows = np.flatnonzero(np.isin(per_poly, quads))
    rows = rows[np.argsort(per_poly[rows], kind="stable")].reshape(-1, 2)  # each quad's two triangles
    start = tri_loops[rows].reshape(len(rows), -1).min(axis=1)  # its first corner
    offset = tri_loops[rows] - start[:, None, None]  # corners 0..3 of each quad, (q, 2, 3)
    on_start = ((offset == 0).any(axis=2) & (offset == 2).any(axis=2)).any(axis=1)  # diagonal 0 - 2 now
    split = np.where(on_start[:, None, None], [[0, 1, 3], [1, 2, 3]], [[0, 1, 2], [0, 2, 3]])
    vert = np.full(int(tri_loops.max()) + 1, -1, dtype=np.int64)
    vert[tri_loops.ravel()] = F.ravel()  # each quad's four corners are in its two triangles
    corners = start[:, None, None] + split  # (q, 2, 3) loops of the new triangles
    # a concave quad's other diagonal runs outside it: its new triangles would face away
    P = sel.V[vert[corners]]  # (q, 2, 3, 3)
    normal = np.cross(P[:, :, 1] - P[:, :, 0], P[:, :, 2] - P[:, :, 0])
    Q = sel.V[F[rows]]
    face = np.cross(Q[:, :, 1] - Q[:, :, 0], Q[:, :, 2] - Q[:, :, 0]).sum(axis=1)  # (q, 3)
    convex = (np.einsum("qtk,qk->qt", normal, face) > 0).all(axis=1)
    if not convex.any():
        return None
    rows, corners = rows[convex], corners[convex]
    new_loops = tri_loops.copy()
    new_loops[rows.ravel()] = corners.reshape(-1, 3)
    new_F = vert[new_loops]
    inner = inner_sides(new_loops, np.arange(len(tri_poly)), total)
    diagonals = np.stack([new_F[inner], new_F[:, [1, 2, 0]][inner]], axis=1)
    return replace(sel, tri_loops=new_loops, F=new_F, diagonals=diagonals)
