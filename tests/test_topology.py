"""Islands, seams, orientation and automatic cuts; the ordered fans of Step 1."""

import numpy as np

from isoparam_addon.solver import metrics, parametrize
from isoparam_addon.solver.charting.resolve import sub_problem
from isoparam_addon.solver.geometry import triangles
from isoparam_addon.solver.mesh.halfedges import HalfEdges, fans, unique_edges
from isoparam_addon.solver.mesh.topology import build_topology
from isoparam_addon.solver.options import Problem
from isoparam_eval import meshes as ex

from .conftest import edge_length_error


def test_fans_are_ordered_counter_clockwise():
    # a hexagon fan around vertex 0, faces given in scrambled order
    F = np.array([[0, 1 + k, 1 + (k + 1) % 6] for k in (3, 0, 5, 1, 4, 2)])
    fan = fans(F, HalfEdges(F, 7).twin, 7)
    corners = fan.corners[fan.start[0] : fan.start[1]]
    nxt = F[:, [1, 2, 0]].ravel()[corners]
    # consecutive neighbours go around counter-clockwise, starting at the lowest corner
    steps = np.diff(nxt) % 6
    assert steps.tolist() == [1, 1, 1, 1, 1] and not fan.boundary[0]
    assert fan.boundary[1:].all()


def test_boundary_fan_starts_at_the_boundary():
    V, F = ex.peaks(5)
    fan = fans(F, HalfEdges(F, len(V)).twin, len(V))
    corners = fan.corners[fan.start[12] - 0 : fan.start[13]]  # vertex 12 is interior (2, 2)
    assert not fan.boundary[12] and len(corners) == 6
    corner0 = fan.corners[fan.start[0] : fan.start[1]]
    assert fan.boundary[0] and len(corner0) in (1, 2)


def test_two_pieces_get_their_own_islands_without_overlap():
    V1, F1, _ = ex.s_surface(30, 8)
    V2, F2 = ex.peaks(11)
    V = np.vstack([V1, V2 + 10])
    F = np.vstack([F1, F2 + len(V1)])
    r = parametrize(V, F)
    assert r.n_islands == 2
    assert set(r.face_island[: len(F1)]) == {r.face_island[0]} != set(r.face_island[len(F1) :])
    boxes = [(r.uv[np.unique(f)].min(0), r.uv[np.unique(f)].max(0)) for f in (F1, F2 + len(V1))]
    (lo1, hi1), (lo2, hi2) = boxes
    assert (hi1 < lo2).any() or (hi2 < lo1).any()  # the boxes are apart along some axis
    assert edge_length_error(V1, F1, r.uv) < 1e-9  # the developable piece stays exact


def test_seam_splits_a_closed_tube_into_one_exact_island():
    # an open cylinder (two boundary loops) with a seam along one ruling
    n_around, n_up = 24, 6
    a, z = np.meshgrid(np.arange(n_around) * 2 * np.pi / n_around, np.linspace(0, 1, n_up), indexing="ij")
    V = np.stack([np.cos(a), np.sin(a), z], -1).reshape(-1, 3)
    i, j = np.meshgrid(np.arange(n_around), np.arange(n_up - 1), indexing="ij")
    p, q = i * n_up + j, ((i + 1) % n_around) * n_up + j
    F = np.concatenate([np.stack([p, q, q + 1], -1).reshape(-1, 3), np.stack([p, q + 1, p + 1], -1).reshape(-1, 3)])
    seams = np.stack([np.arange(n_up - 1), np.arange(1, n_up)], 1)  # the ruling at angle 0
    r = parametrize(V, F, seams=seams)
    assert r.n_islands == 1 and r.cut_islands.size == 0 and not r.warnings
    assert edge_length_error(V, F, r.corner_uv) < 1e-10
    # the vertices on the seam have two different UVs
    on_seam = np.unique(seams)
    cu = r.corner_uv.reshape(-1, 2)
    for v in on_seam[:2]:
        assert len(np.unique(np.round(cu[F.ravel() == v], 9), axis=0)) == 2
    # without the seam the tube is cut automatically, with a warning, and stays exact
    r2 = parametrize(V, F)
    assert r2.cut_islands.tolist() == [0] and r2.warnings
    assert edge_length_error(V, F, r2.corner_uv) < 1e-10


def test_sphere_is_cut_and_reported():
    V, F = ex.sphere(2)
    r = parametrize(V, F)
    topo = build_topology(V, F)[2]
    assert topo.closed_islands.tolist() == [0] and topo.handle_islands.size == 0
    assert len(r.cut_edges) > 0 and any("closed" in w.text for w in r.warnings)
    assert np.isfinite(r.corner_uv).all()


