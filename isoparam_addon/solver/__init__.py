"""isoparam's solver: Sun & Hancock's fast isometric parametrization, in numpy/scipy.

>>> from isoparam_addon.solver import parametrize
>>> result = parametrize(vertices, faces)        # doctest: +SKIP
>>> result.uv                                    # (n, 2) float64, one UV per vertex

This package never imports bpy: it runs in plain CPython and inside Blender alike.
"""

from __future__ import annotations

import time
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, field

import numpy as np

from . import metrics
from ._memory import retained
from .align import fit_rotation_scale, orient, pack_islands, place
from .cuts import area_distortion, next_paths
from .embed import plan_elimination, spectral_embedding
from .errors import InvalidMeshError, IsoparamError, SolverError, counted
from .geometry import signed_areas
from .islands import Islands
from .local import local_flattening
from .mesh import unit_of
from .pins import fit_to_pins, pin_targets, pins_spread, refine_to_pins, similarity
from .refine import quadratic_proxy
from .refine import refine as _refine
from .topology import Topology, build_topology
from .weights import reconstruction_weights

__all__ = [
    "parametrize",
    "Parametrization",
    "IsoparamError",
    "InvalidMeshError",
    "SolverError",
    "metrics",
]


@dataclass
class Parametrization:
    """What :func:`parametrize` returns.

    Attributes
    ----------
    uv : (n, 2) float64
        One UV per input vertex, in mesh units (true scale). A vertex on a seam or an
        automatic cut has several UVs; ``uv`` holds the one of its lowest split copy and
        ``corner_uv`` holds them all. Vertices used by no face get (0, 0).
    corner_uv : (m, 3, 2) float64
        UV of every face corner, in the input corner order.
    face_island : (m,) int64
        Island of each face.
    n_islands : int
    cut_edges : (k, 2) int64
        Vertex pairs of edges cut automatically to open non-disk islands (and to lower
        their distortion, with ``extra_cuts``).
    cut_islands : (j,) int64
        Islands that were not topological disks (closed, with handles, several boundary
        loops, non-orientable) and were cut.
    flipped : (m,) bool
        Faces whose UV triangle is clockwise (folded) or collapsed.
    eigenvalues : (n_islands, 2) float64
        Ritz values of ``M`` for the two embedding vectors (Step 3).
    converged : (n_islands,) bool
        Whether Step 3 met its tolerance on each island.
    warnings : list of str
        Those a caller may word its own way are :class:`Notice` objects, whose ``kind``
        names the case (``"pin_conflict"``).
    timings : dict
        Seconds per step.
    stats : dict
        Counters: extra vertices borrowed, regularized rows, pinned vertices whose corners
        are pinned to different UVs (``pin_conflicts``), iterations, ...
    """

    uv: np.ndarray
    corner_uv: np.ndarray
    face_island: np.ndarray
    n_islands: int
    cut_edges: np.ndarray
    cut_islands: np.ndarray
    flipped: np.ndarray
    eigenvalues: np.ndarray
    converged: np.ndarray
    warnings: list = field(default_factory=list)
    timings: dict = field(default_factory=dict)
    stats: dict = field(default_factory=dict)
    _mesh: tuple = field(default=None, repr=False)
    _turned: np.ndarray = field(default=None, repr=False)  # (m,) faces the solver turned round
    _facts: dict = field(default=None, repr=False)

    def distortion(self) -> dict:
        """All measures of :mod:`isoparam_addon.solver.metrics` for this layout.

        Faces the solver turned round to orient their island consistently are measured
        turned round too, so ``flipped`` counts what :attr:`flipped` flags.
        """
        V, F = self._mesh
        cuv = self.corner_uv
        if self._turned is not None:
            turned = self._turned[:, None]
            F = np.where(turned, F[:, ::-1], F)
            cuv = np.where(turned[:, :, None], cuv[:, ::-1], cuv)
        return metrics.distortion(V, F, cuv, self.face_island)


def _opened(topo: Topology) -> list[str]:
    """Warnings for the islands that were cut into disks automatically."""
    out = []
    for name, isl in (
        ("closed", topo.closed_islands),
        ("with handles", topo.handle_islands),
        ("with several boundary loops", topo.multi_boundary_islands),
        ("non-orientable", topo.nonorientable_islands),
    ):
        if len(isl):
            out.append(
                f"{counted(len(isl), 'island', 'islands')} {name} {'was' if len(isl) == 1 else 'were'} cut into "
                "disks automatically "
                f"(first: island {isl[0]}); mark seams to choose the cut"
            )
    return out


