"""Where islands go in UV space: their canonical frame, the solver's shelf packing, the
fit onto pins and old UVs (one similarity kernel), aspect, and the unit square.

Pure numpy, per-island work as reductions over :class:`.islands.Islands`: a mesh with
10,000 islands costs the same handful of array operations as a mesh with one.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
import scipy.sparse as sp
from scipy.sparse import csgraph

from .geometry import corner_signed_areas
from .islands import Islands
from .mesh import pair_keys
from .overlap import uv_points

__all__ = [
    "FAR",
    "Similarity",
    "Turn",
    "apply_similarity",
    "canonical_turn",
    "pack_islands",
    "place",
    "place_in_uv_space",
    "similarity_fit",
    "choose",
    "identity",
]

# UV coordinates beyond this are no layout (a float32 UV there is 1/16 unit coarse), and
# Blender's packer turns them into NaN or crashes (Convex Hull at 1e8, bpy 5.0.1)
FAR = 1e6


# ---------------------------------------------------------------------------- similarity


class Similarity(NamedTuple):
    """Per-island maps ``y -> scale R(angle) y + shift``, (n_islands,) each (shift (k, 2));
    ``ok``: the fit was determined (see :func:`similarity_fit`)."""

    scale: np.ndarray
    angle: np.ndarray
    shift: np.ndarray
    ok: np.ndarray


def similarity_fit(src, dst, groups: Islands, weight, scale: bool = True) -> Similarity:
    """Per island, the rotation (no reflection), uniform scale and shift taking the rows
    ``src`` onto ``dst`` (r, 2) in least squares over the rows of ``weight`` (r,) 1
    (Umeyama's fit in 2D, closed form); ``groups`` labels the rows by island.

    Where the weighted rows of ``src`` or of ``dst`` are one point to rounding, neither
    rotation nor scale is determined (``ok`` False): the map is the shift that aligns
    their centroids. Islands with no weighted row get the identity. With ``scale=False``
    the scale stays 1.
    """
    w = np.asarray(weight, dtype=np.float64)
    tot = groups.sum(w)
    safe = np.maximum(tot, 1.0)[:, None]  # w is 0 or 1
    ms = groups.sum(src * w[:, None]) / safe
    md = groups.sum(dst * w[:, None]) / safe
    a = (src - groups.expand(ms)) * w[:, None]
    b = (dst - groups.expand(md)) * w[:, None]
    var = groups.sum((a * a).sum(axis=1))
    dot = groups.sum((a * b).sum(axis=1))
    cross = groups.sum(a[:, 0] * b[:, 1] - a[:, 1] * b[:, 0])
    spread = var > 1e-24 * np.maximum(groups.sum((src * src).sum(axis=1) * w), 1e-300)
    apart = groups.sum((b * b).sum(axis=1)) > 1e-24 * np.maximum(groups.sum((dst * dst).sum(axis=1) * w), 1e-300)
    ok = spread & apart & (tot > 0)
    angle = np.where(ok, np.arctan2(cross, dot), 0.0)
    s = np.where(ok & scale, np.hypot(dot, cross) / np.where(ok, var, 1.0), 1.0)
    shift = md - s[:, None] * _turned(ms, angle)
    return Similarity(s, angle, np.where((tot > 0)[:, None], shift, 0.0), ok)


def _turned(P: np.ndarray, angle: np.ndarray) -> np.ndarray:
    """Rows of ``P`` (r, 2) turned counter-clockwise by ``angle`` (r,) each."""
    c, si = np.cos(angle), np.sin(angle)
    return np.stack([c * P[:, 0] - si * P[:, 1], si * P[:, 0] + c * P[:, 1]], axis=1)


def apply_similarity(Y, groups: Islands, sim: Similarity, inverse: bool = False) -> np.ndarray:
    """Each island's map of ``sim`` (or its inverse) applied to its rows of ``Y`` (r, 2)."""
    s, th, t = groups.expand(sim.scale), groups.expand(sim.angle), groups.expand(sim.shift)
    if inverse:
        Y = Y - t
        s, th = 1.0 / s, -th
    out = _turned(Y, th) * s[:, None]
    return out if inverse else out + t


def identity(n: int) -> Similarity:
    return Similarity(np.ones(n), np.zeros(n), np.zeros((n, 2)), np.zeros(n, dtype=bool))


def choose(which: np.ndarray, a: Similarity, b: Similarity) -> Similarity:
    """Per island, ``a`` where ``which`` (n,) holds, else ``b``."""
    return Similarity(*(np.where(which.reshape((-1,) + (1,) * (x.ndim - 1)), x, y) for x, y in zip(a, b)))


# ---------------------------------------------------------------------------- UV space


def _into_unit_square(uv, margin):
    """The layout (t, 3, 2) scaled into [0, 1], relative sizes kept, with the space around
    it that Blender's ``pack_islands`` leaves one island (margin_method SCALED, measured
    on bpy 5.0.1: a gap of margin * sqrt(bounding box area) / 10, so any margin in 0..1
    leaves room)."""
    u, v = uv[..., 0], uv[..., 1]  # column by column: ``min(axis=0)`` of (k, 2) rows is 30x slower
    lo = np.array([u.min(), v.min()])
    box = np.array([u.max(), v.max()]) - lo
    size = max(float(box.max()), 1e-300)
    side = np.sqrt(box[0] * box[1]) / size  # of the box's area once the layout is 1 wide
    room = 1.0 / (1.0 + 0.2 * margin * side)
    out = np.empty_like(uv)
    for c in range(2):  # the two UV columns
        np.multiply(uv[..., c] - lo[c], room / size, out=out[..., c])
        out[..., c] += 0.1 * margin * side * room
    return out


def place_in_uv_space(
    uv, island, n, *, locked, old, in_place, world_scale, aspect=None, margin=0.0, corner_vertex=None
):
    """Final corner UVs of the unwrapped triangles, as the Blender operator writes them.

    Parameters
    ----------
    uv : (t, 3, 2) float64
        The solver's layout, mesh units, islands side by side.
    island : (t,) int64
    n : int
    locked : (t, 3) bool
        Corners that keep their old UV (pins; unselected UVs in the UV editor).
    old : (t, 3, 2) float64
        The UVs before the unwrap.
    in_place : bool
        Put every island where its old UVs were: same centroid, the best-fitting
        rotation, and (unless ``world_scale``) the same UV area, so texel density stays.
        Islands whose old UVs have no area (a mesh never unwrapped), or hold a value that
        is not finite or beyond ``FAR``, are laid out anew: fitted into [0, 1] unless
        ``world_scale``, or beside the islands that stay. Islands that share an old island
        (see ``corner_vertex``) go there together, side by side.
    corner_vertex : (t, 3) int64, optional
        The mesh vertex of every corner. With ``in_place``, islands whose faces lay in one
        island of the old UVs (charts cut from it, or pieces cut apart where it overlapped
        itself; transitively, where new and old islands cross) form a group: shelved in
        rows shaped as the old island's box, and put in that box, centred, at the old
        area if it fits (smaller if not), not turned, so that they land neither on each
        other nor on the neighbours. A group whose faces lay across several old islands,
        and islands without usable old UVs, are laid out anew, beside the islands that
        stay. Without it every island is a group of its own.
    world_scale : bool
        Keep mesh units (1 UV unit = 1 world unit) instead of fitting into [0, 1].
    aspect : float, optional
        Image width / height: u is divided by it, so texels come out square.
    margin : float
        Space kept around the layout when it is fitted into [0, 1], as Blender's
        ``uv.pack_islands`` keeps it.

    Returns
    -------
    uv : (t, 3, 2) float64
    held : (n,) bool
        Islands whose position is fixed by locked corners (the pack step must leave them).
    """
    uv = np.array(uv, dtype=np.float64, copy=True)
    if aspect is not None:
        uv[..., 0] /= aspect
    if not world_scale and not in_place:
        uv = _into_unit_square(uv, margin)
    corners = Islands.labelled(np.repeat(island, 3), n)  # rows: the (t * 3) corners
    held = corners.sum(locked.ravel().astype(np.float64)) > 0
    # old UVs that are not finite, or far out, are no layout to keep or fit to (the
    # operator refuses such pins; a corner locked by the UV selection keeps its value)
    near = (np.abs(old) <= FAR).all(axis=2)
    usable = np.bincount(island, ~near.all(axis=1), minlength=n) == 0
    w_lock = (locked & near).ravel()
    ref = np.where(near[..., None], old, 0.0).reshape(-1, 2)  # the old UVs fitted to (kept ones: ``old``)
    every = np.ones(len(ref))
    has_old_area = np.bincount(island, np.abs(corner_signed_areas(ref.reshape(-1, 3, 2))), minlength=n) > 0
    if in_place:
        # rotation from the best fit (a group of several islands keeps its shelves
        # upright), size from the old area (texel density kept), centroid onto the old one
        group, k, one_old = _old_groups(island, n, corner_vertex, old, held)
        several = np.bincount(group, minlength=k) > 1
        by_group = Islands.labelled(np.repeat(group[island], 3), k)
        old_lo, old_hi = _box(ref, by_group)
        if several.any():  # on shelves shaped as the old island's box
            with np.errstate(divide="ignore", invalid="ignore"):
                aspect = np.nan_to_num((old_hi - old_lo)[:, 0] / (old_hi - old_lo)[:, 1], nan=1.0, posinf=1.0)
            uv = _shelved(uv, island, n, group, several[group], margin or _GROUP_GAP, aspect)
        turn = similarity_fit(uv.reshape(-1, 2), ref, by_group, every, scale=False)
        a_new = np.bincount(group[island], np.abs(corner_signed_areas(uv)), minlength=k)
        a_old = np.bincount(group[island], np.abs(corner_signed_areas(ref.reshape(-1, 3, 2))), minlength=k)
        usable_group = np.bincount(group, ~usable, minlength=k) == 0
        held_group = np.bincount(group, held, minlength=k) > 0
        fit = turn.ok & ~held_group & usable_group & one_old & (a_old > 0) & (a_new > 0)
        s = np.where(fit & (not world_scale), np.sqrt(a_old / np.where(a_new > 0, a_new, 1.0)), 1.0)
        c_new, c_old = by_group.mean(uv.reshape(-1, 2)), by_group.mean(ref)
        if several.any():  # a group's shelves stay within the old island's box, centred on it
            new_lo, new_hi = _box(uv.reshape(-1, 2), by_group)
            with np.errstate(divide="ignore", invalid="ignore"):
                inside = np.nan_to_num(np.min((old_hi - old_lo) / (new_hi - new_lo), axis=1), nan=np.inf)
            s = np.where(several & fit & (not world_scale), np.minimum(s, inside), s)
            c_new = np.where(several[:, None], 0.5 * (new_lo + new_hi), c_new)
            c_old = np.where(several[:, None], 0.5 * (old_lo + old_hi), c_old)
        angle = np.where(fit & ~several, turn.angle, 0.0)
        shift = np.where(fit[:, None], c_old - s[:, None] * _turned(c_new, angle), 0.0)
        moved = Similarity(s, angle, shift, fit)
        uv = apply_similarity(uv.reshape(-1, 2), by_group, moved).reshape(-1, 3, 2)
        fresh = ~fit[group] & ~held  # no old place to go to: laid out anew
        if fresh.any():
            # beside the islands that stay: where they went, and the held ones' old UVs
            there = np.where(near[..., None] & held[island][:, None, None], old, uv)
            uv = _beside(uv, island, n, fresh, there, near, s[fit], world_scale, margin or _GROUP_GAP)
    if held.any():
        flat = uv.reshape(-1, 2)
        # pins on one UV (one pinned vertex, say) fix no rotation: such an island turns as
        # its old UVs lie, so pinning a vertex and unwrapping again does not spin it (after
        # a pack that rotated it, or a turn by hand)
        spread = similarity_fit(flat, ref, corners, w_lock, scale=False).ok
        lie = similarity_fit(flat, ref, corners, every, scale=False)
        turn = held & ~spread & lie.ok & usable & has_old_area
        if turn.any():
            only = Similarity(np.ones(n), np.where(turn, lie.angle, 0.0), np.zeros((n, 2)), turn)
            flat = apply_similarity(flat, corners, only)
        onto = similarity_fit(flat, ref, corners, w_lock, scale=not world_scale)
        flat = apply_similarity(flat, corners, choose(held, onto, identity(n)))
        uv = flat.reshape(-1, 3, 2)
        uv[locked] = old[locked]
    return uv, held


_GROUP_GAP = 0.02  # between islands shelved together in place, as a share of their size


def _old_groups(island, n, corner_vertex, old, held):
    """Per island (n,), its group (numbered from 0); the number of groups; and per group,
    whether its faces lay in one island of the old UVs.

    Old islands are the triangles joined by corners of the same vertex with the same old
    UV; a group is the islands joined through old islands (an old island cut into several,
    and those they share other old islands with). An island with locked corners
    (``held``) is a group of its own; without ``corner_vertex``, every island is."""
    if corner_vertex is None:
        return np.arange(n), n, np.ones(n, dtype=bool)
    corner_key = uv_points(corner_vertex, old).reshape(-1, 3)
    k = int(corner_key.max(initial=-1)) + 1
    # the old islands: a triangle's corners joined
    a, b = corner_key[:, :2].ravel(), corner_key[:, 1:].ravel()
    joins = sp.coo_matrix((np.ones(len(a)), (a, b)), shape=(k, k))
    _, old_island = csgraph.connected_components(joins, directed=False)
    old_island = old_island[corner_key[:, 0]]
    # the islands (0..n-1) joined to the old islands (n..) of their faces
    free = ~held[island]
    link = sp.coo_matrix((np.ones(int(free.sum())), (island[free], n + old_island[free])), shape=(n + k, n + k))
    _, label = csgraph.connected_components(link, directed=False)
    _, group = np.unique(label[:n], return_inverse=True)
    group = group.ravel()
    count = int(group.max(initial=-1)) + 1
    pair = np.unique(pair_keys(group[island], old_island, k, ordered=True))
    return group, count, np.bincount(pair // k, minlength=count) == 1


def _beside(uv, island, n, fresh, there, near, density, world_scale: bool, gap_share: float):
    """``uv`` (t, 3, 2) with the ``fresh`` (n,) bool islands (no old place to go to) on
    shelves of their own, to the right of the islands that stay (``there`` (t, 3, 2): where
    they are going, trusted where ``near``), at their median scale ``density`` (scale
    factors of the islands put in place; the islands' own size with ``world_scale``, one
    unit across when only held islands stay); fitted into [0, 1] as a fresh unwrap is
    when no other island stays."""
    uv = _shelved(uv, island, n, np.zeros(n, dtype=np.int64), fresh, gap_share)
    rows = fresh[island]
    staying = ~rows[:, None] & near
    if not staying.any():
        if not world_scale:
            uv[rows] = _into_unit_square(uv[rows], 0.0)
        return uv
    ours = uv[rows].reshape(-1, 2)
    ours = ours - ours.min(axis=0)
    if not world_scale:
        ours *= float(np.median(density)) if len(density) else 1.0 / max(float(ours.max()), 1e-300)
    them = there[staying]
    lo, hi = them.min(axis=0), them.max(axis=0)
    gap = gap_share * float(np.sqrt(np.prod(hi - lo)))
    uv[rows] = (ours + [hi[0] + gap, lo[1]]).reshape(-1, 3, 2)
    return uv


def _shelved(uv, island, n, group, moving, gap_share, aspect=None):
    """``uv`` (t, 3, 2) with the ``moving`` (n,) bool islands shifted onto shelves, one set
    of shelves per ``group`` (n,), ``gap_share`` of each group's size apart, rows about
    ``aspect`` (per group: width / height, 1 without) times as wide as the shelves are
    tall."""
    corners = Islands.labelled(np.repeat(island, 3), n)
    lo, hi = _box(uv.reshape(-1, 2), corners)
    ids = np.flatnonzero(moving & (corners.size > 0))
    size = hi[ids] - lo[ids]
    kept, g = np.unique(group[ids], return_inverse=True)
    g = g.ravel()
    gap = gap_share * np.sqrt(np.bincount(g, np.prod(size, axis=1)))
    shift = np.zeros((n, 2))
    shift[ids] = _shelves(size, gap, g, None if aspect is None else aspect[kept]) - lo[ids]
    return uv + shift[island][:, None, :]


def _box(points, groups: Islands):
    """Per group, the lower and upper corners (k, 2) of its rows of ``points`` (r, 2)."""
    lo = np.stack([groups.min(points[:, c]) for c in range(2)], axis=1)
    hi = np.stack([-groups.min(-points[:, c]) for c in range(2)], axis=1)
    return lo, hi


# ---------------------------------------------------------------------------- the solver's


def place(Y, islands: Islands, pack: bool = True, margin: float = 0.02, fixed=None):
    """Turn each island into its canonical frame (:func:`canonical_turn`) and put the
    islands side by side.

    The turn makes the layout deterministic and compact. With ``pack`` the islands go on
    shelves in mesh units (true scale, no overlap), ``margin`` being a fraction of the
    square root of their total area; otherwise each island is centred at the origin.
    Islands in ``fixed`` (n_islands,) bool keep their frame (pinned islands); packed
    islands go to the right of them.
    """
    nI = islands.n
    fixed = np.zeros(nI, dtype=bool) if fixed is None else fixed
    Yc = Y - islands.expand(islands.mean(Y))
    Yr = islands.apply(Yc, canonical_turn(Yc, islands).rotation)
    if fixed.any():
        Yr = np.where(fixed[islands.label][:, None], Y, Yr)
    return pack_islands(Yr, islands, margin, fixed) if pack else Yr


_TIE = 1e-3  # moments below this fraction of their scale are ties (symmetric islands)


class Turn(NamedTuple):
    """What :func:`canonical_turn` decided, per island."""

    rotation: np.ndarray  # (n_islands, 2, 2): ``Yc @ rotation`` is the turned island
    by_anchor: np.ndarray  # (n_islands,) bool: symmetric (rules 1-2 tied): the numbering decided


def canonical_turn(Yc: np.ndarray, islands: Islands) -> Turn:
    """Per island, the rotation that puts its centred rows ``Yc`` (n, 2) in a canonical
    frame.

    A turn has to be decided from the layout alone, and must not change when the layout
    changes by rounding (another BLAS kernel, thread count or summation order), also on
    symmetric islands, where every geometric rule ties. With ``z = u + i v`` per vertex
    (centred), the rules, in order:

    1. Principal axes: ``M2 = sum z^2`` gives the major axis (angle ``arg(M2) / 2``) when
       ``|M2| > _TIE sum |z|^2``. Else (as round as it is long), ``M4 = sum z^4`` gives a
       four-fold frame (angle ``arg(M4) / 4``, a square's sides) when ``|M4| > _TIE sum |z|^4``.
       Else the frame is free.
    2. Which of the ``k`` turns left (2 for an axis, 4 for a four-fold frame, any for a
       free one): for an axis, the one with positive skewness ``sum u^3`` along it, when
       ``|sum u^3| > _TIE sum |u|^3``. Else the *anchor*, the island's lowest-numbered
       vertex among those more than half the island's radius from its centre (and, with
       ``k > 1``, more than a tenth of a sector away from the sectors' edges), is turned
       into the sector around +u (onto +u for a free frame).

    Every decision is a comparison with a margin of ``_TIE`` or more, so rounding
    (relative 1e-16 to 1e-10 of the layout) never flips one. The anchor rule depends on
    the vertex numbering (the input's order): a symmetric island relabelled may come out
    turned by one of its symmetries. Asymmetric islands are decided by rules 1-2 alone,
    whatever the numbering.
    """
    n_rows = len(Yc)
    x, y = np.ascontiguousarray(Yc[:, 0]), np.ascontiguousarray(Yc[:, 1])
    # in units of the island's radius: powers of raw coordinates overflow beyond ~1e77
    # (pins far from a mesh collapsed to a point)
    radius = np.hypot(x, y)
    top = islands.max(radius)
    unit = islands.expand(np.where(top > 0, top, 1.0))
    x, y, radius = x / unit, y / unit, radius / unit
    r2 = x * x + y * y
    z2 = np.stack([x * x - y * y, 2.0 * x * y], axis=1)  # z^2 as (re, im)
    z4 = np.stack([z2[:, 0] ** 2 - z2[:, 1] ** 2, 2.0 * z2[:, 0] * z2[:, 1]], axis=1)
    s = islands.sum(np.column_stack([z2, z4, r2, r2 * r2]))
    m2, m4 = s[:, 0] + 1j * s[:, 1], s[:, 2] + 1j * s[:, 3]
    axis = np.abs(m2) > _TIE * s[:, 4]
    square = ~axis & (np.abs(m4) > _TIE * s[:, 5])
    k = np.where(axis, 2, np.where(square, 4, 1))
    theta = np.where(axis, np.angle(m2) / 2, np.where(square, np.angle(m4) / 4, 0.0))
    # rule 2 for an axis: skewness along it
    c, sn = np.cos(theta), np.sin(theta)
    u = x * islands.expand(c) + y * islands.expand(sn)
    s3 = islands.sum(np.column_stack([u**3, np.abs(u) ** 3]))
    skewed = axis & (np.abs(s3[:, 0]) > _TIE * s3[:, 1])
    turn = np.where(skewed & (s3[:, 0] < 0), np.pi, 0.0)
    # rule 2 otherwise: the anchor
    sector = 2.0 * np.pi / k
    alpha = np.arctan2(y, x) - islands.expand(theta)
    step = alpha / islands.expand(sector)
    off_edge = (k[islands.label] == 1) | (np.abs(step - np.round(step)) < 0.4)
    far = radius > 0.5 * islands.expand(np.where(top > 0, 1.0, np.inf))
    anchor = islands.first(far & off_edge)
    anchor = np.where(anchor < n_rows, anchor, islands.first(far))
    has = anchor < n_rows  # islands that are not one point
    a = np.minimum(anchor, max(n_rows - 1, 0))
    to_anchor = np.where(k == 1, alpha[a] if n_rows else 0.0, np.round(step[a] if n_rows else 0.0) * sector)
    turn = np.where(skewed | ~has, turn, to_anchor)
    angle = theta + turn
    c, sn = np.cos(angle), np.sin(angle)
    # y = Yc @ R turns by -angle: the chosen direction goes onto +u
    R = np.stack([np.stack([c, -sn], axis=1), np.stack([sn, c], axis=1)], axis=1)
    return Turn(R, ~skewed & has)


def pack_islands(Y, islands: Islands, margin: float = 0.02, fixed=None):
    """Shift the islands of ``Y`` (n, 2) onto shelves, without turning them (the packing
    step of :func:`place`). Islands in ``fixed`` (n_islands,) bool stay where they are."""
    nI = islands.n
    fixed = np.zeros(nI, dtype=bool) if fixed is None else fixed
    if fixed.all():
        return Y
    lo, hi = _box(Y, islands)
    size = hi - lo
    gap = margin * np.sqrt(max(float(np.prod(size, axis=1).sum()), 1e-300))
    free = np.flatnonzero(~fixed)
    corner = np.zeros((nI, 2))
    corner[free] = _shelves(size[free], gap)
    if fixed.any():  # the free islands go to the right of the pinned ones
        corner[free] += [hi[fixed, 0].max() + gap, lo[fixed, 1].min()]
    shift = np.where(fixed[:, None], 0.0, corner - lo)
    return Y + islands.expand(shift)


def _shelves(size: np.ndarray, gap, group: np.ndarray | None = None, aspect=None) -> np.ndarray:
    """Lower-left corners for boxes (k, 2) on shelves, tallest first, rows ~ square (or
    ``aspect`` times as wide as the shelves are tall); with ``group`` (k,) (numbered from
    0), one set of shelves per group, from the origin, and ``gap`` and ``aspect`` per
    group.

    A shelf takes boxes while they fit in the row's width (at least one): where each
    shelf ends is one search in the running widths, for every group at once, so the loop
    runs once per shelf of the group with most shelves (about the square root of its
    boxes), not once per box."""
    k = len(size)
    group = np.zeros(k, dtype=np.int64) if group is None else group
    n = int(group.max(initial=-1)) + 1
    gap = np.broadcast_to(np.asarray(gap, dtype=np.float64), (n,))
    # tallest first; heights within 1e-6 of the group's tallest count as equal (islands
    # alike up to rounding), so that rounding never reorders them: then by island number
    tallest = np.zeros(n)
    np.maximum.at(tallest, group, size[:, 1])
    height = np.round(size[:, 1] / np.maximum(tallest * 1e-6, 1e-300)[group])
    order = np.lexsort((np.arange(k), -height, group))
    g, w, h = group[order], size[order, 0], size[order, 1]
    widest = np.zeros(n)
    np.maximum.at(widest, g, w)
    shape = np.ones(n) if aspect is None else np.clip(aspect, 1e-3, 1e3)
    width = np.maximum(widest, np.sqrt(shape * np.bincount(g, (w + gap[g]) * (h + gap[g]), minlength=n)))
    first = np.searchsorted(g, np.arange(n))
    end = np.append(first[1:], k)
    run = np.cumsum(w + gap[g])
    before = run - (w + gap[g])
    before -= before[np.minimum(first, k - 1)][g]  # within the group, ahead of each box
    # a box fits on the shelf that starts at box s while before + w <= before[s] + width:
    # one ascending key over all groups, (group, right edge) in lexicographic (complex) order
    key = g + 1j * (before + w)
    starts = np.zeros(k, dtype=bool)
    s, live = first.copy(), np.flatnonzero(first < end)
    while live.size:  # one shelf of every group that has boxes left
        starts[s[live]] = True
        e = np.searchsorted(key, live + 1j * (before[s[live]] + width[live]), side="right")
        s[live] = np.clip(e, s[live] + 1, end[live])
        live = live[s[live] < end[live]]
    shelf = np.cumsum(starts) - 1  # of every box, numbered over all groups
    head = np.flatnonzero(starts)  # the first box of every shelf
    x = before - before[head][shelf]
    row = np.zeros(len(head))
    np.maximum.at(row, shelf, h)
    rise = np.cumsum(row + gap[g[head]])
    below = rise - (row + gap[g[head]])
    y = below - below[np.searchsorted(g[head], g[head])]  # from the group's first shelf
    out = np.zeros((k, 2))
    out[order, 0], out[order, 1] = x, y[shelf]
    return out
