"""Where islands go: their canonical frame, the solver's shelf packing, and the fit onto
pins and old UVs (one similarity kernel). Blender's UV-space rules (the unit square,
aspect, islands kept in their old place) are :mod:`.uv_space`'s.

Pure numpy, per-island work as reductions over :class:`.islands.Islands`: a mesh with
10,000 islands costs the same handful of array operations as a mesh with one.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from ..geometry import TINY
from ..mesh.islands import Islands, Labelled

__all__ = [
    "Similarity",
    "Turn",
    "apply_similarity",
    "canonical_turn",
    "pack_islands",
    "place",
    "similarity_fit",
    "boxes",
    "choose",
    "identity",
    "rotated",
    "shelves",
]


# ---------------------------------------------------------------------------- similarity


class Similarity(NamedTuple):
    """Per-island maps ``y -> scale R(angle) y + shift``, (n_islands,) each (shift (k, 2));
    ``ok``: the fit was determined (see :func:`similarity_fit`)."""

    scale: np.ndarray
    angle: np.ndarray
    shift: np.ndarray
    ok: np.ndarray


def similarity_fit(src, dst, groups: Labelled, weight, scale: bool = True) -> Similarity:
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
    spread = var > 1e-24 * np.maximum(groups.sum((src * src).sum(axis=1) * w), TINY)
    apart = groups.sum((b * b).sum(axis=1)) > 1e-24 * np.maximum(groups.sum((dst * dst).sum(axis=1) * w), TINY)
    ok = spread & apart & (tot > 0)
    angle = np.where(ok, np.arctan2(cross, dot), 0.0)
    s = np.where(ok & scale, np.hypot(dot, cross) / np.where(ok, var, 1.0), 1.0)
    shift = md - s[:, None] * rotated(ms, angle)
    return Similarity(s, angle, np.where((tot > 0)[:, None], shift, 0.0), ok)


def rotated(P: np.ndarray, angle: np.ndarray) -> np.ndarray:
    """Rows of ``P`` (r, 2) turned counter-clockwise by ``angle`` (r,) each."""
    c, si = np.cos(angle), np.sin(angle)
    return np.stack([c * P[:, 0] - si * P[:, 1], si * P[:, 0] + c * P[:, 1]], axis=1)


def apply_similarity(Y, groups: Labelled, sim: Similarity, inverse: bool = False) -> np.ndarray:
    """Each island's map of ``sim`` (or its inverse) applied to its rows of ``Y`` (r, 2)."""
    s, th, t = groups.expand(sim.scale), groups.expand(sim.angle), groups.expand(sim.shift)
    if inverse:
        Y = Y - t
        s, th = 1.0 / s, -th
    out = rotated(Y, th) * s[:, None]
    return out if inverse else out + t


def identity(n: int) -> Similarity:
    return Similarity(np.ones(n), np.zeros(n), np.zeros((n, 2)), np.zeros(n, dtype=bool))


def choose(which: np.ndarray, a: Similarity, b: Similarity) -> Similarity:
    """Per island, ``a`` where ``which`` (n,) holds, else ``b``."""
    return Similarity(*(np.where(which.reshape((-1,) + (1,) * (x.ndim - 1)), x, y) for x, y in zip(a, b)))


def boxes(points, groups: Labelled):
    """Per group, the lower and upper corners (k, 2) of its rows of ``points`` (r, 2)."""
    lo = np.stack([groups.min(points[:, c]) for c in range(2)], axis=1)
    hi = np.stack([-groups.min(-points[:, c]) for c in range(2)], axis=1)
    return lo, hi


# ---------------------------------------------------------------------------- the solver's


def place(Y, islands: Islands, pack: bool = True, margin: float = 0.02, held=None):
    """Turn each island into its canonical frame (:func:`canonical_turn`) and put the
    islands side by side.

    The turn makes the layout deterministic and compact. With ``pack`` the islands go on
    shelves in mesh units (true scale, no overlap), ``margin`` being a fraction of the
    square root of their total area; otherwise each island is centred at the origin.
    Islands in ``held`` (n_islands,) bool keep their frame (pinned islands); packed
    islands go to the right of them.
    """
    nI = islands.n
    held = np.zeros(nI, dtype=bool) if held is None else held
    Yc = Y - islands.expand(islands.mean(Y))
    Yr = islands.apply(Yc, canonical_turn(Yc, islands).rotation)
    if held.any():
        Yr = np.where(held[islands.label][:, None], Y, Yr)
    return pack_islands(Yr, islands, margin, held) if pack else Yr


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


def pack_islands(Y, islands: Islands, margin: float = 0.02, held=None):
    """Shift the islands of ``Y`` (n, 2) onto shelves, without turning them (the packing
    step of :func:`place`). Islands in ``held`` (n_islands,) bool stay where they are."""
    nI = islands.n
    held = np.zeros(nI, dtype=bool) if held is None else held
    if held.all():
        return Y
    lo, hi = boxes(Y, islands)
    size = hi - lo
    gap = margin * np.sqrt(max(float(np.prod(size, axis=1).sum()), TINY))
    free = np.flatnonzero(~held)
    corner = np.zeros((nI, 2))
    corner[free] = shelves(size[free], gap)
    if held.any():  # the free islands go to the right of the pinned ones
        corner[free] += [hi[held, 0].max() + gap, lo[held, 1].min()]
    shift = np.where(held[:, None], 0.0, corner - lo)
    return Y + islands.expand(shift)


def shelves(size: np.ndarray, gap, group: np.ndarray | None = None, aspect=None) -> np.ndarray:
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
    height = np.round(size[:, 1] / np.maximum(tallest * 1e-6, TINY)[group])
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
