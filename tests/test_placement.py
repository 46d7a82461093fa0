"""Where islands go: shelves (one set, or one per group) and the in-place fit onto old UVs."""

import numpy as np

from isoparam_addon.solver.overlap import overlapping_faces
from isoparam_addon.solver.placement import _shelves, place_in_uv_space


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
    corner = _shelves(size, gap, group)
    for g in range(12):
        mine = group == g
        assert np.allclose(corner[mine], _shelves(size[mine], gap[g]), atol=1e-12)
        assert not _boxes_overlap(corner[mine], size[mine])
        assert corner[mine].min() == 0.0


def test_shelves_are_rows_about_as_wide_as_they_are_tall():
    size = np.ones((100, 2))
    corner = _shelves(size, 0.0)
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
    assert abs(area(together) - 2.0) < 1e-12  # texel density kept
    assert np.allclose(together.reshape(-1, 2).mean(axis=0), old.reshape(-1, 2).mean(axis=0))


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
