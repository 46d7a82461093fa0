"""Extra cuts for islands that had to be cut open (solver/charting/cuts.py, parametrize(extra_cuts=))."""

import numpy as np
import pytest

from isoparam_addon.operation.options import DEFAULTS
from isoparam_addon.solver import ErrorKind, InvalidMeshError, metrics, parametrize
from isoparam_addon.solver.charting import cuts, resolve
from isoparam_addon.solver.charting.cuts import area_distortion, next_paths
from isoparam_addon.solver.mesh.halfedges import unique_edges
from isoparam_eval import meshes as ex


def pairs(E):
    """Undirected vertex pairs as a set of sorted tuples."""
    return {tuple(p) for p in np.sort(np.asarray(E).reshape(-1, 2), axis=1).tolist()}


def island_distortion(V, F, r):
    return area_distortion(V, F, r.corner_uv, r.face_island, r.n_islands)[1]


@pytest.mark.parametrize("refine", [0, 100])
def test_extra_cuts_open_a_box_towards_its_corners(refine):
    V, F, diagonals = ex.box(6)
    short = parametrize(V, F, refine=refine, inner_edges=diagonals)
    more = parametrize(V, F, refine=refine, inner_edges=diagonals, extra_cuts=6)
    before, after = island_distortion(V, F, short)[0], island_distortion(V, F, more)[0]
    # measured: refine=100 0.272 -> 0.021 (symmetric Dirichlet 4.61 -> 4.03; 0.0084 before
    # the refinement kept boundaries from crossing: the tries go other ways); refine=0
    # 1.04 -> 0.53 (12.2 -> 8.5)
    assert after < (0.1 if refine else 0.6) * before
    assert more.flipped.sum() == 0
    if refine:
        assert more.distortion().symmetric_dirichlet < 4.05 < short.distortion().symmetric_dirichlet
    assert more.n_islands == 1 and more.cut_islands.tolist() == [0]
    added = pairs(more.cut_edges) - pairs(short.cut_edges)
    assert pairs(short.cut_edges) <= pairs(more.cut_edges) and added
    assert added <= pairs(unique_edges(F)) and not added & pairs(diagonals)  # mesh edges, never a diagonal
    assert more.stats.extra_cut_edges == len(added)
    assert any("more edges cut" in w.text for w in more.warnings)
    assert any("cut into disks automatically" in w.text for w in more.warnings)


def test_extra_cuts_stop_when_they_stop_paying():
    # paper mode on box(6): the fourth path makes the island worse (measured gains 5%,
    # 57%, 38%, then -322%), so three are kept and the search stops there
    V, F, diagonals = ex.box(6)
    short = parametrize(V, F, inner_edges=diagonals)
    r = parametrize(V, F, inner_edges=diagonals, extra_cuts=20)
    gains = np.array(r.stats.extra_cut_gains)
    assert len(gains) == r.stats.extra_cut_tries < 20
    assert (gains[:-1] >= cuts._GAIN).all() and gains[-1] < cuts._GAIN
    # the kept tries are what the result is made of
    before, after = island_distortion(V, F, short)[0], island_distortion(V, F, r)[0]
    assert after == pytest.approx(before * np.prod(1.0 - gains[:-1]), rel=1e-9)