_FAR = 1e3  # a refined island with more symmetric Dirichlet energy per area than this is reported


class Notice(str):
    """A warning's text, and ``kind`` naming the case for a caller that words it its own
    way (the add-on's operator keeps every pinned corner on its own UV, not at the mean)."""

    kind: str = ""

    def __new__(cls, text: str, kind: str = ""):
        self = super().__new__(cls, text)
        self.kind = kind
        return self


def _warnings(facts: dict, converged: np.ndarray, flipped: np.ndarray) -> list[str]:
    """The result's warnings from the per-island ``facts`` (see :func:`_parametrize`)."""
    out = list(facts["opened"])
    bad = np.flatnonzero(~converged)
    if bad.size:
        out.append(
            f"step 3 did not converge on {bad.size} island(s) (first: island {bad[0]}, "
            f"subspace change {facts['change'][bad[0]]:.1e})"
        )
    if facts["clipped"].any():
        out.append(f"step 4 fitted a degenerate scale on {int(facts['clipped'].sum())} island(s)")
    if facts["regularized"].any():
        n = int(facts["regularized"].sum())
        out.append(f"{counted(n, 'vertex has', 'vertices have')} no exact reconstruction (degenerate fans)")
    restarted = {name: int(facts[name].sum()) for name in ("conformal", "tutte")}
    if sum(restarted.values()):
        seeds = " and ".join(
            f"{k} from a {'conformal map' if name == 'conformal' else 'Tutte embedding'}"
            for name, k in restarted.items()
            if k
        )
        out.append(f"the four-step layout folded on some islands; refinement restarted {seeds}")
    one_point = facts["one_point"]
    if one_point.any():
        out.append(
            f"{counted(int(one_point.sum()), 'island has', 'islands have')} all their pins on one UV (first: island "
            f"{np.argmax(one_point)}): moved there, not scaled or shaped by them"
        )
    mean = facts["pin_mean"]
    if mean.any():
        text = (
            f"{counted(int(mean.sum()), 'pinned vertex has', 'pinned vertices have')} corners pinned to different "
            f"UVs (first: island "
            f"{np.argmax(mean > 0)}): each is held at their mean"
        )
        out.append(Notice(text, "pin_conflict"))
    # a seed that crushed faces to 1e-7 of their area (a Tutte embedding of a head cut
    # open through its holes, found by fuzzing) kept an energy of 6e8 through 100
    # iterations; the report's stretch shows it, this says what to do about it
    energy, area = facts["refine_energy"], facts["refine_area"]
    stuck = np.flatnonzero((area > 0) & (energy > _FAR * area) & ~facts["shaped"])
    if stuck.size:
        i = stuck[0]
        out.append(
            f"the refinement left {counted(stuck.size, 'island', 'islands')} far from isometric (first: island {i}, "
            f"symmetric Dirichlet {energy[i] / area[i]:.3g} per area, 4 is isometric): its start squeezed faces the "
            "descent could not open; mark seams to cut it where it is squeezed"
        )
    missed = np.flatnonzero(~facts["reached"])
    if missed.size:
        out.append(
            f"the pins of {missed.size} island(s) could not all be reached without folding the layout "
            f"(first: island {missed[0]})"
        )
    if flipped.any():
        n = int(flipped.sum())
        out.append(
            f"{counted(n, 'triangle is', 'triangles are')} flipped in the layout (first: face {np.argmax(flipped)})"
        )
    if facts["unused"]:
        n = facts["unused"]
        out.append(
            f"{counted(n, 'vertex belongs', 'vertices belong')} to no face and "
            f"{'was' if n == 1 else 'were'} placed at (0, 0)"
        )
    return out


def _stats(facts: dict, steps: dict) -> dict:
    """The result's counters: the per-island ``facts`` summed, and ``steps``."""
    stats = {key: int(facts[key].sum()) for key in ("extra_vertex", "regularized")}
    stats["pin_conflicts"] = int(facts["pin_mean"].sum())
    stats.update(steps)
    if "refine_iterations" in steps:
        stats["reseeded"] = {name: int(facts[name].sum()) for name in ("conformal", "tutte")}
    return stats


