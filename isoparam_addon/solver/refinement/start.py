"""Where the refinement starts each island: its seed, unless the seed folds, crushes a
face or overlaps itself; then the best of the seed, a conformal map and a Tutte embedding
(:mod:`.seeds`).
"""

from __future__ import annotations

import numpy as np

from ..geometry import signed_double_areas
from ..mesh.islands import Islands, Labelled
from .per_face import FaceFrames, layout_energy
from .seeds import lscm, tutte

__all__ = ["start_layout"]

_CLEAR_PRICE = 1.5  # a start that does not overlap itself replaces one that does up to this much energy
_COLLAPSED = 1e-6  # a seed face with less UV area than this times its 3D area is crushed


def start_layout(
    X,
    faces,
    x,
    he_twin,
    islands: Islands,
    frames: FaceFrames,
    per_face: Labelled,
    pinned,
    order=None,
    poor=None,
    crossed=None,
):
    """The start of every island: its seed ``x`` (n, 2), unless the seed folds or crushes a
    face (UV area below ``_COLLAPSED`` times its 3D area), or overlaps itself (``crossed``:
    a function of a layout, per island whether its boundary crosses itself, if given),
    and the island has no pins (``poor`` (n_islands,) bool, if given, names the islands
    instead of this rule); then the lowest-energy layout that neither folds nor overlaps
    itself among the seed, a conformal map and (where the conformal map fails too) a
    Tutte embedding (one-to-one: Tutte 1963, Floater 2003).

    Returns the start, the islands that still fold, and those started from a conformal
    map and from a Tutte embedding, (n_islands,) bool each.
    """
    area2 = 2.0 * frames.area
    det = signed_double_areas(x, faces) / area2
    never = np.zeros(islands.n, dtype=bool)
    overlapping = never if crossed is None else crossed(x, None)
    crushed = per_face.sum(det <= _COLLAPSED) > 0
    if poor is None:
        poor = (crushed | overlapping) & (np.bincount(islands.label, pinned, minlength=islands.n) == 0)
    else:
        crushed = poor
    none = np.zeros(islands.n, dtype=bool)
    if not poor.any():
        return x, per_face.sum(det <= 0) > 0, none, none
    # per candidate (the seed, a conformal map, a Tutte embedding): energy (inf where it
    # folds or was not made) and whether it overlaps itself
    energy = [np.where(per_face.sum(det <= 0) > 0, np.inf, layout_energy(frames, per_face, x))]
    overlap = [overlapping]
    candidates = [x]
    want = poor
    for seed in (lscm, tutte):
        if not want.any():
            break
        try:
            y = (
                lscm(X, faces, islands, frames, want, order)
                if seed is lscm
                else tutte(X, faces, he_twin, islands, frames, want, order)
            )
        except RuntimeError:  # SuperLU: "Factor is exactly singular"; they keep what they have
            break
        d = signed_double_areas(y, faces) / area2
        folded = per_face.sum(d <= 0) > 0
        overlaps = never if crossed is None else crossed(y, want)
        energy.append(np.where(want & ~folded, layout_energy(frames, per_face, y), np.inf))
        overlap.append(overlaps)
        candidates.append(y)
        # a Tutte embedding only where the conformal map folds, crushes or overlaps itself
        want = want & (folded | (per_face.sum(d <= _COLLAPSED) > 0) | overlaps)
    E, crossing = np.array(energy), np.array(overlap)
    # the lowest energy that does not fold; if one that does not overlap itself either starts
    # at most _CLEAR_PRICE times that, the lowest such (the refinement then keeps it from
    # overlapping); an island whose seed only overlaps keeps it unless such a one is found
    lowest = E.min(axis=0)
    clear = ~crossing & (E <= _CLEAR_PRICE * lowest) & np.isfinite(E)
    chosen = np.where(clear.any(axis=0), np.argmin(np.where(clear, E, np.inf), axis=0), np.argmin(E, axis=0))
    chosen = np.where(poor & (crushed | clear.any(axis=0)), chosen, 0)
    x = candidates[0]
    for k in range(1, len(candidates)):
        x = np.where((chosen == k)[islands.label][:, None], candidates[k], x)
    still = per_face.sum(signed_double_areas(x, faces) <= 0) > 0
    return x, still, chosen == 1, chosen == 2
