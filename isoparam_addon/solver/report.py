"""What a solve reports besides the UVs: per-island facts, counters, timings, warnings.

Every record here is typed: a caller reads fields, never message text. A warning has a
``kind`` (the table in :class:`SolverWarning`), a ``count``, the ``first`` element
concerned and its ``text``, so the operator can word or drop a case without parsing.
"""

from __future__ import annotations

from dataclasses import dataclass, field, fields

import numpy as np

from .errors import counted

__all__ = ["IslandReport", "SolverWarning", "Stats", "Timings", "warnings"]

FAR = 1e3  # a refined island with more symmetric Dirichlet energy per area than this is reported


@dataclass(frozen=True)
class SolverWarning:
    """One thing about a result that its user should know.

    ``kind``, and what ``count`` and ``first`` count:

    ==================== ==========================================================
    ``cut_closed``       islands closed, cut into disks automatically (islands)
    ``cut_handles``      islands with handles, cut (islands)
    ``cut_holes``        islands with several boundary loops, cut (islands)
    ``cut_nonorientable`` non-orientable islands, cut (islands)
    ``extra_cuts``       edges cut further to lower distortion (edges; first: None)
    ``not_converged``    islands on which Step 3 missed its tolerance (islands)
    ``degenerate_scale`` islands whose Step 4 scale was clipped (islands; first: None)
    ``degenerate_fans``  vertices with no exact reconstruction (vertices; first: None)
    ``restarted``        islands whose four-step layout folded and was replaced (islands)
    ``pins_on_one_uv``   islands whose pins all sit on one UV (islands)
    ``pin_conflict``     pinned vertices whose corners have different UVs (vertices;
                         first: an island holding one)
    ``far_from_isometric`` refined islands left far from isometric (islands)
    ``pins_unreached``   islands whose pins could not all be reached unfolded (islands)
    ``flipped``          triangles folded in the layout (faces)
    ``unused_vertices``  vertices of no face, placed at (0, 0) (vertices; first: None)
    ==================== ==========================================================
    """

    kind: str
    count: int
    first: int | None
    text: str

    def __str__(self) -> str:
        return self.text


@dataclass
class IslandReport:
    """Per-island facts of a solve, each (n_islands,); a result composed from several
    solves (extra cuts) takes each island's facts from the solve that laid it out.

    Attributes
    ----------
    change : float
        Step 3's last subspace change.
    clipped : bool
        Step 4 fitted a degenerate scale.
    extra_vertex, regularized : int
        Vertices that borrowed a neighbour's neighbour / kept regularised weights (Step 2).
    held : bool
        Its pins fix its frame (the pack leaves it where it is).
    one_point : bool
        Pinned, with every pin on one UV.
    pin_conflicts : int
        Pinned vertices whose corners are pinned to different UVs.
    shaped : bool
        Three or more pins shape it (refinement keeps them fixed).
    reached : bool
        Its pins were all reached without folding (True without pins).
    conformal, tutte : bool
        The refinement restarted it from a conformal map / a Tutte embedding.
    refine_energy, refine_area : float
        Symmetric Dirichlet energy and 3D area of its refined faces, mesh units (0 where
        not refined).
    """

    change: np.ndarray
    clipped: np.ndarray
    extra_vertex: np.ndarray
    regularized: np.ndarray
    held: np.ndarray
    one_point: np.ndarray
    pin_conflicts: np.ndarray
    shaped: np.ndarray
    reached: np.ndarray
    conformal: np.ndarray
    tutte: np.ndarray
    refine_energy: np.ndarray
    refine_area: np.ndarray

    def copy(self) -> IslandReport:
        return IslandReport(**{f.name: getattr(self, f.name).copy() for f in fields(self)})

    def take_from(self, other: IslandReport, to: np.ndarray, which: np.ndarray) -> None:
        """Islands ``to`` get the facts of ``other``'s islands ``which``."""
        for f in fields(self):  # a dozen fields
            getattr(self, f.name)[to] = getattr(other, f.name)[which]


