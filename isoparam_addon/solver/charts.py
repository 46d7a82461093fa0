"""Beyond the paper: charts. Every island the artist's seams do not bound (and every island
that is not a disk) is cut until its charts are laid out within a stretch budget.

A closed surface opened along its shortest cut (:mod:`.cutgraph`) flattens with regions
squeezed and others blown up: Suzanne, spot or a character is far from isometric as one
island; so is an open part with bumps (a face scan, a terrain), whose curvature cancels
in sum but not in its layout. Region-growing chart makers (D-Charts, Julius et al. 2005;
xatlas) cut into tens to thousands of charts by face normals; distortion-driven cutting
(Gu, Gortler and Hoppe, "Geometry images", 2002; OptCuts, Li et al. 2018) cuts only where
the layout needs it. Here, in that second spirit, and with few solves:

1. **Cells.** An island that holds more Gaussian curvature than half a sphere (a closed
   part, or one with small holes: no single cut flattens it without crushing some of it)
   is split into ``_CELLS`` cells around seeds spread by farthest-point sampling
   (geodesic distance over the faces' adjacency), each face going to its nearest seed;
   where two seeds are about as near, the boundary moves onto the cheapest edges
   (:mod:`.mincut`: short, along creases). Each cell flattens without the extreme
   squeeze of one cut, which also spares the refinement its slowest starts. Tubes and
   tori (little curvature) are opened by the usual cut (:mod:`.cutgraph`) instead.
2. **Slit what a conformal map crushes.** A cap that a conformal map of its island squeezes
   far beyond the budget is slit open before anything is refined
   (:func:`_conformal_slits`): one sparse solve per island where a round costs a
   refinement.
3. **Solve** the mesh with the cells' boundaries and those slits as seams (a cell that is
   still not a disk is cut open as usual).
4. **Cut where it stretches**, judged on the refined layout. While an island's charts are
   more distorted than the budget on (area-weighted) average, the charts that hold most
   of its excess are each cut once: where a chart squeezes a cap by more than the budget
   allows (a tip, a bump, the end of a limb), a slit from its boundary to the most
   squeezed place lets the cap open like a cone cut along a ruling; elsewhere a minimum
   cut parts a ball around its most squeezed faces from one around its most stretched,
   which lie on either side of where the layout had to tear the surface. Charts that
   overlap themselves are cut apart in the same round (:func:`.untangle.separating_cuts`).
   The pieces go on from the layout they were cut from, alone
   (:func:`.resolve.cut_further`), so a round costs one solve of the charts it cuts.

The budget is given as a stretch factor ``s``: an island may be as distorted (symmetric
Dirichlet energy per area, each chart at its best scale) as one stretched uniformly by
``s`` (:func:`energy_budget`), which is the energy the refinement lowers; a face squeezed
to less than ``1 / s^2`` of its area is beyond it.

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

from . import metrics
from .geometry import TINY, corner_angles, corner_signed_areas, face_areas, safe_divide
from .islands import Islands, first_rows
from .mesh import HalfEdges, edge_mask, pair_keys, unit_of
from .mincut import FaceGraph, face_graph, minimum_cut, source_side
from .options import Options, Problem
from .pipeline import solve, topology_of
from .progress import geometric, stage, tick
from .refinement import FaceFrames
from .report import (
    OPENED_KINDS,
    TOPOLOGY_KINDS,
    SolverWarning,
    WarningKind,
    charted,
    cut_apart,
    opened,
    over_budget,
)
from .resolve import cut_further, pairs, sub_problem
from .result import Parametrization, topology_warnings
from .seeds import lscm
from .topology import Topology
from .untangle import separating_cuts, without_overlaps

__all__ = ["with_charts"]

_CELLS = 3  # cells per island ...
_CURVED = 2.0 * np.pi  # ... whose interior holds more Gaussian curvature than this (half a sphere)
_ROUNDS = 8  # split, solve again, measure: at most this many times
_COVER = 0.5  # a round splits the charts that hold this share of their island's excess stretch
_BALL = 0.35  # radius of the balls cut apart, as a share of the distance between their centres
_SMOOTH = 3  # rounds of neighbour averaging of the area ratio that places the balls
_PREDICT = 2.0  # caps a conformal map squeezes below 1 / s^(2 _PREDICT) of their area are slit at once
_LEAVE = 0.1  # charts within this share of the budget's excess over isometric are not split
_BAND = 0.1  # a cell boundary moves where its two seeds' distances differ by less than this share of the cell radius
_GRID = 64  # the log area ratios that place cuts are rounded to 1 / _GRID
_TIE = 1e-9  # distances this close (relative) are equal: the lowest-numbered face is the seed
# the refinement's stopping tolerance wherever charts are cut: at the default 2e-4 an
# island stops while its layout can still move by 1e-3 of its size, which decides where
# the next cut goes (rounding of the input then moved the charts found, and their
# energy by up to 0.4%); at 1e-5 the layout has settled, for about 10% more time
_SETTLED = 1e-5
# ... and an island whose energy is over this share of the budget's excess over isometric,
# which may be cut next, refines until its layout stops moving too (see
# :func:`.refinement._converged`): where it is most squeezed, which decides the cut,
# converges slowest
_DECIDING = 0.8


@dataclass(frozen=True)
class _Owners:
    """The islands as the caller's seams make them, which charts are cut from."""

    face: np.ndarray  # (m,) the island of each face
    charted: np.ndarray  # (k,) islands that may be cut into charts (no pins)
    held: np.ndarray  # (j,) islands that would be, but pins keep whole
    curved: np.ndarray  # (n,) bool: islands curved like a closed part (cut into cells first)
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
        result.warnings += _over_budget(result, owners, options.max_stretch, options.refine > 0)
        return result
    settle = np.isin(owners.face, owners.charted)  # (only where charts are cut)
    problem = replace(
        problem,
        face_tol=np.where(settle, min(options.refine_tol, _SETTLED), options.refine_tol),
        settle_above=np.where(settle, 4.0 + _DECIDING * (energy_budget(options.max_stretch) - 4.0), np.inf),
    )
    with stage("cutting closed parts into cells", 0.04, 0.05):
        cells = _cell_boundaries(owners.graph, owners.face, owners.charted[owners.curved[owners.charted]])
    with stage("slitting squeezed caps", 0.05, 0.08):
        slits, slit = _conformal_slits(problem, options, np.vstack([seams, cells]), owners)
    first = np.vstack([cells, slits])  # the cuts of the first solve
    with stage("charting", 0.08, 0.5):
        if len(first):
            result = solve(replace(problem, seams=np.vstack([seams, first])), options)
        else:
            result = solve(problem, options, built)
    first_solve = result.timings.total
    result.cut_edges = np.vstack([first, result.cut_edges])
    rounds = 0
    stretch_cut = np.zeros(topo.n_islands, dtype=bool)  # islands cut where they stretched
    stretch_cut[slit] = True
    with stage("charting", 0.5, 0.9):  # rounds: cut, solve the islands cut again
        for rounds in range(1, _ROUNDS + 1):
            # split what stretches too much, and cut apart what overlaps itself, in one solve
            seams_now = np.vstack([seams, result.cut_edges])
            graph = face_graph(V, F, result.face_island, seams_now, problem.inner_edges)
            tick()
            new, split = _stretch_cuts(result, graph, owners, options.max_stretch)
            tick()
            stretch_cut[owners.face[first_rows(result.face_island, result.n_islands)[split]]] = True
            overlapping = np.flatnonzero(result.islands.crossings > 0) if options.split_overlaps else split[:0]
            if len(overlapping):
                apart = separating_cuts(result, problem, overlapping, graph)
                result.stats.overlap_cuts += len(apart)
                new, split = np.vstack([new, apart]), np.union1d(split, overlapping)
            if not len(new):
                rounds -= 1
                break
            with stage(f"round {rounds + 1}", *geometric(rounds)):
                result = cut_further(result, problem, new, split, options)
    result.cut_islands = topo.cut_islands
    result.timings.topology += t_topology
    result.timings.charts = time.perf_counter() - t0 - first_solve - t_topology
    if options.split_overlaps and (result.islands.crossings > 0).any():
        with stage("overlap cuts", 0.9, 1.0):
            result = without_overlaps(result, problem, options)
    result.warnings = _warnings(result, owners, stretch_cut, options.max_stretch, options.refine > 0)
    cut = _cut_by_charting(result, owners, stretch_cut)
    result.stats.charts = int(len(np.unique(result.face_island[np.isin(owners.face, cut)])))
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
    return _Owners(topo.face_island, charted, np.flatnonzero(wanted & pinned), curved, topo, graph)


