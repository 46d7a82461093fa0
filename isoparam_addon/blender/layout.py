"""Where unwrapped islands go in UV space: aspect, pins, in place, normalisation.

Pure numpy (no bpy), per-island work as segment sums: a mesh with 10,000 islands costs
the same handful of array operations as a mesh with one.

All arrays are per triangle corner: ``uv (t, 3, 2)``, ``island (t,)``, ``locked (t, 3)``.
"""

from __future__ import annotations

import numpy as np

__all__ = ["FAR", "similarity_fit", "place"]

# UV coordinates beyond this are no layout (a float32 UV there is 1/16 unit coarse), and
# Blender's packer turns them into NaN or crashes (Convex Hull at 1e8, bpy 5.0.1)
FAR = 1e6


def _sums(island, values, n):
    """Per-island sums of per-corner values: (t, 3, ...) -> (n, ...)."""
    flat = values.reshape(-1, *values.shape[2:]) if values.ndim > 2 else values.ravel()
    idx = np.repeat(island, 3)
    if flat.ndim == 1:
        return np.bincount(idx, flat, minlength=n)
    return np.stack([np.bincount(idx, flat[:, j], minlength=n) for j in range(flat.shape[1])], axis=1)


def similarity_fit(src, dst, island, weight, n, scale=True):
    """Per-island rotation (no reflection), uniform scale and shift taking src onto dst.

    Least squares (Umeyama in 2D, closed form) over corners with ``weight`` 1.

    Parameters
    ----------
    src, dst : (t, 3, 2) float64
    island : (t,) int64
    weight : (t, 3) float64
    n : int
        Number of islands.
    scale : bool
        Fit the scale too; otherwise keep it.

    Returns
    -------
    s : (n,) float64, R : (n, 2, 2) float64, shift : (n, 2) float64, ok : (n,) bool
        ``ok`` is False where src has no spread over the weighted corners (the fit would
        be undetermined); there s = 1, R = I and shift aligns the weighted centroids.
    """
    w = weight
    tot = _sums(island, w, n)
    safe = np.where(tot > 0, tot, 1.0)
    ms = _sums(island, src * w[..., None], n) / safe[:, None]
    md = _sums(island, dst * w[..., None], n) / safe[:, None]
    a = src - ms[island][:, None, :]
    b = dst - md[island][:, None, :]
    dot = _sums(island, (a * b).sum(axis=2) * w, n)
    cross = _sums(island, (a[..., 0] * b[..., 1] - a[..., 1] * b[..., 0]) * w, n)
    var = _sums(island, (a * a).sum(axis=2) * w, n)
    ok = (var > 1e-24 * np.maximum(_sums(island, (src * src).sum(axis=2) * w, n), 1e-300)) & (tot > 0)
    theta = np.where(ok, np.arctan2(cross, dot), 0.0)
    c, si = np.cos(theta), np.sin(theta)
    R = np.stack([np.stack([c, -si], axis=1), np.stack([si, c], axis=1)], axis=1)
    s = np.where(ok & scale, np.hypot(dot, cross) / np.where(ok, var, 1.0), 1.0)
    shift = md - s[:, None] * np.einsum("nij,nj->ni", R, ms)
    return s, R, shift, ok


def _areas(uv):
    """Signed area of every UV triangle (t,)."""
    q1, q2 = uv[:, 1] - uv[:, 0], uv[:, 2] - uv[:, 0]
    return 0.5 * (q1[:, 0] * q2[:, 1] - q1[:, 1] * q2[:, 0])


def _apply(uv, island, s, R, shift):
    return s[island][:, None, None] * np.einsum("tij,tkj->tki", R[island], uv) + shift[island][:, None, :]


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


def place(uv, island, n, *, locked, old, in_place, world_scale, aspect=None, margin=0.0):
    """Final corner UVs of the unwrapped triangles.

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
        is not finite or beyond ``FAR``, are laid out anew, fitted into [0, 1] unless
        ``world_scale``.
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
    n_locked = _sums(island, locked.astype(np.float64), n)
    held = n_locked > 0
    # old UVs that are not finite, or far out, are no layout to keep or fit to (the
    # operator refuses such pins; a corner locked by the UV selection keeps its value)
    near = (np.abs(old) <= FAR).all(axis=2)
    usable = np.bincount(island, ~near.all(axis=1), minlength=n) == 0
    w_lock = (locked & near).astype(np.float64)
    ref = np.where(near[..., None], old, 0.0)  # the old UVs fitted to (kept ones: ``old``)
    if in_place:
        # rotation from the best fit, size from the old area (texel density kept),
        # centroid onto the old centroid
        ones = np.ones_like(w_lock)
        _, R, _, ok = similarity_fit(uv, ref, island, ones, n, scale=False)
        a_new = np.bincount(island, np.abs(_areas(uv)), minlength=n)
        a_old = np.bincount(island, np.abs(_areas(ref)), minlength=n)
        fit = ok & ~held & usable & (a_old > 0) & (a_new > 0)
        s = np.where(fit & (not world_scale), np.sqrt(a_old / np.where(a_new > 0, a_new, 1.0)), 1.0)
        count = 3 * np.bincount(island, minlength=n)
        c_new = _sums(island, uv, n) / np.maximum(count, 1)[:, None]
        c_old = _sums(island, ref, n) / np.maximum(count, 1)[:, None]
        R = np.where(fit[:, None, None], R, np.eye(2))
        shift = np.where(fit[:, None], c_old - s[:, None] * np.einsum("nij,nj->ni", R, c_new), 0.0)
        uv = _apply(uv, island, s, R, shift)
        fresh = ~fit & ~held  # no old UVs to keep: laid out as without in_place
        if not world_scale and fresh.any():
            rows = fresh[island]
            uv[rows] = _into_unit_square(uv[rows], 0.0)
    if held.any():
        # pins on one UV (one pinned vertex, say) fix no rotation: such an island turns as
        # its old UVs lie, so pinning a vertex and unwrapping again does not spin it (after
        # a pack that rotated it, or a turn by hand)
        _, _, _, spread = similarity_fit(uv, ref, island, w_lock, n, scale=False)
        _, R_old, _, ok_old = similarity_fit(uv, ref, island, np.ones_like(w_lock), n, scale=False)
        turn = held & ~spread & ok_old & usable & (np.bincount(island, np.abs(_areas(ref)), minlength=n) > 0)
        if turn.any():
            R_turn = np.where(turn[:, None, None], R_old, np.eye(2))
            uv = _apply(uv, island, np.ones(n), R_turn, np.zeros((n, 2)))
        s, R, shift, ok = similarity_fit(uv, ref, island, w_lock, n, scale=not world_scale)
        s = np.where(held, s, 1.0)
        R = np.where(held[:, None, None], R, np.eye(2))
        shift = np.where(held[:, None], shift, 0.0)
        uv = _apply(uv, island, s, R, shift)
        uv[locked] = old[locked]
    return uv, held