@dataclass
class Stats:
    """Counters of a solve.

    Attributes
    ----------
    vertices, faces, split_vertices : int
        Input vertices and triangles, and vertices once split along seams and cuts.
    iterations : int
        Step 3 iterations (the most any solve took, with extra cuts).
    extra_vertex, regularized, pin_conflicts : int
        :class:`IslandReport`'s counts, summed.
    refine_iterations : int
        Refinement iterations (0 without refinement).
    refine_energy : list of float
        Symmetric Dirichlet energy per area after each refinement iteration, the seed's
        first (empty without refinement); with extra cuts, the first solve's history
        followed by the final layout's energy.
    restarted_conformal, restarted_tutte : int
        Islands the refinement restarted from a conformal map / a Tutte embedding.
    extra_cut_tries, extra_cut_edges : int
        Solves tried with more cuts, and edges cut beyond the shortest opening cut.
    extra_cut_gains : list of float or None
        Per try, the largest relative drop of area distortion among the islands tried
        (None: the try split an island and ended the search).
    """

    vertices: int = 0
    faces: int = 0
    split_vertices: int = 0
    iterations: int = 0
    extra_vertex: int = 0
    regularized: int = 0
    pin_conflicts: int = 0
    refine_iterations: int = 0
    refine_energy: list[float] = field(default_factory=list)
    restarted_conformal: int = 0
    restarted_tutte: int = 0
    extra_cut_tries: int = 0
    extra_cut_edges: int = 0
    extra_cut_gains: list[float | None] = field(default_factory=list)

    def count(self, islands: IslandReport) -> None:
        """Set the counters that sum :class:`IslandReport` facts."""
        self.extra_vertex = int(islands.extra_vertex.sum())
        self.regularized = int(islands.regularized.sum())
        self.pin_conflicts = int(islands.pin_conflicts.sum())
        self.restarted_conformal = int(islands.conformal.sum())
        self.restarted_tutte = int(islands.tutte.sum())


@dataclass
class Timings:
    """Seconds per step of a solve (``embedding_*``: inside Step 3)."""

    topology: float = 0.0
    local: float = 0.0
    weights: float = 0.0
    embedding: float = 0.0
    align: float = 0.0
    refine: float = 0.0
    placement: float = 0.0
    extra_cuts: float = 0.0
    merge: float = 0.0
    total: float = 0.0
    embedding_ordering: float = 0.0
    embedding_factorization: float = 0.0
    embedding_pinned_basis: float = 0.0
    embedding_iterations: float = 0.0


def opened(closed, handles, holes, nonorientable) -> list[SolverWarning]:
    """Warnings for the islands cut into disks automatically, (k,) int64 each: closed ones,
    ones with handles, with several boundary loops, non-orientable ones."""
    out = []
    for kind, name, isl in (
        ("cut_closed", "closed", closed),
        ("cut_handles", "with handles", handles),
        ("cut_holes", "with several boundary loops", holes),
        ("cut_nonorientable", "non-orientable", nonorientable),
    ):
        if len(isl):
            text = (
                f"{counted(len(isl), 'island', 'islands')} {name} {'was' if len(isl) == 1 else 'were'} cut into "
                f"disks automatically (first: island {isl[0]}); mark seams to choose the cut"
            )
            out.append(SolverWarning(kind, len(isl), int(isl[0]), text))
    return out


def lowered(added: int, before: np.ndarray, score: np.ndarray) -> list[SolverWarning]:
    """The warning that says what the extra cuts did (``before``/``score``: area
    distortion of the islands that were cut open, before and after)."""
    if not added:
        return []
    text = (
        f"{added} more edges cut on {int((score < before).sum())} of them, lowering "
        f"their area distortion from {before.mean():.3g} to {score.mean():.3g}"
    )
    return [SolverWarning("extra_cuts", added, None, text)]


def warnings(islands: IslandReport, converged: np.ndarray, flipped: np.ndarray, unused: int) -> list[SolverWarning]:
    """The warnings that follow from a result's per-island facts, its Step 3 convergence
    (n_islands,) bool, its folded faces (m,) bool and its count of unused vertices."""
    return [*_step_warnings(islands, converged), *_pin_warnings(islands), *_layout_warnings(flipped, unused)]


