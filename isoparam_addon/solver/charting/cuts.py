"""Beyond the paper: longer cuts for islands that had to be cut automatically.

A closed island, or one with handles or holes, is opened into a disk by the shortest cut
that does it (:func:`.cutgraph.cut_to_disks`). That cut only fixes the topology: a closed
surface opened along one short path is flattened with a few regions squeezed and others
blown up (Suzanne with no seams: the layout's area is off by a factor ``e^2 ~ 7`` on
average). Gu, Gortler and Hoppe ("Geometry images", SIGGRAPH 2002, Section 3.2) grow the
cut instead: find the vertex whose neighbourhood is most distorted, cut the shortest
path from the current boundary to it, parametrize again, and keep going while the
distortion falls. A path from the boundary to an interior vertex is a slit, so the
island stays one disk and keeps its number.

Here the distortion is the area distortion ``|log(area_uv / area_3d)|`` at the island's
own scale, which neither a fold nor the layout's scale can hide. Measured on Suzanne
subdivided twice with no seams (7,958 vertices, refine=100): symmetric Dirichlet 16.3
with the shortest cut, then 7.46, 4.49 and 4.20 after one, two and three paths of 54,
49 and 43 edges; a fourth path of one edge gained 0.05%.
"""

from __future__ import annotations

import time
from dataclasses import replace

import numpy as np
import scipy.sparse as sp
from scipy.sparse import csgraph

from ..geometry import TINY, corner_signed_areas, face_areas
from ..mesh.halfedges import HalfEdges, edge_mask
from ..options import Options, Problem
from ..pipeline import solve
from ..progress import geometric, stage
from ..report import TOPOLOGY_KINDS, SolverWarning, WarningKind, warning
from ..result import Parametrization
from .resolve import Part, combine, pairs, solve_islands

__all__ = ["area_distortion", "next_paths", "with_extra_cuts"]

_GAIN = 0.01  # an extra cut stays if it lowers its island's area distortion by this much

_WORTH = np.log(1.5)  # a vertex whose faces are off by less than 1.5x in area needs no cut
# targets keep this many edges away from the cut: the tip of a slit is a cone point whose
# neighbours always look squeezed, and a path of an edge or two there only moves the tip
# and ends the search before it reaches the squeezed part
_CLEAR = 2
_TIE = 1e-3  # distortions this close (relative) are equal: the refinement stops within 1e-4 of its energy


def area_distortion(V: np.ndarray, F: np.ndarray, corner_uv: np.ndarray, face_island: np.ndarray, n: int):
    """Per face ``|log(area_uv / (s_i area_3d))|`` (m,), and per island its area-weighted
    mean (n,), with ``s_i`` the island's UV area over its 3D area. Faces without 3D area
    weigh nothing; a collapsed UV triangle counts as 1e-12 of its share."""
    a3 = face_areas(V, F)
    a2 = np.abs(corner_signed_areas(corner_uv))
    A3 = np.bincount(face_island, a3, minlength=n)
    s = np.bincount(face_island, a2, minlength=n) / np.where(A3 > 0, A3, 1.0)
    expected = a3 * s[face_island]
    ok = expected > 0
    with np.errstate(divide="ignore", invalid="ignore"):
        bad = np.where(ok, np.abs(np.log(np.maximum(a2, 1e-12 * expected) / np.where(ok, expected, 1.0))), 0.0)
    mean = np.bincount(face_island, bad * a3, minlength=n) / np.where(A3 > 0, A3, 1.0)
    return bad, mean


