"""The packer: islands turned and fitted together into the UV square, holes filled, so that
more of the texture's texels land on the model.

1. Every island gets a few frames: the turn to its tightest box (the least-area bounding
   rectangle, searched over angles), the turn to its smallest bounding square, and, for
   the largest islands, turns in between.
2. The largest islands (``_SHAPED``, of ``_SHAPED_CELLS`` cells or more), and beyond them
   every island of that size that fills less than ``_BOXY`` of its tightest box (one that
   fills it is placed as well by its box, on the finer grid), are rasterized
   conservatively (the triangles on their outline, and the cells those enclose: the
   work follows the outlines, not the faces), grown by half the margin, at a cell that
   puts about ``_CELLS`` cells along the side of a square as large as all the boxes (or
   along half the longest island, where that is longer).
   They go in one at a time, largest first, each in the best of its frames and their four
   quarter turns, at the free position that keeps the layout's bounding square smallest,
   then its bounding box, then nearest the origin: the rule of xatlas's packer (J. Young,
   ``xatlas``: ``findChartLocation_bruteForce`` in ``packCharts``). Where an island fits,
   at every position at once, is read off the free cells held as the bits of one integer:
   shifted by each run of the island's cells along a row and ANDed, one shift and one
   AND per run (:class:`_Cells`). An island tried in many poses (the largest, in every
   frame) is first placed on the cells two by two (a quarter of the bits), and only its
   best poses there are placed at full resolution.
3. The other islands go by their boxes (lying or standing), smallest last, on a grid
   ``_FINER`` times finer, into the room left, holes first (the free positions worked out
   once per run of boxes of one size); the tiniest on shelves in blocks first.
4. Both steps run by two placement rules (xatlas's smallest square, Blender's nearest
   corner); the packing with the smaller square is kept, then turned as a whole to the
   angle of its smallest bounding square. The rules place the large islands side by
   side, so that while their layouts are the same the free positions serve both; the
   boxes go in first by the rule whose large islands left the smaller square, and the
   other rule's boxes stop once its square cannot be the smaller (most often before the
   first: the boxes fill holes).

Islands end ``2 * margin`` apart at least: each is grown by half of it (its cells cover
every point within that Chebyshev distance), and grown islands never share a cell. Pure
numpy (and Python's integers as bit sets); the loops run once per large island and pose,
once per run of an island's cells, and once per size of box (per rule).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.ndimage

from .. import progress
from ..geometry import TINY, corner_signed_areas
from ..mesh.islands import Islands
from .placement import boxes, shelves

__all__ = ["Packing", "pack_layout"]


_CELLS = 200  # cells along the side of a square as large as the islands' boxes together
_SHAPED = 48  # the largest islands, placed by their cells (beyond them: _BOXY); the rest by their boxes
_SHAPED_CELLS = 64  # ... if their tightest box spans this many cells at least
_BOXY = 0.9  # beyond _SHAPED, the islands that fill less than this share of their box too
_TURNED = 4  # the largest islands, tried in more frames (turns between the two boxes')
_BETWEEN = 3  # turns of pi / 8 apart tried beyond the tightest box's
_FINER = 2  # the boxes' grid: cells this many times finer
_TINY = 2  # islands under this many fine cells (grown) go on shelves in blocks
_BLOCK = 12  # the side of those blocks, in fine cells
_TIE = 1e-6  # relative differences below this are ties (decided by island number, or angle)
_RULES = ("square", "corner")  # the placement rules tried (:func:`_best_box`)
_SCREENED = 8  # islands tried in more poses than this are screened on a grid twice as coarse
_SCREEN = 4  # ... and only their best poses there are placed at full resolution
_TRIES = 6  # packings at most, each with a gap guessed from the last (:func:`_next_guess`)
_PAD_CELLS = 2  # the pad (half the gap between islands) spans at most this many cells
_ANGLES = 16  # first search for the tightest box, over a quarter turn; then refined


@dataclass(frozen=True)
class Packing:
    """A packed layout.

    Attributes
    ----------
    uv : (t, 3, 2) float64
        The corner UVs, in the unit square, ``margin`` from its sides.
    cell : float
        The raster's cell (the large islands'), as a share of the square's side.
    shaped : int
        Islands placed by their shapes (the rest by their boxes).
    gap_kept : float
        The share of the gap asked (``2 * margin``) that the islands keep at least: 1
        where it is kept, less where the margin is too wide for so many islands (the
        gaps alone would need more than the square).
    """

    uv: np.ndarray
    cell: float
    shaped: int
    gap_kept: float = 1.0


@dataclass(frozen=True)
class _Frame:
    """Per island: the turn to its tightest box and the box, in layout units."""

    angle: np.ndarray  # (n,)
    lo: np.ndarray  # (n, 2), of the turned island
    size: np.ndarray  # (n, 2)


def pack_layout(uv, island, n: int, margin: float = 0.0, aspect: float = 1.0) -> Packing:
    """The islands of the layout ``uv`` (t, 3, 2) (``island`` (t,) numbered below ``n``;
    relative sizes are kept, positions and turns are not) packed into the unit square.

    ``margin`` is the space kept around every island, as a share of the square's side:
    islands end at least ``2 * margin`` apart and ``margin`` from the sides (Blender's
    pack margin method FRACTION). ``aspect`` is the texture's width over its height: ``uv``
    is then in texels' proportions scaled (u already divided by ``aspect``, as the
    operator writes it), and the islands are packed in the texture's shape.
    """
    uv = np.asarray(uv, dtype=np.float64)
    t = len(uv)
    if not t:
        return Packing(uv.copy(), 0.0, 0)
    if not np.isfinite(uv).all():
        raise ValueError("pack_layout: UVs that are not finite")
    margin = float(min(max(margin, 0.0), 0.49))
    order = np.argsort(island, kind="stable")
    label = np.asarray(island, dtype=np.int64)[order]
    pts = uv[order].copy()
    pts[..., 0] *= aspect  # square texels
    present, label = np.unique(label, return_inverse=True)
    label = label.ravel()
    k = len(present)
    corners = Islands(np.repeat(label, 3), k)
    flat = pts.reshape(-1, 2)
    outline = _outline(pts, label)
    rim = np.flatnonzero(np.repeat(outline, 3))  # the rows that bound the islands
    edge = Islands(corners.label[rim], k)
    frames = list(_tightest_boxes(flat[rim], edge))
    frames += [_frame_at(flat[rim], edge, frames[0].angle + j * np.pi / 8) for j in range(1, _BETWEEN + 1)]
    island_area = np.bincount(label, np.abs(corner_signed_areas(pts)), minlength=k)
    area = float(island_area.sum())
    boxes_area = float(np.prod(frames[0].size, axis=1).sum())
    room = max(boxes_area, area, TINY)
    # the cell follows the square the layout will need: the boxes' area, or half the
    # longest island's side where that is more (a long strip would take thousands of cells)
    cell = max(np.sqrt(room), 0.5 * float(frames[1].size.max(initial=0.0))) / _CELLS
    # the gap in layout units follows the side the layout ends up with: guessed, then
    # checked against the side packed, and packed again wider if it was short
    guess = np.sqrt(room / 0.5) / (1.0 - 2.0 * margin)
    tried: list[tuple[float, float]] = []  # (side guessed, side packed)
    with progress.stage("packing", 0.0, 1.0):
        for _ in range(_TRIES):
            gap = 2.0 * margin * guess * max(aspect, 1.0)
            # (a margin wide against the islands sets the cell: a pad of many cells would
            # spread the boxes' grid over thousands of cells for gaps)
            grid_cell = max(cell, 0.5 * gap / _PAD_CELLS)
            placed, shaped = _pack_units(flat, corners, outline, frames, island_area, grid_cell, 0.5 * gap, aspect)
            placed = _squarest(placed, rim, aspect)
            lo = placed.min(axis=0)
            ext = placed.max(axis=0) - lo
            side = max(ext[0] / aspect, ext[1], TINY) / (1.0 - 2.0 * margin)
            if 2.0 * margin * side * max(aspect, 1.0) <= gap * (1 + 1e-9):
                break
            tried.append((guess, side))
            guess = _next_guess(tried)
        out = np.empty_like(flat)
        out[:, 0] = margin + (placed[:, 0] - lo[0]) / (aspect * side)
        out[:, 1] = margin + (placed[:, 1] - lo[1]) / side
    result = np.empty_like(uv)
    result[order] = out.reshape(-1, 3, 2)
    short = 2.0 * margin * side * max(aspect, 1.0)
    return Packing(result, grid_cell / side, shaped, min(1.0, gap / short) if short > 0 else 1.0)


def _next_guess(tried: list[tuple[float, float]]) -> float:
    """The side to guess the gap from after the tries ``tried`` ((side guessed, side
    packed), the last one short): 2% above the side packed, or, where the side packed
    grows with the side guessed slower than it (a wide margin: the gaps make the side),
    2% above where the line through the last two tries meets the side guessed."""
    guessed, packed = tried[-1]
    nxt = 1.02 * packed
    if len(tried) > 1 and tried[-2][0] != guessed:
        slope = (packed - tried[-2][1]) / (guessed - tried[-2][0])
        if 0.0 <= slope < 0.9:
            nxt = max(nxt, 1.02 * (packed - slope * guessed) / (1.0 - slope))
    return nxt


def _squarest(points: np.ndarray, rim: np.ndarray, aspect: float) -> np.ndarray:
    """The packed layout ``points`` (r, 2) turned as one (rigidly: nothing moves apart or
    together) to the angle whose bounding box, in the texture's shape, is smallest; kept as
    it is unless that saves more than a tie. Packed along the axes, a layout often leaves
    its corners empty: turned, its square shrinks (Blender's packer turns its first
    islands as a group this way, ``rotate_inside_square``). ``rim``: the rows that may
    bound the layout (the islands' outlines)."""
    whole = Islands(np.zeros(len(rim), dtype=np.int64), 1)
    hull = points[rim][_hull_candidates(points[rim], whole)]
    hull = hull - hull.mean(axis=0)

    def side(angle):
        c, s = np.cos(angle)[:, None], np.sin(angle)[:, None]
        u = c * hull[None, :, 0] + s * hull[None, :, 1]
        v = c * hull[None, :, 1] - s * hull[None, :, 0]
        return np.maximum(np.ptp(u, axis=1) / aspect, np.ptp(v, axis=1))

    step = 0.5 * np.pi / 64
    angles = np.arange(64) * step
    best = angles[int(np.argmin(side(angles)))]
    fine = best + np.linspace(-step, step, 17)
    best = fine[int(np.argmin(side(fine)))]
    if side(np.array([best]))[0] >= side(np.zeros(1))[0] * (1 - _TIE):
        return points
    return _turn(points, Islands(np.zeros(len(points), dtype=np.int64), 1), np.array([best]))


# ---------------------------------------------------------------------------- boxes


def _turn(points, groups: Islands, angle) -> np.ndarray:
    """Rows of ``points`` (r, 2) turned clockwise by their island's ``angle`` (n,): as
    :func:`.placement.rotated` by ``-angle``, with one sine and cosine per island, not per row."""
    c, s = groups.expand(np.cos(angle)), groups.expand(np.sin(angle))
    x, y = points[:, 0], points[:, 1]
    return np.stack([c * x + s * y, c * y - s * x], axis=1)


def _box_sizes(points, groups: Islands, angle) -> np.ndarray:
    lo, hi = boxes(_turn(points, groups, angle), groups)
    return hi - lo


def _frame_at(points, groups: Islands, angle) -> _Frame:
    lo, hi = boxes(_turn(points, groups, angle), groups)
    return _Frame(angle, lo, hi - lo)


def _hull_candidates(points, groups: Islands) -> np.ndarray:
    """Rows that may be corners of their island's convex hull: not strictly inside the
    octagon through the island's extreme rows in eight directions (Akl and Toussaint's
    filter); usually a small share of the rows."""
    x, y = points[:, 0], points[:, 1]
    keep = np.zeros(len(points), dtype=bool)
    dirs = [(1.0, 0.0), (1.0, 1.0), (0.0, 1.0), (-1.0, 1.0), (-1.0, 0.0), (-1.0, -1.0), (0.0, -1.0), (1.0, -1.0)]
    extreme = []
    for dx, dy in dirs:
        proj = dx * x + dy * y
        top = groups.max(proj)
        at = proj >= groups.expand(top)
        first = groups.first(at)
        keep[first] = True
        extreme.append(points[first])
    inside = np.ones(len(points), dtype=bool)
    for a, b in zip(extreme, extreme[1:] + extreme[:1]):
        # the octagon runs counter-clockwise: inside is left of every edge a -> b
        ea, eb = groups.expand(a), groups.expand(b)
        cross = (eb[:, 0] - ea[:, 0]) * (y - ea[:, 1]) - (eb[:, 1] - ea[:, 1]) * (x - ea[:, 0])
        same = groups.expand(np.all(a == b, axis=1))  # (merged corners: no edge)
        inside &= (cross > 0) | same
    return np.flatnonzero(keep | ~inside)


def _tightest_boxes(points, groups: Islands) -> tuple[_Frame, _Frame]:
    """Per island, two turns (within a quarter): the one whose bounding box has the least
    area, and the one whose box has the shortest longer side (the smallest square around
    the island). ``_ANGLES`` angles, then a finer search around each best; only rows that
    may be on the convex hull are turned."""
    rows = _hull_candidates(points, groups)
    sub = Islands(groups.label[rows], groups.n)
    pts = points[rows] - sub.expand(sub.mean(points[rows]))
    n = groups.n
    step = 0.5 * np.pi / _ANGLES
    measures = (lambda s: s[:, 0] * s[:, 1], lambda s: s.max(axis=1))
    best = [np.full(n, np.inf), np.full(n, np.inf)]
    angle = [np.zeros(n), np.zeros(n)]

    def consider(a, which):
        a = np.broadcast_to(a, (n,))
        size = _box_sizes(pts, sub, a)
        for j in which:
            value = measures[j](size)
            better = value < best[j] * (1 - _TIE)
            best[j] = np.where(better, value, best[j])
            angle[j] = np.where(better, a, angle[j])

    for a in np.arange(_ANGLES) * step:
        consider(a, (0, 1))
    for j in (0, 1):  # refine around each island's best
        base = angle[j].copy()
        for i in (-3, -2, -1, 1, 2, 3):
            consider(base + i * step / 4, (j,))
    frames = []
    for a in angle:
        lo, hi = boxes(_turn(points, groups, a), groups)
        frames.append(_Frame(a, lo, hi - lo))
    return frames[0], frames[1]


# ---------------------------------------------------------------------------- units


def _framed(flat, corners: Islands, frame: _Frame) -> np.ndarray:
    return _turn(flat, corners, frame.angle) - corners.expand(frame.lo)


def _pack_units(
    flat, corners: Islands, outline, frames: list[_Frame], island_area, cell: float, pad: float, aspect: float
):
    """Place every island of the rows ``flat``, each grown by ``pad``; the rows where they
    went (layout units) and the number of islands placed by their shapes. ``outline``:
    the triangles that mark an island's cells (:func:`_outline`); ``island_area`` (n,):
    each island's UV area."""
    n, nf = corners.n, len(frames)
    rank = np.empty(n, dtype=np.int64)
    box = np.prod(frames[0].size, axis=1)
    alike = np.round(box / max(float(box.max()) * _TIE, TINY))  # (islands alike up to rounding tie)
    rank[np.lexsort((np.arange(n), -alike))] = np.arange(n)
    # shapes for the largest islands, and beyond them for those a box would fit loosely
    # (a square is placed as well by its box, on the finer grid); only for islands whose
    # box spans _SHAPED_CELLS cells: a smaller one differs from its box by a few cells, and
    # a box's free positions cost less
    big = box >= _SHAPED_CELLS * cell * cell
    shaped = (rank < min(_SHAPED, int(big.sum()))) | (big & (island_area < _BOXY * box))
    n_shaped = int(shaped.sum())
    by_rank = np.argsort(rank)
    by_rank = by_rank[shaped[by_rank]]
    slot = np.zeros(n, dtype=np.int64)
    slot[by_rank] = np.arange(n_shaped)
    # the shapes: one per frame of each large island, numbered nf * slot + frame
    # (the frames beyond the first two only for the _TURNED largest, which try them all)
    tri_label = corners.label[::3]
    pick = np.flatnonzero(shaped[tri_label] & outline)
    coords, units = [], []
    for f, frame in enumerate(frames):
        if f >= 2:
            pick = pick[slot[tri_label[pick]] < _TURNED]
        rows = (3 * pick[:, None] + np.arange(3)).ravel()
        coords.append((_framed(flat[rows], Islands(corners.label[rows], n), frame) + pad).reshape(-1, 3, 2))
        units.append(nf * slot[tri_label[pick]] + f)
    masks, dims = _rasterize(np.concatenate(coords), np.concatenate(units), nf * n_shaped, cell, pad)
    masks = _filled(masks)  # the cells the outlines enclose
    # the small islands' boxes, on a finer grid (closed: a side on a cell's edge takes the next)
    fine = cell / _FINER
    unit, offset, unit_size = _box_units(frames[0].size, ~shaped, pad, fine)
    box_cells = np.floor(unit_size / fine).astype(np.int64) + 1
    lying = np.sort(box_cells, axis=1)[:, ::-1]  # (long, short): one run per size, either way up
    standing = box_cells[:, 1] > box_cells[:, 0]
    k = len(box_cells)
    boxes_order = np.lexsort((np.arange(k), lying[:, 1], lying[:, 0], -np.prod(lying, axis=1)))
    where, shape, turn, box_where, box_turn = _best_of_rules(
        masks, _choices(frames, by_rank, nf), lying[boxes_order], aspect
    )
    placed_at, placed_turn = np.zeros((k, 2)), np.zeros(k, dtype=np.int64)
    placed_at[boxes_order], placed_turn[boxes_order] = box_where * fine, box_turn ^ standing[boxes_order]
    # per island: its frame, its cells' extent and lower-left corner (layout units), turn
    extent = np.zeros((n, 2))
    at = np.zeros((n, 2))
    q = np.zeros(n, dtype=np.int64)
    which = np.zeros(n, dtype=np.int64)
    extent[by_rank], at[by_rank], q[by_rank], which[by_rank] = dims[shape] * cell, where * cell, turn, shape % nf
    small = np.flatnonzero(unit >= 0)
    u = unit[small]
    extent[small], at[small], q[small] = box_cells[u] * fine, placed_at[u], placed_turn[u]
    chosen = _Frame(
        np.choose(which, [f.angle for f in frames]),
        np.stack([np.choose(which, [f.lo[:, c] for f in frames]) for c in range(2)], axis=1),
        np.zeros((n, 2)),
    )
    local = _framed(flat, corners, chosen) + pad + corners.expand(offset)
    W, H = corners.expand(extent[:, 0]), corners.expand(extent[:, 1])
    x, y, qr = local[:, 0], local[:, 1], corners.expand(q)
    px = np.select([qr == 1, qr == 2, qr == 3], [H - y, W - x, y], x)
    py = np.select([qr == 1, qr == 2, qr == 3], [x, H - y, W - x], y)
    return np.stack([px, py], axis=1) + corners.expand(at), n_shaped


def _outline(pts: np.ndarray, label: np.ndarray) -> np.ndarray:
    """Per triangle of ``pts`` (t, 3, 2) (islands ``label`` (t,)), whether it may touch its
    island's outline: it has an edge that no other triangle of the island shares (corners
    matched by their UVs; an edge shared three times counts as open), or it is flipped or
    degenerate against its island's orientation.

    An island where no triangle folds is locally one-to-one away from such triangles, so
    every point of the outline of its faces lies on one of them: the cells they mark, and
    every cell those enclose, are all the cells the island touches. Rasterizing them
    alone makes the raster's work follow the outlines, not the faces."""
    t = len(pts)
    flat = pts.reshape(-1, 2)
    lab3 = np.repeat(label, 3)
    order = np.lexsort((flat[:, 1], flat[:, 0], lab3))
    new = np.ones(3 * t, dtype=bool)
    new[1:] = (lab3[order][1:] != lab3[order][:-1]) | (flat[order][1:] != flat[order][:-1]).any(axis=1)
    corner = np.empty(3 * t, dtype=np.int64)
    corner[order] = np.cumsum(new) - 1
    a = corner.reshape(-1, 3)
    b = np.roll(a, -1, axis=1)
    _, edge, shared = np.unique(np.minimum(a, b) * (3 * t) + np.maximum(a, b), return_inverse=True, return_counts=True)
    open_edge = (shared[edge.ravel()] != 2).reshape(-1, 3).any(axis=1)
    area = corner_signed_areas(pts)
    way = np.bincount(label, weights=area, minlength=int(label.max(initial=0)) + 1)[label]
    return open_edge | (area * way <= 0.0)


def _box_units(size, small, pad: float, fine: float):
    """The units the ``small`` (n,) islands (tightest boxes ``size`` (n, 2)) are placed in by
    their boxes: each on its own, but the tiny ones (under ``_TINY`` fine cells, grown by
    ``pad``) shelved into blocks of about ``_BLOCK`` cells square, ``2 * pad`` apart
    (:func:`.placement.shelves`), so that a cell's rounding is not paid per island.

    Returns per island its unit (-1: none), its corner within the unit (layout units, the
    pad not counted), and per unit its size grown by ``pad`` on every side (k, 2)."""
    n = len(size)
    unit = np.full(n, -1, dtype=np.int64)
    offset = np.zeros((n, 2))
    grown = size + 2.0 * pad
    tiny = small & (grown.max(axis=1) < _TINY * fine)
    alone = np.flatnonzero(small & ~tiny)
    unit[alone] = np.arange(len(alone))
    sizes = [grown[alone]]
    few = np.flatnonzero(tiny)
    if len(few):
        few = few[np.lexsort((few, -size[few, 1]))]  # by height: blocks of like islands
        area = np.prod(grown[few], axis=1)
        block = np.floor((np.cumsum(area) - area) / (_BLOCK * fine) ** 2).astype(np.int64)
        offset[few] = shelves(size[few], 2.0 * pad, group=block)
        reach = np.zeros((int(block.max()) + 1, 2))
        np.maximum.at(reach, block, offset[few] + size[few])
        unit[few] = len(alone) + block
        sizes.append(reach + 2.0 * pad)
    return unit, offset, np.concatenate(sizes)


def _best_of_rules(masks, choices, boxes_lying: np.ndarray, aspect: float):
    """The large islands (``masks``, ``choices`` as :func:`_place` takes them), then the
    small ones' boxes (``boxes_lying``: columns >= rows), placed by each rule of
    ``_RULES``: the greedy placement is short-sighted, so the rule that leaves the smaller
    square is kept (the first on a tie). Returns the large islands' cells, shapes and
    turns, and the boxes' cells (on the grid ``_FINER`` times finer) and turns.

    A layout's square only grows as boxes go in, so the rule whose large islands leave the
    smaller square places its boxes first, and the other's stop as soon as they cannot
    leave a smaller one: on most layouts before their first box (the boxes fill holes)."""

    def square(ex: int, ey: int) -> tuple[float, int]:
        return (max(ex / aspect, ey), ex * ey)

    layouts = _place(masks, choices, aspect)
    start = [square(lay.ex * _FINER, lay.ey * _FINER) for lay in layouts]
    best: tuple | None = None  # ((square, rule number), what it placed)
    for r in sorted(range(len(layouts)), key=lambda r: (start[r], r)):
        lay = layouts[r]
        bound = None if best is None else best[0]
        if bound is not None and (start[r], r) > bound:
            continue
        box_where, box_turn = np.zeros((0, 2), dtype=np.int64), np.zeros(0, dtype=np.int64)
        ex, ey = lay.ex * _FINER, lay.ey * _FINER
        if len(boxes_lying):
            grid = np.repeat(np.repeat(lay.grid > 0, _FINER, axis=0), _FINER, axis=1)
            stop = None if bound is None else (lambda ex, ey, r=r, bound=bound: (square(ex, ey), r) > bound)
            placed = _place_boxes(grid, ex, ey, boxes_lying, aspect, lay.rule, stop)
            if placed is None:
                continue
            box_where, box_turn, ex, ey = placed
        key = (square(ex, ey), r)
        if best is None or key < best[0]:
            best = (key, (lay.where, lay.shape, lay.turn, box_where, box_turn))
    assert best is not None
    return best[1]


def _choices(frames: list[_Frame], by_rank: np.ndarray, nf: int) -> list[list[int]]:
    """The shapes (numbered ``nf * slot + frame``, ``slot`` the island's place in ``by_rank``) tried
    for each large island, by rank:
    every frame for the ``_TURNED`` largest, the first two for the rest, less the frames a
    quarter turn (or none) from an earlier one."""
    angles = np.stack([f.angle[by_rank] for f in frames], axis=1)
    apart = (angles[:, :, None] - angles[:, None, :]) / (0.5 * np.pi)
    repeat = (np.abs(apart - np.round(apart)) < 1e-9) & np.tril(np.ones((nf, nf), dtype=bool), -1)[None]
    return [
        [nf * j + f for f in range(nf if j < _TURNED else min(nf, 2)) if not repeat[j, f].any()]
        for j in range(len(by_rank))
    ]


# ---------------------------------------------------------------------------- raster


def _rasterize(tri, unit, n_units: int, cell: float, pad: float = 0.0):
    """Every unit's cells within Chebyshev distance ``pad`` of its triangles ``tri``
    (t, 3, 2), coordinates >= ``pad``: a bool mask (rows y, columns x) per unit, and the
    masks' (columns, rows) (k, 2).

    Conservative: a cell is marked when the closed triangle meets the closed cell grown by
    ``pad`` (separating axes: the box's two and the triangle's three edge normals, with a
    tolerance of 1e-9 cell), so every point within ``pad`` of an island lies in a marked
    cell. The triangles are tested in groups of one box size (in cells), each group one
    broadcast."""
    p = tri / cell
    grow = pad / cell
    lo_c = np.maximum(np.floor(np.minimum(np.minimum(p[:, 0], p[:, 1]), p[:, 2]) - grow), 0).astype(np.int64)
    hi_c = np.floor(np.maximum(np.maximum(p[:, 0], p[:, 1]), p[:, 2]) + grow).astype(np.int64)
    dims = np.zeros((n_units, 2), dtype=np.int64)
    np.maximum.at(dims, unit, hi_c + 1)
    start = np.zeros(n_units + 1, dtype=np.int64)
    start[1:] = np.cumsum(dims[:, 0] * dims[:, 1])
    buffer = np.zeros(int(start[-1]), dtype=bool)
    base = start[unit] + lo_c[:, 1] * dims[unit, 0] + lo_c[:, 0]  # each box's first cell
    span = hi_c - lo_c + 1
    one = (span == 1).all(axis=1)
    buffer[base[one]] = True  # a triangle within one cell marks it
    # per triangle and edge, the outward normal n (in cells) and the bound on n . c for
    # the centre c of a cell the edge's closed half-plane meets (grown cell: half 0.5 + grow)
    nx = np.roll(p[:, :, 1], -1, axis=1) - p[:, :, 1]
    ny = p[:, :, 0] - np.roll(p[:, :, 0], -1, axis=1)
    flip = np.where(corner_signed_areas(p) < 0, -1.0, 1.0)[:, None]
    nx, ny = nx * flip, ny * flip
    reach = (0.5 + grow) * (np.abs(nx) + np.abs(ny))
    bound = nx * p[:, :, 0] + ny * p[:, :, 1] + reach * (1 + 1e-9) + 1e-9
    rest = np.flatnonzero(~one)
    key = span[rest, 0] * (int(span[:, 1].max(initial=1)) + 1) + span[rest, 1]
    sizes, group = np.unique(key, return_inverse=True)
    group = group.ravel()
    by_group = np.argsort(group, kind="stable")
    cut = np.searchsorted(group[by_group], np.arange(len(sizes) + 1))
    for g in range(len(sizes)):  # one broadcast per box size
        tris = rest[by_group[cut[g] : cut[g + 1]]]
        sx, sy = int(span[tris[0], 0]), int(span[tris[0], 1])
        cx = lo_c[tris, 0][:, None, None] + 0.5 + np.arange(sx)[None, None, :]
        cy = lo_c[tris, 1][:, None, None] + 0.5 + np.arange(sy)[None, :, None]
        keep = np.ones((len(tris), sy, sx), dtype=bool)
        for e in range(3):
            keep &= nx[tris, e][:, None, None] * cx + ny[tris, e][:, None, None] * cy <= bound[tris, e][:, None, None]
        t_i, yy, xx = np.nonzero(keep)
        tt = tris[t_i]
        buffer[base[tt] + yy * dims[unit[tt], 0] + xx] = True
    masks = [buffer[start[i] : start[i + 1]].reshape(dims[i, 1], dims[i, 0]) for i in range(n_units)]
    return masks, dims


def _filled(masks: list[np.ndarray]) -> list[np.ndarray]:
    """The masks with the cells they enclose filled (holes: free cells 4-connected to no
    border, as ``scipy.ndimage.binary_fill_holes`` fills them), all in one labelling: the
    masks stacked one above the other, a free row between and a free column beside, so
    that every mask's outside meets the image's border and no hole meets another mask."""
    if not masks:
        return []
    width = max(m.shape[1] for m in masks) + 1
    top = np.cumsum([0] + [m.shape[0] + 1 for m in masks])
    image = np.zeros((int(top[-1]) + 1, width), dtype=bool)
    for m, y in zip(masks, top):
        image[y + 1 : y + 1 + m.shape[0], : m.shape[1]] = m
    label, n = scipy.ndimage.label(~image)
    outside = np.zeros(n + 1, dtype=bool)
    for side in (label[0], label[-1], label[:, 0], label[:, -1]):
        outside[side] = True
    image |= ~outside[label]
    return [image[y + 1 : y + 1 + m.shape[0], : m.shape[1]] for m, y in zip(masks, top)]


def _turned_masks(mask: np.ndarray) -> list[np.ndarray]:
    """The mask's four quarter turns counter-clockwise (x right, y up), as the rows move in
    :func:`_pack_units`."""
    return [mask, mask.T[:, ::-1], mask[::-1, ::-1], mask.T[::-1, :]]


def _room(grid: np.ndarray, need: int) -> np.ndarray:
    """``grid``, made at least ``need`` cells square (twice that, when it must grow)."""
    if need <= min(grid.shape):
        return grid
    bigger = np.zeros((2 * need, 2 * need), dtype=grid.dtype)
    bigger[: grid.shape[0], : grid.shape[1]] = grid
    return bigger


@dataclass
class _Layout:
    """The large islands placed by one rule: the cells taken (``grid[y, x]``), the columns
    ``ex`` and rows ``ey`` they span, and per island its mask's lower-left cell, shape and
    quarter turn."""

    rule: str
    grid: np.ndarray
    where: np.ndarray  # (k, 2)
    shape: np.ndarray  # (k,)
    turn: np.ndarray  # (k,)
    ex: int = 0
    ey: int = 0

    def region(self, reach: int) -> np.ndarray:
        """The cells where a pose at most ``reach`` cells across can be placed (the grid
        made larger first where it is short)."""
        self.grid = _room(self.grid, max(self.ex, self.ey) + reach)
        return self.grid[: min(self.ey + reach, self.grid.shape[0]), : min(self.ex + reach, self.grid.shape[1])]

    def take(self, u: int, x: int, y: int, mask: np.ndarray, shape: int, turn: int) -> None:
        """Unit ``u`` placed with its lower-left cell at (``x``, ``y``): the cells of
        ``mask`` (its ``shape`` in its quarter ``turn``) taken."""
        h, w = mask.shape
        self.grid[y : y + h, x : x + w] += mask
        self.ex, self.ey = max(self.ex, x + w), max(self.ey, y + h)
        self.where[u], self.shape[u], self.turn[u] = (x, y), shape, turn


def _place(masks: list[np.ndarray], choices: list[list[int]], aspect: float) -> list[_Layout]:
    """Place the units, largest first, each in the best of its shapes (``choices``: mask
    numbers per unit) and their quarter turns, by every rule of ``_RULES`` side by side
    (while the rules' layouts are the same, a pose's free positions serve both). Returns
    the layouts, one per rule, in the order of ``_RULES``."""
    k = len(choices)
    cells = np.array([masks[c[0]].sum() for c in choices])
    order = np.lexsort((np.arange(k), -cells))
    biggest = max((max(masks[c].shape) for pose in choices for c in pose), default=1)
    side = int(np.ceil(np.sqrt(sum(masks[c[0]].size for c in choices)) * 1.6)) + biggest
    layouts = [
        _Layout(
            rule,
            np.zeros((side, side), dtype=np.float32),
            np.zeros((k, 2), dtype=np.int64),
            np.zeros(k, dtype=np.int64),
            np.zeros(k, dtype=np.int64),
        )
        for rule in _RULES
    ]
    for done, u in enumerate(order):
        progress.tick(done / max(k, 1))
        poses = [(c, q, m) for c in choices[u] for q, m in enumerate(_turned_masks(masks[c]))]
        tried = [m for _, _, m in poses]
        reach = max(max(masks[c].shape) for c in choices[u])
        regions = [lay.region(reach) for lay in layouts]
        free = _free_maps(regions, tried, _screened(regions, tried, layouts, aspect))
        for lay, f in zip(layouts, free):
            i, x, y = _best_pose(f, tried, lay.ex, lay.ey, aspect, lay.rule)
            c, q, m = poses[i]
            lay.take(u, x, y, m, c, q)
    return layouts


def _pooled(mask: np.ndarray) -> np.ndarray:
    """``mask``'s cells two by two: a coarse cell is taken where any of its four is."""
    h, w = mask.shape
    padded = np.zeros((h + h % 2, w + w % 2), dtype=bool)
    padded[:h, :w] = mask > 0
    return padded[0::2, 0::2] | padded[1::2, 0::2] | padded[0::2, 1::2] | padded[1::2, 1::2]


def _screened(regions: list[np.ndarray], poses: list[np.ndarray], layouts: list[_Layout], aspect: float):
    """Per layout, the poses worth placing at full resolution: for an island tried in more
    than ``_SCREENED`` poses, the ``_SCREEN`` best when each is placed on the cells two by
    two (a coarse fit is a fine one); all of them for the others."""
    every = list(range(len(poses)))
    if len(poses) <= _SCREENED or not any(r.any() for r in regions):
        return [every for _ in regions]
    coarse = [_pooled(m) for m in poses]
    # (two free rows and columns beyond the region, as in the grid: a region of an odd
    # side would otherwise lose its last, free, row or column to the coarse cells)
    pooled = [_pooled(np.pad(r > 0, ((0, 2), (0, 2)))) for r in regions]
    kept = []
    for lay, region, free in zip(layouts, regions, _free_maps(pooled, coarse, None)):
        if not region.any():
            kept.append(every)
            continue
        keys = []
        for j, (f, m) in enumerate(zip(free, coarse)):
            found = _best_in(_Free(f), m.shape[1], m.shape[0], (lay.ex + 1) // 2, (lay.ey + 1) // 2, aspect, lay.rule)
            keys.append(((0,) + found[0] if found is not None else (1,), j))
        kept.append(sorted(j for _, j in sorted(keys)[:_SCREEN]))
    return kept


class _Free:
    """A map of a shape's free lower-left cells (``cells[y, x]``) and, per row, its first
    free cell (``first``; ``any``: whether the row has one): both rules read only those
    (along a row, each rule's best position is its first free cell). A box placed rules
    out a window of positions; only the rows whose first free cell it covered are searched
    again."""

    def __init__(self, cells: np.ndarray):
        self.cells = cells
        rows = np.arange(len(cells))
        self.first = cells.argmax(axis=1) if cells.size else np.zeros(len(cells), dtype=np.int64)
        self.any = cells[rows, self.first] if cells.size else np.zeros(len(cells), dtype=bool)

    def take(self, y0: int, y1: int, x0: int, x1: int) -> None:
        """The positions in rows ``y0:y1``, columns ``x0:x1`` no longer free."""
        self.cells[y0:y1, x0:x1] = False
        first = self.first[y0:y1]
        again = y0 + np.flatnonzero(self.any[y0:y1] & (first >= x0) & (first < x1))
        if len(again):
            found = self.cells[again].argmax(axis=1)
            self.first[again] = found
            self.any[again] = self.cells[again, found]


def _place_boxes(grid: np.ndarray, ex: int, ey: int, cells: np.ndarray, aspect: float, rule: str, stop=None):
    """Boxes of ``cells`` (k, 2) (columns, rows; boxes of one size next to each other)
    placed one by one, in order, lying or standing, at the free position (``grid``'s cells
    taken) that keeps the bounding square smallest, then nearest the origin, as
    :func:`_place` does. Returns per box its lower-left cell (k, 2) and quarter turn (0 or
    1); None once ``stop(ex, ey)`` (if given) holds for the cells spanned.

    Where a box fits is worked out once per run of boxes of one size (:class:`_Cells`);
    each box placed then rules out the positions it covers, and only the rows whose first
    free position it took are searched again (:class:`_Free`)."""
    k = len(cells)
    where = np.zeros((k, 2), dtype=np.int64)
    turn = np.zeros(k, dtype=np.int64)
    i = 0
    while i < k:
        progress.tick(i / max(k, 1))
        w0, h0 = int(cells[i, 0]), int(cells[i, 1])
        run_end = i + 1
        while run_end < k and (cells[run_end] == cells[i]).all():
            run_end += 1
        reach = max(w0, h0)
        grid = _room(grid, max(ex, ey) + reach)
        ax, ay = min(ex + reach, grid.shape[1]), min(ey + reach, grid.shape[0])
        region = _Cells(~grid[:ay, :ax])
        shapes = [(w0, h0)] if w0 == h0 else [(w0, h0), (h0, w0)]
        free = [_Free(region.fits(_box_runs(w, h), ay - h + 1, ax - w + 1)) for w, h in shapes]
        grown = False
        while i < run_end and not grown:
            q, x, y = _best_box(free, shapes, ex, ey, aspect, rule)
            w, h = shapes[q]
            grid[y : y + h, x : x + w] = True
            for (w2, h2), f in zip(shapes, free):  # the positions that now overlap it
                f.take(max(y - h2 + 1, 0), y + h, max(x - w2 + 1, 0), x + w)
            grown = x + w > ex or y + h > ey
            ex, ey = max(ex, x + w), max(ey, y + h)
            where[i], turn[i] = (x, y), q
            i += 1
            if grown and stop is not None and stop(ex, ey):
                return None
    return where, turn, ex, ey


def _best_box(free: list[_Free], shapes, ex: int, ey: int, aspect: float, rule: str):
    """The turn and lower-left cell of the best position among ``free`` (one map of free
    lower-left cells per shape (columns, rows)), by ``rule``:

    - ``"square"`` (xatlas's): the position that leaves the smallest bounding square, then
      the smallest bounding box; within the cells spanned so far (all alike by that), the
      one whose lower-left cell is nearest the origin (least ``max(x, y)``);
    - ``"corner"`` (Blender's ``find_best_fit_for_island``): the position whose upper-right
      corner is nearest the origin (least ``max(x + w, y + h)``), whatever the square.

    Ties go to the lowest, then leftmost."""
    best = None
    for q, ((w, h), f) in enumerate(zip(shapes, free)):
        found = _best_in(f, w, h, ex, ey, aspect, rule)
        if found is not None and (best is None or found[0] < best[0]):
            best = (found[0], q, found[1], found[2])
    if best is None:  # (positions beside the cells taken are always free)
        raise AssertionError("packing: no free position")
    return best[1], best[2], best[3]


def _best_in(f: _Free, w: int, h: int, ex: int, ey: int, aspect: float, rule: str):
    """The key (as :func:`_best_box` ranks positions) and lower-left cell of the best free
    position of one shape of ``w`` x ``h`` cells, ``f`` its map of free lower-left cells;
    None where it fits nowhere."""
    if not f.cells.size:
        return None
    # both rules grow with x along a row: each row's best is its first free cell
    y = np.flatnonzero(f.any)
    if not len(y):
        return None
    x = f.first[y]
    inner = (x + w <= ex) & (y + h <= ey)
    if rule == "square" and inner.any():
        x, y = x[inner], y[inner]
    if rule == "corner" or inner.any():
        reach = np.maximum(x, y) if rule == "square" else np.maximum((x + w) / aspect, y + h)
        j = int(np.argmin(reach))  # (rows ascend, one position each: the lowest of the ties)
        key = (0.0 if rule == "square" else float(reach[j]), float(reach[j]), int(y[j]), int(x[j]))
    else:
        wide, high = np.maximum(ex, x + w), np.maximum(ey, y + h)
        square = np.maximum(wide / aspect, high)
        metric = square * square + wide * high / aspect
        tied = np.flatnonzero(metric == metric.min())
        j = tied[np.lexsort((x[tied], y[tied], np.maximum(x[tied], y[tied])))[0]]
        key = (1.0 + float(metric[j]), float(max(x[j], y[j])), int(y[j]), int(x[j]))
    return key, int(x[j]), int(y[j])


def _free_maps(regions: list[np.ndarray], poses: list[np.ndarray], wanted: list[list[int]] | None):
    """Per region and pose (mask), the map of the pose's lower-left cells where it takes no
    cell the region takes; empty where it does not fit, or is not ``wanted`` (per region,
    pose numbers; None: all). Each region's free cells are one integer (:class:`_Cells`),
    and a pose fits where that integer, shifted by each run of the pose's cells along a
    row, is set for all runs: one shift and one AND per run, for every position at once."""
    free = [[np.zeros((0, 0), dtype=bool) for _ in poses] for _ in regions]
    twin = [_twin(regions, wanted, r) for r in range(len(regions))]  # (the rules agree so far)
    tasks = []  # (region, pose, rows, columns of its map)
    for r, region in enumerate(regions):
        if twin[r] < r:
            continue
        ay, ax = region.shape
        taken = region.any()
        for j in range(len(poses)) if wanted is None else wanted[r]:
            sy, sx = ay - poses[j].shape[0] + 1, ax - poses[j].shape[1] + 1
            if min(sy, sx) <= 0:
                continue
            if taken:
                tasks.append((r, j, sy, sx))
            else:
                free[r][j] = np.ones((sy, sx), dtype=bool)
    need = sorted({j for _, j, _, _ in tasks})
    runs = dict(zip(need, _runs([poses[j] for j in need])))  # per pose, made once for every region
    cells: dict[int, _Cells] = {}
    for r, j, sy, sx in tasks:
        if r not in cells:
            cells[r] = _Cells(regions[r] == 0)
        free[r][j] = cells[r].fits(runs[j], sy, sx)
    return [free[t] for t in twin]


def _runs(masks: list[np.ndarray]) -> list[tuple[list, list, list, list]]:
    """Per mask, the runs of its cells along its rows, rows alike in a run stacked: per
    stack its first row, first column, length and number of rows. All masks at once."""
    if not masks:
        return []
    h = max(m.shape[0] for m in masks)
    w = max(m.shape[1] for m in masks)
    padded = np.zeros((len(masks), h, w + 2), dtype=np.int8)
    for i, m in enumerate(masks):
        padded[i, : m.shape[0], 1 : m.shape[1] + 1] = m
    edge = np.diff(padded, axis=2)
    pose, row, first = np.nonzero(edge == 1)
    end = np.nonzero(edge == -1)[2]
    # a run that the row before has too (same columns) joins its stack
    key = (pose * (w + 1) + first) * (w + 1) + (end - first)
    order = np.lexsort((row, key))
    row, key = row[order], key[order]
    new = np.ones(len(row), dtype=bool)
    new[1:] = (key[1:] != key[:-1]) | (row[1:] != row[:-1] + 1)
    head = np.flatnonzero(new)
    count = np.diff(np.append(head, len(row)))
    rest, length = np.divmod(key[head], w + 1)
    pose, first = np.divmod(rest, w + 1)
    cut = np.searchsorted(pose, np.arange(len(masks) + 1)).tolist()
    rows, firsts, lengths, counts = row[head].tolist(), first.tolist(), length.tolist(), count.tolist()
    return [(rows[a:b], firsts[a:b], lengths[a:b], counts[a:b]) for a, b in zip(cut, cut[1:])]


def _box_runs(w: int, h: int):
    """The runs (as :func:`_runs` gives them) of a box of ``w`` x ``h`` cells."""
    return [0], [0], [w], [h]


class _Cells:
    """A region's free cells (``free[y, x]``) as one integer, bit ``y * width + x``; and
    per run length ``w`` the cells that start ``w`` free cells in a row. A pose whose runs
    are (row ``r``, column ``c``, length ``w``) fits at (``x``, ``y``) where the cells
    starting ``w`` free ones have bit ``(y + r) * width + x + c`` for every run: the
    region's integer shifted and ANDed once per run (a stack of ``k`` rows alike, about
    ``log2 k`` times). Bits that wrap into the next row belong to positions past the
    region's side, which :meth:`fits` leaves out."""

    def __init__(self, free: np.ndarray):
        self.width = free.shape[1]
        self.bits = int.from_bytes(np.packbits(free.ravel(), bitorder="little").tobytes(), "little")
        self.starts = {1: self.bits}  # w: the cells that start w free cells

    def _start(self, lengths) -> None:
        """:attr:`starts` for every one of ``lengths``: from the next shorter one known,
        one cell longer at a time where it is near, else from runs of powers of two
        (``starts(a + b)`` is ``starts(a)`` and ``starts(b)`` shifted by ``a``)."""
        starts = self.starts
        for w in sorted(set(lengths) - set(starts)):
            near = [j for j in (w - 1, w - 2) if j in starts]
            if near:
                for j in range(near[0], w):
                    starts[j + 1] = starts[j] & (self.bits >> j)
                continue
            p = 1
            while 2 * p <= w:
                if 2 * p not in starts:
                    starts[2 * p] = starts[p] & (starts[p] >> p)
                p *= 2
            run, done = starts[p], p
            while done < w:
                q = 1 << ((w - done).bit_length() - 1)
                run &= starts[q] >> done
                done += q
            starts[w] = run

    def fits(self, runs, sy: int, sx: int) -> np.ndarray:
        """The map (``sy``, ``sx``) of the lower-left cells where the pose of ``runs``
        (:func:`_runs`) meets no cell taken."""
        rows, cols, lengths, counts = runs
        self._start(lengths)
        starts, width = self.starts, self.width
        n = sy * width
        fit = (1 << n) - 1
        for r, c, w, k in zip(rows, cols, lengths, counts):
            stack, done = starts[w], 1
            while done < k:  # (rows [0, done) free, then [0, 2 done), up to k)
                stack &= stack >> (min(done, k - done) * width)
                done += min(done, k - done)
            fit &= stack >> (r * width + c)
        row = np.unpackbits(np.frombuffer(fit.to_bytes((n + 7) // 8, "little"), dtype=np.uint8), bitorder="little")
        return row[:n].view(bool).reshape(sy, width)[:, :sx]


def _twin(regions: list[np.ndarray], wanted: list[list[int]] | None, r: int) -> int:
    """The first region whose free maps are region ``r``'s: the same cells, the same poses
    wanted."""
    for t in range(r):
        same_poses = wanted is None or wanted[t] == wanted[r]
        if same_poses and regions[t].shape == regions[r].shape and np.array_equal(regions[t], regions[r]):
            return t
    return r


def _best_pose(free: list[np.ndarray], poses: list[np.ndarray], ex: int, ey: int, aspect: float, rule: str):
    """The pose (index into ``poses``, masks) and lower-left cell of the best free
    position, ``free`` being one region's maps of :func:`_free_maps` (empty for the poses
    not tried there or that fit nowhere), as :func:`_best_box` ranks them."""
    fits = [i for i, f in enumerate(free) if f.size]
    q, x, y = _best_box([_Free(free[i]) for i in fits], [poses[i].shape[::-1] for i in fits], ex, ey, aspect, rule)
    return fits[q], x, y