def test_a_try_solves_only_the_islands_being_cut(monkeypatch):
    # a closed box beside a disk (peaks): the whole mesh is solved once, the box is then
    # grown alone, and the result (the first solve with the box's last kept try merged
    # in) is what solving the whole mesh with the cuts found gives
    (Vb, Fb, D), (Vp, Fp) = ex.box(6), ex.peaks(15)
    V = np.vstack([Vb, Vp + [5.0, 0.0, 0.0]])
    F = np.vstack([Fb, Fp + len(Vb)])
    sizes, asked = [], []
    inner, paths = cuts.solve, cuts.next_paths
    for module in (cuts, resolve):  # the first solve, and the tries
        monkeypatch.setattr(module, "solve", lambda p, o: sizes.append(len(p.vertices)) or inner(p, o))
    monkeypatch.setattr(cuts, "next_paths", lambda *a: asked.append((a[4].copy(), a[5].copy())) or paths(*a))
    r = parametrize(V, F, refine=100, inner_edges=D, extra_cuts=6)
    tries = r.stats.extra_cut_tries
    # the whole mesh once, then the box's tries
    assert tries >= 2 and sizes == [len(V)] + [len(Vb)] * tries
    # each round aims at the worst spot of the box's best layout so far, and goes on from
    # it: the result is the whole mesh solved with the cuts found, to the refinement's
    # tolerance (a descent from another start ends at another point of the same valley)
    assert len(asked) == tries + 1 and all(np.isfinite(face_bad).all() for face_bad, _ in asked)
    again = parametrize(V, F, r.cut_edges, refine=100, inner_edges=D)
    ours, theirs = (metrics.per_island(V, F, x.corner_uv, x.face_island).symmetric_dirichlet for x in (r, again))
    np.testing.assert_allclose(ours, theirs, rtol=2e-3)
    # the same warnings after the two that say the box was cut open and cut further
    assert r.warnings[2:] == again.warnings and again.stats.split_vertices == r.stats.split_vertices
    # the box's distortion as the tries measured it on the box alone
    box = r.face_island[0]
    plain = parametrize(V, F, refine=100, inner_edges=D)
    d, d0 = island_distortion(V, F, r), island_distortion(V, F, plain)
    gains = np.array(r.stats.extra_cut_gains)
    kept = gains[gains >= cuts._GAIN]
    # from where extra_cuts=0 leaves the box
    assert len(kept) >= 2 and d[box] == pytest.approx(d0[box] * np.prod(1.0 - kept), rel=1e-6)  # as the tries measured
    assert d[box] < 0.1 * d0[box]  # (0.076: see test_extra_cuts_open_a_box_towards_its_corners)
    # and the disk's as without extra cuts
    assert d[1 - box] == pytest.approx(d0[1 - box], rel=1e-9)


def test_extra_cuts_leave_islands_that_needed_no_cut_alone():
    V, F = ex.peaks(21)
    a = parametrize(V, F, refine=20)
    b = parametrize(V, F, refine=20, extra_cuts=DEFAULTS.extra_cuts)
    assert np.array_equal(a.corner_uv, b.corner_uv) and len(b.cut_edges) == 0


def test_a_new_path_runs_from_the_cut_to_the_worst_vertex_along_mesh_edges():
    V, F, diagonals = ex.box(6)
    r = parametrize(V, F, refine=100, inner_edges=diagonals)
    bad, _ = area_distortion(V, F, r.corner_uv, r.face_island, r.n_islands)
    new, owner, got = next_paths(V, F, r.face_island, np.array([0]), bad, r.cut_edges, diagonals)
    assert got.tolist() == [True] and (owner == 0).all()
    assert pairs(new) <= pairs(unique_edges(F)) and not pairs(new) & pairs(diagonals)
    on_cut = np.zeros(len(V), dtype=bool)
    on_cut[r.cut_edges.ravel()] = True
    # a simple path: its first vertex is the target (interior), its last one on the cut
    assert not on_cut[new[0, 0]] and on_cut[new[-1, 1]]
    assert np.array_equal(new[1:, 0], new[:-1, 1]) and len(set(new.ravel().tolist())) == len(new) + 1
    assert not on_cut[new[:-1, 1]].any()
    # the target is the vertex of largest mean face distortion more than two edges from
    # the cut (next to a slit's tip everything looks squeezed: a path there only moves it)
    import scipy.sparse as sp
    from scipy.sparse.csgraph import shortest_path

    E = unique_edges(F)
    graph = sp.coo_matrix((np.ones(len(E)), (E[:, 0], E[:, 1])), shape=(len(V), len(V)))
    hops = shortest_path(graph, directed=False, unweighted=True, indices=np.flatnonzero(on_cut)).min(axis=0)
    score = np.bincount(F.ravel(), np.repeat(bad, 3), minlength=len(V)) / np.bincount(F.ravel(), minlength=len(V))
    assert hops[new[0, 0]] > 2 and len(new) >= 3
    assert score[new[0, 0]] == pytest.approx(score[hops > 2].max())