def _tetrahedron():
    V = np.array([[1, 1, 1], [1, -1, -1], [-1, 1, -1], [-1, -1, 1]], dtype=float)
    return V, np.array([[0, 1, 2], [0, 3, 1], [0, 2, 3], [1, 3, 2]])


def _bipyramid():
    V = np.array([[1, 0, 0], [-0.5, 0.8, 0], [-0.5, -0.8, 0], [0, 0, 1], [0, 0, -1]])
    return V, np.array([[0, 1, 3], [1, 2, 3], [2, 0, 3], [1, 0, 4], [2, 1, 4], [0, 2, 4]])


def test_small_closed_meshes_whose_farthest_vertex_is_a_neighbour_are_cut():
    # every vertex of a tetrahedron is adjacent to the root: the shortest path to the
    # farthest vertex is one edge, and cutting one edge does not open a closed mesh
    for V, F in (_tetrahedron(), _bipyramid(), (_tetrahedron()[0] * [1, 2, 3], _tetrahedron()[1])):
        for refine in (0, 100):
            r = parametrize(V, F, refine=refine)
            assert len(r.cut_edges) == 2 and r.cut_islands.tolist() == [0]
            assert np.isfinite(r.corner_uv).all()
            if refine:
                assert metrics.flipped(V, F, r.corner_uv) == 0


def test_torus_is_cut_along_two_short_loops():
    V, F = ex.torus(40, 16)
    topo = build_topology(V, F)[2]
    assert topo.handle_islands.tolist() == [0]
    assert len(topo.cut_edges) == 40 + 16  # one loop around each way: the shortest cut graph
    r = parametrize(V, F)
    assert metrics.flipped(V, F, r.corner_uv) == 0


def test_moebius_strip_is_cut_and_solved():
    n = 40
    t = np.linspace(0, 2 * np.pi, n, endpoint=False)
    w = np.array([-0.3, 0.0, 0.3])
    tt, ww = np.meshgrid(t, w, indexing="ij")
    rad = 1 + ww * np.cos(tt / 2)
    V = np.stack([rad * np.cos(tt), rad * np.sin(tt), ww * np.sin(tt / 2)], -1).reshape(-1, 3)
    F = []
    for i in range(n):  # building a test mesh, 40 strips
        j = (i + 1) % n
        a, b = 3 * i + np.arange(3), 3 * j + (np.arange(3) if j else np.arange(3)[::-1])
        F += [[a[k], b[k], b[k + 1]] for k in range(2)] + [[a[k], b[k + 1], a[k + 1]] for k in range(2)]
    F = np.array(F)
    topo = build_topology(V, F)[2]
    assert topo.nonorientable_islands.tolist() == [0]
    r = parametrize(V, F)
    assert np.isfinite(r.corner_uv).all() and r.cut_edges.size


def test_inconsistent_face_orientation_is_repaired():
    V, F = ex.peaks(21)
    F2 = F.copy()
    F2[::3] = F2[::3, ::-1]  # flip every third face
    r1, r2 = parametrize(V, F), parametrize(V, F2)
    assert r2.n_islands == 1 and not r2.warnings
    np.testing.assert_allclose(
        metrics.uv_edge_lengths(V, F2, r2.corner_uv)[1], metrics.uv_edge_lengths(V, F2, r1.uv[F2])[1], rtol=1e-9
    )
    # the majority orientation decides which way the layout faces
    topo = build_topology(V, F2)[2]
    assert topo.turned.sum() == len(F2[::3])


def test_results_are_bit_identical_run_after_run():
    V, F, _ = ex.s_surface_random(800, 7)
    a, b = parametrize(V, F), parametrize(V, F)
    assert np.array_equal(a.uv, b.uv) and np.array_equal(a.corner_uv, b.corner_uv)


def test_bow_ties_can_be_split_instead_of_rejected():
    # two triangles touching at vertex 0, as a selection in Blender can leave them
    V = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [-1, 0, 0], [0, -1, 0]], dtype=float)
    F = np.array([[0, 1, 2], [0, 3, 4]])
    r = parametrize(V, F, split_nonmanifold=True)
    assert r.n_islands == 2
    assert np.isfinite(r.corner_uv).all()
    d = metrics.uv_edge_lengths(V, F, r.corner_uv)
    np.testing.assert_allclose(d[1], d[0], rtol=1e-12)


