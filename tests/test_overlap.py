"""Islands that overlap themselves: exact detection (solver/overlap.py) and their removal by
a shortest separating cut (solver/charting/untangle.py)."""

import numpy as np
import pytest

from isoparam_addon.operation.options import DEFAULTS
from isoparam_addon.solver import WarningKind, metrics, overlap, parametrize
from isoparam_addon.solver.overlap import _pairs_in_cells, box_pairs, crossings, overlapping_faces, shared_area
from isoparam_eval import meshes as ex


def test_shared_area_of_two_triangles_is_exact(rng):
    T = np.array([[[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]]])
    assert shared_area(T, T) == pytest.approx([0.5])
    assert shared_area(T, T + [0.5, 0.0]) == pytest.approx([0.125])
    assert shared_area(T, T[:, ::-1]) == pytest.approx([0.5])  # either orientation
    assert shared_area(T, T + [2.0, 0.0]) == pytest.approx([0.0])
    # against the area of the intersection polygon found by brute force on a fine grid
    A, B = rng.random((20, 3, 2)), rng.random((20, 3, 2))
    g = (np.arange(600) + 0.5) / 600
    P = np.stack(np.meshgrid(g, g), axis=-1).reshape(-1, 2)

    def inside(T):
        s = [
            (T[(k + 1) % 3, 0] - T[k, 0]) * (P[:, 1] - T[k, 1]) - (T[(k + 1) % 3, 1] - T[k, 1]) * (P[:, 0] - T[k, 0])
            for k in range(3)
        ]
        return np.all(np.array(s) >= 0, axis=0) | np.all(np.array(s) <= 0, axis=0)

    grid = np.array([(inside(a) & inside(b)).mean() for a, b in zip(A, B)])
    np.testing.assert_allclose(shared_area(A, B), grid, atol=3e-3)


def test_segments_cross_only_where_each_separates_the_other():
    uv = np.array([[0, 0], [2, 2], [0, 2], [2, 0], [3, 0], [4, 0], [1, 1], [5, 5]], dtype=float)
    edges = np.array([[0, 1], [2, 3], [4, 5], [1, 7], [6, 7]])
    i, j = crossings(uv, edges, np.zeros(len(edges), dtype=np.int64))
    # 0-1 crosses 2-3; 6-7 starts on 0-1 (touches, no crossing); 1-7 shares an end with 0-1
    assert sorted(zip(i.tolist(), j.tolist())) == [(0, 1)]
    # in different groups (islands) nothing is tested
    assert len(crossings(uv, edges, np.arange(len(edges)))[0]) == 0


def test_faces_overlap_only_with_positive_area():
    cuv = np.array([[[0, 0], [1, 0], [0, 1]], [[0.2, 0.2], [1, 0.2], [0.2, 1]], [[1, 0], [1, 1], [0, 1]]], float)
    faces = np.array([[0, 1, 2], [3, 4, 5], [6, 7, 8]])
    i, j = overlapping_faces(cuv, faces, np.zeros(3, dtype=np.int64))
    # 0 and 1 overlap; 2 only touches 0 along the hypotenuse
    assert sorted(zip(i.tolist(), j.tolist())) == [(0, 1), (1, 2)]


def test_two_flaps_hinged_at_a_vertex_overlap_with_the_area_they_share():
    # found on the beast with Smart UV Project's seams: two faces that met at an edge of
    # four faces (split as a seam) kept one vertex in common and lay one over the other
    # from it; with no pair of faces found, the repair cut elsewhere for six rounds
    F = np.array([[0, 1, 2], [0, 3, 4], [0, 5, 6]])
    uv = np.array([[0, 0], [1, 0], [0.5, 1], [1, 0.2], [0.4, 1.1], [-1, 0], [-0.5, -1]], float)
    found = overlap.self_overlaps(F, uv[F], np.zeros(3, dtype=np.int64), 1)
    assert found.crossings[0] > 0 and found.area[0] > 0.05
    assert sorted(zip(*(p.tolist() for p in found.pairs))) == [(0, 1)]  # the third only meets them at 0
    np.testing.assert_allclose(found.pair_area, shared_area(uv[F[[0]]], uv[F[[1]]]))