def _step_warnings(islands: IslandReport, converged: np.ndarray) -> list[SolverWarning]:
    out = []
    bad = np.flatnonzero(~converged)
    if bad.size:
        text = (
            f"step 3 did not converge on {bad.size} island(s) (first: island {bad[0]}, "
            f"subspace change {islands.change[bad[0]]:.1e})"
        )
        out.append(SolverWarning("not_converged", bad.size, int(bad[0]), text))
    if islands.clipped.any():
        n = int(islands.clipped.sum())
        out.append(SolverWarning("degenerate_scale", n, None, f"step 4 fitted a degenerate scale on {n} island(s)"))
    if islands.regularized.any():
        n = int(islands.regularized.sum())
        text = f"{counted(n, 'vertex has', 'vertices have')} no exact reconstruction (degenerate fans)"
        out.append(SolverWarning("degenerate_fans", n, None, text))
    restarted = {"conformal map": int(islands.conformal.sum()), "Tutte embedding": int(islands.tutte.sum())}
    if sum(restarted.values()):
        seeds = " and ".join(f"{k} from a {name}" for name, k in restarted.items() if k)
        first = int(np.argmax(islands.conformal | islands.tutte))
        text = f"the four-step layout folded on some islands; refinement restarted {seeds}"
        out.append(SolverWarning("restarted", sum(restarted.values()), first, text))
    # a start that crushed faces the descent could not open: the report's stretch shows
    # it, this says what to do about it
    energy, area = islands.refine_energy, islands.refine_area
    stuck = np.flatnonzero((area > 0) & (energy > FAR * area) & ~islands.shaped)
    if stuck.size:
        i = int(stuck[0])
        text = (
            f"the refinement left {counted(stuck.size, 'island', 'islands')} far from isometric (first: island "
            f"{i}, symmetric Dirichlet {energy[i] / area[i]:.3g} per area, 4 is isometric): its start squeezed "
            "faces the descent could not open; mark seams to cut it where it is squeezed"
        )
        out.append(SolverWarning("far_from_isometric", stuck.size, i, text))
    return out


def _pin_warnings(islands: IslandReport) -> list[SolverWarning]:
    out = []
    if islands.one_point.any():
        n, first = int(islands.one_point.sum()), int(np.argmax(islands.one_point))
        text = (
            f"{counted(n, 'island has', 'islands have')} all their pins on one UV (first: island {first}): "
            "moved there, not scaled or shaped by them"
        )
        out.append(SolverWarning("pins_on_one_uv", n, first, text))
    if islands.pin_conflicts.any():
        n, first = int(islands.pin_conflicts.sum()), int(np.argmax(islands.pin_conflicts > 0))
        text = (
            f"{counted(n, 'pinned vertex has', 'pinned vertices have')} corners pinned to different UVs "
            f"(first: island {first}): each is held at their mean"
        )
        out.append(SolverWarning("pin_conflict", n, first, text))
    missed = np.flatnonzero(~islands.reached)
    if missed.size:
        text = (
            f"the pins of {missed.size} island(s) could not all be reached without folding the layout "
            f"(first: island {missed[0]})"
        )
        out.append(SolverWarning("pins_unreached", missed.size, int(missed[0]), text))
    return out


def _layout_warnings(flipped: np.ndarray, unused: int) -> list[SolverWarning]:
    out = []
    if flipped.any():
        n, first = int(flipped.sum()), int(np.argmax(flipped))
        text = f"{counted(n, 'triangle is', 'triangles are')} flipped in the layout (first: face {first})"
        out.append(SolverWarning("flipped", n, first, text))
    if unused:
        text = (
            f"{counted(unused, 'vertex belongs', 'vertices belong')} to no face and "
            f"{'was' if unused == 1 else 'were'} placed at (0, 0)"
        )
        out.append(SolverWarning("unused_vertices", unused, None, text))
    return out