def test_a_part_solved_alone_keeps_apart_the_faces_of_an_edge_that_more_faces_share():
    # three fins on the edge (0, 1): split, every fin is an island of its own; two of them
    # taken alone share the edge with nothing else, and must still not be joined across it
    V = np.array([[0, 0, 0], [1, 0, 0], [0.5, 1, 0], [0.5, -1, 0], [0.5, 0, 1]], dtype=float)
    F = np.array([[0, 1, 2], [1, 0, 3], [0, 1, 4]])
    assert build_topology(V, F, split_nonmanifold=True)[2].n_islands == 3
    for faces in ([0, 1], [1, 2], [0, 2]):
        part, used = sub_problem(Problem(V, F), np.array(faces))
        topo = build_topology(part.vertices, part.faces, part.seams, split_nonmanifold=True)[2]
        assert topo.n_islands == 2 and np.array_equal(used, np.unique(F[faces]))
    # a face given twice is an island of its own, and splits none of the edges it repeats
    part, _ = sub_problem(Problem(V, np.vstack([F[:2], F[:1]])), np.array([0, 1]))
    assert part.seams is None or not len(part.seams)


def test_automatic_cuts_avoid_the_diagonals_of_triangulated_quads():
    # a closed box of 2x2 quads per side, each quad split along one diagonal
    g = np.linspace(-1.0, 1.0, 3)
    pts = {tuple(p) for p in np.array(np.meshgrid(g, g, g)).reshape(3, -1).T if np.abs(p).max() == 1.0}
    V = np.array(sorted(pts))
    index = {tuple(p): i for i, p in enumerate(V)}
    F, diagonals = [], []
    for axis in range(3):
        for side in (-1.0, 1.0):
            u, w = [a for a in range(3) if a != axis]
            for i in range(2):
                for j in range(2):
                    quad = []
                    for du, dw in ((0, 0), (1, 0), (1, 1), (0, 1)):
                        p = np.zeros(3)
                        p[axis], p[u], p[w] = side, g[i + du], g[j + dw]
                        quad.append(index[tuple(p)])
                    F += [[quad[0], quad[1], quad[2]], [quad[0], quad[2], quad[3]]]
                    diagonals.append([quad[0], quad[2]])
    F = np.array(F)
    # consistent outward orientation: flip faces whose normal points inwards
    n = np.cross(V[F[:, 1]] - V[F[:, 0]], V[F[:, 2]] - V[F[:, 0]])
    inward = (n * V[F].mean(axis=1)).sum(axis=1) < 0
    F[inward] = F[inward][:, ::-1]
    r = parametrize(V, F, inner_edges=np.array(diagonals), refine=20)
    assert len(r.cut_islands) == 1 and len(r.cut_edges)
    cut = {tuple(sorted(e)) for e in r.cut_edges.tolist()}
    assert not cut & {tuple(sorted(d)) for d in diagonals}
    assert not r.flipped.any()


def test_a_closed_island_is_cut_open_beside_a_large_disk():
    # regression: the dual spanning tree's face-pair keys overflowed int32 (numpy 1.26
    # keeps int32 * np.int64 scalar in int32) once the faces numbered past 46,341, so a
    # closed box after a 200x200 peaks was "cut" along all its edges and the solve failed
    (Vp, Fp), (Vb, Fb, _) = ex.peaks(200), ex.box(4)
    V, F = np.vstack([Vp, Vb + [5.0, 0.0, 0.0]]), np.vstack([Fp, Fb + len(Vp)])
    assert len(F) > 46_341
    _, _, topo = build_topology(V, F)
    assert topo.cut_islands.tolist() == [1] and 2 <= len(topo.cut_edges) < 20


def test_half_edges_take_int32_faces():
    # Blender's corner buffers are int32; so is numpy 1.x's default integer on Windows
    V, F = ex.peaks(9)
    assert np.array_equal(unique_edges(F.astype(np.int32)), unique_edges(F))
    assert unique_edges(F.astype(np.int32)).dtype == np.int64


def test_an_islands_automatic_cut_does_not_depend_on_the_disks_beside_it():
    # the cut graph runs on the faces of the islands being cut alone: selecting another
    # object with a closed one must not move the closed one's seam (ties between equal
    # paths were broken by edge lengths taken over the whole mesh before)
    Vp, Fp = ex.peaks(15)
    Vp = 64.0 * Vp  # longer edges beside; a power of two keeps the scaled lengths exact
    for Vc, Fc in (ex.sphere(2)[:2], ex.annulus()[:2], ex.torus(20, 8)[:2]):
        alone = build_topology(Vc, Fc)[2]
        V, F = np.vstack([Vp, Vc, Vp]), np.vstack([Fp, Fc + len(Vp), Fp + len(Vp) + len(Vc)])
        beside = build_topology(V, F)[2]
        assert alone.cut_islands.tolist() == [0] and beside.cut_islands.tolist() == [1]
        np.testing.assert_array_equal(beside.cut_edges - len(Vp), alone.cut_edges)