def test_targets_keep_two_edges_clear_of_the_cut():
    # a squeezed spot next to the cut (as at a slit's tip) is passed over for one further in
    import scipy.sparse as sp
    from scipy.sparse.csgraph import shortest_path

    V, F, diagonals = ex.box(6)
    r = parametrize(V, F, refine=100, inner_edges=diagonals)
    E = unique_edges(F)
    graph = sp.coo_matrix((np.ones(len(E)), (E[:, 0], E[:, 1])), shape=(len(V), len(V)))
    hops = shortest_path(graph, directed=False, unweighted=True, indices=np.unique(r.cut_edges)).min(axis=0)
    near, far = np.flatnonzero(hops == 1)[0], np.flatnonzero(hops == 3)[0]
    bad = np.zeros(len(F))
    bad[(F == near).any(axis=1)] = 5.0
    bad[(F == far).any(axis=1)] = 1.0
    new, _, got = next_paths(V, F, r.face_island, np.array([0]), bad, r.cut_edges, diagonals)
    assert got.tolist() == [True] and new[0, 0] == far and len(new) == 3


def test_no_path_where_nothing_is_distorted_enough():
    V, F, diagonals = ex.box(4)
    r = parametrize(V, F, refine=100, inner_edges=diagonals)
    flat = np.zeros(len(F))  # no face distorted
    new, owner, got = next_paths(V, F, r.face_island, np.array([0]), flat, r.cut_edges, diagonals)
    assert got.tolist() == [False] and len(new) == 0 and len(owner) == 0


def test_a_lone_seam_edge_is_not_where_a_path_starts():
    # a single interior seam edge opens nothing; a path ending there would be a floating
    # slit, a hole the next solve would have to cut open again (found in review)
    from isoparam_addon.solver.mesh.topology import build_topology

    V, F, diagonals = ex.box(6)
    r = parametrize(V, F, [[1, 2]], refine=100, inner_edges=diagonals, extra_cuts=DEFAULTS.extra_cuts)
    assert r.stats.extra_cut_edges > 0
    assert build_topology(V, F, np.vstack([[[1, 2]], r.cut_edges]))[2].cut_islands.size == 0
    assert not any("several boundary loops" in w.text for w in r.warnings)


def test_every_island_cut_open_gets_its_own_extra_cuts():
    # two closed boxes of different sizes in one mesh: each island is tried, kept and
    # stopped on its own (measured: 0.268 -> 0.006 and 0.273 -> 0.10; 0.0092 and 8e-14
    # before the refinement kept boundaries from crossing, which sends the tries other ways)
    (V1, F1, D1), (V2, F2, D2) = ex.box(6), ex.box(4)
    V = np.vstack([V1, V2 + [5.0, 0.0, 0.0]])
    F, D = np.vstack([F1, F2 + len(V1)]), np.vstack([D1, D2 + len(V1)])
    short = parametrize(V, F, refine=100, inner_edges=D)
    more = parametrize(V, F, refine=100, inner_edges=D, extra_cuts=6)
    assert more.n_islands == 2 and sorted(more.cut_islands.tolist()) == [0, 1]
    before, after = island_distortion(V, F, short), island_distortion(V, F, more)
    assert (after < 0.5 * before).all() and after.min() < 0.05 * before.min()
    first = (more.cut_edges < len(V1)).all(axis=1)  # cut edges of the first box
    assert first.sum() > (short.cut_edges < len(V1)).all(axis=1).sum()
    assert (~first).sum() > (~(short.cut_edges < len(V1)).all(axis=1)).sum()
    assert more.flipped.sum() == 0