def parametrize(
    vertices,
    faces,
    seams=None,
    *,
    pack: bool = True,
    margin: float = 0.02,
    tol: float = 1e-8,
    max_iter: int = 40,
    split_bowties: bool = False,
    refine: int = 0,
    pins=None,
    inner_edges=None,
    extra_cuts: int = 0,
) -> Parametrization:
    """Unwrap a triangle mesh with Sun & Hancock's isometric parametrization.

    Parameters
    ----------
    vertices : (n, 3) array_like of float
    faces : (m, 3) array_like of int
    seams : (k, 2) array_like of int, optional
        Vertex pairs of edges to cut along; pairs that are not edges are ignored.
    inner_edges : (k, 2) array_like of int, optional
        Vertex pairs of edges that automatic cuts avoid whenever they can: the diagonals
        of triangulated quads and n-gons, which a polygon mesh does not have (a cut
        there would give one face corner two UVs).
    pack : bool
        Place islands side by side without overlap (mesh units). If False every island
        is centred at the origin in its own frame.
    margin : float
        Gap between packed islands, as a fraction of the square root of their total area.
    tol, max_iter :
        Convergence of Step 3 (sine of the subspace change) and its iteration cap.
    split_bowties : bool
        Split vertices whose faces form several fans (bow-ties; faces touching at one
        vertex go to different islands, as in Blender) instead of raising.
    refine : int
        Iterations of isometric refinement (symmetric Dirichlet, no folds; see
        :mod:`.refine`) after the four steps. 0, the default, is the paper's method.
    pins : (corners (m, 3) bool, uv (m, 3, 2) float), optional
        Face corners whose UV is given. An island with pins is fitted to them (rotation,
        scale and shift from two pins on, shift from one); refinement keeps them fixed,
        so three or more also shape the island. Islands with two or more pins on distinct
        UVs keep the pins' frame; one pin (or pins on one UV) moves the island without
        turning it from an unpinned island's frame. Automatic cuts keep off pinned
        vertices where they can.
    extra_cuts : int
        Islands that had to be cut automatically (closed, handles, holes) get up to this
        many more cuts, each the shortest path from the island's boundary to its most
        distorted vertex, as long as each lowers the island's area distortion by 1% or
        more (see :mod:`.cuts`). Every attempt solves those islands again, alone; the
        result is the first solve of the whole mesh with each island taken from the last
        attempt that kept its cut (``stats["refine_energy"]`` is then the first solve's
        history followed by the final layout's energy). 0: the shortest cut that opens
        the island, nothing more. ``stats["extra_cut_gains"]`` lists per attempt the
        largest relative drop among the islands tried (None: the attempt split an island
        or left one to be cut open again, and ended the search).

    Returns
    -------
    Parametrization

    Raises
    ------
    InvalidMeshError
        For invalid input (see :func:`mesh.validate`); nothing is modified in place.
    """
    options = dict(
        pack=pack,
        margin=margin,
        tol=tol,
        max_iter=max_iter,
        split_bowties=split_bowties,
        inner_edges=_off_pins(faces, _pinned_vertices(faces, pins), inner_edges),
        refine=refine,
        pins=pins,
    )
    with retained(enabled=_is_large(vertices)):
        if extra_cuts > 0:
            return _with_extra_cuts(vertices, faces, seams, extra_cuts, options)
        return _parametrize(vertices, faces, seams, **options)


_GAIN = 0.01  # an extra cut stays if it lowers its island's area distortion by this much


def _pinned_vertices(faces, pins) -> np.ndarray | None:
    """The mesh vertices with a pinned corner, or None (no pins, or input that validation
    will reject: it is passed on as it is)."""
    try:
        F, mask = np.asarray(faces), np.asarray(pins[0], dtype=bool)
    except (TypeError, ValueError, IndexError):
        return None
    if F.ndim != 2 or F.shape[1:] != (3,) or F.dtype.kind not in "iu" or mask.shape != F.shape or not mask.any():
        return None
    return np.unique(F[mask]).astype(np.int64)