def _curvature(V: np.ndarray, topo: Topology) -> np.ndarray:
    """Per island (n,), the Gaussian curvature of its interior: the sum of the angle
    defects ``2 pi - sum of angles`` of its vertices off its boundary and seams (the cuts
    that opened it do not count as boundary): 4 pi for a closed surface of genus 0, less
    the turning of its boundary for one with holes; 0 for a torus, about 0 for a tube or
    a height field."""
    angle, _, _ = corner_angles(V[topo.vertex_of], topo.faces)
    corner = topo.vertex_of[topo.faces.ravel()]  # the mesh vertex of every corner
    n = len(V)
    defect = 2.0 * np.pi - np.bincount(corner, angle, minlength=n)
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


def _stretch_cuts(result: Parametrization, graph: FaceGraph, owners: _Owners, budget: float):
    """The cuts of one round (k, 2 vertex pairs) and the islands of ``result`` they cut:
    in every charted island whose charts stretch more than ``budget`` on average, the
    charts holding ``_COVER`` of its excess, each slit to every cap it squeezes beyond the
    budget (:func:`_slits`), or, with none, cut in two between its most squeezed and its
    most stretched place (:func:`_balls`)."""
    none = np.zeros((0, 2), dtype=np.int64), np.zeros(0, dtype=np.int64)
    energy, area, owner = _chart_energy(result, owners)
    k = owners.topo.n_islands
    mean = safe_divide(np.bincount(owner, energy * area, minlength=k), np.bincount(owner, area, minlength=k))
    limit = energy_budget(budget)
    over = (area > 0) & (mean[owner] > limit)
    if not over.any():
        return none
    excess = np.where(over, (energy - 4.0) * area, 0.0)
    order = np.lexsort((-excess, owner))  # by island, most excess first
    sorted_owner = owner[order]
    running = np.concatenate([[0.0], np.cumsum(excess[order])])
    before = running[:-1] - running[np.searchsorted(sorted_owner, sorted_owner)]  # excess ahead in its island
    total = np.bincount(owner, excess, minlength=k)
    chosen = order[(before < _COVER * total[sorted_owner]) & over[order]]
    chosen = chosen[energy[chosen] > 4.0 + _LEAVE * (limit - 4.0)]  # leave near-isometric charts
    if not len(chosen):
        return none
    ratio = _area_ratio(result, graph)
    on = np.isin(result.face_island, chosen)
    # every region the layout squeezes beyond the budget is a cap to let open: a slit to
    # its most squeezed face
    tips = _tips(graph, on & (ratio < -2.0 * np.log(budget)), ratio)
    slit, slitted = _slits(result, graph.among(on), tips, ratio)
    rest = np.setdiff1d(chosen, slitted)
    cuts = [slit]
    if len(rest):
        source, sink = _balls(result, graph, rest, ratio)
        cuts.append(minimum_cut(graph.among(np.isin(result.face_island, rest)), source, sink))
    cut = np.vstack(cuts)
    return (cut, chosen) if len(cut) else none