def next_paths(V, F, face_island, islands, face_bad, seams, inner=None):
    """One more cut per island in ``islands``: the shortest path (3D edge lengths) from
    the island's boundary (mesh boundary and ``seams``, which include the cuts so far) to
    its interior vertex of largest mean face distortion ``face_bad`` among those more
    than ``_CLEAR`` edges away from the boundary.

    Paths never use ``inner`` edges (polygon diagonals) or a bow-tie's pinch vertex, and
    never start at a lone seam edge that opens nothing; an island whose worst vertex is
    below ``_WORTH``, or cannot be reached that way, gets no path.

    ``V`` (n, 3), ``F`` (m, 3), ``face_island`` (m,), ``islands`` (j,) island numbers,
    ``face_bad`` (m,) (from :func:`area_distortion`), ``seams`` and ``inner`` (k, 2) vertex
    pairs. Returns the new edges (k, 2) as vertex pairs, the island of each (k,), and which
    of ``islands`` got a path (j,) bool.
    """
    n = len(V)
    he = HalfEdges(F, n)
    ev = he.edge_vertices
    want = np.zeros(int(face_island.max()) + 1, dtype=bool)
    want[islands] = True
    e_isl = np.empty(he.n_edges, dtype=np.int64)
    e_isl[he.edge] = np.repeat(face_island, 3)
    in_isl = want[e_isl]
    cut = edge_mask(he, n, seams) | (he.edge_count == 1)
    # a lone interior seam edge (no other cut at either end) opens nothing: not a boundary
    degree = np.bincount(ev[cut].ravel(), minlength=n)
    cut &= ~((he.edge_count == 2) & (degree[ev[:, 0]] == 1) & (degree[ev[:, 1]] == 1))
    diag = edge_mask(he, n, inner, "inner_edges")
    on_cut = np.zeros(n, dtype=bool)
    on_cut[ev[cut].ravel()] = True
    # vertex score: mean distortion of its faces; boundary vertices are where paths start
    count = np.bincount(F.ravel(), minlength=n)
    score = np.bincount(F.ravel(), np.repeat(face_bad, 3), minlength=n) / np.maximum(count, 1)
    v_isl = np.full(n, -1, dtype=np.int64)
    v_isl[F.ravel()] = np.repeat(face_island, 3)
    # a vertex in several islands and on no cut is a bow-tie's pinch: paths keep off it
    low = np.full(n, np.iinfo(np.int64).max)
    np.minimum.at(low, F.ravel(), np.repeat(face_island, 3))
    pinch = (v_isl >= 0) & (low != v_isl) & ~on_cut
    near = on_cut.copy()
    for _ in range(_CLEAR):  # grow by one ring of edges
        step = near[ev[:, 0]] | near[ev[:, 1]]
        near[ev[step].ravel()] = True
    live = (v_isl >= 0) & want[np.maximum(v_isl, 0)] & ~near & ~pinch & (score > _WORTH)
    best = np.full(len(want), -np.inf)
    np.maximum.at(best, v_isl[live], score[live])
    # the lowest-numbered of the vertices within _TIE of the worst: on a symmetric island
    # (a box's eight corners) rounding must not choose among equals
    hit = live & (score >= best[np.maximum(v_isl, 0)] * (1.0 - _TIE))
    target = np.full(len(want), n, dtype=np.int64)
    np.minimum.at(target, v_isl[hit], np.flatnonzero(hit))
    target = target[islands]
    got = target < n
    if not got.any():
        return np.zeros((0, 2), dtype=np.int64), np.zeros(0, dtype=np.int64), got
    # walk the island's edges only, never along a cut (it is boundary already) or a diagonal
    use = in_isl & ~cut & ~diag & ~pinch[ev[:, 0]] & ~pinch[ev[:, 1]]
    length = np.linalg.norm(V[ev[use, 0]] - V[ev[use, 1]], axis=1)
    length += 1e-12 * max(float(length.max(initial=0.0)), TINY)  # csgraph drops zero weights
    graph = sp.coo_matrix((length, (ev[use, 0], ev[use, 1])), shape=(n, n)).tocsr()
    sources = np.flatnonzero(on_cut)
    dist, pred, _ = csgraph.dijkstra(graph, directed=False, indices=sources, min_only=True, return_predecessors=True)
    got &= np.isfinite(dist[np.minimum(target, n - 1)])
    cur = target[got]
    path = np.flatnonzero(got)  # which of ``islands`` each walk belongs to
    edges, owner = [], []
    while cur.size:  # one step along every path at once; as many rounds as the longest path
        prev = pred[cur]
        edges.append(np.stack([cur, prev], axis=1))
        owner.append(path)
        going = ~on_cut[prev]
        cur, path = prev[going], path[going]
    if not edges:
        return np.zeros((0, 2), dtype=np.int64), np.zeros(0, dtype=np.int64), got
    return np.concatenate(edges), islands[np.concatenate(owner)], got


# ---------------------------------------------------------------------------- the search


