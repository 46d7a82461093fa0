"""Beyond the paper: charts. Every island the artist's seams do not bound (and every island
that is not a disk) is cut until its charts are laid out within a stretch budget.

A closed surface opened along its shortest cut (:mod:`.cutgraph`) flattens with regions
squeezed and others blown up: Suzanne, spot or a character is far from isometric as one
island; so is an open part with bumps (a face scan, a terrain), whose curvature cancels
in sum but not in its layout. Region-growing chart makers (D-Charts, Julius et al. 2005;
xatlas) cut into tens to thousands of charts by face normals; distortion-driven cutting
(Gu, Gortler and Hoppe, "Geometry images", 2002; OptCuts, Li et al. 2018) cuts only where
the layout needs it. Here, in that second spirit, the cuts are decided, then refined:

1. **Cells.** An island that holds more Gaussian curvature than half a sphere (a closed
   part, or one with small holes: no single cut flattens it without crushing some of it)
   is split into ``_CELLS`` cells around seeds spread by farthest-point sampling
   (geodesic distance over the faces' adjacency), each face going to its nearest seed;
   where two seeds are about as near, the boundary moves onto the cheapest edges
   (:mod:`.mincut`: short, along creases). Tubes and tori (little curvature) are opened
   by the usual cut (:mod:`.cutgraph`) instead.
2. **Cuts placed on a prediction.** Round after round, the charts of every island are
   predicted by one linear solve (:mod:`.stress`: how much, and where, the layout will
   stretch and squeeze them), and while an island is predicted beyond the budget, the
   charts that hold most of its excess are cut: where a chart squeezes a cap beyond the
   budget (a tip, a bump, the end of a limb), a slit from its border to the most
   squeezed place (its sharpest vertex, on a coarse mesh) lets the cap open like a cone
   cut along a ruling, along edges the prediction pulls apart; elsewhere a minimum cut
   parts a ball around its most squeezed face from one around its most stretched. A
   round costs a prediction, not a solve.
3. **Solve** the mesh once with those cuts as seams. The refinement keeps every chart's
   boundary from crossing itself (:mod:`.contact`), so slits do not fold over.
4. **Check.** A chart still beyond the budget as refined is cut again as in 2, its
   prediction scaled to what the refinement reached, and the charts cut alone are solved
   again from their layout (at most ``_CHECKS`` times); charts that overlap themselves
   (a start that did) are cut apart in the same solve (:func:`.untangle.separating_cuts`).

Every decision but the check reads linear solves and quantities rounded to a grid, with
ties broken by face number: the charts do not follow the rounding of another machine.

The budget is given as a stretch factor ``s``: every chart may be as distorted (symmetric
Dirichlet energy per area, at its best scale) as one stretched uniformly by ``s``
(:func:`energy_budget`), which is the energy the refinement lowers; a face squeezed to
less than ``1 / s^2`` of its area is beyond it. Before the solve an island is judged by
its charts' mean (the linear prediction of one chart is too rough to cut on); the check
judges each chart as refined, and a chart it cannot bring within the budget is warned of.

Disks bounded by the artist's seams are the artist's to cut: they are charted only on
request (``Options.chart_disks``). Islands with pins are left as they are (their layout
is the pins' to shape).
"""

from __future__ import annotations

import time
from dataclasses import dataclass, replace

import numpy as np
import scipy.sparse as sp
from scipy.sparse import csgraph

from .. import metrics
from ..errors import counted
from ..geometry import TINY, angle_defects, face_areas, safe_divide
from ..mesh.halfedges import HalfEdges, edge_mask, pair_keys, split, unique_edges, unique_sorted, unit_of
from ..mesh.islands import first_rows
from ..mesh.ordering import nested_dissection
from ..mesh.topology import Topology
from ..options import Options, Problem
from ..pipeline import solve, topology_of
from ..progress import geometric, stage, tick
from ..report import OPENED_KINDS, TOPOLOGY_KINDS, SolverWarning, WarningKind, opened, warning
from ..result import Parametrization, topology_warnings
from . import stress
from .mincut import FaceGraph, face_graph, minimum_cut, source_side, without_chips
from .resolve import cut_further, pairs, sub_problem
from .untangle import cut_apart, separating_cuts, without_overlaps

__all__ = ["with_charts"]

_CELLS = 3  # cells per island ...
_CURVED = 2.0 * np.pi  # ... whose interior holds more Gaussian curvature than this (half a sphere)
_ROUNDS = 8  # predict, cut: at most this many times before the solve
_COVER = 0.5  # a round splits the charts that hold this share of their island's excess stretch
_BALL = 0.35  # radius of the balls cut apart, as a share of the distance between their centres
_SMOOTH = 3  # rounds of neighbour averaging of the area ratio that places the balls
_LEAVE = 0.1  # charts within this share of the budget's excess over isometric are not split
_BAND = 0.1  # a cell boundary moves where its two seeds' distances differ by less than this share of the cell radius
_GRID = 64  # the log area ratios that place cuts are rounded to 1 / _GRID
_FOLDING = 4.0  # a slit along edges whose banks the prediction folds over each other costs this much more
_FEWEST = 64  # a chart of fewer faces is not cut further ...
_CHIP = 0.02  # ... and one of fewer faces and this share of its island is a chip, joined to a neighbour
_CHECKS = 2  # solves after the first: where the charts are still over the budget as refined
_FIRST_AIM = 1.25  # before the solve, the prediction is taken to stretch this much more (it underestimates) ...
_AIM = 1.25  # ... and after it, this much more than the refinement showed (a check's cuts are the last)
_MOST_SCALE = 100.0  # a refined island is taken to stretch at most this many times its prediction
_CONE = 1.0  # angle defects are counted in these (radians), rounded: short of half of one, no cone
_TIE = 1e-9  # distances this close (relative) are equal: the lowest-numbered face is the seed


@dataclass(frozen=True)
class _Owners:
    """The islands as the caller's seams make them, which charts are cut from."""

    face: np.ndarray  # (m,) the island of each face
    charted: np.ndarray  # (k,) islands that may be cut into charts (no pins)
    held: np.ndarray  # (j,) islands that would be, but pins keep whole
    curved: np.ndarray  # (n,) bool: islands curved like a closed part (cut into cells first)
    marked: np.ndarray  # (n,) bool: islands a seam of the caller's bounds
    topo: Topology
    graph: FaceGraph | None  # the faces' adjacency within islands (None when none is charted)