@dataclass(frozen=True)
class _Layout:
    """A layout of the mesh's faces, per face corner, and its islands: what the cuts of a
    round read (a :class:`.result.Parametrization` is one too)."""

    vertices: np.ndarray  # (n, 3)
    faces: np.ndarray  # (m, 3)
    corner_uv: np.ndarray  # (m, 3, 2)
    face_island: np.ndarray  # (m,)
    n_islands: int


def _conformal_slits(
    problem: Problem, options: Options, seams: np.ndarray, owners: _Owners
) -> tuple[np.ndarray, np.ndarray]:
    """Slits (k, 2 vertex pairs) into the caps that a conformal map of every charted island
    (cut along ``seams`` and opened into disks) squeezes to less than ``1 / s^(2 _PREDICT)``
    of their area (``s``: Max Stretch), chosen as in a round (:func:`_slits`), and the
    islands (of ``owners``) they slit.

    A conformal map keeps angles and puts all of its distortion into area; an isometric
    layout shares it between area and angle. Where the conformal map squeezes a cap far
    beyond the budget, the refined layout squeezes it beyond the budget too: slit before
    the first refinement, which then starts nearer its end, such a cap costs no round. One
    sparse solve per island (:func:`.seeds.lscm`), where a round costs a refinement."""
    faces = np.flatnonzero(np.isin(owners.face, owners.charted))  # the charted islands alone
    problem, used = sub_problem(replace(problem, seams=seams), faces)
    V, F = np.asarray(problem.vertices), np.asarray(problem.faces)
    # (two wedges of an island that other islands' faces separated meet at a bare vertex)
    _, _, topo = topology_of(problem, replace(options, split_nonmanifold=True))
    tick(0.3)
    unit = unit_of(V)
    X = V[topo.vertex_of] / unit
    islands = Islands(topo.vertex_island, topo.n_islands)
    owner = owners.face[faces[first_rows(topo.face_island, topo.n_islands)]]
    none = np.zeros((0, 2), dtype=np.int64), np.zeros(0, dtype=np.int64)
    try:
        uv = lscm(X, topo.faces, islands, FaceFrames(X, topo.faces), np.ones(topo.n_islands, dtype=bool))
    except RuntimeError:  # SuperLU: "Factor is exactly singular": no prediction, the rounds decide
        return none
    tick(0.6)
    layout = _Layout(V, F, uv[topo.corner_vertex], topo.face_island, topo.n_islands)
    graph = face_graph(V, F, topo.face_island, np.vstack([pairs(problem.seams), topo.cut_edges]), problem.inner_edges)
    tick(0.8)
    ratio = _area_ratio(layout, graph)
    tips = _tips(graph, ratio < -2.0 * _PREDICT * np.log(options.max_stretch), ratio)
    if not len(tips):
        return none
    slits, slit = _slits(layout, graph, tips, ratio)
    return used[slits], np.unique(owner[slit])


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


