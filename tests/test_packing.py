"""The packer (Fill Shapes): islands moved rigidly, at one common scale, into the unit
square; never closer than the margin; denser than shelves of boxes; deterministic."""

import numpy as np
import pytest
import scipy.ndimage

from isoparam_addon.solver import Cancelled, metrics, parametrize
from isoparam_addon.solver.layout import packing
from isoparam_addon.solver.layout.uv_space import place_in_uv_space
from isoparam_addon.solver.progress import tracking
from isoparam_eval import meshes as ex
from isoparam_eval.layouts import islands_overlapping, least_gap


@pytest.fixture(scope="module")
def spot_charts():
    """Spot with charts: a closed mesh cut into a few large islands (the operator's case)."""
    V, F, _ = ex.load_obj(ex.SPOT)
    res = parametrize(V, F, charts=True, refine=100)
    return res.corner_uv, res.face_island, res.n_islands


def _many_islands(k: int = 600, seed: int = 0):
    """``k`` islands of one to four triangles, sizes over three orders of magnitude, some
    long and thin, lying across each other (the packer ignores where they are)."""
    rng = np.random.default_rng(seed)
    tris, label = [], []
    for i in range(k):
        size = 10.0 ** rng.uniform(-2, 1)
        stretch = rng.choice([1.0, 1.0, 6.0])
        at = rng.uniform(-5, 5, 2)
        for _ in range(rng.integers(1, 5)):
            tri = rng.uniform(0, 1, (3, 2)) * [size * stretch, size] + at
            if metrics.corner_signed_areas(tri[None])[0] < 0:
                tri = tri[::-1]
            tris.append(tri)
            label.append(i)
    return np.array(tris), np.array(label), k


def _edge_lengths(uv):
    return np.linalg.norm(uv - np.roll(uv, 1, axis=1), axis=2)


def test_islands_move_rigidly_at_one_common_scale(spot_charts):
    uv, island, n = spot_charts
    out = packing.pack_layout(uv, island, n, margin=0.002).uv
    ratio = _edge_lengths(out) / _edge_lengths(uv)
    assert np.allclose(ratio, np.median(ratio), rtol=1e-9)  # one scale, every island
    before, after = metrics.corner_signed_areas(uv), metrics.corner_signed_areas(out)
    assert (np.sign(before) == np.sign(after)).all()  # turned, never mirrored
    assert n > 2 and len(np.unique(island)) == n


@pytest.mark.parametrize("margin", [0.0, 0.002, 4 / 1024, 0.03])
def test_islands_end_inside_the_square_and_at_least_twice_the_margin_apart(spot_charts, margin):
    uv, island, n = spot_charts
    out = packing.pack_layout(uv, island, n, margin=margin).uv
    p = out.reshape(-1, 2)
    assert p.min() >= margin - 1e-12 and p.max() <= 1 - margin + 1e-12
    assert np.isclose(p.min(axis=0), margin).all()  # the layout starts at the margin
    assert np.isclose(p.max(axis=0), 1 - margin).any()  # and fills the square to it
    assert islands_overlapping(out, island) == 0
    if margin > 0:
        assert least_gap(out, island, spacing=margin / 2) >= 2 * margin * (1 - 1e-9)


def test_many_small_islands_are_packed_apart_by_their_boxes():
    uv, island, n = _many_islands()
    res = packing.pack_layout(uv, island, n, margin=0.001)
    out = res.uv
    assert res.shaped < n  # most went by their boxes
    assert out.min() >= 0.001 - 1e-12 and out.max() <= 0.999 + 1e-12
    assert islands_overlapping(out, island) == 0
    assert least_gap(out, island, spacing=0.0005) >= 0.002 * (1 - 1e-9)
    ratio = _edge_lengths(out) / _edge_lengths(uv)
    assert np.allclose(ratio, np.median(ratio), rtol=1e-9)


def test_it_covers_more_than_shelves_of_boxes(spot_charts):
    # the solver's own placement (the islands in their canonical frame, on shelves) is
    # what Blender's Bounding Box pack gives, give or take: Fill Shapes must beat it clearly
    uv, island, n = spot_charts
    t = len(uv)
    shelved, _ = place_in_uv_space(
        uv, island, n, locked=np.zeros((t, 3), bool), old=np.zeros((t, 3, 2)), in_place=False, world_scale=False
    )
    filled = packing.pack_layout(uv, island, n, margin=0.0).uv
    assert metrics.coverage(filled) > 1.2 * metrics.coverage(shelved)
    many, label, k = _many_islands()
    assert metrics.coverage(packing.pack_layout(many, label, k).uv) > 0.5