def _off_pins(faces, pinned, inner_edges):
    """``inner_edges`` and every edge at a ``pinned`` vertex: automatic and extra cuts keep
    off those where they can. A cut through a pinned vertex splits it into copies that its
    pins, all on the vertex's one UV, would glue back together, folding the layout there
    (found in review: a torus pinned where its two cut loops meet, 6 flipped faces)."""
    if pinned is None:
        return inner_edges
    F = np.asarray(faces, dtype=np.int64)
    E = np.zeros((0, 2), dtype=np.int64) if inner_edges is None else np.asarray(inner_edges)
    if E.size and (E.ndim != 2 or E.shape[1] != 2 or E.dtype.kind not in "iu"):
        return inner_edges  # validation reports it
    at = np.isin(F, pinned)
    edges = np.stack([F, F[:, [1, 2, 0]]], axis=2)[at | at[:, [1, 2, 0]]]  # each corner's edge to the next
    return np.vstack([E.reshape(-1, 2).astype(np.int64), edges])


def _pairs(seams) -> np.ndarray:
    """Seams as a (k, 2) int64 array (k = 0 for None)."""
    return np.zeros((0, 2), dtype=np.int64) if seams is None else np.asarray(seams, dtype=np.int64).reshape(-1, 2)


def _sub_problem(V, F, faces, seams, options: dict):
    """The mesh of ``faces`` (indices into F) alone: its vertices, faces, seams and options
    (unpacked; pins, seams and polygon diagonals renumbered)."""
    used = np.unique(F[faces])
    index = np.full(len(V), -1, dtype=np.int64)
    index[used] = np.arange(len(used))

    def inside(pairs):
        if pairs is None:
            return None
        p = index[np.asarray(pairs, dtype=np.int64).reshape(-1, 2)]
        return p[(p >= 0).all(axis=1)]

    # split_bowties: two wedges of an island around a vertex that other islands' faces
    # separated (with seams) meet at a bare vertex once those faces are left out
    part = dict(options, pack=False, split_bowties=True, inner_edges=inside(options["inner_edges"]))
    if options["pins"] is not None:
        part["pins"] = tuple(np.asarray(a)[faces] for a in options["pins"])
    return V[used], index[F[faces]], inside(seams), part


def _solve_part(V, F, face_island, islands, seams, options: dict):
    """Solve the faces of ``islands`` alone (islands are independent problems), unpacked.

    Returns the result and the faces it covers (indices into F, or None for all of them:
    then it is the whole mesh's result with ``options`` as given)."""
    faces = np.flatnonzero(np.isin(face_island, islands))
    if len(faces) == len(F):
        return _parametrize(V, F, seams, **options), None
    Vs, Fs, seams_s, part = _sub_problem(V, F, faces, seams, options)
    return _parametrize(Vs, Fs, seams_s, **part), faces


def _with_extra_cuts(vertices, faces, seams, rounds: int, options: dict) -> Parametrization:
    """:func:`parametrize` with ``extra_cuts=rounds``.

    The whole mesh is solved once, as with ``extra_cuts=0``; the cuts are then grown on
    the islands that had to be cut open, each try solving those islands alone; the
    result is the first solve with the kept tries' islands put in (:func:`_merge`).
    Nothing is solved twice. Before, the cut islands were solved alone first and the
    whole mesh after the tries, which paid that first solve again when no cut was kept
    (islands with holes that their automatic cut opens well enough). Measured on Suzanne
    subdivided four times with Smart UV seams (4 of 344 islands cut open, no try made,
    refine=100): 8.6-9.0 s before, 6.4-7.5 s now, 6.75 s with ``extra_cuts=0``; a 100k
    peaks beside a closed box (4 tries kept): 5.8-6.6 s before, 5.0-6.3 s now.
    """
    first = _parametrize(vertices, faces, seams, **options)
    if not first.cut_islands.size:  # nothing was cut open: the same keys, nothing done
        first.stats.update(extra_cut_tries=0, extra_cut_edges=0, extra_cut_gains=[])
        return first
    return _extend_cuts(first, seams, rounds, options)


def _lowered(added: int, before: np.ndarray, score: np.ndarray) -> list[str]:
    """The warning that says what the extra cuts did (``before``/``score``: area
    distortion of the islands that were cut open, before and after)."""
    if not added:
        return []
    return [
        f"{added} more edges cut on {int((score < before).sum())} of them, lowering "
        f"their area distortion from {before.mean():.3g} to {score.mean():.3g}"
    ]