def test_automatic_cuts_keep_off_pinned_vertices():
    # a cut through a pinned vertex splits it into copies that its pins, all on its one
    # UV, glue back together, folding the layout there; pinned where the torus's two cut
    # loops meet (its root) it folded 6 faces, and a box's extra cut through a pinned
    # corner folded 4 (found in review)
    V, F = ex.torus(24, 10)
    free = build_topology(V, F)[2]
    v = int(np.argmax(np.bincount(free.vertex_of, minlength=len(V))))
    assert np.bincount(free.vertex_of)[v] >= 3  # the unpinned cut meets there
    mask = F == v
    uv = np.where(mask[:, :, None], [0.3, 0.7], 0.0)
    for refine in (0, 10):
        r = parametrize(V, F, refine=refine, pins=(mask, uv))
        assert r.cut_islands.tolist() == [0] and not np.isin(v, r.cut_edges)
        assert np.abs(r.corner_uv[mask] - [0.3, 0.7]).max() < 1e-12
        assert metrics.flipped(V, F, r.corner_uv) == 0
    Vb, Fb, diagonals = ex.box(6)
    Vb = Vb + 1e-4 * np.random.default_rng(0).standard_normal(Vb.shape)
    mask = Fb == 5
    uv = np.where(mask[:, :, None], [0.25, -1.0], 0.0)
    for refine, extra in ((0, 0), (20, 2)):
        r = parametrize(Vb, Fb, inner_edges=diagonals, refine=refine, extra_cuts=extra, pins=(mask, uv))
        assert not np.isin(5, r.cut_edges) and not r.flipped.any()
        assert np.abs(r.corner_uv[mask] - [0.25, -1.0]).max() < 1e-12


def test_small_closed_meshes_are_cut_open_with_and_without_pins():
    # the genus-0 cut's fallback for a one-edge path read b's neighbours from a graph that
    # holds each edge once, at its lower vertex: none, or only the root, on small convex
    # hulls (26% of random tetrahedra raised); pinned vertices pushed the path's far end
    # back onto the root (Blender's default cube with pins raised). Found by fuzzing.
    from scipy.spatial import ConvexHull

    rng = np.random.default_rng(18)
    for k in (4, 4, 4, 4, 4, 4, 5, 5, 6, 7, 8, 9):
        for _ in range(4):
            V = rng.standard_normal((k, 3))
            F = ConvexHull(V).simplices
            r = parametrize(V, F)
            assert r.cut_islands.tolist() == [0] and np.isfinite(r.corner_uv).all()
    cube = np.array([[x, y, z] for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)], dtype=float)
    F = ConvexHull(cube).simplices
    for pinned in ([0, 1, 2, 4], list(range(8)), [0, 1]):
        mask = np.isin(F, pinned)
        uv = np.where(mask[:, :, None], cube[F][:, :, :2], 0.0)
        for refine in (0, 20):
            r = parametrize(cube, F, refine=refine, pins=(mask, uv))
            assert r.cut_islands.tolist() == [0] and np.isfinite(r.corner_uv).all()
            assert np.abs(r.corner_uv[mask] - uv[mask]).max() < 1e-12


def test_flipped_faces_are_those_of_the_layout_returned():
    # r.flipped was taken before the islands were turned and packed, which rounds some
    # faces of ~1e-26 the mesh's area to clockwise or nothing: a planar fuzzing mesh
    # (disks with collinear and coincident vertices, inconsistently oriented) had two
    # such faces neither flagged nor warned about
    from pathlib import Path

    mesh = np.load(Path(__file__).parent / "data" / "fuzz_flat_sliver_cluster.npz")
    V, F = mesh["V"], mesh["F"].astype(np.int64)
    Vs, Fs, _ = ex.s_surface_random(600, 3)
    Fs[::5] = Fs[::5, ::-1]  # inconsistent input orientation: the solver reverses these
    for Vi, Fi in ((V, F), (Vs + [0.0, 0.0, 1e6], Fs)):
        for refine, pack in ((0, True), (100, True), (20, False)):
            r = parametrize(Vi, Fi, refine=refine, pack=pack, split_nonmanifold=True)
            e1, e2 = r.corner_uv[:, 1] - r.corner_uv[:, 0], r.corner_uv[:, 2] - r.corner_uv[:, 0]
            a = e1[:, 0] * e2[:, 1] - e1[:, 1] * e2[:, 0]
            reversed_ = build_topology(Vi, Fi, split_nonmanifold=True)[2].turned
            # (a face with no 3D area has no orientation: never counted)
            collapsed = triangles(Vi, Fi).collapsed
            np.testing.assert_array_equal(r.flipped, (np.where(reversed_, -a, a) <= 0) & ~collapsed)
            # and the metrics count the same faces: they used the input winding, so an
            # island's faces given the other way round counted as folded
            assert r.distortion().flipped == r.flipped.sum()
