"""Where islands go: shelves (one set, or one per group) and the in-place fit onto old UVs."""

import numpy as np

from isoparam_addon.solver.layout.placement import shelves
from isoparam_addon.solver.layout.uv_space import place_in_uv_space
from isoparam_addon.solver.overlap import overlapping_faces


def _boxes_overlap(lo, size):
    hi = lo + size
    meet = ((lo[:, None] < hi[None] - 1e-12) & (lo[None] < hi[:, None] - 1e-12)).all(axis=2)
    np.fill_diagonal(meet, False)
    return meet.any()


def test_shelves_per_group_are_each_groups_shelves_alone():
    rng = np.random.default_rng(3)
    size = rng.random((300, 2)) * rng.random((300, 1))
    group = rng.integers(0, 12, 300)
    gap = rng.random(12) * 0.05
    corner = shelves(size, gap, group)
    for g in range(12):
        mine = group == g
        assert np.allclose(corner[mine], shelves(size[mine], gap[g]), atol=1e-12)
        assert not _boxes_overlap(corner[mine], size[mine])
        assert corner[mine].min() == 0.0


def test_shelves_are_rows_about_as_wide_as_they_are_tall():
    size = np.ones((100, 2))
    corner = shelves(size, 0.0)
    assert not _boxes_overlap(corner, size)
    assert np.ptp(corner[:, 0]) + 1 == np.ptp(corner[:, 1]) + 1 == 10


def _quads(origins):
    """Unit squares (two triangles each) at ``origins`` (k, 2): corner UVs (2k, 3, 2) and
    vertex ids (each square its own four vertices)."""
    square = np.array([[0, 0], [1, 0], [1, 1], [0, 1]], dtype=float)
    tris = np.array([[0, 1, 2], [0, 2, 3]])
    uv = np.concatenate([(square + o)[tris] for o in np.asarray(origins, dtype=float)])
    faces = np.concatenate([tris + 4 * k for k in range(len(origins))])
    return uv, faces


def test_islands_cut_from_one_old_island_go_there_side_by_side():
    # a 2x1 strip, unwrapped before as one island; now cut in two, each laid out 2 x 0.5
    old, _ = _quads([[0, 0], [1, 0]])
    faces = np.array([[0, 1, 2], [0, 2, 3], [1, 4, 5], [1, 5, 2]])  # the squares share an edge
    new = np.concatenate([_quads([[0, 0]])[0] * [2.0, 0.5]] * 2)
    island = np.array([0, 0, 1, 1])
    args = dict(locked=np.zeros((4, 3), dtype=bool), old=old, in_place=True, world_scale=False)
    ids, one = np.arange(12).reshape(4, 3), np.zeros(4, dtype=np.int64)
    alone, _ = place_in_uv_space(new, island, 2, **args)  # each onto its own old square
    assert len(overlapping_faces(alone, ids, one)[0])
    together, _ = place_in_uv_space(new, island, 2, corner_vertex=faces, **args)
    assert not len(overlapping_faces(together, ids, one)[0])
    area = lambda c: 0.5 * np.abs(np.cross(c[:, 1] - c[:, 0], c[:, 2] - c[:, 0])).sum()  # noqa: E731
    assert 0.9 * 2.0 < area(together) <= 2.0  # texel density, as far as the old box allows
    corners = together.reshape(-1, 2)
    assert np.all(corners.min(axis=0) >= -1e-12) and np.all(corners.max(axis=0) <= [2 + 1e-12, 1 + 1e-12])
    assert np.allclose(0.5 * (corners.min(axis=0) + corners.max(axis=0)), [1.0, 0.5])  # centred on it