def _grow(first: Parametrization, seams, rounds: int, options: dict):
    """Grow the automatic cuts of ``first`` (see :mod:`.cuts`): one path per island and
    round, kept where it lowers that island's area distortion by ``_GAIN``. A try solves
    only the islands still being grown.

    Returns the cuts (automatic, then extra), the kept tries as ``(result, faces, won)``
    (the try's result, the faces it covers as indices into the mesh's, and the islands,
    in ``first``'s numbering, whose cut it kept), the number of tries, their gains, and
    the area distortion of the islands cut open before and after.
    """
    V, F = first._mesh
    base = _pairs(seams)
    isl = first.face_island
    cuts = first.cut_edges
    bad, before = area_distortion(V, F, first.corner_uv, isl, first.n_islands)
    score = before.copy()
    active = first.cut_islands.copy()
    kept, tries, gains = [], 0, []
    while active.size and tries < rounds:
        new, owner, got = next_paths(V, F, isl, active, bad, np.vstack([base, cuts]), options["inner_edges"])
        active = active[got]
        if not active.size:
            break
        tries += 1
        trial, faces = _solve_part(V, F, isl, active, np.vstack([base, cuts, new]), options)
        if trial.n_islands != len(active) or trial.cut_islands.size:  # a slit keeps one disk
            gains.append(None)  # tried, not measured
            break
        if faces is None:
            t_bad, m = area_distortion(V, F, trial.corner_uv, trial.face_island, trial.n_islands)
            faces = np.arange(len(F))
        else:
            t_bad, m = area_distortion(*trial._mesh, trial.corner_uv, trial.face_island, trial.n_islands)
            label = np.empty(trial.n_islands, dtype=np.int64)  # the trial's islands in ``first``'s numbering
            label[trial.face_island] = isl[faces]
            m = np.bincount(label, m, minlength=first.n_islands)
        gain = 1.0 - m[active] / np.maximum(score[active], 1e-300)
        gains.append(float(gain.max()))
        better = gain >= _GAIN
        if not better.any():
            break
        won = active[better]
        cuts = np.vstack([cuts, new[np.isin(owner, won)]])
        score[won] = m[won]
        mine = np.isin(isl[faces], won)
        bad[faces[mine]] = t_bad[mine]
        kept.append((trial, faces, won))
        active = won
    opened = first.cut_islands
    return cuts, kept, tries, gains, before[opened], score[opened]


def _extend_cuts(first: Parametrization, seams, rounds: int, options: dict) -> Parametrization:
    """:func:`_grow` on ``first``, then the whole mesh's result with the cuts kept: the
    last kept try when it covered the whole mesh, else ``first`` with the kept tries'
    islands merged in."""
    t0 = time.perf_counter()
    cuts, kept, tries, gains, before, score = _grow(first, seams, rounds, options)
    added = len(cuts) - len(first.cut_edges)
    best = first
    if kept:
        trial, faces, won = kept[-1]
        if len(faces) == len(first.face_island) and len(won) == first.n_islands:
            best = trial  # every island tried and kept: the try is the whole mesh's solve
        elif options["refine"] and first._facts["shaped"].any():
            # islands with three or more pins are moved onto them in stages, and every
            # stage refines all of them (pins.refine_to_pins), so a try alone can take
            # another path than the whole mesh would: solve it (found in review)
            V, F = first._mesh
            best = _parametrize(V, F, np.vstack([_pairs(seams), cuts]), **options)
        else:
            best = _merge(first, kept, np.vstack([_pairs(seams), cuts]), options)
        best.cut_edges, best.cut_islands = cuts, first.cut_islands
        best.warnings = [*first._facts["opened"], *_lowered(added, before, score), *best.warnings]
    best.timings["extra_cuts"] = time.perf_counter() - t0
    best.timings["total"] = first.timings["total"] + best.timings["extra_cuts"]
    best.stats.update(extra_cut_tries=tries, extra_cut_edges=added, extra_cut_gains=gains)
    return best


_PER_ISLAND = (
    *("change", "clipped", "held", "one_point", "pin_mean", "shaped", "extra_vertex", "regularized"),
    *("conformal", "tutte", "refine_energy", "refine_area", "reached"),
)
_STEPS = ("iterations", "vertices", "faces", "refine_iterations", "refine_energy")  # the counters not in facts