def _area_ratio(result: Parametrization | _Layout, graph: FaceGraph) -> np.ndarray:
    """Per face (m,), the log of its UV area over its 3D area against its island's,
    smoothed by ``_SMOOTH`` rounds of area-weighted averaging over its neighbours and
    rounded to ``1 / _GRID``: negative where the layout squeezes the surface, positive
    where it stretches it."""
    V, F, isl = result.vertices, result.faces, result.face_island
    m = len(F)
    a3 = face_areas(V, F)
    a2 = np.abs(corner_signed_areas(result.corner_uv))
    A3 = np.bincount(isl, a3, minlength=result.n_islands)
    A2 = np.bincount(isl, a2, minlength=result.n_islands)
    with np.errstate(divide="ignore", invalid="ignore"):
        ratio = np.log(np.maximum(a2, TINY) / np.maximum(a3, TINY)) - np.log(A2 / A3)[isl]
    ratio = np.where(np.isfinite(ratio), ratio, 0.0)
    adjacency = sp.coo_matrix((np.ones(len(graph.f)), (graph.f, graph.g)), shape=(m, m))
    adjacency = (adjacency + adjacency.T).tocsr()
    for _ in range(_SMOOTH):  # area-weighted mean over each face and its neighbours
        ratio = safe_divide(adjacency @ (ratio * a3) + ratio * a3, adjacency @ a3 + a3)
    # on a grid of 1/64: which face is most squeezed, and which path is shortest, must not
    # follow the rounding of the layout (another machine's sums)
    return np.round(_GRID * ratio) / _GRID


def _balls(result: Parametrization, graph: FaceGraph, charts: np.ndarray, ratio: np.ndarray):
    """Per chart in ``charts``, the faces (m,) bool within ``_BALL`` of the distance between
    its most squeezed and its most stretched face (by ``ratio``, :func:`_area_ratio`) of
    the one and of the other."""
    isl = result.face_island
    on = np.isin(isl, charts)
    low = _extreme(np.where(on, ratio, np.inf), isl, charts, np.minimum, np.inf)
    high = _extreme(np.where(on, ratio, -np.inf), isl, charts, np.maximum, -np.inf)
    G = graph.distances()
    from_low = csgraph.dijkstra(G, directed=False, indices=low, min_only=True)
    from_high = csgraph.dijkstra(G, directed=False, indices=high, min_only=True)
    reach = np.full(result.n_islands, -1.0)
    reach[charts] = _BALL * from_low[high]
    source = on & (from_low <= reach[isl])
    sink = on & (from_high <= reach[isl]) & ~source
    return source, sink