def test_a_try_on_an_island_whose_wedges_other_islands_separate():
    # two faces at one vertex of a torus, seamed off as islands of their own, leave the
    # torus two wedges there; a try that solves the torus alone sees those wedges meet
    # at a bare vertex (a bow-tie) and must split it, as the whole mesh's seams did
    # (found in review: InvalidMeshError on a valid mesh)
    V, F = ex.torus(24, 12)
    at = np.flatnonzero((F == 0).any(axis=1))
    edge_sets = [pairs(np.stack([F[f], np.roll(F[f], -1)], axis=1)) for f in at]
    a, b = next((i, j) for i in range(len(at)) for j in range(i + 1, len(at)) if not edge_sets[i] & edge_sets[j])
    seams = np.array(sorted(edge_sets[a] | edge_sets[b]))
    plain = parametrize(V, F, seams)
    assert plain.n_islands == 3 and len(plain.cut_islands) == 1
    r = parametrize(V, F, seams, extra_cuts=2)
    assert r.stats.extra_cut_tries >= 1 and np.isfinite(r.corner_uv).all()
    assert r.n_islands == 3 and r.flipped.sum() == 0


def test_the_gains_are_listed_when_nothing_was_cut_open_too():
    V, F = ex.peaks(9)
    r = parametrize(V, F, extra_cuts=2)
    assert r.stats.extra_cut_tries == 0 and r.stats.extra_cut_gains == []


def test_extra_cuts_start_from_the_whole_meshs_cut_and_check_pins_on_it():
    # found in review: a symmetric closed island cut open alone broke ties differently
    # from the whole mesh, and pins were checked on the islands alone (wrong face numbers)
    (Vs, Fs), (Vp, Fp) = ex.sphere(2), ex.peaks(15)
    V, F = np.vstack([Vs, Vp + [5.0, 0.0, 0.0]]), np.vstack([Fs, Fp + len(Vs)])
    plain = parametrize(V, F)
    r = parametrize(V, F, extra_cuts=1)
    assert r.stats.extra_cut_edges == 0  # nothing kept: the result extra_cuts=0 gives
    assert pairs(r.cut_edges) == pairs(plain.cut_edges) and np.array_equal(r.corner_uv, plain.corner_uv)
    (Vb, Fb, _), (Vp, Fp) = ex.box(4), ex.peaks(10)
    V, F = np.vstack([Vp, Vb + [5.0, 0.0, 0.0]]), np.vstack([Fp, Fb + len(Vp)])
    corners, uv = np.zeros((len(F), 3), dtype=bool), np.zeros((len(F), 3, 2))
    corners[-5, 0], uv[-5, 0] = True, np.nan
    with pytest.raises(InvalidMeshError, match=f"face {len(F) - 5}") as info:
        parametrize(V, F, pins=(corners, uv), extra_cuts=3)
    assert info.value.kind is ErrorKind.NON_FINITE_PIN and info.value.indices.tolist() == [len(F) - 5]
    with pytest.raises(InvalidMeshError) as info:
        parametrize(V, F, pins=(corners[:-1], uv[:-1]), extra_cuts=3)
    assert info.value.kind is ErrorKind.SHAPE


def two_boxes_and_a_disk():
    """Two closed boxes (that stop growing at different tries with refine=100) beside a
    disk, their polygon diagonals, and the disk's faces."""
    (Va, Fa, Da), (Vb, Fb, Db), (Vp, Fp) = ex.box(6), ex.box(3), ex.peaks(9)
    V = np.vstack([Va, Vb * 0.5 + [4.0, 0.0, 0.0], Vp + [0.0, 5.0, 0.0]])
    F = np.vstack([Fa, Fb + len(Va), Fp + len(Va) + len(Vb)])
    return V, F, np.vstack([Da, Db + len(Va)]), np.arange(len(Fa) + len(Fb), len(F))


def pinned(F, at, where):
    corners, uv = np.zeros((len(F), 3), dtype=bool), np.zeros((len(F), 3, 2))
    for (f, k), p in zip(at, where):
        corners[f, k], uv[f, k] = True, p
    return corners, uv


