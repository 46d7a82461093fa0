"""What a solve reports besides the UVs: per-island facts, counters, timings, warnings.

Every record here is typed: a caller reads fields, never message text. A warning has a
``kind`` (the table in :class:`SolverWarning`), a ``count``, the ``first`` element
concerned and a text template, so the operator can drop a case, or name elements its
own way, without parsing. The words of a warning are built next to the feature that
raises it (:func:`warning` makes one): the topology's and the four steps' here, the
charts', the extra cuts' and the overlap cuts' in :mod:`.charting`.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field, fields
from enum import StrEnum

import numpy as np

from .errors import counted

__all__ = [
    "FOUR_STEP_KINDS",
    "OPENED_KINDS",
    "TOPOLOGY_KINDS",
    "IslandReport",
    "SolverWarning",
    "Stats",
    "Timings",
    "WarningKind",
    "defects",
    "opened",
    "solver_names",
    "warning",
    "warnings",
]

FAR_ENERGY = 1e3  # a refined island with more symmetric Dirichlet energy per area than this is reported


Namer = Callable[[str, tuple[int, ...]], str]


def solver_names(element: str, first: tuple[int, ...]) -> str:
    """The solver's own names for an element: ``face 12`` (a triangle of the input),
    ``vertex 5``, ``edge (5, 9)`` (a vertex pair), ``island 3``."""
    if element == "edge":
        return f"edge ({first[0]}, {first[1]})"
    return f"{element} {first[0]}"


class WarningKind(StrEnum):
    """What a :class:`SolverWarning` is about; what its ``count`` counts and its
    ``element`` (``first`` names the first one)."""

    DUPLICATE_FACES = "duplicate_faces"  # faces repeating an earlier face's vertices (faces)
    NON_MANIFOLD_EDGES = "non_manifold_edges"  # edges shared by more than two faces, cut (edges)
    BOWTIES = "bowties"  # vertices whose faces form several fans, split (vertices)
    CUT_CLOSED = "cut_closed"  # islands closed, cut into disks automatically (islands)
    CUT_HANDLES = "cut_handles"  # islands with handles, cut (islands)
    CUT_HOLES = "cut_holes"  # islands with several boundary loops, cut (islands)
    CUT_NONORIENTABLE = "cut_nonorientable"  # non-orientable islands, cut (islands)
    EXTRA_CUTS = "extra_cuts"  # edges cut further to lower distortion (edges; no first)
    CHARTS = "charts"  # charts that islands were cut into (charts; first: one of them)
    OVER_BUDGET = "over_budget"  # islands whose charts stretch beyond Max Stretch (islands)
    CUT_APART = "cut_apart"  # islands that overlapped themselves, cut apart (islands; first: a piece)
    NOT_CONVERGED = "not_converged"  # islands on which Step 3 missed its tolerance (islands)
    DEGENERATE_SCALE = "degenerate_scale"  # islands whose Step 4 scale was clipped (islands; no first)
    DEGENERATE_FANS = "degenerate_fans"  # vertices with no exact reconstruction (vertices; no first)
    RESTARTED = "restarted"  # islands whose four-step layout folded and was replaced (islands)
    PINS_ON_ONE_UV = "pins_on_one_uv"  # islands whose pins all sit on one UV (islands)
    PIN_CONFLICT = "pin_conflict"  # pinned vertices whose corners have different UVs (vertices; first: an island)
    FAR_FROM_ISOMETRIC = "far_from_isometric"  # refined islands left far from isometric (islands)
    PINS_UNREACHED = "pins_unreached"  # islands whose pins could not all be reached unfolded (islands)
    OVERLAPPING = "overlapping"  # islands whose layout overlaps itself (islands)
    FLIPPED = "flipped"  # triangles folded in the layout (faces)
    UNUSED_VERTICES = "unused_vertices"  # vertices of no face, placed at (0, 0) (vertices; no first)


# what the topology split or cut open (the first solve says it; solving some islands again does not)
TOPOLOGY_KINDS = frozenset(
    {
        WarningKind.DUPLICATE_FACES,
        WarningKind.NON_MANIFOLD_EDGES,
        WarningKind.BOWTIES,
        WarningKind.CUT_CLOSED,
        WarningKind.CUT_HANDLES,
        WarningKind.CUT_HOLES,
        WarningKind.CUT_NONORIENTABLE,
    }
)
OPENED_KINDS = frozenset(
    {WarningKind.CUT_CLOSED, WarningKind.CUT_HANDLES, WarningKind.CUT_HOLES, WarningKind.CUT_NONORIENTABLE}
)
# what the paper's four steps met on the way (the refined layout starts from theirs)
FOUR_STEP_KINDS = frozenset(
    {WarningKind.NOT_CONVERGED, WarningKind.DEGENERATE_SCALE, WarningKind.DEGENERATE_FANS, WarningKind.RESTARTED}
)


@dataclass(frozen=True)
class SolverWarning:
    """One thing about a result that its user should know.

    ``kind`` is a :class:`WarningKind` (a string enum: it compares equal to its value),
    which says what ``count`` counts and what ``element`` ``first`` names.

    The text is ``template`` with ``{first}`` naming the first element; a caller that
    numbers elements its own way (the Blender operator: mesh faces and vertices, not
    triangles and split vertices) words it with :meth:`worded`.
    """

    kind: WarningKind
    count: int
    element: str  # "face", "vertex", "edge", "island", or "" (no first element)
    first: tuple[int, ...]
    template: str

    @property
    def text(self) -> str:
        return self.worded(solver_names)

    def worded(self, names: Namer) -> str:
        """The text, with the first element named by ``names(element, first)``."""
        return self.template.format(first=names(self.element, self.first) if self.first else "")

    def __str__(self) -> str:
        return self.text


def warning(kind: WarningKind, count: int, element: str, first, template: str) -> SolverWarning:
    """A warning of ``kind`` on ``count`` elements (``first``: the first one's indices),
    worded by ``template`` (its ``{first}`` is filled in with the caller's names)."""
    first = () if first is None else tuple(int(i) for i in np.atleast_1d(first))
    return SolverWarning(kind, int(count), element, first, template)


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
        Its four-step layout folded (or, refined, crushed faces): it was laid out from a
        conformal map / a Tutte embedding instead.
    refine_energy, refine_area : float
        Symmetric Dirichlet energy and 3D area of its refined faces, mesh units (0 where
        not refined).
    crossings : int
        Pairs of its boundary edges that cross in UV space: it overlaps itself.
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
    crossings: np.ndarray

    @classmethod
    def empty(cls, n: int) -> IslandReport:
        """Facts for ``n`` islands, all zero (False)."""
        kinds = {
            "change": float,
            "refine_energy": float,
            "refine_area": float,
            "extra_vertex": np.int64,
            "regularized": np.int64,
            "pin_conflicts": np.int64,
            "crossings": np.int64,
        }
        return cls(**{f.name: np.zeros(n, dtype=kinds.get(f.name, bool)) for f in fields(cls)})

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
        Islands laid out from a conformal map / a Tutte embedding instead of their
        four-step layout (it folded, or, refined, crushed faces).
    extra_cut_tries, extra_cut_edges : int
        Solves tried with more cuts, and edges cut beyond the shortest opening cut.
    overlap_cuts : int
        Edges cut to part islands that overlapped themselves.
    charts, chart_rounds : int
        Islands of the result that are charts of an island that could be cut into charts
        (no pins), and the rounds of stretch-driven splitting that made them.
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
    overlap_cuts: int = 0
    charts: int = 0
    chart_rounds: int = 0

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
    charts: float = 0.0
    untangle: float = 0.0
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
        (WarningKind.CUT_CLOSED, "closed", closed),
        (WarningKind.CUT_HANDLES, "with handles", handles),
        (WarningKind.CUT_HOLES, "with several boundary loops", holes),
        (WarningKind.CUT_NONORIENTABLE, "non-orientable", nonorientable),
    ):
        if len(isl):
            template = (
                f"{counted(len(isl), 'island', 'islands')} {name} {'was' if len(isl) == 1 else 'were'} cut into "
                "disks automatically (first: {first}); mark seams to choose the cut"
            )
            out.append(warning(kind, len(isl), "island", isl[0], template))
    return out


def defects(found) -> list[SolverWarning]:
    """Warnings for what validation split because it was not a manifold (a
    :class:`.halfedges.Defects`), as Blender's unwrap does."""
    out = []
    if len(found.duplicate_faces):
        n = len(found.duplicate_faces)
        template = (
            f"{counted(n, 'face repeats', 'faces repeat')} the vertices of an earlier face (first: {{first}}): "
            f"{'it is' if n == 1 else 'each is'} laid out as an island of its own; delete the copies"
        )
        out.append(warning(WarningKind.DUPLICATE_FACES, n, "face", found.duplicate_faces[0], template))
    if len(found.edges):
        n = len(found.edges)
        template = (
            f"{counted(n, 'edge is', 'edges are')} shared by more than two faces (first: {{first}}): cut as seams, "
            "each fan of faces on its own side (Select > Select All by Trait > Non Manifold shows them)"
        )
        out.append(warning(WarningKind.NON_MANIFOLD_EDGES, n, "edge", found.edges[0], template))
    if len(found.bowties):
        n = len(found.bowties)
        template = (
            f"{counted(n, 'vertex joins', 'vertices join')} faces that share no edge around "
            f"{'it' if n == 1 else 'them'} (first: {{first}}): split into one copy for each group of faces"
        )
        out.append(warning(WarningKind.BOWTIES, n, "vertex", found.bowties[0], template))
    return out


def warnings(islands: IslandReport, converged: np.ndarray, flipped: np.ndarray, unused: int) -> list[SolverWarning]:
    """The warnings that follow from a result's per-island facts, its Step 3 convergence
    (n_islands,) bool, its folded faces (m,) bool and its count of unused vertices."""
    return [*_step_warnings(islands, converged), *_pin_warnings(islands), *_layout_warnings(islands, flipped, unused)]


def _step_warnings(islands: IslandReport, converged: np.ndarray) -> list[SolverWarning]:
    out = []
    bad = np.flatnonzero(~converged)
    if bad.size:
        template = (
            f"step 3 did not converge on {counted(bad.size, 'island', 'islands')} (first: {{first}}, "
            f"subspace change {islands.change[bad[0]]:.1e})"
        )
        out.append(warning(WarningKind.NOT_CONVERGED, bad.size, "island", bad[0], template))
    if islands.clipped.any():
        n = int(islands.clipped.sum())
        template = f"step 4 fitted a degenerate scale on {counted(n, 'island', 'islands')}"
        out.append(warning(WarningKind.DEGENERATE_SCALE, n, "", None, template))
    if islands.regularized.any():
        n = int(islands.regularized.sum())
        template = f"{counted(n, 'vertex has', 'vertices have')} no exact reconstruction (degenerate fans)"
        out.append(warning(WarningKind.DEGENERATE_FANS, n, "", None, template))
    restarted = {"conformal map": int(islands.conformal.sum()), "Tutte embedding": int(islands.tutte.sum())}
    if sum(restarted.values()):
        seeds = " and ".join(f"{k} from a {name}" for name, k in restarted.items() if k)
        first = np.argmax(islands.conformal | islands.tutte)
        template = f"the four-step layout folded on some islands; laid out instead: {seeds}"
        out.append(warning(WarningKind.RESTARTED, sum(restarted.values()), "island", first, template))
    # a start that crushed faces the descent could not open: the report's stretch shows
    # it, this says what to do about it
    energy, area = islands.refine_energy, islands.refine_area
    stuck = np.flatnonzero((area > 0) & (energy > FAR_ENERGY * area) & ~islands.shaped)
    if stuck.size:
        i = int(stuck[0])
        template = (
            f"the refinement left {counted(stuck.size, 'island', 'islands')} far from isometric (first: {{first}}, "
            f"distortion {energy[i] / area[i]:.3g}, 4 is isometric): parts of it stay squeezed flat; "
            "mark seams to cut it where it is squeezed"
        )
        out.append(warning(WarningKind.FAR_FROM_ISOMETRIC, stuck.size, "island", i, template))
    return out


def _pin_warnings(islands: IslandReport) -> list[SolverWarning]:
    out = []
    if islands.one_point.any():
        n = int(islands.one_point.sum())
        template = (
            f"{counted(n, 'island has', 'islands have')} all their pins on one UV (first: {{first}}): "
            "moved there, not scaled or shaped by them"
        )
        out.append(warning(WarningKind.PINS_ON_ONE_UV, n, "island", np.argmax(islands.one_point), template))
    if islands.pin_conflicts.any():
        n = int(islands.pin_conflicts.sum())
        template = (
            f"{counted(n, 'pinned vertex has', 'pinned vertices have')} corners pinned to different UVs "
            "(first: {first}): each is held at their mean"
        )
        out.append(warning(WarningKind.PIN_CONFLICT, n, "island", np.argmax(islands.pin_conflicts > 0), template))
    missed = np.flatnonzero(~islands.reached)
    if missed.size:
        template = (
            f"the pins of {counted(missed.size, 'island', 'islands')} could not all be reached without folding "
            "the layout (first: {first})"
        )
        out.append(warning(WarningKind.PINS_UNREACHED, missed.size, "island", missed[0], template))
    return out


def _layout_warnings(islands: IslandReport, flipped: np.ndarray, unused: int) -> list[SolverWarning]:
    out = []
    over = np.flatnonzero(islands.crossings > 0)
    if over.size:
        template = (
            f"{counted(over.size, 'island overlaps', 'islands overlap')} itself in UV space (first: {{first}}): "
            "a texture painted there shows up twice; a seam across the overlap separates it"
        )
        out.append(warning(WarningKind.OVERLAPPING, over.size, "island", over[0], template))
    if flipped.any():
        n = int(flipped.sum())
        template = f"{counted(n, 'triangle is', 'triangles are')} flipped in the layout (first: {{first}})"
        out.append(warning(WarningKind.FLIPPED, n, "face", np.argmax(flipped), template))
    if unused:
        template = (
            f"{counted(unused, 'vertex belongs', 'vertices belong')} to no face and "
            f"{'was' if unused == 1 else 'were'} placed at (0, 0)"
        )
        out.append(warning(WarningKind.UNUSED_VERTICES, unused, "", None, template))
    return out