def test_faces_around_a_vertex_far_from_the_origin_do_not_overlap():
    # faces sharing one vertex are tested: projected where they lie (0.73 away, 1e-5 in
    # size), rounding made the touch at the vertex an overlap of a fan laid out correctly
    a = np.linspace(0.0, 2.0 * np.pi, 30, endpoint=False) + 0.1
    P = np.vstack([[0.0, 0.0], np.c_[np.cos(a), np.sin(a)]]) * 1e-5 + 0.7312
    F = np.c_[np.zeros(30, dtype=np.int64), 1 + np.arange(30), 1 + (np.arange(30) + 1) % 30]
    i, _ = overlapping_faces(P[F], F, np.zeros(30, dtype=np.int64))
    assert len(i) == 0


def test_an_island_whose_boundary_would_fold_over_itself_is_kept_from_it():
    # a C-shaped strip on a saddle: laid out isometrically its ends overlap; the
    # refinement keeps its boundary from crossing itself (solver/refinement/contact.py), so it stays
    # one island, a little stretched, where without contact it overlapped and was cut in two
    V, F = ex.saddle_c()
    r = parametrize(V, F, refine=DEFAULTS.refine, split_overlaps=True)
    assert r.n_islands == 1 and not (r.islands.crossings > 0).any() and not r.flipped.any()
    assert metrics.self_overlaps(V, F, r.corner_uv).islands == 0 and not r.warnings
    assert metrics.per_island(V, F, r.corner_uv, r.face_island).mean_symmetric_dirichlet < 4.1