def with_charts(problem: Problem, options: Options) -> Parametrization:
    """:func:`.pipeline.solve`, with every island that is not a disk or that no seam of the
    caller's bounds (any island, with ``options.chart_disks``) cut into charts as distorted
    as ``options.max_stretch`` allows (:func:`energy_budget`) at most; with
    ``options.split_overlaps``, charts that overlap themselves are cut apart."""
    t0 = time.perf_counter()
    with stage("topology", 0.0, 0.03):
        built = topology_of(problem, options)
    V, F, topo = built
    seams = pairs(problem.seams)
    problem = replace(problem, vertices=V, faces=F)
    t_topology = time.perf_counter() - t0
    with stage("finding the parts to chart", 0.03, 0.04):
        owners = _owners(problem, V, F, topo, options.chart_disks)
    if owners.graph is None:  # nothing to chart: the solve as without charts, topology reused
        with stage("", 0.03, 0.9):
            result = solve(problem, options, built)
        result.timings.topology += t_topology
        result.timings.charts = time.perf_counter() - t0 - t_topology - result.timings.total
        result.timings.total += t_topology + result.timings.charts
        if options.split_overlaps and (result.islands.crossings > 0).any():
            with stage("overlap cuts", 0.9, 1.0):
                result = without_overlaps(result, problem, options)
        result.warnings += _over_budget(result, owners, options.max_stretch, options.refine > 0, False)
        return result
    with stage("cutting closed parts into cells", 0.04, 0.06):
        cells = _cell_boundaries(owners.graph, owners.face, owners.charted[owners.curved[owners.charted]])
    with stage("placing cuts", 0.06, 0.15):
        placed, stretched, _ = _placed_cuts(problem, options, np.vstack([seams, cells]), owners)
    first = _without_chips(owners, np.vstack([cells, placed]))  # every cut decided before the solve
    with stage("charting", 0.15, 0.75):
        problem_ = replace(problem, seams=np.vstack([seams, first]))
        result = solve(problem_, options) if len(first) else solve(problem, options, built)
    first_solve = result.timings.total
    result.cut_edges = np.vstack([first, result.cut_edges])
    stretch_cut = np.zeros(topo.n_islands, dtype=bool)  # islands cut where they stretched
    stretch_cut[stretched] = True
    rounds = 0
    with stage("checking the charts", 0.75, 0.9):  # cut what is still over the budget or overlaps itself
        for check in range(1, _CHECKS + 1):
            new, split = _checked_cuts(result, problem, owners, options)
            stretch_cut[owners.face[first_rows(result.face_island, result.n_islands)[split[0]]]] = True
            if len(new):
                new = _new_without_chips(owners, result, problem, new)
            if not len(new):
                break
            rounds = check
            with stage(f"round {check + 1}", *geometric(check)):
                result = cut_further(result, problem, new, unique_sorted(np.concatenate(split)), options)
    result.cut_islands = topo.cut_islands
    result.timings.topology += t_topology
    result.timings.charts = time.perf_counter() - t0 - first_solve - t_topology
    if options.split_overlaps and (result.islands.crossings > 0).any():
        with stage("overlap cuts", 0.9, 1.0):
            result = without_overlaps(result, problem, options)
    exhausted = rounds == _CHECKS  # (the last check cut, and what it left was not checked again)
    result.warnings = _warnings(result, owners, stretch_cut, options.max_stretch, options.refine > 0, exhausted)
    cut = _cut_by_charting(result, owners, stretch_cut)
    result.stats.charts = int(len(unique_sorted(result.face_island[np.isin(owners.face, cut)])))
    result.stats.chart_rounds = rounds
    result.timings.total = time.perf_counter() - t0
    return result