def _slits(
    result: Parametrization | _Layout, inside: FaceGraph, faces: np.ndarray, ratio: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """Slits (k, 2 vertex pairs) from the boundary of each chart to a corner of its face in
    ``faces``, and the charts that got one (k,): the shortest paths, as laid out, over the
    edges of ``inside`` (the charts' faces joined), each edge's cost scaled by the layout's
    length scale there (``ratio``, :func:`_area_ratio`, is its log squared). A slit then
    runs through what the layout squeezes, where it must tear, not through what it
    stretches. A squeezed cap that a slit reaches opens like a cone
    cut along a ruling (Gu, Gortler & Hoppe, "Geometry images", 2002, cut the same way to
    where a layout is most distorted)."""
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
    w = w + 1e-12 * max(float(w.max(initial=0.0)), TINY)  # csgraph drops zeros
    G = sp.coo_matrix((w, (a, b)), shape=(n, n)).tocsr()
    target = F[faces, 0]
    reached = ~boundary[target]
    if not reached.any():
        return none
    dist, pred, _ = csgraph.dijkstra(
        G, directed=False, indices=np.flatnonzero(boundary), min_only=True, return_predecessors=True
    )
    reached &= np.isfinite(dist[target])
    cur = target[reached]
    pieces = []
    while cur.size:  # one step along every slit at once; as many rounds as the longest
        prev = pred[cur].astype(np.int64)
        pieces.append(np.stack([cur, prev], axis=1))
        cur = prev[~boundary[prev]]
    if not pieces:
        return none
    return np.unique(np.sort(np.concatenate(pieces), axis=1), axis=0), np.unique(result.face_island[faces[reached]])


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


def _over_budget(result: Parametrization, owners: _Owners, budget: float, refined: bool) -> list[SolverWarning]:
    """The warning on the islands charting is for (:func:`_owners`) whose charts still
    stretch beyond ``budget`` on average, pinned ones included: how many, how far, and
    what would help."""
    islands = np.union1d(owners.charted, owners.held)
    energy, area, owner = _chart_energy(result, owners, islands)
    k = owners.topo.n_islands
    total = np.bincount(owner, area, minlength=k)
    mean = safe_divide(np.bincount(owner, energy * area, minlength=k), total)
    over = np.flatnonzero(mean > energy_budget(budget))
    if not len(over):
        return []
    return over_budget(
        islands=len(over),
        pinned=int(np.isin(over, owners.held).sum()),
        energy=float(safe_divide((mean[over] * total[over]).sum(), total[over].sum())),
        budget=budget,
        allowed=energy_budget(budget),
        refined=refined,
        first=int(result.face_island[first_rows(owners.face)[over[0]]]),
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
    result: Parametrization, owners: _Owners, stretch_cut: np.ndarray, budget: float, refined: bool
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
    kept = np.setdiff1d(topo.cut_islands, cut)
    first = first_rows(owners.face, n)

    def now(islands):  # the result's island holding each island's first face
        return result.face_island[first[np.intersect1d(islands, kept)]]

    before = topology_warnings(topo)
    out = [w for w in before if w.kind not in OPENED_KINDS]
    out += opened(
        now(topo.closed_islands),
        now(topo.handle_islands),
        now(topo.multi_boundary_islands),
        now(topo.nonorientable_islands),
    )
    out += _charted(result, owners, cut, budget)
    out += _over_budget(result, owners, budget, refined)
    apart = np.setdiff1d(np.flatnonzero(pieces > 1), cut)  # islands cut apart where they overlapped
    out += cut_apart(result.face_island[first[apart]])
    return out + [w for w in result.warnings if w.kind not in TOPOLOGY_KINDS | {WarningKind.CUT_APART}]