def test_an_island_that_overlaps_itself_is_found_and_cut_apart():
    # a ribbon winding more than a turn: its isometric layout (it is developable) overlaps
    # itself from the start; no refinement can undo that, a cut can
    V, F = ex.helical_ribbon()
    plain = parametrize(V, F, refine=DEFAULTS.refine)
    assert plain.islands.crossings[0] > 0 and plain.overlaps().area[0] > 0
    assert [w.kind for w in plain.warnings] == [WarningKind.OVERLAPPING]
    # the metric on any layout agrees with the solver's report
    measured = metrics.self_overlaps(V, F, plain.corner_uv)
    assert measured.islands == 1 and measured.area.sum() == pytest.approx(plain.overlaps().area.sum())
    assert measured.crossings.sum() == plain.islands.crossings.sum()
    cut = parametrize(V, F, refine=DEFAULTS.refine, split_overlaps=True)
    assert cut.n_islands > 1 and cut.stats.overlap_cuts > 0
    assert not (cut.islands.crossings > 0).any() and not cut.flipped.any()
    assert metrics.self_overlaps(V, F, cut.corner_uv).islands == 0
    assert [w.kind for w in cut.warnings] == [WarningKind.CUT_APART]  # said, as news
    # with charts too: a disk cut apart is no chart
    charted = parametrize(V, F, refine=DEFAULTS.refine, split_overlaps=True, charts=True)
    assert charted.n_islands > 1 and [w.kind for w in charted.warnings] == [WarningKind.CUT_APART]
    assert charted.stats.charts == 0
    before = metrics.per_island(V, F, plain.corner_uv, plain.face_island).mean_symmetric_dirichlet
    after = metrics.per_island(V, F, cut.corner_uv, cut.face_island).mean_symmetric_dirichlet
    assert after <= before * 1.01
    # the cuts never run along a polygon's diagonal: cutting a quadrangulated ribbon
    quads_inner = F[: len(F) // 2][:, [0, 2]]  # grid_faces: the cell's triangles a-b-d and a-d-c share a-d
    again = parametrize(V, F, refine=DEFAULTS.refine, split_overlaps=True, inner_edges=quads_inner)
    cut_pairs = {tuple(e) for e in np.sort(again.cut_edges, axis=1).tolist()}
    assert not cut_pairs & {tuple(e) for e in np.sort(quads_inner, axis=1).tolist()}
    assert not (again.islands.crossings > 0).any()


def test_islands_that_do_not_overlap_are_left_alone():
    V, F = ex.peaks(21)
    a, b = parametrize(V, F, refine=100), parametrize(V, F, refine=100, split_overlaps=True)
    assert np.array_equal(a.corner_uv, b.corner_uv) and b.stats.overlap_cuts == 0


def test_the_face_graph_of_some_islands_is_the_whole_graph_among_them():
    # the repair builds the graph of the islands that overlap only: the same edges, costs
    # and face numbers as the whole mesh's graph narrowed to them
    from isoparam_addon.solver.charting.mincut import face_graph
    from isoparam_addon.solver.mesh.topology import build_topology

    V, F = ex.sphere(3)
    V = np.vstack([V + [3.0 * k, 0.0, 0.0] for k in range(3)])  # three parts
    F = np.vstack([F + k * (len(V) // 3) for k in range(3)])
    seams = F[::7, :2]
    V, F, topo = build_topology(V, F, seams)
    island = topo.face_island
    some = island != island[0]
    assert 0 < some.sum() < len(F)
    whole = face_graph(V, F, island, seams).among(some)
    part = face_graph(V, F, island, seams, faces=np.flatnonzero(some))
    key = lambda g: np.lexsort((g.g, g.f))  # noqa: E731
    a, b = key(whole), key(part)
    assert len(whole.f) > 0 and np.array_equal(whole.f[a], part.f[b]) and np.array_equal(whole.g[a], part.g[b])
    assert np.array_equal(whole.edges[a], part.edges[b]) and np.array_equal(whole.cost[a], part.cost[b])
    assert np.array_equal(whole.centroids, part.centroids)


@pytest.mark.parametrize(
    ("pairs", "column"),
    [(box_pairs, False), (box_pairs, True), (_pairs_in_cells, False)],
    ids=["sweep", "boxes stacked along u: the grid", "grid"],
)
def test_pairs_asked_for_some_items_or_across_two_kinds_are_those_of_the_boxes_that_meet(
    rng, monkeypatch, pairs, column
):
    lo = rng.uniform(0.0, 10.0, size=(400, 2)) * [4.0, 1.0]
    if column:  # (a straight boundary along v: every box meets every other along u)
        lo[:, 0] = rng.uniform(0.0, 0.01, size=400)
    hi = lo + rng.exponential(0.3, size=(400, 2)) * np.where(rng.uniform(size=(400, 1)) < 0.05, 20.0, 1.0)
    gridded = []
    monkeypatch.setattr(overlap, "_pairs_in_cells", lambda *a: gridded.append(a) or _pairs_in_cells(*a))
    group = rng.integers(0, 3, 400)
    query = rng.uniform(size=400) < 0.1
    i, j = pairs(lo, hi, group, 0.6)
    brute = {
        (a, b)
        for a in range(400)
        for b in range(a + 1, 400)
        if group[a] == group[b] and (lo[a] <= hi[b]).all() and (lo[b] <= hi[a]).all()
    }
    assert set(zip(i.tolist(), j.tolist())) == brute
    asked = set(zip(*pairs(lo, hi, group, 0.6, query)))
    assert asked == {(a, b) for a, b in brute if query[a] or query[b]} and asked
    # points against segments: only the pairs across the two kinds, the first kind first
    across = rng.uniform(size=400) < 0.4
    crossed = {(a, b) if across[b] else (b, a) for a, b in brute if across[a] != across[b]}
    assert set(zip(*pairs(lo, hi, group, 0.6, across=across))) == crossed and crossed
    asked = set(zip(*pairs(lo, hi, group, 0.6, query, across)))
    assert asked == {(a, b) for a, b in crossed if query[a] or query[b]} and asked
    assert bool(gridded) == (column and pairs is box_pairs)  # (which way was taken)
