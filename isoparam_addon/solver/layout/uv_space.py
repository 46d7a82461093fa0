"""Blender's UV space: the solver's layout placed as the operator writes it, into the unit
square (with the pack's margin, as ``uv.pack_islands`` keeps it), corrected for the
image's aspect, or in place of the old UVs, with pinned and locked corners kept. The
kernels it places with (similarity fits, shelves) are :mod:`.placement`'s.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp
from scipy.sparse import csgraph

from ..geometry import TINY, corner_signed_areas
from ..mesh.halfedges import pair_keys, unique_sorted
from ..mesh.islands import Islands, Labelled
from ..overlap import uv_points
from .placement import Similarity, apply_similarity, boxes, choose, identity, rotated, shelves, similarity_fit

__all__ = ["FAR_UV", "place_in_uv_space"]


# UV coordinates beyond this are no layout (a float32 UV there is 1/16 unit coarse), and
# Blender's packer turns them into NaN or crashes (Convex Hull at 1e8, bpy 5.0.1)
FAR_UV = 1e6


# ---------------------------------------------------------------------------- UV space


def _into_unit_square(uv, margin, share: bool = False):
    """The layout (t, 3, 2) scaled into [0, 1], relative sizes kept, with the space around
    it that Blender's ``pack_islands`` leaves one island: with margin_method SCALED a gap
    of margin * sqrt(bounding box area) / 10 (so any margin in 0..1 leaves room), with
    FRACTION (``share``) a gap of ``margin`` of the square (bpy 5.0.1)."""
    u, v = uv[..., 0], uv[..., 1]  # column by column: ``min(axis=0)`` of (k, 2) rows is 30x slower
    lo = np.array([u.min(), v.min()])
    box = np.array([u.max(), v.max()]) - lo
    size = max(float(box.max()), TINY)
    if share:
        gap = min(margin, 0.49)
        room = 1.0 - 2.0 * gap
    else:
        side = np.sqrt(box[0] * box[1]) / size  # of the box's area once the layout is 1 wide
        room = 1.0 / (1.0 + 0.2 * margin * side)
        gap = 0.1 * margin * side * room
    out = np.empty_like(uv)
    for c in range(2):  # the two UV columns
        np.multiply(uv[..., c] - lo[c], room / size, out=out[..., c])
        out[..., c] += gap
    return out


def place_in_uv_space(
    uv,
    island,
    n,
    *,
    locked,
    old,
    in_place,
    world_scale,
    aspect=None,
    margin=0.0,
    margin_share=False,
    corner_vertex=None,
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
        is not finite or beyond ``FAR_UV``, are laid out anew: fitted into [0, 1] unless
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
        ``uv.pack_islands`` keeps it: its margin method SCALED, or with ``margin_share``
        FRACTION (``margin`` is then the share of the square, e.g. pixels / texture size).

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
        uv = _into_unit_square(uv, margin, margin_share)
    corners = Islands.labelled(np.repeat(island, 3), n)  # rows: the (t * 3) corners
    held = corners.sum(locked.ravel().astype(np.float64)) > 0
    before = _OldUVs.of(old, island, n)
    if in_place:
        uv = _in_place(uv, island, n, before, held, corner_vertex, world_scale, margin or _GROUP_GAP)
    if held.any():
        uv = _onto_pins(uv, corners, held, locked, before, world_scale)
    return uv, held


_GROUP_GAP = 0.02  # between islands shelved together in place, as a share of their size


@dataclass(frozen=True)
class _OldUVs:
    """The UVs before the unwrap, as the placement fits to them.

    Attributes
    ----------
    uv : (t, 3, 2) float64
        As given.
    near : (t, 3) bool
        Corners whose old UV is a layout to keep or fit to: finite and within ``FAR_UV``
        (the operator refuses pins that are not; a corner locked by the UV selection keeps
        its value whatever it is).
    ref : (t * 3, 2) float64
        The old UVs fitted to, a row per corner: ``uv`` where ``near``, else 0.
    usable : (n,) bool
        Islands whose old UVs are all ``near``.
    has_area : (n,) bool
        Islands whose old UVs cover some area (a mesh never unwrapped has none).
    """

    uv: np.ndarray
    near: np.ndarray
    ref: np.ndarray
    usable: np.ndarray
    has_area: np.ndarray

    @classmethod
    def of(cls, old, island, n) -> _OldUVs:
        """The old UVs (t, 3, 2) of the triangles of ``island`` (t,), n islands."""
        near = (np.abs(old) <= FAR_UV).all(axis=2)
        usable = np.bincount(island, ~near.all(axis=1), minlength=n) == 0
        ref = np.where(near[..., None], old, 0.0).reshape(-1, 2)
        has_area = np.bincount(island, np.abs(corner_signed_areas(ref.reshape(-1, 3, 2))), minlength=n) > 0
        return cls(old, near, ref, usable, has_area)


@dataclass(frozen=True)
class _Groups:
    """The islands put in place together (see :func:`_old_groups`), ``count`` groups.

    Attributes
    ----------
    label : (n,) int64
        Group of each island.
    count : int
    one_old : (count,) bool
        Groups whose faces lay in one island of the old UVs.
    several : (count,) bool
        Groups of more than one island (shelved, and put in the old island's box).
    corners : Labelled
        The (t * 3) corners, by group.
    old_lo, old_hi : (count, 2) float64
        Box of each group's old UVs.
    """

    label: np.ndarray
    count: int
    one_old: np.ndarray
    several: np.ndarray
    corners: Labelled
    old_lo: np.ndarray
    old_hi: np.ndarray

    @classmethod
    def of(cls, island, n, corner_vertex, before: _OldUVs, held) -> _Groups:
        """The groups of the n islands (``island`` (t,): of each triangle)."""
        group, k, one_old = _old_groups(island, n, corner_vertex, before.uv, held)
        several = np.bincount(group, minlength=k) > 1
        corners = Islands.labelled(np.repeat(group[island], 3), k)
        old_lo, old_hi = boxes(before.ref, corners)
        return cls(group, k, one_old, several, corners, old_lo, old_hi)

    def old_aspect(self) -> np.ndarray:
        """Width / height (count,) of each group's old box; 1 where it has no extent."""
        with np.errstate(divide="ignore", invalid="ignore"):
            return np.nan_to_num(
                (self.old_hi - self.old_lo)[:, 0] / (self.old_hi - self.old_lo)[:, 1], nan=1.0, posinf=1.0
            )


def _in_place(uv, island, n, before: _OldUVs, held, corner_vertex, world_scale: bool, gap_share: float):
    """``uv`` (t, 3, 2) with every group of islands put where its old UVs were
    (:func:`_onto_old`), a group of several on shelves shaped as its old box, ``gap_share``
    of its size apart; islands with no old place to go to are laid out anew beside the
    ones that stay (:func:`_beside`). Held islands are left to :func:`_onto_pins`."""
    groups = _Groups.of(island, n, corner_vertex, before, held)
    if groups.several.any():  # on shelves shaped as the old island's box
        in_several = groups.several[groups.label]
        uv = _shelved(uv, island, n, groups.label, in_several, gap_share, groups.old_aspect())
    moved = _onto_old(uv, island, groups, before, held, world_scale)
    uv = apply_similarity(uv.reshape(-1, 2), groups.corners, moved).reshape(-1, 3, 2)
    fresh = ~moved.ok[groups.label] & ~held  # no old place to go to: laid out anew
    if fresh.any():
        # beside the islands that stay: where they went, and the held ones' old UVs
        there = np.where(before.near[..., None] & held[island][:, None, None], before.uv, uv)
        uv = _beside(uv, island, n, fresh, there, before.near, moved.scale[moved.ok], world_scale, gap_share)
    return uv


def _onto_old(uv, island, groups: _Groups, before: _OldUVs, held, world_scale: bool) -> Similarity:
    """Per group, the similarity that puts ``uv`` (t, 3, 2) where the old UVs were: turned
    as they lie (a group of several islands keeps its shelves upright), at their area
    (texel density kept; the own size with ``world_scale``), centroid onto centroid, or
    for a group of several, box centre onto box centre and no larger than the old box.

    ``ok`` where the group has such a place: no held island, every old UV usable, all its
    faces from one old island, and area both in the old UVs and in the new ones."""
    g = groups
    turn = similarity_fit(uv.reshape(-1, 2), before.ref, g.corners, np.ones(len(before.ref)), scale=False)
    a_new = np.bincount(g.label[island], np.abs(corner_signed_areas(uv)), minlength=g.count)
    a_old = np.bincount(g.label[island], np.abs(corner_signed_areas(before.ref.reshape(-1, 3, 2))), minlength=g.count)
    usable_group = np.bincount(g.label, ~before.usable, minlength=g.count) == 0
    held_group = np.bincount(g.label, held, minlength=g.count) > 0
    fit = turn.ok & ~held_group & usable_group & g.one_old & (a_old > 0) & (a_new > 0)
    s = np.where(fit & (not world_scale), np.sqrt(a_old / np.where(a_new > 0, a_new, 1.0)), 1.0)
    c_new, c_old = g.corners.mean(uv.reshape(-1, 2)), g.corners.mean(before.ref)
    if g.several.any():  # a group's shelves stay within the old island's box, centred on it
        new_lo, new_hi = boxes(uv.reshape(-1, 2), g.corners)
        with np.errstate(divide="ignore", invalid="ignore"):
            inside = np.nan_to_num(np.min((g.old_hi - g.old_lo) / (new_hi - new_lo), axis=1), nan=np.inf)
        s = np.where(g.several & fit & (not world_scale), np.minimum(s, inside), s)
        c_new = np.where(g.several[:, None], 0.5 * (new_lo + new_hi), c_new)
        c_old = np.where(g.several[:, None], 0.5 * (g.old_lo + g.old_hi), c_old)
    angle = np.where(fit & ~g.several, turn.angle, 0.0)
    shift = np.where(fit[:, None], c_old - s[:, None] * rotated(c_new, angle), 0.0)
    return Similarity(s, angle, shift, fit)


def _onto_pins(uv, corners: Labelled, held, locked, before: _OldUVs, world_scale: bool):
    """``uv`` (t, 3, 2) with every ``held`` (n,) island fitted onto the old UVs of its
    ``locked`` (t, 3) corners (turned, and scaled unless ``world_scale``), and the locked
    corners given their old UVs exactly."""
    n = corners.n
    flat = uv.reshape(-1, 2)
    w_lock = (locked & before.near).ravel()
    every = np.ones(len(before.ref))
    # pins on one UV (one pinned vertex, say) fix no rotation: such an island turns as
    # its old UVs lie, so pinning a vertex and unwrapping again does not spin it (after
    # a pack that rotated it, or a turn by hand)
    spread = similarity_fit(flat, before.ref, corners, w_lock, scale=False).ok
    lie = similarity_fit(flat, before.ref, corners, every, scale=False)
    turn = held & ~spread & lie.ok & before.usable & before.has_area
    if turn.any():
        only = Similarity(np.ones(n), np.where(turn, lie.angle, 0.0), np.zeros((n, 2)), turn)
        flat = apply_similarity(flat, corners, only)
    onto = similarity_fit(flat, before.ref, corners, w_lock, scale=not world_scale)
    flat = apply_similarity(flat, corners, choose(held, onto, identity(n)))
    uv = flat.reshape(-1, 3, 2)
    uv[locked] = before.uv[locked]
    return uv


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
    pair = unique_sorted(pair_keys(group[island], old_island, k, ordered=True))
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
        ours *= float(np.median(density)) if len(density) else 1.0 / max(float(ours.max()), TINY)
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
    lo, hi = boxes(uv.reshape(-1, 2), corners)
    ids = np.flatnonzero(moving & (corners.size > 0))
    size = hi[ids] - lo[ids]
    kept, g = np.unique(group[ids], return_inverse=True)
    g = g.ravel()
    gap = gap_share * np.sqrt(np.bincount(g, np.prod(size, axis=1)))
    shift = np.zeros((n, 2))
    shift[ids] = shelves(size, gap, g, None if aspect is None else aspect[kept]) - lo[ids]
    return uv + shift[island][:, None, :]