def _merge(first: Parametrization, kept: list, seams: np.ndarray, options: dict) -> Parametrization:
    """``first`` with the islands of the kept tries (``(result, faces, won)``, see
    :func:`_grow`) taken from the last try that kept each, packed together again.

    Islands are independent problems, so this is the whole mesh's solve with ``seams``
    (the cuts kept) to the solver's tolerance, without solving the islands no try changed
    again. (The refinement's L-BFGS history is a window shared by the islands, which
    couples them weakly: measured in review, an island no try touched moved by 6e-5 of
    the layout's size, its energy by 6e-7 relative.) The tries' islands come unpacked and
    turned to their principal axes, as ``first``'s are before packing, so only the packing
    is redone. ``refine_energy`` is ``first``'s history, then the merged layout's energy;
    ``iterations`` and ``refine_iterations`` the most any of the solves took.
    """
    t0 = time.perf_counter()
    V, F = first._mesh
    _, _, topo = build_topology(V, F, seams, options["split_bowties"], options["inner_edges"])
    same = topo.n_islands == first.n_islands and np.array_equal(topo.face_island, first.face_island)
    if not same or topo.cut_islands.size:  # not expected (a slit keeps one disk): solve it all
        return _parametrize(V, F, seams, **options)
    corner_uv = first.corner_uv.copy()
    eigenvalues, converged = first.eigenvalues.copy(), first.converged.copy()
    facts = {key: first._facts[key].copy() for key in _PER_ISLAND}
    steps = {key: value for key, value in first.stats.items() if key in _STEPS}
    for trial, faces, won in kept:  # later tries override earlier ones
        label = np.empty(trial.n_islands, dtype=np.int64)
        label[trial.face_island] = first.face_island[faces]
        mine = np.isin(first.face_island[faces], won)
        corner_uv[faces[mine]] = trial.corner_uv[mine]
        take = np.isin(label, won)
        to = label[take]
        eigenvalues[to], converged[to] = trial.eigenvalues[take], trial.converged[take]
        for key in _PER_ISLAND:
            facts[key][to] = trial._facts[key][take]
        for key in ("iterations", "refine_iterations"):
            if key in steps:
                steps[key] = max(steps[key], trial.stats[key])
    uv_split = np.zeros((len(topo.vertex_of), 2))
    uv_split[topo.corner_vertex.ravel()] = corner_uv.reshape(-1, 2)
    if options["pack"]:
        uv_split = pack_islands(uv_split, Islands(topo.vertex_island, topo.n_islands), options["margin"], facts["held"])
    flipped = signed_areas(uv_split / unit_of(V), topo.faces) <= 0  # as returned (see _parametrize)
    corner_uv, uv, unused = _per_corner_and_vertex(uv_split, topo, len(V))
    facts.update(opened=[], unused=unused)
    steps["split_vertices"] = len(topo.vertex_of)
    if "refine_energy" in steps:  # the merged layout's energy, as the refinement measures it
        area = facts["refine_area"].sum()
        steps["refine_energy"] = [*steps["refine_energy"], float(facts["refine_energy"].sum() / max(area, 1e-300))]
    timings = dict(first.timings)
    timings["merge"] = time.perf_counter() - t0
    return Parametrization(
        uv=uv,
        corner_uv=corner_uv,
        face_island=first.face_island,
        n_islands=first.n_islands,
        cut_edges=topo.cut_edges,
        cut_islands=topo.cut_islands,
        flipped=flipped,
        eigenvalues=eigenvalues,
        converged=converged,
        warnings=_warnings(facts, converged, flipped),
        timings=timings,
        stats=_stats(facts, steps),
        _mesh=(V, F),
        _turned=topo.flipped,
        _facts=facts,
    )


_THREAD_FROM = 20_000  # below this a second thread costs more than it saves


class _Inline:
    """A stand-in for a one-worker pool that runs the task when its result is asked for."""

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        return False

    def submit(self, fn, *args):
        return _Deferred(fn, args)


class _Deferred:
    def __init__(self, fn, args):
        self.fn, self.args = fn, args

    def result(self):
        if self.fn is not None:  # run once, on first demand
            self.value, self.fn, self.args = self.fn(*self.args), None, None
        return self.value


def _proxy(X, faces, islands, pinned, plan):
    """The refinement's factored proxy, in the plan's elimination order (``plan`` is a
    future of the same one-worker pool, so it has finished when this task starts)."""
    plan = plan.result()
    return quadratic_proxy(X, faces, islands, pinned, np.concatenate([plan.free_order, plan.pins.ravel()]))