def _owners(problem: Problem, V: np.ndarray, F: np.ndarray, topo: Topology, disks: bool) -> _Owners:
    """Which islands may be cut into charts: those without a pinned corner that are not
    disks, or that no seam of the caller's bounds (seams there are the artist's cut), or,
    with ``disks``, any. Those curved like a closed part (more than ``_CURVED``) are cut
    into cells first."""
    n = topo.n_islands
    pinned = np.zeros(n, dtype=bool)
    if problem.pins is not None:
        pinned[topo.face_island[np.asarray(problem.pins[0], dtype=bool).any(axis=1)]] = True
    marked = np.zeros(n, dtype=bool)
    if len(pairs(problem.seams)):
        he = HalfEdges(F, len(V))
        marked[topo.face_island[np.flatnonzero(edge_mask(he, len(V), problem.seams)[he.edge]) // 3]] = True
    wanted = ~marked | disks
    wanted[topo.cut_islands] = True  # (whatever the seams on them)
    curved = _curvature(V, topo) > _CURVED if (wanted & ~pinned).any() else np.zeros(n, dtype=bool)
    charted = np.flatnonzero(wanted & ~pinned)
    graph = face_graph(V, F, topo.face_island, problem.seams, problem.inner_edges) if len(charted) else None
    return _Owners(topo.face_island, charted, np.flatnonzero(wanted & pinned), curved, marked, topo, graph)


def _curvature(V: np.ndarray, topo: Topology) -> np.ndarray:
    """Per island (n,), the Gaussian curvature of its interior: the sum of the angle
    defects ``2 pi - sum of angles`` of its vertices off its boundary and seams (the cuts
    that opened it do not count as boundary): 4 pi for a closed surface of genus 0, less
    the turning of its boundary for one with holes; 0 for a torus, about 0 for a tube or
    a height field."""
    corner = topo.vertex_of[topo.faces.ravel()]  # the mesh vertex of every corner
    n = len(V)
    defect = angle_defects(V[topo.vertex_of], topo.faces, topo.vertex_of, n)
    h = np.flatnonzero(topo.he.twin < 0)  # boundary, seams and cuts
    ends = np.sort(topo.vertex_of[np.stack([topo.faces[h // 3, h % 3], topo.faces[h // 3, (h + 1) % 3]], 1)], 1)
    cut = np.sort(topo.cut_edges, axis=1)
    real = ~np.isin(pair_keys(ends[:, 0], ends[:, 1], n), pair_keys(cut[:, 0], cut[:, 1], n))
    inside = np.bincount(corner, minlength=n) > 0
    inside[ends[real].ravel()] = False
    island = np.zeros(n, dtype=np.int64)
    island[corner] = np.repeat(topo.face_island, 3)
    return np.bincount(island[inside], defect[inside], minlength=topo.n_islands)


def _cell_boundaries(graph: FaceGraph, face_island: np.ndarray, islands: np.ndarray) -> np.ndarray:
    """The edges (k, 2 vertex pairs) between ``_CELLS`` cells of each island in ``islands``.

    Seeds are spread by farthest-point sampling and every face goes to the cell of its
    nearest seed; then the cells' boundaries are moved, within a band where the two
    nearest seeds are about as near, onto the cheapest edges (:mod:`.mincut`), one cell
    after the other against the cores of those not placed yet."""
    if not len(islands):
        return np.zeros((0, 2), dtype=np.int64)
    G = graph.distances()
    on = np.isin(face_island, islands)
    far = csgraph.dijkstra(G, directed=False, indices=first_rows(face_island)[islands], min_only=True)
    seeds = [_farthest(far, on, face_island, islands)]
    reach = [csgraph.dijkstra(G, directed=False, indices=seeds[0], min_only=True)]
    for j in range(_CELLS - 1):
        tick(j / (2 * _CELLS))
        seeds.append(_farthest(np.min(reach, axis=0), on, face_island, islands))
        reach.append(csgraph.dijkstra(G, directed=False, indices=seeds[-1], min_only=True))
    distance = np.array(reach)  # (cells, m): from every island's j-th seed
    cell = np.argmin(distance, axis=0)
    near = np.sort(distance, axis=0)
    radius = np.zeros(int(face_island.max()) + 1)
    np.maximum.at(radius, face_island[on], near[0][on])
    with np.errstate(invalid="ignore"):  # (inf - inf off the islands)
        loose = on & (near[1] - near[0] < _BAND * radius[face_island])  # where a boundary may move
    open_ = on.copy()  # faces not placed in a cell yet
    for j in range(_CELLS - 1):
        tick(0.5 + j / (2 * _CELLS))
        source = open_ & (cell == j) & ~loose
        sink = open_ & (cell > j) & ~loose
        side = source_side(graph.among(open_), source, sink) & open_
        cell[open_] = np.where(side[open_], j, np.maximum(cell[open_], j + 1))
        open_ &= ~side
    cell = _whole_polygons(graph, cell)
    crossed = on[graph.f] & (cell[graph.f] != cell[graph.g])
    return np.unique(graph.edges[crossed], axis=0)


def _whole_polygons(graph: FaceGraph, cell: np.ndarray) -> np.ndarray:
    """``cell`` (m,) with the triangles of every polygon in the cell of its lowest-numbered
    triangle: a seam along a diagonal would give a face corner two UVs."""
    polygon = graph.polygons()
    return cell if polygon is None else cell[polygon]


def _farthest(distance: np.ndarray, on: np.ndarray, face_island: np.ndarray, islands: np.ndarray) -> np.ndarray:
    """Per island in ``islands``, its face farthest by ``distance`` (m,) (the lowest-numbered
    among those within ``_TIE`` of the farthest, so that rounding does not choose)."""
    d = np.where(on & np.isfinite(distance), distance, -np.inf)
    best = np.full(int(face_island.max()) + 1, -np.inf)
    np.maximum.at(best, face_island[on], d[on])
    hit = on & (d >= best[face_island] * (1.0 - _TIE))
    first = np.full(len(best), len(d), dtype=np.int64)
    np.minimum.at(first, face_island[hit], np.flatnonzero(hit))
    return first[islands]


def energy_budget(max_stretch: float) -> float:
    """The symmetric Dirichlet energy per area of a layout stretched uniformly by
    ``max_stretch``: ``2 (s^2 + 1 / s^2)`` (4 at 1, isometric)."""
    return 2.0 * (max_stretch**2 + max_stretch**-2)


def _chart_energy(result: Parametrization, owners: _Owners, islands: np.ndarray | None = None):
    """Per island of ``result`` (a chart): its symmetric Dirichlet energy per area at its
    best scale, its 3D area (0 for charts of islands not in ``islands``, by default the
    charted ones, or without area), and the island it was cut from."""
    sd, area = metrics.island_energy(
        result.vertices, result.faces, result.corner_uv, result.face_island, result.n_islands
    )
    owner = owners.face[first_rows(result.face_island, result.n_islands)]
    islands = owners.charted if islands is None else islands
    ok = np.isin(owner, islands) & (area > 0) & np.isfinite(sd)
    return np.where(ok, sd, 4.0), np.where(ok, area, 0.0), owner


@dataclass(frozen=True)
class _Charts:
    """Charts of some islands and how distorted each is (as laid out, or as predicted):
    what the cuts of a round read. Faces and vertices are those of ``vertices``,
    ``faces``, which may be a part of the mesh."""

    vertices: np.ndarray  # (n, 3)
    faces: np.ndarray  # (m, 3)
    face_island: np.ndarray  # (m,) the chart of each face
    n_islands: int
    energy: np.ndarray  # (k,) per chart, symmetric Dirichlet energy per area at its best scale
    area: np.ndarray  # (k,) per chart, 3D area (0: not to judge)
    owner: np.ndarray  # (k,) per chart, the island (of ``_Owners``) it was cut from
    ratio: np.ndarray  # (m,) per face, log area ratio, smoothed and rounded (see _smoothed)
    defect: np.ndarray  # (n,) per vertex, its angle defect over all its faces (a cone's sharpness)


def _stretch_cuts(charts: _Charts, graph: FaceGraph, n_owners: int, budget: float, opening=None, each=True):
    """The cuts of one round (k, 2 vertex pairs) and the charts they cut: with ``each``,
    every chart that stretches more than ``budget``; and in every island whose charts do
    on average, the charts holding ``_COVER`` of its excess. Each is slit to every cap it
    squeezes beyond the budget (:func:`_slits`), or, with none, cut in two between its
    most squeezed and its most stretched place (:func:`_balls`). ``opening`` (per edge
    of ``graph``): how far a slit along it would open (see :func:`_slits`)."""
    none = np.zeros((0, 2), dtype=np.int64), np.zeros(0, dtype=np.int64)
    energy, area, owner = charts.energy, charts.area, charts.owner
    k = n_owners
    mean = _per_chart(energy, area, owner, k)  # (per island: the area-weighted mean of its charts)
    limit = energy_budget(budget)
    over = (area > 0) & (mean[owner] > limit)
    beyond = (area > 0) & (energy > limit) & each  # (a chart beyond the budget, whatever its island's mean)
    if not (over | beyond).any():
        return none
    excess = np.where(over, (energy - 4.0) * area, 0.0)
    order = np.lexsort((-excess, owner))  # by island, most excess first
    sorted_owner = owner[order]
    running = np.concatenate([[0.0], np.cumsum(excess[order])])
    before = running[:-1] - running[np.searchsorted(sorted_owner, sorted_owner)]  # excess ahead in its island
    total = np.bincount(owner, excess, minlength=k)
    chosen = order[(before < _COVER * total[sorted_owner]) & over[order]]
    chosen = unique_sorted(np.concatenate([chosen, np.flatnonzero(beyond)]))
    chosen = chosen[energy[chosen] > 4.0 + _LEAVE * (limit - 4.0)]  # leave near-isometric charts
    faces = np.bincount(charts.face_island, minlength=charts.n_islands)
    owned = np.bincount(owner, faces, minlength=k)[owner]  # faces of each chart's island
    chosen = chosen[faces[chosen] >= np.minimum(_FEWEST, 2.0 * _CHIP * owned[chosen])]  # (no chips)
    if not len(chosen):
        return none
    ratio = charts.ratio
    on = np.isin(charts.face_island, chosen)
    # every region the layout squeezes beyond the budget is a cap to let open: a slit to
    # its most squeezed face
    tips = _tips(graph, on & (ratio < -2.0 * np.log(budget)), ratio)
    keep = on[graph.f] & on[graph.g]
    slit, slitted = _slits(charts, graph.among(on), tips, ratio, None if opening is None else opening[keep])
    rest = unique_sorted(chosen)
    rest = rest[~np.isin(rest, slitted)]
    cuts = [slit]
    if len(rest):
        source, sink, centres = _balls(charts, graph, rest, ratio)
        inside = graph.among(np.isin(charts.face_island, rest))
        cuts.append(without_chips(inside, minimum_cut(inside, source, sink), centres))
    cut = np.vstack(cuts)
    return (cut, chosen) if len(cut) else none


def _checked_cuts(result: Parametrization, problem: Problem, owners: _Owners, options: Options):
    """The cuts (k, 2 vertex pairs) of the one round after the solve, and the charts of
    ``result`` they cut because they stretch and because they overlap themselves: the
    charts still beyond the budget as refined (:func:`_stretch_cuts`, which the
    prediction missed), and, with ``options.split_overlaps``, those that overlap
    themselves (:func:`.untangle.separating_cuts`)."""
    V, F = result.vertices, result.faces
    graph = face_graph(
        V, F, result.face_island, np.vstack([pairs(problem.seams), result.cut_edges]), problem.inner_edges
    )
    tick()
    energy, area, _ = _chart_energy(result, owners)
    # (an island beyond the budget on average holds such a chart at least)
    beyond = (area > 0) & (energy > energy_budget(options.max_stretch))
    new, split = np.zeros((0, 2), dtype=np.int64), np.zeros(0, dtype=np.int64)
    if beyond.any():  # those charts alone are predicted and cut: the others keep their layout
        seams = np.vstack([pairs(problem.seams), result.cut_edges])
        judged = np.flatnonzero(beyond[result.face_island])
        new, _, cut = _placed_cuts(problem, options, seams, owners, judged, (energy - 4.0)[result.face_island])
        split = unique_sorted(result.face_island[cut])
    tick()
    overlapping = np.flatnonzero(result.islands.crossings > 0) if options.split_overlaps else split[:0]
    # (a chart of an island the caller's seams bound, or no chart, is left to the overlap
    # repair after the check, which parts all its layers in one round, chips and all)
    owner_of = owners.face[first_rows(result.face_island, result.n_islands)][overlapping]
    overlapping = overlapping[np.isin(owner_of, owners.charted) & ~owners.marked[owner_of]]
    if len(overlapping):
        apart = separating_cuts(result, problem, overlapping, graph)
        result.stats.overlap_cuts += len(apart)
        new = np.vstack([new, apart])
    return new, (split, overlapping)


def _placed_cuts(
    problem: Problem,
    options: Options,
    seams: np.ndarray,
    owners: _Owners,
    faces: np.ndarray | None = None,
    measured: np.ndarray | None = None,
):
    """The cuts (k, 2 vertex pairs) that bring the charts of ``faces`` (by default,
    every charted island of ``owners``) within the budget as predicted (:mod:`.stress`),
    the islands (of ``owners``) they cut, and the faces of the charts they cut.

    ``measured`` (per face): the energy per area above isometric of its chart as
    refined, if it was. The prediction of each chart is then scaled to it (a linear
    prediction misses what large strains and banks pressed together add), a chart is
    judged at first by no less than what it reached, a chart cut later keeps the scale of
    the faces it holds, and every chart is judged on its own;
    before the solve, an island is judged by its charts' mean (one chart's linear
    prediction alone is too rough to cut on).

    Rounds as after a solve (:func:`_stretch_cuts`), but each reads the linear prediction
    of the charts cut along ``seams`` and the cuts so far, where a round after a solve
    reads a refined layout: a prediction costs one factor of a Laplacian, moves smoothly
    with the mesh (no stopping test of a descent decides it), and leaves the solve one
    refinement from a start near its end. A slit runs where the prediction pulls its
    banks apart (:func:`.stress.normal_stress`), not where they would fold over each
    other."""
    if faces is None:
        faces = np.flatnonzero(np.isin(owners.face, owners.charted))
    sub, used = sub_problem(replace(problem, seams=seams), faces)
    base = _Base.of(sub, options)
    n_owners = owners.topo.n_islands
    scale = None  # (per face of ``faces``) how much more than predicted its chart stretched
    cuts = np.zeros((0, 2), dtype=np.int64)
    cut_owners = np.zeros(0, dtype=np.int64)
    cut_faces = np.zeros(len(faces), dtype=bool)
    touched = None  # the islands the last round cut: the only ones predicted (and judged) again
    for j in range(_ROUNDS):
        tick(j / _ROUNDS)
        charts, graph, ends, split_faces, X = base.cut(cuts)
        owner = owners.face[faces[first_rows(charts.face_chart, charts.n)]]
        judged = np.ones(charts.n, dtype=bool) if touched is None else np.isin(owner, touched)
        prediction = _predicted(X, split_faces, charts, judged)
        ratio = _smoothed(graph, prediction.face_trace(split_faces), base.area)
        if measured is not None and scale is None:  # refined against predicted, per chart
            refined = _per_chart(measured[faces], base.area, charts.face_chart, charts.n)
            predicted = safe_divide(prediction.excess, prediction.area)
            # (aimed lower: a cut after the solve is the last)
            scale = (_AIM * np.clip(safe_divide(refined, predicted, 1.0), 1.0, _MOST_SCALE))[charts.face_chart]
        aim = _FIRST_AIM if scale is None else _per_chart(scale, base.area, charts.face_chart, charts.n)
        excess = prediction.excess * aim
        energy = 4.0 + safe_divide(excess, prediction.area)
        if measured is not None and j == 0:
            # a chart as refined is judged by what it reached where its prediction misses
            # it (a sharp cone in a few slivers: scaled from almost nothing, or clipped)
            energy = np.maximum(energy, 4.0 + _AIM * refined)
        laid = _Charts(base.V, base.F, charts.face_chart, charts.n, energy, prediction.area, owner, ratio, base.defect)
        opening = stress.normal_stress(X, split_faces, prediction.phi, ends)
        new, split = _stretch_cuts(laid, graph, n_owners, options.max_stretch, opening, measured is not None)
        if not len(new):
            break
        cuts = np.vstack([cuts, new])
        touched = unique_sorted(owner[split])
        cut_owners = unique_sorted(np.concatenate([cut_owners, touched]))
        cut_faces |= np.isin(charts.face_chart, split)
    return used[cuts], cut_owners, faces[cut_faces]


def _per_chart(value: np.ndarray, area: np.ndarray, face_chart: np.ndarray, n: int) -> np.ndarray:
    """Per chart (n,), the area-weighted mean of ``value`` (per face, or per member of
    whatever ``face_chart`` (m,) groups) over its faces."""
    return safe_divide(np.bincount(face_chart, value * area, minlength=n), np.bincount(face_chart, area, minlength=n))


def _predicted(X: np.ndarray, faces: np.ndarray, charts: _Split, judged: np.ndarray) -> stress.Prediction:
    """:func:`.stress.predict` of the charts ``judged`` (per chart) alone, over the split
    vertices ``X`` and ``faces`` of all: the others get nothing (no excess, no area, phi 0).
    A round's cuts change only the charts they cut, and a chart's prediction is its own
    (its Laplacian is a block of its own), so a round after the first predicts the islands
    the last one cut, not the whole part again."""
    if judged.all():
        return stress.predict(X, faces, charts.boundary, charts.face_chart, charts.n, charts.order)
    rows = np.flatnonzero(judged[charts.face_chart])
    used = unique_sorted(faces[rows])
    index = np.full(len(X), -1, dtype=np.int64)
    index[used] = np.arange(len(used))
    ids = np.flatnonzero(judged)
    local = np.full(charts.n, -1, dtype=np.int64)
    local[ids] = np.arange(len(ids))
    order = index[charts.order]
    part = stress.predict(
        X[used], index[faces[rows]], charts.boundary[used], local[charts.face_chart[rows]], len(ids), order[order >= 0]
    )
    excess, area = np.zeros(charts.n), np.zeros(charts.n)
    excess[ids], area[ids] = part.excess, part.area
    trace, phi = np.zeros(len(X)), np.zeros(len(X))
    trace[used], phi[used] = part.trace, part.phi
    return stress.Prediction(excess, area, trace, phi)


@dataclass(frozen=True)
class _Split:
    """Charts as a round of :func:`_placed_cuts` cut them: per face its chart, per split
    vertex whether it is on a chart's boundary, and the split vertices' elimination order."""

    face_chart: np.ndarray  # (m,)
    n: int
    boundary: np.ndarray  # (ns,) bool
    order: np.ndarray  # (ns,)


@dataclass(frozen=True)
class _Base:
    """The charted islands of a sub-problem split along its seams once (its topology),
    from which every round's charts are split further along the round's cuts alone:
    a round costs a vertex split and a filter of the faces' adjacency, not a topology."""

    V: np.ndarray  # (n, 3) the sub-problem's vertices, and faces (m, 3)
    F: np.ndarray
    X: np.ndarray  # (ns, 3) the topology's split vertices, in units of ``unit``
    faces: np.ndarray  # (m, 3) its faces over them (oriented)
    he: HalfEdges
    vertex_of: np.ndarray  # (ns,) the sub-problem vertex of each split vertex
    edge_keys: np.ndarray  # per undirected edge of ``he``: its sub-problem vertex pair's key
    corner: np.ndarray  # (m, 3) per input corner, its position in ``faces``' row
    graph: FaceGraph  # the faces' adjacency across the seams and the topology's cuts
    rank: np.ndarray  # (n,) each sub-problem vertex's place in a nested-dissection order
    area: np.ndarray  # (m,) 3D areas
    defect: np.ndarray  # (n,) each sub-problem vertex's angle defect (:func:`_tip_corner`)

    @classmethod
    def of(cls, sub: Problem, options: Options) -> _Base:
        # (two wedges of an island that other islands' faces separated meet at a bare vertex)
        V, F, topo = topology_of(sub, replace(options, split_nonmanifold=True))
        unit = unit_of(V)
        rank = np.empty(len(V), dtype=np.int64)
        rank[nested_dissection(V / unit, unique_edges(F))] = np.arange(len(V))
        ends = topo.vertex_of[topo.he.edge_vertices]
        edge_keys = pair_keys(ends[:, 0], ends[:, 1], len(V))
        corner = np.argmax(topo.faces[:, :, None] == topo.corner_vertex[:, None, :], axis=1)
        graph = face_graph(V, F, topo.face_island, np.vstack([pairs(sub.seams), topo.cut_edges]), sub.inner_edges)
        X = V[topo.vertex_of] / unit
        return cls(
            V,
            F,
            X,
            topo.faces,
            topo.he,
            topo.vertex_of,
            edge_keys,
            corner,
            graph,
            rank,
            face_areas(V, F),
            angle_defects(V, F),
        )

    def cut(self, cuts: np.ndarray):
        """The charts cut further along ``cuts`` (k, 2 sub-problem vertex pairs), their
        adjacency, the split vertices at the ends of its edges (k, 2), the faces over
        split vertices and those vertices (in units)."""
        n = len(self.V)
        keys = pair_keys(cuts[:, 0], cuts[:, 1], n)
        cut_edge = np.isin(self.edge_keys, keys)
        faces, vertex_of = split(self.faces, len(self.X), cut_edge, self.he)
        X = self.X[vertex_of]
        h = np.flatnonzero((self.he.twin < 0) | cut_edge[self.he.edge])
        boundary = np.zeros(len(X), dtype=bool)
        boundary[faces.ravel()[h]] = True
        boundary[faces[h // 3, (h % 3 + 1) % 3]] = True
        graph = self.graph
        if len(keys):
            graph = graph.among_edges(~np.isin(pair_keys(graph.edges[:, 0], graph.edges[:, 1], n), keys))
        m = len(faces)
        joined = sp.coo_matrix((np.ones(len(graph.f)), (graph.f, graph.g)), shape=(m, m))
        n_charts, face_chart = csgraph.connected_components(joined, directed=False)
        _, face_chart = np.unique(face_chart, return_inverse=True)  # numbered by lowest face
        face_chart = face_chart.ravel()
        # (renumber by the lowest face of each chart, as the topology numbers islands)
        first = first_rows(face_chart, n_charts)
        relabel = np.empty(n_charts, dtype=np.int64)
        relabel[np.argsort(first, kind="stable")] = np.arange(n_charts)
        face_chart = relabel[face_chart]
        order = np.argsort(self.rank[self.vertex_of[vertex_of]], kind="stable")
        # the split vertex at each end of every edge of the adjacency, from face f's side
        in_row = faces[graph.f]
        mesh = self.vertex_of[vertex_of][in_row]  # (k, 3) sub-problem vertices of face f's row
        ends = np.stack(
            [in_row[np.arange(len(graph.f)), np.argmax(mesh == graph.edges[:, c, None], axis=1)] for c in (0, 1)],
            axis=1,
        )
        return _Split(face_chart, n_charts, boundary, order), graph, ends, faces, X


def _without_chips(owners: _Owners, cuts: np.ndarray) -> np.ndarray:
    """``cuts`` (k, 2 vertex pairs) less those that only bound chips: charts of fewer than
    ``_FEWEST`` faces and ``_CHIP`` of their island's join the chart beside them they
    share most seam with (where a slit, a ball's cut and a cell's boundary meet, they can
    close round a few faces)."""
    assert owners.graph is not None
    size = np.bincount(owners.face)[owners.face]
    return without_chips(owners.graph, cuts, fewest=np.minimum(_FEWEST, _CHIP * size))


def _new_without_chips(owners: _Owners, result: Parametrization, problem: Problem, new: np.ndarray) -> np.ndarray:
    """The ``new`` cuts of ``result``'s charts less those that only bound chips (see
    :func:`_without_chips`; the cuts made so far stay)."""
    graph = face_graph(
        result.vertices,
        result.faces,
        owners.face,
        np.vstack([pairs(problem.seams), result.cut_edges]),
        problem.inner_edges,
    )
    size = np.bincount(owners.face)[owners.face]
    return without_chips(graph, new, fewest=np.minimum(_FEWEST, _CHIP * size))


def _smoothed(graph: FaceGraph, value: np.ndarray, area: np.ndarray) -> np.ndarray:
    """``value`` (m,) per face smoothed by ``_SMOOTH`` rounds of ``area``-weighted averaging
    over each face and its neighbours in ``graph``, and rounded to ``1 / _GRID``: which
    face is most squeezed, and which path is shortest, must not follow the rounding of
    the layout (another machine's sums)."""
    m = len(value)
    adjacency = sp.coo_matrix((np.ones(len(graph.f)), (graph.f, graph.g)), shape=(m, m))
    adjacency = (adjacency + adjacency.T).tocsr()
    for _ in range(_SMOOTH):
        value = safe_divide(adjacency @ (value * area) + value * area, adjacency @ area + area)
    return np.round(_GRID * value) / _GRID


def _tips(graph: FaceGraph, squeezed: np.ndarray, ratio: np.ndarray) -> np.ndarray:
    """The most squeezed face (by ``ratio``) of every connected region of ``squeezed``
    faces (m,) bool: one per cap, (k,)."""
    caps = _regions(graph, squeezed)
    n_caps = int(caps.max(initial=-1)) + 1
    depth = np.where(caps >= 0, ratio, np.inf)
    return _extreme(depth, np.where(caps >= 0, caps, n_caps), np.arange(n_caps), np.minimum, np.inf)


def _regions(graph: FaceGraph, faces: np.ndarray) -> np.ndarray:
    """Per face (m,), the connected region of ``faces`` (m,) bool it belongs to, numbered
    from 0 by lowest face (-1 off ``faces``)."""
    inside = graph.among(faces)
    m = graph.n_faces
    joined = sp.coo_matrix((np.ones(len(inside.f), dtype=np.int8), (inside.f, inside.g)), shape=(m, m))
    _, label = csgraph.connected_components(joined, directed=False)
    label = np.where(faces, label, -1)
    _, number = np.unique(label[faces], return_inverse=True)
    label[faces] = number.ravel()
    return label


def _balls(result: _Charts, graph: FaceGraph, charts: np.ndarray, ratio: np.ndarray):
    """Per chart in ``charts``, the faces (m,) bool within ``_BALL`` of the distance between
    its most squeezed face and its most stretched face at least half the chart's extent
    away from it (by ``ratio``, :func:`_smoothed`) of the one and of the other, and those
    faces (2k,). (Two extremes side by side would give balls so small that the cut
    between them goes round a few faces.)"""
    isl = result.face_island
    on = np.isin(isl, charts)
    low = _extreme(np.where(on, ratio, np.inf), isl, charts, np.minimum, np.inf)
    G = graph.distances()
    from_low = csgraph.dijkstra(G, directed=False, indices=low, min_only=True)
    reached = on & np.isfinite(from_low)
    size = np.zeros(result.n_islands)  # each chart's extent: the farthest face from its most squeezed
    np.maximum.at(size, isl[reached], from_low[reached])
    far = reached & (from_low >= 0.5 * size[isl])
    high = _extreme(np.where(far, ratio, -np.inf), isl, charts, np.maximum, -np.inf)
    from_high = csgraph.dijkstra(G, directed=False, indices=high, min_only=True)
    reach = np.full(result.n_islands, -1.0)
    reach[charts] = _BALL * from_low[high]
    source = on & (from_low <= reach[isl])
    sink = on & (from_high <= reach[isl]) & ~source
    return source, sink, np.concatenate([low, high])


def _slits(
    result: _Charts, inside: FaceGraph, faces: np.ndarray, ratio: np.ndarray, opening: np.ndarray | None = None
) -> tuple[np.ndarray, np.ndarray]:
    """Slits (k, 2 vertex pairs) from the boundary of each chart to a corner of its face in
    ``faces``, and the charts that got one (k,): the shortest paths, as laid out, over the
    edges of ``inside`` (the charts' faces joined), each edge's cost scaled by the layout's
    length scale there (``ratio``, :func:`_smoothed`, is its log squared). A slit then
    runs through what the layout squeezes, where it must tear, not through what it
    stretches. A squeezed cap that a slit reaches opens like a cone
    cut along a ruling (Gu, Gortler & Hoppe, "Geometry images", 2002, cut the same way to
    where a layout is most distorted). With ``opening`` (per edge of ``inside``, negative
    where a slit's banks would fold over each other), such edges cost ``_FOLDING`` times
    more."""
    F, n = result.faces, len(result.vertices)
    none = np.zeros((0, 2), dtype=np.int64), np.zeros(0, dtype=np.int64)
    if not len(faces):
        return none
    # the charts' boundary vertices: the ends of their faces' sides that join no face
    on = np.zeros(len(F), dtype=bool)
    on[inside.f] = on[inside.g] = True
    on |= np.isin(result.face_island, result.face_island[faces])
    ends_a, ends_b = F[on].ravel(), F[on][:, [1, 2, 0]].ravel()
    joined = np.isin(pair_keys(ends_a, ends_b, n), pair_keys(inside.edges[:, 0], inside.edges[:, 1], n))
    boundary = np.zeros(n, dtype=bool)
    boundary[ends_a[~joined]] = boundary[ends_b[~joined]] = True
    use = np.isfinite(inside.cost)  # (never along a polygon's diagonal)
    a, b = inside.edges[use, 0], inside.edges[use, 1]
    w = inside.cost[use] * np.exp(0.25 * (ratio[inside.f[use]] + ratio[inside.g[use]]))
    if opening is not None:
        w = np.where(opening[use] < 0.0, _FOLDING * w, w)
    w = w + 1e-12 * max(float(w.max(initial=0.0)), TINY)  # csgraph drops zeros
    G = sp.coo_matrix((w, (a, b)), shape=(n, n)).tocsr()
    target = _tip_corner(F, faces, result.defect, boundary)
    reached = ~boundary[target]
    if not reached.any():
        return none
    dist, pred, _ = csgraph.dijkstra(
        G, directed=False, indices=np.flatnonzero(boundary), min_only=True, return_predecessors=True
    )
    reached &= np.isfinite(dist[target])
    cur = target[reached]
    slit_of = np.arange(len(cur))  # per slit being walked, its number
    pieces: list[np.ndarray] = []
    owner: list[np.ndarray] = []
    steps: list[np.ndarray] = []
    while cur.size:  # one step along every slit at once; as many rounds as the longest
        prev = pred[cur].astype(np.int64)
        pieces.append(np.stack([cur, prev], axis=1))
        owner.append(slit_of)
        steps.append(np.full(len(cur), len(steps)))
        slit_of, cur = slit_of[~boundary[prev]], prev[~boundary[prev]]
    if not pieces:
        return none
    edges, slit_of, step = np.concatenate(pieces), np.concatenate(owner), np.concatenate(steps)
    keep = np.ones(len(edges), dtype=bool)
    if opening is not None:
        keep = _opening(edges, slit_of, step, len(target[reached]), inside.edges[use], opening[use], n)
    slit_faces = faces[reached][unique_sorted(slit_of[keep])]
    if not keep.any():
        return none
    return np.unique(np.sort(edges[keep], axis=1), axis=0), np.unique(result.face_island[slit_faces])


def _tip_corner(F: np.ndarray, faces: np.ndarray, defect: np.ndarray, boundary: np.ndarray) -> np.ndarray:
    """Per face of ``faces`` (k,) (rows of ``F`` (m, 3)), the vertex a slit to it ends at:
    the corner of sharpest cone, its angle ``defect`` (n,) rounded to whole ``_CONE``s,
    where a vertex short of half of one, or on the charts' ``boundary`` (n,) bool, is no
    cone; ties (as on a smooth surface) go to the first corner. On a coarse mesh the
    curvature a chart cannot flatten sits at a few sharp vertices (a low-poly ear's tip);
    a slit opens such a cone only if it ends at its apex."""
    corners = F[faces]
    sharp = np.where(boundary[corners], 0.0, np.floor(defect[corners] / _CONE + 0.5))
    return corners[np.arange(len(faces)), np.argmax(sharp, axis=1)]


def _opening(edges, slit_of, step, n_slits: int, graph_edges, opening, n: int) -> np.ndarray:
    """Which steps (k,) of the slits ``edges`` (k, 2; each of slit ``slit_of``, ``step``
    edges from its tip) to cut, given the predicted ``opening`` of the ``graph_edges``:
    from its tip, a slit loses the edges whose banks would fold over each other, so it
    ends where it starts to open (at a cap's very centre the layout squeezes every way)."""
    keys = pair_keys(graph_edges[:, 0], graph_edges[:, 1], n)
    by_key = np.argsort(keys)
    folds = opening[by_key[np.searchsorted(keys, pair_keys(edges[:, 0], edges[:, 1], n), sorter=by_key)]] < 0.0
    opens_from = np.full(n_slits, np.iinfo(np.int64).max)
    np.minimum.at(opens_from, slit_of[~folds], step[~folds])
    return step >= opens_from[slit_of]


def _charted(result: Parametrization, owners: _Owners, cut: np.ndarray, budget: float) -> list[SolverWarning]:
    """The note on the islands ``cut`` (k,) into charts, or slit open: how many, why, into
    how many charts, and how much they stretch."""
    if not len(cut):
        return []
    energy, area, owner = _chart_energy(result, owners)
    topo = owners.topo
    pieces = np.bincount(owner, minlength=topo.n_islands)
    total = np.bincount(owner, area, minlength=len(pieces))
    mean = safe_divide(np.bincount(owner, energy * area, minlength=len(pieces)), total)
    first = result.face_island[first_rows(owners.face)[cut[0]]]
    not_disk = np.isin(cut, topo.cut_islands)
    return charted(
        islands=len(cut),
        not_disks=int(not_disk.sum()),
        curved=int((owners.curved[cut] & ~not_disk).sum()),
        charts=int(pieces[cut].sum()),
        energy=float(safe_divide((mean[cut] * total[cut]).sum(), total[cut].sum())),
        budget=budget,
        first=int(first),
    )


def _over_budget(
    result: Parametrization, owners: _Owners, budget: float, refined: bool, exhausted: bool
) -> list[SolverWarning]:
    """The warning on the charts of the islands charting is for (:func:`_owners`), pinned
    ones included, that still stretch beyond ``budget``: how many, how far (their mean),
    why (pins; the checks ran out, ``exhausted``, or found no cut) and what would help."""
    islands = unique_sorted(np.concatenate([owners.charted, owners.held]))
    energy, area, owner = _chart_energy(result, owners, islands)
    over = np.flatnonzero((area > 0) & (energy > energy_budget(budget)))
    if not len(over):
        return []
    return over_budget(
        islands=len(over),
        pinned=int(np.isin(owner[over], owners.held).sum()),
        energy=float(safe_divide((energy[over] * area[over]).sum(), area[over].sum())),
        budget=budget,
        allowed=energy_budget(budget),
        refined=refined,
        first=int(over[0]),
        checks=_CHECKS if exhausted else 0,
    )


def _extreme(value: np.ndarray, isl: np.ndarray, charts: np.ndarray, ufunc, empty: float) -> np.ndarray:
    """Per chart in ``charts``, the lowest-numbered face where ``value`` (m,) is extreme."""
    best = np.full(int(isl.max()) + 1, empty)
    ufunc.at(best, isl, value)
    hit = np.isin(isl, charts) & (value == best[isl])
    first = np.full(len(best), len(value), dtype=np.int64)
    np.minimum.at(first, isl[hit], np.flatnonzero(hit))
    return first[charts]


def _cut_by_charting(result: Parametrization, owners: _Owners, stretch_cut: np.ndarray) -> np.ndarray:
    """The islands (k,) that charting cut: charted ones cut into several charts because
    they were not disks, were curved like a closed part (cells) or stretched
    (``stretch_cut`` (n,) bool), and disks slit open where they stretched (not those only
    cut apart where they overlapped themselves)."""
    topo = owners.topo
    n = topo.n_islands
    pieces = np.bincount(owners.face[first_rows(result.face_island, result.n_islands)], minlength=n)
    not_disk = np.zeros(n, dtype=bool)
    not_disk[topo.cut_islands] = True
    charted_ = np.zeros(n, dtype=bool)
    charted_[owners.charted] = True
    why = not_disk | owners.curved | stretch_cut
    return np.flatnonzero(charted_ & (((pieces > 1) & why) | (stretch_cut & ~not_disk)))


def _warnings(
    result: Parametrization, owners: _Owners, stretch_cut: np.ndarray, budget: float, refined: bool, exhausted: bool
) -> list[SolverWarning]:
    """The result's warnings, with what the charts did in place of what the topology cut.

    The islands charting cut are named once, by why: into several charts because they
    were not disks, curved like a closed part (cells) or stretched (``stretch_cut`` (n,)
    bool), or slit open where they stretched; those only opened (one chart, or pinned) as
    before; those only cut apart where they overlapped themselves as such; and those
    still beyond the budget."""
    topo = owners.topo
    n = topo.n_islands
    pieces = np.bincount(owners.face[first_rows(result.face_island, result.n_islands)], minlength=n)
    cut = _cut_by_charting(result, owners, stretch_cut)
    kept = unique_sorted(topo.cut_islands)
    kept = kept[~np.isin(kept, cut)]
    first = first_rows(owners.face, n)

    def now(islands):  # the result's island holding each island's first face
        return result.face_island[first[kept[np.isin(kept, islands)]]]

    before = topology_warnings(topo)
    out = [w for w in before if w.kind not in OPENED_KINDS]
    out += opened(
        now(topo.closed_islands),
        now(topo.handle_islands),
        now(topo.multi_boundary_islands),
        now(topo.nonorientable_islands),
    )
    out += _charted(result, owners, cut, budget)
    out += _over_budget(result, owners, budget, refined, exhausted)
    apart = np.flatnonzero(pieces > 1)  # islands cut apart where they overlapped
    apart = apart[~np.isin(apart, cut)]
    out += cut_apart(result.face_island[first[apart]])
    return out + [w for w in result.warnings if w.kind not in TOPOLOGY_KINDS | {WarningKind.CUT_APART}]


def charted(islands: int, not_disks: int, curved: int, charts: int, energy: float, budget: float, first: int):
    """The note that says what was cut into charts (:func:`with_charts`): ``islands`` cut into
    ``charts`` in all (as many: slit open only), ``not_disks`` of them because they were
    not disks, ``curved`` disks because they were curved like closed parts (the others
    because they stretched more than ``budget``), and their charts' mean symmetric
    Dirichlet ``energy`` per area."""
    why = []
    if not_disks:
        why.append(f"{not_disks} not {'a disk' if not_disks == 1 else 'disks'}")
    if curved:
        why.append(f"{curved} curved like a closed part")
    if islands - not_disks - curved:
        why.append(f"{islands - not_disks - curved} stretched beyond {budget:.3g}")
    into = "slit open" if charts == islands else f"cut into {charts} charts"
    template = (
        f"{counted(islands, 'island was', 'islands were')} {into} ({', '.join(why)}; "
        f"first: {{first}}), distortion {energy:.3f} (4 is isometric)"
    )
    return [warning(WarningKind.CHARTS, charts, "island", first, template)]


def over_budget(
    islands: int, pinned: int, energy: float, budget: float, allowed: float, refined: bool, first: int, checks: int
):
    """The warning on ``islands`` whose charts still stretch beyond ``budget`` (Max Stretch,
    which ``allowed`` symmetric Dirichlet energy per area) after charting: their mean energy
    per area, why they are left so (``pinned`` of them kept whole by their pins; the others
    left so after ``checks`` checks, or, with ``checks`` 0, where the checks found
    no cut to make), and what would help: seams, a higher budget, or (not ``refined``)
    refinement."""
    why = f"; {pinned} kept whole by {'its' if pinned == 1 else 'their'} pins" if pinned else ""
    if islands > pinned:
        rest = islands - pinned
        if checks:
            why += f"; {rest} left so after charting's {checks} checks"
        else:
            why += f"; {rest} where charting finds no cut"
    help_ = "mark seams there or raise Max Stretch" if refined else "not refined: refinement lowers it"
    template = (
        f"{counted(islands, 'island stretches', 'islands stretch')} beyond {budget:.3g} "
        f"(distortion {energy:.3f} where {budget:.3g} allows {allowed:.3f}{why}; "
        f"first: {{first}}): {help_}"
    )
    return [warning(WarningKind.OVER_BUDGET, islands, "island", first, template)]