def test_a_wide_texture_gets_a_wide_layout_with_square_texels(spot_charts):
    uv, island, n = spot_charts
    wide = uv.copy()
    wide[..., 0] /= 2.0  # as the operator gives it for a 2:1 image: u divided by the aspect
    out = packing.pack_layout(wide, island, n, margin=0.01, aspect=2.0).uv
    assert out.min() >= 0.01 - 1e-12 and out.max() <= 0.99 + 1e-12
    texels = out.copy()
    texels[..., 0] *= 2.0  # in the image's pixels: rigid, one scale
    ratio = _edge_lengths(texels) / _edge_lengths(uv)
    assert np.allclose(ratio, np.median(ratio), rtol=1e-9)


def test_odd_islands_one_island_a_point_and_gaps_in_the_numbering(spot_charts):
    uv, island, n = spot_charts
    one = packing.pack_layout(uv[island == 0], np.zeros(int((island == 0).sum()), dtype=np.int64), 1).uv
    assert np.isclose(one.reshape(-1, 2).max(axis=0), 1.0).any() and one.min() >= 0
    point = np.zeros((1, 3, 2))  # an island of no area
    both = packing.pack_layout(np.concatenate([uv, point + 3.0]), np.append(island * 2, 2 * n + 5), 2 * n + 6).uv
    assert np.isfinite(both).all() and both.min() >= 0 and both.max() <= 1
    assert islands_overlapping(both[:-1], island) == 0
    assert packing.pack_layout(np.zeros((0, 3, 2)), np.zeros(0, dtype=np.int64), 0).uv.shape == (0, 3, 2)
    with pytest.raises(ValueError, match="not finite"):
        packing.pack_layout(np.full((1, 3, 2), np.nan), np.zeros(1, dtype=np.int64), 1)


def test_the_packing_does_not_depend_on_the_run(spot_charts):
    uv, island, n = spot_charts
    first = packing.pack_layout(uv, island, n, margin=0.002).uv
    assert np.array_equal(packing.pack_layout(uv, island, n, margin=0.002).uv, first)
    # rounding in the input (another BLAS, another thread count) moves it by rounding only
    nudged = packing.pack_layout(uv * (1 + 1e-13), island, n, margin=0.002).uv
    assert np.abs(nudged - first).max() < 1e-9


def test_a_cancel_stops_the_packing():
    uv, island, n = _many_islands(200)
    seen = []

    def stop(fraction, stage):
        seen.append(stage)
        return stage != "packing"

    with pytest.raises(Cancelled), tracking(stop):
        packing.pack_layout(uv, island, n)
    assert seen[-1] == "packing"


def test_islands_alike_are_packed_alike_whatever_the_rounding(spot_charts):
    # 30 copies of one island (every other one a quarter turn round, exactly): which go
    # first, which are placed by their shapes (the largest 24) and how each is turned
    # must not follow rounding noise (another BLAS or thread count moves a layout by
    # ~1e-12), or the copies trade places
    uv, island, n = spot_charts
    smallest = np.argmin(np.bincount(island, minlength=n))
    one = uv[island == smallest]
    turned = np.stack([-one[..., 1], one[..., 0]], axis=-1)
    copies = np.concatenate([(turned if k % 2 else one) + 10.0 * k for k in range(30)])
    label = np.repeat(np.arange(30), len(one))
    first = packing.pack_layout(copies, label, 30, margin=0.002).uv
    rng = np.random.default_rng(1)
    for _ in range(4):
        nudged = copies * (1 + 1e-12 * rng.standard_normal()) + 1e-13 * rng.standard_normal(copies.shape)
        assert np.abs(packing.pack_layout(nudged, label, 30, margin=0.002).uv - first).max() < 1e-9