def test_an_island_across_old_islands_goes_beside_those_that_stay():
    # old: three separate squares A, B, C; new: A and B joined into one island, C as it was
    old, faces = _quads([[0, 0], [5, 0], [2, 2]])
    new, _ = _quads([[0, 0], [1, 0], [0, 0]])
    new[4:] = old[4:] + 7.0  # C's layout, somewhere else
    island = np.array([0, 0, 0, 0, 1, 1])
    args = dict(locked=np.zeros((6, 3), dtype=bool), old=old, in_place=True, world_scale=False)
    uv, _ = place_in_uv_space(new, island, 2, corner_vertex=faces, **args)
    assert np.allclose(uv[4:], old[4:])  # C stays where it was
    assert uv[:4, :, 0].min() > 3.0  # A + B to its right, not spread over where A and B were
    assert np.allclose(np.ptp(uv[:4].reshape(-1, 2), axis=0), [2, 1])  # at C's scale


def test_charts_of_a_tall_old_island_stay_within_its_box():
    # old: a vertical 1 x 10 strip X and a square Y beside its middle; X now comes as two
    # charts, each laid out lying down: shelved as the strip stood, within its box
    rungs = [[2 * j, 2 * j + 1, 2 * j + 3] for j in range(10)] + [[2 * j, 2 * j + 3, 2 * j + 2] for j in range(10)]
    F = np.array(rungs)
    F = F[np.argsort(np.r_[np.arange(10), np.arange(10)], kind="stable")]
    old_x = np.stack([F % 2, F // 2], -1).astype(float)
    old_y, _ = _quads([[1.1, 4.5]])
    faces = np.vstack([F, np.array([[100, 101, 102], [100, 102, 103]])])
    old = np.concatenate([old_x, old_y])
    lying = old_x[..., ::-1] * [1.0, -1.0]
    new = np.concatenate([lying[:10], lying[10:] + [30.0, 0.0], old_y + 50.0])
    island = np.array([0] * 10 + [1] * 10 + [2] * 2)
    args = dict(locked=np.zeros((22, 3), dtype=bool), old=old, in_place=True, world_scale=False)
    uv, _ = place_in_uv_space(new, island, 3, corner_vertex=faces, **args)
    assert not len(overlapping_faces(uv, np.arange(66).reshape(22, 3), np.zeros(22, dtype=np.int64))[0])
    assert np.allclose(uv[20:], old_y)  # Y stays
    x = uv[:20].reshape(-1, 2)
    assert np.all(x.min(axis=0) >= -1e-12) and np.all(x.max(axis=0) <= [1 + 1e-12, 10 + 1e-12])


def test_islands_laid_out_anew_go_beside_where_the_others_went():
    # island 0 is fitted onto its old square but comes out 4 x 0.25 (past the old box);
    # island 1 was never unwrapped: it goes to the right of island 0 as it now lies
    old, faces = _quads([[0, 0], [5, 5]])
    old[2:] = 0.0
    new = np.concatenate([_quads([[0, 0]])[0] * [4.0, 0.25], _quads([[10, 10]])[0]])
    island = np.array([0, 0, 1, 1])
    for world_scale in (False, True):
        args = dict(locked=np.zeros((4, 3), dtype=bool), old=old, in_place=True, world_scale=world_scale)
        uv, _ = place_in_uv_space(new, island, 2, corner_vertex=faces, **args)
        assert not len(overlapping_faces(uv, np.arange(12).reshape(4, 3), np.zeros(4, dtype=np.int64))[0])
        assert uv[2:, :, 0].min() > uv[:2, :, 0].max()


def test_an_island_laid_out_anew_beside_pinned_ones_is_not_in_mesh_units():
    # a 100-unit mesh: island 0 pinned (stays), island 1 never unwrapped
    old, faces = _quads([[0, 0], [0, 0]])
    old[2:] = 0.0
    new = np.concatenate([_quads([[0, 0]])[0] * 100.0, _quads([[3, 3]])[0] * 100.0])
    locked = np.zeros((4, 3), dtype=bool)
    locked[0, 0] = True
    args = dict(locked=locked, old=old, in_place=True, world_scale=False)
    uv, _ = place_in_uv_space(new, np.array([0, 0, 1, 1]), 2, corner_vertex=faces, **args)
    assert np.allclose(np.ptp(uv[2:].reshape(-1, 2), axis=0), 1.0)
