"""Pinned UVs: where they come from, and fitting an island to them.

As in Blender: one pin places an island (turned as an unpinned island is, to its
principal axes), two also fix its rotation and scale (a similarity fit), and with
refinement three or more also shape it (the pins become Dirichlet constraints of
:func:`.descent.refine`). Before refining, the pins are moved onto their targets by a
harmonic deformation of the fitted layout, so the descent starts with every pin in
place (in stages if one move would fold, see
:func:`refine_to_pins`).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp
from scipy.sparse.linalg import splu

from ..errors import ErrorKind, InvalidMeshError, offenders
from ..geometry import signed_double_areas
from ..mesh.halfedges import pair_keys, unique_sorted
from ..mesh.islands import Islands
from ..refinement.descent import Refinement
from .placement import apply_similarity, place, similarity_fit

__all__ = ["Pins", "layout_on_pins", "pin_targets", "pins_on_islands", "refine_to_pins"]


def pin_targets(topo, pins, n: int):
    """Pinned split vertices and their UVs from per-corner input.

    Parameters
    ----------
    topo : Topology
    pins : (mask (m, 3) bool, uv (m, 3, 2) float)
    n : int

    Returns
    -------
    pinned : (n,) bool, target : (n, 2) float64
        A vertex pinned at several corners with different UVs gets their mean.
    disagree : (n,) bool
        Those vertices (corners more than 1e-9 of the largest pinned UV apart).
    """
    m = len(topo.corner_vertex)
    shapes = f"pins must be ((m, 3) bool, (m, 3, 2) float) with m = {m}"
    try:
        mask, uv = pins
        mask = np.asarray(mask, dtype=bool)
        uv = np.asarray(uv, dtype=np.float64)
    except (TypeError, ValueError) as e:  # not a pair, ragged lists, non-numbers
        raise InvalidMeshError(ErrorKind.SHAPE, f"{shapes}: {e}") from None
    if mask.shape != (m, 3) or uv.shape != (m, 3, 2):
        raise InvalidMeshError(ErrorKind.SHAPE, shapes)
    bad = np.flatnonzero((mask & ~np.isfinite(uv).all(axis=2)).any(axis=1))
    if bad.size:
        raise offenders(ErrorKind.NON_FINITE_PIN, "have pinned corners with non-finite UVs", "face", bad)
    v = topo.corner_vertex[mask]
    count = np.bincount(v, minlength=n)
    target = np.zeros((n, 2))
    given = uv[mask]
    for c in range(2):  # u and v
        target[:, c] = np.bincount(v, given[:, c], minlength=n) / np.maximum(count, 1)
    off = np.bincount(v, ((given - target[v]) ** 2).sum(axis=1), minlength=n)
    scale = float(np.abs(given).max(initial=0.0))
    return count > 0, target, off > (1e-9 * scale) ** 2 * count


class _Deformation:
    """Moves pins onto their targets, the rest following harmonically (uniform weights):
    ``_Deformation(faces, pinned, n)(Y, target)``, factored once for many moves."""

    def __init__(self, faces, pinned, n: int):
        self.pinned = pinned
        self.free = np.flatnonzero(~pinned)
        if not pinned.any() or not self.free.size:
            return
        e = np.concatenate([faces[:, [0, 1]], faces[:, [1, 2]], faces[:, [2, 0]]])
        A = sp.coo_matrix((np.ones(len(e)), (e[:, 0], e[:, 1])), shape=(n, n)).tocsr()
        A = ((A + A.T) > 0).astype(np.float64)
        Lap = (sp.diags(np.asarray(A.sum(axis=1)).ravel()) - A).tocsr()[self.free]
        K = Lap[:, self.free].tocsc()
        K = K + sp.identity(len(self.free), format="csc") * 1e-12 * K.diagonal().mean()
        self.lu = splu(K)
        self.coupling = Lap[:, np.flatnonzero(pinned)]

    def __call__(self, Y, target):
        move = target - Y
        if not self.pinned.any() or np.abs(move[self.pinned]).max() == 0:
            return Y
        d = np.zeros_like(Y)
        d[self.pinned] = move[self.pinned]
        if self.free.size:
            d[self.free] = self.lu.solve(np.ascontiguousarray(-(self.coupling @ move[self.pinned])))
        return Y + d


def refine_to_pins(solve, Y, faces, shaping, target, islands: Islands, stages: int = 8):
    """Refine with the shaping pins moved onto their targets, in stages if needed.

    Moving every pin at once can fold the layout when the targets are far from where
    the isometric layout puts them, and a barrier energy cannot start from a fold: the
    move is then halved until it leaves no fold, refined (the barrier keeps the result
    unfolded), and the rest of the way attempted again. Each island has its own move
    length and fold test: a fold in one island neither shortens another's move nor stops
    it. An island whose layout folds already (the four-step layout can) is refined
    without its pins (which restarts it from an unfolded seed, see :func:`.descent.refine`)
    and fitted to them by a similarity before they are moved.

    Parameters
    ----------
    solve : callable
        ``solve(uv, pinned) -> Refinement``: the refinement.
    Y : (n, 2) float64
    faces : (m, 3) int64
    shaping : (n,) bool
    target : (n, 2) float64
    islands : Islands
    stages : int
        Halvings and refinements together, at most (as many as pins that cannot be
        reached without a fold are worth).

    Returns
    -------
    (Refinement, reached (n_islands,) bool)
        The last refinement, with the iterations of all of them and, per island, the
        seed it was restarted from last; and per island whether its pins were all
        reached (True for islands without shaping pins).
    """
    lab = islands.label
    nI = islands.n
    reached = np.bincount(lab, shaping, minlength=nI) == 0
    if reached.all():  # nothing to move: a folded start is the refinement's to repair
        return solve(Y, shaping), reached
    face_island = lab[faces[:, 0]]
    deform = _Deformation(faces, shaping, len(Y))
    current, info, iterations = Y, None, 0
    folded = _folded(current, faces, face_island, nI) & ~reached
    fraction = np.where(folded | reached, 0.0, 1.0)
    for _ in range(stages):  # a few halvings and refinements
        goal = current + fraction[lab][:, None] * (target - current)
        trial = deform(current, goal)
        bad = _folded(trial, faces, face_island, nI) & (fraction > 0)
        if bad.any():
            fraction[bad] *= 0.5
            continue
        trial = trial.copy()
        trial[shaping] = goal[shaping]
        last, info = info, solve(trial, shaping & ~folded[lab])
        iterations += info.iterations
        if last is not None:  # where an island was restarted again, the later seed counts
            again = info.restarted_conformal | info.restarted_tutte
            info.restarted_conformal = np.where(again, info.restarted_conformal, last.restarted_conformal)
            info.restarted_tutte = np.where(again, info.restarted_tutte, last.restarted_tutte)
        current = info.uv
        reached |= fraction == 1.0
        if folded.any():  # refined without pins (and restarted): onto their pins' frame
            fit = similarity_fit(current, target, islands, shaping & folded[lab])
            current = np.where(folded[lab][:, None], apply_similarity(current, islands, fit), current)
            info.uv = current
            info.rescale(folded, fit.scale)  # the energy of the layout returned, if it is the last
        if reached.all():
            break
        folded = _folded(current, faces, face_island, nI) & ~reached
        fraction = np.where(folded | reached, 0.0, 1.0)
    if info is None:  # every move folded: refine without the pins
        info = solve(current, np.zeros(len(current), dtype=bool))
        iterations = info.iterations
    info.iterations = iterations
    return info, reached


def _folded(uv, faces, face_island, n_islands: int) -> np.ndarray:
    """(n_islands,) bool: the island has a face of zero or negative area in ``uv``."""
    bad = signed_double_areas(uv, faces) <= 0
    return np.bincount(face_island[bad], minlength=n_islands) > 0


@dataclass
class Pins:
    """The user's pins on the split vertices, and what they do to each island.

    As in Blender: one pin places an island (turned as an unpinned island is, to its
    canonical frame), two also fix its rotation and scale (a similarity fit), and with
    refinement three or more also shape it. Several pinned vertices all on one UV place
    the island but neither scale nor turn it.

    Attributes
    ----------
    pinned : (n,) bool
        Split vertices with a pin.
    target : (n, 2) float64
        Their UVs, in the solver's units.
    conflicts : (n,) bool
        Pinned vertices whose corners have different UVs (held at their mean).
    count : (n_islands,) int64
        Pinned split vertices per island.
    spread : (n_islands,) bool
        Pinned, and not all on one UV.
    one_point : (n_islands,) bool
        Two or more pinned mesh vertices, all on one UV.
    shaping : (n,) bool
        The pins that shape their island (refinement keeps them fixed).
    """

    pinned: np.ndarray
    target: np.ndarray
    conflicts: np.ndarray
    count: np.ndarray
    spread: np.ndarray
    one_point: np.ndarray
    shaping: np.ndarray

    @property
    def shaped(self) -> np.ndarray:
        """(n_islands,) bool: three or more pins, not all on one UV, shape the island."""
        return (self.count >= 3) & ~self.one_point

    @property
    def light(self) -> np.ndarray:
        """(n_islands,) bool: pins that place the island without shaping it."""
        return (self.count <= 2) | self.one_point


def pins_on_islands(topo, corners, islands: Islands, unit: float, n_mesh: int) -> Pins:
    """:class:`Pins` from per-corner input ``corners`` = (mask (m, 3), uv (m, 3, 2)) on the
    split vertices of ``topo``; ``unit`` is the solver's length unit, ``n_mesh`` the
    number of mesh vertices."""
    pinned, target, conflicts = pin_targets(topo, corners, len(islands.label))
    target = target / unit
    count = np.bincount(islands.label, pinned, minlength=islands.n)
    # the copies of one pinned vertex split by a seam or cut count once
    pairs = unique_sorted(pair_keys(islands.label[pinned], topo.vertex_of[pinned], n_mesh, ordered=True))
    distinct = np.bincount(pairs // n_mesh, minlength=islands.n)
    spread = similarity_fit(target, target, islands, pinned).ok  # pinned, and not all on one UV
    one_point = (distinct >= 2) & ~spread
    shaping = pinned & ((count >= 3) & ~one_point)[islands.label]
    return Pins(pinned, target, conflicts, count, spread, one_point, shaping)


def layout_on_pins(
    Y: np.ndarray, faces: np.ndarray, islands: Islands, pins: Pins, solve: Callable[..., Refinement] | None
):
    """The layout ``Y`` (n, 2) moved onto its pins, refined with them (``solve(uv,
    pinned) -> Refinement``) unless ``solve`` is None.

    The refinement runs in the layout's own frame (mesh units, what the energy measures)
    with the pins mapped into it; each island is then moved onto its pins. Islands the
    pins do not shape are fitted to them again at the end (exactly, with one or two pins);
    pins on one UV give no rotation, so such islands take the canonical frame of an
    unpinned island rather than the eigenvectors' (arbitrary up to a half turn).

    Returns ``(Y, refinement or None, reached (n_islands,) bool, held (n_islands,) bool)``:
    whether each island's pins were all reached, and whether they fix its frame.
    """
    fit = similarity_fit(Y, pins.target, islands, pins.pinned)
    held = pins.count > 0
    info, reached = None, np.ones(islands.n, dtype=bool)
    if solve is not None:
        local = apply_similarity(pins.target, islands, fit, inverse=True)
        info, reached = refine_to_pins(solve, Y, faces, pins.shaping, local, islands)
        Y = info.uv
    Y = apply_similarity(Y, islands, fit)
    unturned = pins.light & (pins.count > 0) & ~pins.spread
    if unturned.any():  # (copies of one vertex on several UVs, split by a seam, do turn an island)
        Y = np.where(unturned[islands.label][:, None], place(Y, islands, pack=False), Y)
    refit = similarity_fit(Y, pins.target, islands, pins.pinned)  # islands with one or two pins: exact
    Y = np.where(pins.light[islands.label][:, None], apply_similarity(Y, islands, refit), Y)
    Y[pins.pinned] = pins.target[pins.pinned]
    return Y, info, reached, held