def test_a_long_strip_keeps_the_raster_small():
    # a ribbon 1000 times as long as it is wide, beside five small squares: the cell
    # follows the square the layout needs, not the islands' area (which would put tens of
    # thousands of cells along the ribbon, and minutes into the FFTs)
    xs = np.linspace(0.0, 100.0, 201)
    ribbon = np.concatenate(
        [
            np.stack([np.c_[xs[:-1], 0 * xs[:-1]], np.c_[xs[1:], 0 * xs[1:]], np.c_[xs[1:], 0 * xs[1:] + 0.1]], 1),
            np.stack(
                [np.c_[xs[:-1], 0 * xs[:-1]], np.c_[xs[1:], 0 * xs[1:] + 0.1], np.c_[xs[:-1], 0 * xs[:-1] + 0.1]], 1
            ),
        ]
    )
    square = np.array([[[0, 0], [1, 0], [1, 1]], [[0, 0], [1, 1], [0, 1]]], dtype=np.float64)
    uv = np.concatenate([ribbon] + [square + [0, 2 + 2 * k] for k in range(5)])
    island = np.repeat(np.arange(6), [len(ribbon)] + [2] * 5)
    res = packing.pack_layout(uv, island, 6, margin=0.001)
    assert res.cell > 1 / 1000  # fewer than a thousand cells along the square's side
    assert islands_overlapping(res.uv, island) == 0
    assert res.uv.min() >= 0.001 - 1e-12 and res.uv.max() <= 0.999 + 1e-12


def _grid(nx: int, ny: int, warp=None):
    """A grid of ``nx`` by ``ny`` squares, two triangles each, counter-clockwise, its
    corners mapped by ``warp`` (x, y) -> (u, v)."""
    x, y = np.meshgrid(np.arange(nx + 1.0), np.arange(ny + 1.0), indexing="ij")
    p = np.stack([x, y], axis=-1) if warp is None else warp(x, y)
    a, b, c, d = p[:-1, :-1], p[1:, :-1], p[1:, 1:], p[:-1, 1:]
    return np.concatenate([np.stack([a, b, c], 2).reshape(-1, 3, 2), np.stack([a, c, d], 2).reshape(-1, 3, 2)])


def test_rings_folds_and_dense_islands_keep_their_margin():
    # the raster marks an island's cells from the triangles on its outline and fills what
    # they enclose: a ring (a hole inside), a sheet folded over itself (its fold is no
    # outline edge), a dense disk, and small squares that would fit in the ring's hole or
    # under the fold must all still end apart
    def ring(x, y):  # 48 x 3 squares bent into an annulus, radii 6 to 9
        angle, radius = (x % 48) * (2 * np.pi / 48), 6.0 + y  # closed: the last column is the first
        return np.stack([radius * np.cos(angle), radius * np.sin(angle)], axis=-1)

    def fold(x, y):  # 8 x 4 squares, the right three laid back over the left five
        return np.stack([np.where(x > 5, 10 - x, x), y], axis=-1)

    def disk(x, y):  # 60 x 60 squares squeezed into a disk of radius 5
        s, t = x / 30 - 1, y / 30 - 1
        return 5 * np.stack([s * np.sqrt(1 - t * t / 2), t * np.sqrt(1 - s * s / 2)], axis=-1)

    parts = [_grid(48, 3, ring), _grid(8, 4, fold), _grid(60, 60, disk)] + [_grid(1, 1) * 1.5] * 40
    uv = np.concatenate(parts)
    island = np.repeat(np.arange(len(parts)), [len(p) for p in parts])
    outline = packing._outline(uv, island)
    folded = np.flatnonzero(island == 1)[metrics.corner_signed_areas(parts[1]) < 0]
    assert outline[folded].all()  # the fold's outline runs along no open edge
    assert 0 < outline[island == 2].sum() <= 4 * 60  # the disk's outline, none of its inside
    assert outline[island == 0].sum() == 2 * 48  # the ring's, inside and out
    for margin in (0.0, 0.004):
        out = packing.pack_layout(uv, island, len(parts), margin=margin).uv
        assert islands_overlapping(out, island) == 0
        if margin:
            assert least_gap(out, island, spacing=margin / 2) >= 2 * margin * (1 - 1e-9)


def test_the_free_positions_kept_as_boxes_are_placed_are_the_positions_made_anew(rng):
    # the box phase works out a run's free positions once and then rules out, box by box,
    # the positions each box covers, searching again only the rows whose first free
    # position it took: the positions, and each row's first, are the ones worked out anew
    grid = rng.uniform(size=(40, 60)) < 0.1
    w, h = 5, 3
    kept = packing._Free(packing._Cells(~grid).fits(packing._box_runs(w, h), 40 - h + 1, 60 - w + 1))
    placed = 0
    for _ in range(200):
        bw, bh = rng.integers(1, 9, size=2)
        x, y = rng.integers(0, 60 - bw + 1), rng.integers(0, 40 - bh + 1)
        if grid[y : y + bh, x : x + bw].any():
            continue  # (only free boxes are placed)
        grid[y : y + bh, x : x + bw] = True
        kept.take(max(y - h + 1, 0), y + bh, max(x - w + 1, 0), x + bw)
        placed += 1
    anew = packing._Free(_fits_directly(grid, np.ones((h, w), dtype=bool)))
    assert placed > 10 and np.array_equal(kept.cells, anew.cells)
    assert np.array_equal(kept.any, anew.any) and np.array_equal(kept.first[anew.any], anew.first[anew.any])