@pytest.mark.parametrize("pack", [True, False])
@pytest.mark.parametrize("refine", [0, 100])
def test_a_merged_result_is_the_whole_mesh_solved_with_the_cuts_kept(pack, refine):
    # each island comes from the last try that kept its cut (or from the first solve),
    # and the merge is the whole mesh solved with those cuts: layout, packing, pins (two,
    # on the disk: they place it, refine=0), warnings, counters
    V, F, D, disk = two_boxes_and_a_disk()
    pins = pinned(F, [(disk[0], 0), (disk[-1], 1)], [[10.0, -3.0], [12.0, -3.5]]) if not refine else None
    options = dict(refine=refine, inner_edges=D, pins=pins, pack=pack)
    r = parametrize(V, F, extra_cuts=6, **options)
    gains = r.stats.extra_cut_gains
    assert r.stats.extra_cut_edges > 0 and len(gains) >= (4 if refine else 2)
    assert r.timings.merge > 0  # not a try that covered the whole mesh
    again = parametrize(V, F, r.cut_edges, **options)
    assert r.n_islands == again.n_islands == 3 and np.array_equal(r.face_island, again.face_island)
    size = np.ptp(again.corner_uv.reshape(-1, 2), axis=0).max()
    for key in ("vertices", "faces", "split_vertices"):
        assert getattr(r.stats, key) == getattr(again.stats, key)
    if refine:  # the tries went on from the layout so far: the same to the refinement's tolerance
        ours, theirs = (metrics.per_island(V, F, x.corner_uv, x.face_island).symmetric_dirichlet for x in (r, again))
        np.testing.assert_allclose(ours, theirs, rtol=2e-3)
        assert not r.flipped.any() and not again.flipped.any()
        assert r.stats.refine_energy[-1] == pytest.approx(again.stats.refine_energy[-1], rel=1e-3)
        return
    assert np.abs(again.corner_uv - r.corner_uv).max() < 1e-9 * size
    assert np.abs(again.uv - r.uv).max() < 1e-9 * size
    assert np.array_equal(again.flipped, r.flipped) and np.array_equal(again.converged, r.converged)
    assert np.allclose(again.eigenvalues, r.eigenvalues, rtol=1e-6, atol=1e-12)
    assert (r.stats.extra_vertex, r.stats.regularized) == (again.stats.extra_vertex, again.stats.regularized)
    assert r.warnings[2:] == again.warnings
    # the pins hold: the disk stays in their frame
    assert np.allclose(r.corner_uv[disk[0], 0], [10.0, -3.0])
    assert np.allclose(r.corner_uv[disk[-1], 1], [12.0, -3.5])


@pytest.mark.parametrize("refine", [0, 100])
def test_a_merged_result_measures_the_faces_the_solver_turned_round(refine):
    # inconsistent input winding: the metrics take the faces as the solver oriented them
    # on the merged result too (review: 136 flipped by the input winding, 8 in fact)
    V, F, D, _ = two_boxes_and_a_disk()
    F = F.copy()
    F[::5] = F[::5, ::-1]
    r = parametrize(V, F, refine=refine, inner_edges=D, extra_cuts=6)
    assert r.timings.merge > 0
    assert r.distortion().flipped == r.flipped.sum()


def test_islands_shaped_by_pins_are_refined_with_the_whole_mesh_after_extra_cuts():
    # three pins shape an island, and the refinement moves every such island onto its
    # pins together (one step length, one fold test): a try alone would take another
    # path, so the result is the whole mesh solved with the cuts kept (found in review)
    V, F, D, _ = two_boxes_and_a_disk()
    p = V[F[5]]  # a face of the large box, pinned in its true shape (found by helper review)
    e1 = (p[1] - p[0]) / np.linalg.norm(p[1] - p[0])
    e2 = np.cross(np.cross(p[1] - p[0], p[2] - p[0]), e1)
    e2 /= np.linalg.norm(e2)
    pins = pinned(F, [(5, 0), (5, 1), (5, 2)], np.stack([(p - p[0]) @ e1, (p - p[0]) @ e2], 1) + [20.0, 3.0])
    options = dict(refine=100, inner_edges=D, pins=pins, pack=False)
    r = parametrize(V, F, extra_cuts=6, **options)
    assert r.stats.extra_cut_edges > 0 and r.timings.merge == 0
    again = parametrize(V, F, r.cut_edges, **options)
    assert np.array_equal(again.corner_uv, r.corner_uv) and r.warnings[2:] == again.warnings