def with_extra_cuts(problem: Problem, options: Options) -> Parametrization:
    """:func:`.pipeline.solve` with up to ``options.extra_cuts`` more cuts per island cut open.

    The whole mesh is solved once, as with no extra cuts; the cuts are then grown on the
    islands that had to be cut open, each try solving those islands alone
    (:func:`_grow`); the result is the first solve with the kept tries' islands put in
    (:func:`.resolve.combine`). Nothing is solved twice.
    """
    with stage("", 0.0, 0.5):
        first = solve(problem, options)
    if not first.cut_islands.size:  # nothing was cut open
        return first
    t0 = time.perf_counter()
    cuts, kept, tries, gains, before, score = _grow(first, problem, options)
    added = len(cuts) - len(first.cut_edges)
    best = first
    if kept:
        seams = np.vstack([pairs(problem.seams), cuts])
        if options.refine and first.islands.shaped.any():
            # islands with three or more pins are moved onto them in stages, and every
            # stage refines all of them (pins.refine_to_pins), so a try alone can take
            # another path than the whole mesh would: solve it
            best = solve(replace(problem, vertices=first.vertices, faces=first.faces, seams=seams), options)
        else:
            best = combine(first, kept, replace(problem, seams=seams), options)
        best.cut_edges, best.cut_islands = cuts, first.cut_islands
        topology = [w for w in first.warnings if w.kind in TOPOLOGY_KINDS]
        rest = [w for w in best.warnings if w.kind not in TOPOLOGY_KINDS]
        best.warnings = [*topology, *lowered(added, before, score), *rest]
    best.timings.extra_cuts = time.perf_counter() - t0
    best.timings.total = first.timings.total + best.timings.extra_cuts
    best.stats.extra_cut_tries, best.stats.extra_cut_edges, best.stats.extra_cut_gains = tries, added, gains
    return best


def _grow(first: Parametrization, problem: Problem, options: Options):
    """Grow the automatic cuts of ``first``: one path per island and round, kept where it
    lowers that island's area distortion by ``_GAIN``. A try solves only the islands still
    being grown.

    Returns the cuts (automatic, then extra), the kept tries (:class:`.resolve.Part`,
    keeping the islands whose cut each kept), the number of tries, their gains, and the
    area distortion of the islands cut open before and after.
    """
    V, F = first.vertices, first.faces
    base = pairs(problem.seams)
    isl = first.face_island
    cuts = first.cut_edges
    bad, before = area_distortion(V, F, first.corner_uv, isl, first.n_islands)
    score = before.copy()
    active = first.cut_islands.copy()
    kept: list[Part] = []
    tries, gains = 0, list[float | None]()
    layout = first.corner_uv.copy()  # the best layout so far: each try goes on from it
    while active.size and tries < options.extra_cuts:
        new, owner, got = next_paths(V, F, isl, active, bad, np.vstack([base, cuts]), problem.inner_edges)
        active = active[got]
        if not active.size:
            break
        tries += 1
        # a slit leaves the layout as it was (both sides on one line) and fold-free: the try
        # refines it on, rather than starting again from the four steps
        start = layout if options.refine else None
        trying = replace(problem, vertices=V, faces=F, seams=np.vstack([base, cuts, new]), start=start)
        with stage(f"extra cut {tries}", *(0.5 + 0.5 * f for f in geometric(tries))):
            part = solve_islands(trying, np.flatnonzero(np.isin(isl, active)), options)
        trial, faces = part.result, part.faces
        if trial.n_islands != len(active) or trial.cut_islands.size:  # a slit keeps one disk
            gains.append(None)  # tried, not measured
            break
        t_bad, m = area_distortion(trial.vertices, trial.faces, trial.corner_uv, trial.face_island, trial.n_islands)
        label = np.empty(trial.n_islands, dtype=np.int64)  # the trial's islands in ``first``'s numbering
        label[trial.face_island] = isl[faces]
        m = np.bincount(label, m, minlength=first.n_islands)
        gain = 1.0 - m[active] / np.maximum(score[active], TINY)
        gains.append(float(gain.max()))
        better = gain >= _GAIN
        if not better.any():
            break
        won = active[better]
        cuts = np.vstack([cuts, new[np.isin(owner, won)]])
        score[won] = m[won]
        mine = np.isin(isl[faces], won)
        bad[faces[mine]] = t_bad[mine]
        layout[faces[mine]] = trial.corner_uv[mine]
        kept.append(Part(trial, faces, part.vertices, mine))
        active = won
    opened = first.cut_islands
    return cuts, kept, tries, gains, before[opened], score[opened]


def lowered(added: int, before: np.ndarray, score: np.ndarray) -> list[SolverWarning]:
    """The warning that says what the extra cuts did (``before``/``score``: area
    distortion of the islands that were cut open, before and after)."""
    if not added:
        return []
    template = (
        f"{added} more edges cut on {int((score < before).sum())} of them, lowering "
        f"their area distortion from {before.mean():.3g} to {score.mean():.3g}"
    )
    return [warning(WarningKind.EXTRA_CUTS, added, "", None, template)]