def _edge_lengths(X: np.ndarray, edges: np.ndarray) -> np.ndarray:
    """3D length of every edge (e,), from 1-D column gathers (row gathers of (n, 3)
    arrays take 5x longer)."""
    a, b = np.ascontiguousarray(edges[:, 0]), np.ascontiguousarray(edges[:, 1])
    total = np.zeros(len(edges))
    for c in range(3):  # x, y, z
        col = np.ascontiguousarray(X[:, c])
        d = col[a] - col[b]
        total += d * d
    return np.sqrt(total)


def _is_large(vertices) -> bool:
    try:
        return len(vertices) >= 200_000
    except TypeError:
        return False


def _parametrize(vertices, faces, seams, *, pack, margin, tol, max_iter, split_bowties, refine, pins, inner_edges):
    t = {}
    t0 = time.perf_counter()
    # a closed island's cut loops all meet at its root: never a pinned vertex if it can be helped
    V, F, topo = build_topology(vertices, faces, seams, split_bowties, inner_edges, _pinned_vertices(faces, pins))
    faces_i = topo.faces
    # work in units of a power of two near the mesh's size (exact in floating point)
    unit = unit_of(V)
    X = V[topo.vertex_of] / unit
    islands = Islands(topo.vertex_island, topo.n_islands)
    he = topo.he
    fan = topo.fans
    pinned = target = one_point = disagree = None
    if pins is not None:
        pinned, target, disagree = pin_targets(topo, pins, len(X))
        target = target / unit
        count = np.bincount(islands.label, pinned, minlength=islands.n)
        # several pinned mesh vertices on one UV place the island but do not scale it (the
        # copies of one pinned vertex split by a seam or cut count once)
        pin_pairs = np.unique(islands.label[pinned] * np.int64(len(V)) + topo.vertex_of[pinned])
        distinct = np.bincount(pin_pairs // len(V), minlength=islands.n)
        spread = pins_spread(pinned, target, islands)  # pinned, and not all on one UV
        one_point = (distinct >= 2) & ~spread
        # one or two pins, or pins all on one UV, do not shape an island
        shaping = pinned & ((count >= 3) & ~one_point)[islands.label]
    t1 = time.perf_counter()
    # the elimination plan needs no weights: on large meshes it runs beside Steps 1-2, and
    # the refinement's factored proxy (it needs the plan's order) beside Step 3
    with ThreadPoolExecutor(max_workers=1) if len(X) > _THREAD_FROM else _Inline() as pool:
        plan = pool.submit(plan_elimination, X, he.edge_vertices, islands)
        if refine:
            proxy = pool.submit(_proxy, X, faces_i, islands, shaping if pins is not None else None, plan)
        patches = local_flattening(X, faces_i, fan)
        t2 = time.perf_counter()
        L, flagged = reconstruction_weights(X, faces_i, he.twin, patches, len(X))
        t3 = time.perf_counter()
        plan = plan.result()
        emb = spectral_embedding(L, X, islands, tol=tol, max_iter=max_iter, plan=plan)
        t4 = time.perf_counter()
        proxy = proxy.result() if refine else None
    t_wait = time.perf_counter()  # past t4 only if the proxy outlasted Step 3
    edges = he.edge_vertices
    length = _edge_lengths(X, edges)
    Y, _, clipped = fit_rotation_scale(emb.coords, edges, length, islands.label[edges[:, 0]], islands)
    Y = orient(Y, faces_i, topo.face_island, islands)
    t5 = time.perf_counter()
    held = np.zeros(topo.n_islands, dtype=bool)
    order = np.concatenate([plan.free_order, plan.pins.ravel()])
    run = lambda seed, fixed: _refine(  # noqa: E731
        X, faces_i, seed, islands, he.twin, iterations=refine, pinned=fixed, order=order, proxy=proxy
    )
    info, reached = None, np.ones(islands.n, dtype=bool)
    if pins is not None:
        # refine in the layout's own frame (mesh units, what the energy measures) with the
        # pins mapped into it, then move each island onto its pins
        fit = fit_to_pins(Y, pinned, target, islands)
        held = fit[3]
        if refine:
            local = similarity(target, islands, *fit[:3], inverse=True)
            info, reached = refine_to_pins(run, Y, faces_i, shaping, local, islands)
            Y = info.uv
        Y = similarity(Y, islands, *fit[:3])
        light = (count <= 2) | one_point  # not shaped: fitted again below
        # pins on one UV give no rotation: islands they do not shape take the frame
        # unpinned islands get (principal axes), not the eigenvectors', which is arbitrary
        # up to a half turn and turned with the mesh in 3D; the refit moves them onto the
        # pins (copies of one vertex on several UVs, split by a seam, do turn an island)
        unturned = light & (count > 0) & ~spread
        if unturned.any():
            Y = np.where(unturned[islands.label][:, None], place(Y, islands, pack=False), Y)
        refit = fit_to_pins(Y, pinned, target, islands)  # islands with one or two pins: exact
        Y = np.where(light[islands.label][:, None], similarity(Y, islands, *refit[:3]), Y)
        Y[pinned] = target[pinned]
    elif refine:
        info = run(Y, None)
        Y = info.uv
    t6 = time.perf_counter()
    placed = place(Y, islands, pack=pack, margin=margin, fixed=held)
    # of the layout as returned (up to the power-of-two unit, which keeps every sign):
    # moving an island rounds a face of 1e-26 the mesh's area to clockwise or nothing
    # (found by fuzzing: unflagged, unwarned)
    flipped = signed_areas(placed, faces_i) <= 0
    uv_split = placed * unit
    corner_uv, uv, unused = _per_corner_and_vertex(uv_split, topo, len(V))
    t.update(topology=t1 - t0, local=t2 - t1, weights=t3 - t2, embedding=t4 - t3, align=t5 - t_wait)
    t["refine"] = t6 - t5 + (t_wait - t4)
    t.update({f"embedding.{k}": v for k, v in emb.timings.items()})
    t["total"] = time.perf_counter() - t0
    # what the warnings and counters say, per island: a result composed from several
    # solves (extra cuts) recombines these
    nI = islands.n
    never = np.zeros(nI, dtype=bool)
    facts = dict(
        opened=_opened(topo),
        change=emb.change,
        clipped=clipped,
        held=held,
        one_point=never if one_point is None else one_point,
        pin_mean=np.zeros(nI, dtype=np.int64)
        if disagree is None
        else np.bincount(islands.label, disagree, minlength=nI),
        shaped=never if pins is None else (count >= 3) & ~one_point,
        reached=reached,
        unused=unused,
        **{key: np.bincount(islands.label[idx], minlength=nI) for key, idx in flagged.items()},
        **(info.reseeded if info is not None else {"conformal": never, "tutte": never}),
        # in mesh units: another solve of some of these islands has another unit
        refine_energy=info.island_energy * unit**2 if info is not None else np.zeros(nI),
        refine_area=info.island_area * unit**2 if info is not None else np.zeros(nI),
    )
    steps = dict(iterations=emb.iterations, vertices=len(V), faces=len(F), split_vertices=len(X))
    if info is not None:
        steps.update(refine_iterations=info.iterations, refine_energy=info.energy)
    return Parametrization(
        uv=uv,
        corner_uv=corner_uv,
        face_island=topo.face_island,
        n_islands=topo.n_islands,
        cut_edges=topo.cut_edges,
        cut_islands=topo.cut_islands,
        flipped=flipped,
        eigenvalues=emb.eigenvalues,
        converged=emb.converged,
        warnings=_warnings(facts, emb.converged, flipped),
        timings=t,
        stats=_stats(facts, steps),
        _mesh=(V, F),
        _turned=topo.flipped,
        _facts=facts,
    )


def _per_corner_and_vertex(uv_split: np.ndarray, topo: Topology, n: int):
    """UVs of the split vertices (mesh units) as ``corner_uv`` (m, 3, 2) and ``uv`` (n, 2),
    and how many mesh vertices no face uses: a mesh vertex takes the UV of its lowest
    split copy, (0, 0) if it has none."""
    corner_uv = np.take(uv_split, topo.corner_vertex, axis=0)  # np.take: row gathers 5x faster
    uv = np.zeros((n, 2))
    first = np.full(n, len(uv_split), dtype=np.int64)
    np.minimum.at(first, topo.vertex_of, np.arange(len(uv_split)))
    used = first < len(uv_split)
    uv[used] = np.take(uv_split, first[used], axis=0)
    return corner_uv, uv, int(n - used.sum())
