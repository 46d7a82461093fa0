"""The cut graph is total: every island of every mesh becomes a topological disk.

A property test over closed and open meshes of many sizes and topologies (voxel sets of
any genus, with the non-manifold edges and bow-ties that touching voxels make; spheres,
tori, annuli, cubes), with holes punched, noise, renumbering, copies and coarse vertex
clustering; and the case that once failed: a closed genus-0 mesh of more than 46,341
vertices, where edge keys built from csgraph's int32 predecessors wrapped around.
"""

import numpy as np
import pytest
import scipy.sparse as sp
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from scipy.sparse import csgraph

from isoparam_addon.solver.mesh.halfedges import HalfEdges, pair_keys, unique_sorted
from isoparam_addon.solver.mesh.topology import build_topology
from isoparam_eval import meshes as ex
from isoparam_eval import variants as va


def islands_are_disks(topo) -> None:
    """Every island of ``topo``: one boundary loop, Euler characteristic 1, consistently
    oriented."""
    F, k = topo.faces, topo.n_islands
    he = HalfEdges(F, len(topo.vertex_of))
    assert he.consistent(F)
    assert (he.edge_count <= 2).all()
    v_isl = np.full(len(topo.vertex_of), -1)
    v_isl[F.ravel()] = np.repeat(topo.face_island, 3)
    e_isl = np.empty(he.n_edges, dtype=np.int64)
    e_isl[he.edge] = np.repeat(topo.face_island, 3)
    chi = (
        np.bincount(v_isl[v_isl >= 0], minlength=k)
        - np.bincount(e_isl, minlength=k)
        + np.bincount(topo.face_island, minlength=k)
    )
    boundary = he.edge_vertices[he.edge_count == 1]
    n = len(topo.vertex_of)
    g = sp.coo_matrix((np.ones(len(boundary)), (boundary[:, 0], boundary[:, 1])), shape=(n, n))
    _, loop = csgraph.connected_components(g, directed=False)
    on = np.unique(boundary)
    loops = np.bincount(v_isl[on[np.unique(loop[on], return_index=True)[1]]], minlength=k)
    assert (chi == 1).all(), np.flatnonzero(chi != 1)
    assert (loops == 1).all(), np.flatnonzero(loops != 1)


def shape(kind: str, size: int, rng: np.random.Generator):
    if kind == "voxels":
        return va.voxels(va.voxel_blob(rng, size=size))
    if kind == "sphere":
        return ex.sphere(size % 4)
    if kind == "torus":
        return ex.torus(nu=6 + 3 * size, nv=4 + size)
    if kind == "annulus":
        return ex.annulus(n_radial=2 + size, n_around=8 + 4 * size)
    V, F, _ = ex.box(size)
    return V, F


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(
    kind=st.sampled_from(["voxels", "sphere", "torus", "annulus", "box"]),
    size=st.integers(1, 5),
    holes=st.integers(0, 4),
    noise=st.booleans(),
    parts=st.integers(1, 2),
    clustered=st.booleans(),
    seed=st.integers(0, 2**31 - 1),
)
def test_every_island_of_any_mesh_is_cut_into_a_disk(kind, size, holes, noise, parts, clustered, seed):
    rng = np.random.default_rng(seed)
    V, F = shape(kind, size, rng)
    if holes:
        V, F = va.punched(V, F, rng, holes=holes)
    if noise:
        V, F = va.noisy(V, F, rng, 0.2)
    if clustered:
        edge = np.linalg.norm(V[F[:, 0]] - V[F[:, 1]], axis=1).mean()
        V, F = va.cluster(V, F, 1.5 * edge)
        if not len(F):
            return
    V, F = va.copies(V, F, parts)
    V, F = va.renumbered(V, F, rng)
    _, _, topo = build_topology(V, F)
    islands_are_disks(topo)


@pytest.mark.parametrize("seed", [0, 1])
def test_a_closed_mesh_of_more_than_46341_vertices_is_cut_along_one_path(seed):
    V, F, _ = ex.box(90)  # 48,602 vertices, genus 0
    V, F = va.renumbered(V, F, np.random.default_rng(seed))
    _, _, topo = build_topology(V, F)
    islands_are_disks(topo)
    cut = topo.cut_edges
    degree = np.bincount(cut.ravel())
    assert (degree[degree > 0] <= 2).all() and (degree == 1).sum() == 2  # one simple path
    assert np.isin(pair_keys(cut[:, 0], cut[:, 1], len(V)), pair_keys(F, F[:, [1, 2, 0]], len(V))).all()


def test_pair_keys_do_not_wrap_around_for_int32_input():
    a = np.array([46_000, 60_000], dtype=np.int32)
    b = np.array([60_000, 46_000], dtype=np.int32)
    keys = pair_keys(a, b, 70_000)
    assert keys.dtype == np.int64
    assert (keys == 46_000 * 70_000 + 60_000).all()
    assert pair_keys(a, b, 70_000, ordered=True)[1] == 60_000 * 70_000 + 46_000


@pytest.mark.parametrize("n", [0, 1, 2, 1000])
def test_unique_sorted_gives_numpys_distinct_values(n):
    rng = np.random.default_rng(n)
    for values in (rng.integers(0, max(n // 3, 1), n), rng.integers(-(2**40), 2**40, n), np.arange(n)[::-1]):
        for dtype in (np.int32, np.int64):
            got, want = unique_sorted(values.astype(dtype)), np.unique(values.astype(dtype))
            assert got.dtype == want.dtype
            assert np.array_equal(got, want)


def test_a_genus_two_plate_is_cut_into_a_disk():
    plate = np.ones((5, 3, 1), dtype=bool)
    plate[1, 1, 0] = plate[3, 1, 0] = False  # two holes through it
    V, F = va.voxels(plate)
    _, _, topo = build_topology(V, F)
    assert topo.handle_islands.tolist() == [0]
    islands_are_disks(topo)