def _fits_directly(region, mask):
    """Where ``mask`` fits in ``region``, position by position (the definition)."""
    h, w = mask.shape
    sy, sx = region.shape[0] - h + 1, region.shape[1] - w + 1
    return np.array([[not (region[y : y + h, x : x + w] & mask).any() for x in range(sx)] for y in range(sy)])


def test_the_free_positions_of_regions_that_share_their_transforms_are_each_regions_own(rng):
    # the rules' layouts grow apart: one transform size for both (the larger) must give
    # each region the positions it would get alone, which are the positions where the
    # mask meets no cell taken
    regions = [rng.uniform(size=(37, 52)) < 0.08, rng.uniform(size=(45, 41)) < 0.05]
    regions.append(regions[0].copy())  # (rules that agree so far: worked out once)
    poses = [rng.uniform(size=s) < 0.6 for s in ((5, 7), (9, 4), (1, 1), (50, 3))]
    poses.append(np.pad(np.zeros((3, 4), dtype=bool), 2, constant_values=True))  # (runs in stacks, two a row)
    together = packing._free_maps(regions, poses, None)
    for r, region in enumerate(regions):
        alone = packing._free_maps([region], poses, None)[0]
        for j, pose in enumerate(poses):
            assert np.array_equal(together[r][j], alone[j])
            if pose.shape[0] <= region.shape[0]:
                assert np.array_equal(together[r][j], _fits_directly(region, pose))
            else:  # (does not fit at all)
                assert together[r][j].size == 0
    wanted = packing._free_maps(regions, poses, [[1], [], [0, 1]])
    assert np.array_equal(wanted[0][1], together[0][1]) and np.array_equal(wanted[2][0], together[0][0])
    assert sum(f.size for f in wanted[0]) == together[0][1].size and not any(f.size for f in wanted[1])


def test_beyond_the_largest_islands_only_those_unlike_their_boxes_go_by_their_shapes():
    # 120 large islands: L shapes (a third of their box empty) and squares. The largest
    # _SHAPED go by their shapes whatever they are; beyond them only the L shapes, whose
    # boxes would waste a third; the squares go by their boxes (as well placed, on a
    # finer grid)
    square = np.array([[[0, 0], [1, 0], [1, 1]], [[0, 0], [1, 1], [0, 1]]], dtype=float)
    ell = np.concatenate([square * [2, 1], square + [0, 1]])  # (a 2 x 2 box, 3/4 filled)
    tris, island = [], []
    for i in range(120):
        size = 1.0 + 0.001 * i  # (sizes apart: the ranking is by box area)
        shape = ell if i % 2 else square * 2  # (the same box)
        tris.append(shape * size)
        island += [i] * len(shape)
    uv, island = np.concatenate(tris), np.array(island)
    out = packing.pack_layout(uv, island, 120, margin=0.001)
    assert out.shaped == packing._SHAPED + (120 - packing._SHAPED) // 2
    assert islands_overlapping(out.uv, island) == 0


@pytest.mark.parametrize(("k", "seed", "calls"), [(600, 1, [True, False]), (300, 3, [True])])
def test_a_rule_that_cannot_leave_the_smaller_square_stops_and_the_packing_is_the_same(monkeypatch, k, seed, calls):
    # the rule whose large islands leave the smaller square places its boxes first; the
    # other stops once its square is past that one's (a square only grows), here midway
    # through its boxes, or before the first: the layout kept is the one both rules
    # placed in full would keep
    uv, island, n = _many_islands(k, seed=seed)
    done = []
    place_boxes = packing._place_boxes

    def watched(*args, **kwargs):
        out = place_boxes(*args, **kwargs)
        done.append(out is not None)
        return out

    monkeypatch.setattr(packing, "_place_boxes", watched)
    early = packing.pack_layout(uv, island, n, margin=0.001).uv
    monkeypatch.setattr(packing, "_place_boxes", place_boxes)
    monkeypatch.setattr(packing, "_best_of_rules", _every_rule_in_full)
    full = packing.pack_layout(uv, island, n, margin=0.001).uv
    assert done == calls and np.array_equal(early, full)


def _every_rule_in_full(masks, choices, boxes_lying, aspect):
    """:func:`packing._best_of_rules` by its definition: every rule's boxes placed, the
    smaller square kept (the first rule on a tie)."""
    best = None
    for lay in packing._place(masks, choices, aspect):
        ex, ey = lay.ex * packing._FINER, lay.ey * packing._FINER
        grid = np.repeat(np.repeat(lay.grid > 0, packing._FINER, axis=0), packing._FINER, axis=1)
        where, turn, ex, ey = packing._place_boxes(grid, ex, ey, boxes_lying, aspect, lay.rule)
        square = (max(ex / aspect, ey), ex * ey)
        if best is None or square < best[0]:
            best = (square, (lay.where, lay.shape, lay.turn, where, turn))
    return best[1]


def test_the_cells_enclosed_are_filled_for_all_masks_at_once_as_for_each_alone(rng):
    # the masks are filled in one labelling, stacked with free cells between: each is
    # filled as scipy fills it alone (holes 4-connected to no border), whatever its
    # neighbours in the stack hold
    ring = np.pad(np.zeros((3, 4), dtype=bool), 1, constant_values=True)
    open_ring = ring.copy()
    open_ring[0, 2] = False  # (a gap in the outline: nothing enclosed)
    corner = ring.copy()
    corner[0, 0] = False  # (a hole whose outside meets only diagonally: still a hole)
    masks = [ring, open_ring, corner, np.ones((1, 1), dtype=bool), np.zeros((2, 9), dtype=bool)]
    masks += [rng.uniform(size=(int(rng.integers(1, 30)), int(rng.integers(1, 30)))) < 0.55 for _ in range(40)]
    filled = packing._filled(masks)
    assert filled[0].all() and not filled[1][1:-1, 1:-1].any()
    for mask, mine in zip(masks, filled):
        assert np.array_equal(mine, scipy.ndimage.binary_fill_holes(mask))


def test_a_pose_that_fits_on_the_coarse_cells_fits_at_full_resolution(rng):
    # the screening places every pose on cells two by two: wherever it fits there, it
    # fits at twice the position at full resolution (the screen never ranks a pose by a
    # position it cannot take; past the region's last row and column the cells are free)
    region = rng.uniform(size=(61, 58)) < 0.04
    for shape in ((7, 10), (12, 5), (3, 3)):
        pose = rng.uniform(size=shape) < 0.7
        coarse = packing._free_maps([packing._pooled(region)], [packing._pooled(pose)], None)[0][0]
        fine = _fits_directly(np.pad(region, ((0, 1), (0, 0))), pose)
        ys, xs = np.nonzero(coarse)
        assert len(ys) > 20
        assert fine[2 * ys, 2 * xs].all()


def test_the_screen_keeps_a_pose_that_fits_only_at_the_regions_edge():
    # a 5 x 5 island placed, the region reaches 5 cells beyond it: a 5 x 5 pose fits only
    # in the last 5 rows or columns, which the coarse cells of an odd side would lose;
    # the poses that fit nowhere rank last, so the one that fits is kept
    lay = packing._Layout("square", np.zeros((20, 20), np.float32), *(np.zeros(k, np.int64) for k in ((1, 2), 1, 1)))
    lay.take(0, 0, 0, np.ones((5, 5), dtype=bool), 0, 0)
    region = lay.region(5)
    poses = [np.ones((7, 7), dtype=bool)] * 8 + [np.ones((5, 5), dtype=bool)]
    assert packing._free_maps([region], poses, None)[0][8].any()
    (kept,) = packing._screened([region], poses, [lay], 1.0)
    assert 8 in kept


def test_a_wide_margin_is_kept_where_it_fits_and_reported_where_it_cannot():
    # 600 islands: gaps of 0.02 fit in the square (the gaps alone need about 600 * 0.02^2
    # of it), so they are kept; gaps of 0.06 cannot be (600 * 0.06^2 > 1), and the
    # packing says how much of them it kept instead of hiding it
    uv, island, k = _many_islands(600, seed=3)
    kept = packing.pack_layout(uv, island, k, margin=0.01)
    assert kept.gap_kept == 1.0
    assert least_gap(kept.uv, island, spacing=0.005) >= 0.02 * (1 - 1e-9)
    short = packing.pack_layout(uv, island, k, margin=0.03)
    assert 0.0 < short.gap_kept < 1.0
    assert least_gap(short.uv, island, spacing=0.015) >= 0.06 * short.gap_kept * (1 - 1e-6)
    assert islands_overlapping(short.uv, island) == 0
