"""Solving some islands again and putting them back: the machinery the searches beyond one
solve share (extra cuts, splitting islands that overlap themselves).

Islands are independent problems: the faces of some islands, solved alone with more
seams, give the same layouts as the whole mesh solved with those seams (to the solver's
tolerance), so a search solves only the islands it changes, and :func:`combine` packs
them back beside the others. Every solve returns its islands unpacked in their canonical
frame, as :func:`.pipeline.solve` has them before packing, so only the packing is redone.
"""

from __future__ import annotations

import time
from dataclasses import replace
from typing import NamedTuple

import numpy as np

from ..geometry import safe_divide, signed_double_areas
from ..layout.placement import pack_islands
from ..mesh.halfedges import repeated_faces, split_edges, unique_sorted, unit_of
from ..mesh.islands import Islands, first_rows
from ..mesh.topology import build_topology
from ..options import Options, Problem
from ..pipeline import solve
from ..report import TOPOLOGY_KINDS, IslandReport, SolverWarning, WarningKind
from ..result import Parametrization, assemble

__all__ = ["Part", "carried_warnings", "combine", "cut_further", "pairs", "solve_islands", "sub_problem"]

# what a search's first solve decided, which solving some islands again does not say again
_DECIDED = TOPOLOGY_KINDS | {WarningKind.EXTRA_CUTS, WarningKind.CHARTS}


class Part:
    """A solve of some faces of the mesh: ``result`` covers ``faces`` (k,) (indices into the
    mesh's faces, in the result's face order) over ``vertices`` (its vertex i is the
    mesh's ``vertices[i]``); ``keep`` (k,) bool are the faces whose layout is taken (the
    islands whose seams stay)."""

    def __init__(self, result: Parametrization, faces: np.ndarray, vertices: np.ndarray, keep=None):
        self.result, self.faces, self.vertices = result, faces, vertices
        self.keep = np.ones(len(faces), dtype=bool) if keep is None else keep

    @property
    def cut_edges(self) -> np.ndarray:
        """The part's automatic cuts, as vertex pairs of the mesh (k, 2)."""
        return self.vertices[self.result.cut_edges]


def pairs(seams) -> np.ndarray:
    """Vertex pairs as a (k, 2) int64 array (k = 0 for None)."""
    return np.zeros((0, 2), dtype=np.int64) if seams is None else np.asarray(seams, dtype=np.int64).reshape(-1, 2)


def solve_islands(problem: Problem, faces: np.ndarray, options: Options) -> Part:
    """Solve ``faces`` (indices into the problem's faces: whole islands) alone, unpacked,
    from ``problem.start`` if it holds a layout to go on from."""
    if len(faces) == len(np.asarray(problem.faces)):
        return Part(solve(problem, replace(options, pack=False)), faces, np.arange(len(np.asarray(problem.vertices))))
    part, used = sub_problem(problem, faces)
    # split_nonmanifold: two wedges of an island around a vertex that other islands' faces
    # separated (with seams) meet at a bare vertex once those faces are left out
    return Part(solve(part, replace(options, pack=False, split_nonmanifold=True)), faces, used)


def sub_problem(problem: Problem, faces: np.ndarray) -> tuple[Problem, np.ndarray]:
    """The problem of ``faces`` (k,, indices into the problem's faces) alone, over the
    vertices they use, and those vertices (j,) (its vertex i is the problem's ``used[i]``):
    seams and inner edges between two of them kept, per-face data taken.

    An edge that more than two faces of the problem share is a seam of the part too: the
    whole problem's topology splits it (:func:`.halfedges.split_edges`), and a part that holds
    only two of its faces would otherwise join them across it (two islands made one, or an
    island's layout glued to itself where it was apart)."""
    V, F = np.asarray(problem.vertices), np.asarray(problem.faces)
    used = unique_sorted(F[faces])
    index = np.full(len(V), -1, dtype=np.int64)
    index[used] = np.arange(len(used))

    def inside(vertex_pairs):
        if vertex_pairs is None:
            return None
        p = index[pairs(vertex_pairs)]
        return p[(p >= 0).all(axis=1)]

    seams = inside(problem.seams)
    edges = split_edges(F, len(V), repeated_faces(F, len(V)))
    split = inside(edges.edge_vertices[edges.overfull])
    if len(split):
        seams = split if seams is None else np.vstack([seams, split])
    pins = None if problem.pins is None else (np.asarray(problem.pins[0])[faces], np.asarray(problem.pins[1])[faces])
    start = None if problem.start is None else problem.start[faces]
    part = Problem(V[used], index[F[faces]], seams, inside(problem.inner_edges), pins, start)
    return part, used


def cut_further(
    result: Parametrization, problem: Problem, new: np.ndarray, islands: np.ndarray, options: Options
) -> Parametrization:
    """``result`` (whose ``cut_edges`` are every cut so far) with ``islands`` cut along the
    ``new`` edges (k, 2 vertex pairs) too, solved again alone from their layout (with
    refinement: the pieces go on from it, fold-free) and put back. The result's
    ``cut_edges`` are all cuts: the old, the new, and those that opened a piece that was
    no disk."""
    cuts = np.vstack([result.cut_edges, new])
    start = result.corner_uv if options.refine else None
    seams = np.vstack([pairs(problem.seams), cuts])
    trying = replace(problem, vertices=result.vertices, faces=result.faces, seams=seams, start=start)
    part = solve_islands(trying, np.flatnonzero(np.isin(result.face_island, islands)), options)
    cuts = np.vstack([cuts, part.cut_edges])
    cut_islands = result.cut_islands
    result = combine(result, [part], replace(trying, seams=np.vstack([seams, part.cut_edges]), start=None), options)
    result.cut_edges, result.cut_islands = cuts, cut_islands
    return result


class _Source(NamedTuple):
    islands: np.ndarray  # the new islands this source lays out
    own: np.ndarray  # ... and their numbers in the source


def combine(first: Parametrization, parts: list[Part], problem: Problem, options: Options) -> Parametrization:
    """``first`` with the faces of ``parts`` laid out as those parts solved them (later
    parts over earlier ones), every island packed again: the whole mesh's result with
    ``problem.seams`` (which must hold every seam and cut of the parts, so that its islands
    are theirs) without solving again what no part changed.

    Per-island facts and Step 3 values come from the solve that laid each island out;
    ``iterations`` and ``refine_iterations`` are the most any solve took, and
    ``refine_energy`` is ``first``'s history followed by the combined layout's energy.
    """
    t0 = time.perf_counter()
    V, F = first.vertices, first.faces
    _, _, topo = build_topology(V, F, problem.seams, options.split_nonmanifold, problem.inner_edges)
    if topo.cut_islands.size:  # not expected (the parts' cuts are among the seams): solve it all
        return solve(replace(problem, vertices=V, faces=F), options)
    corner_uv = first.corner_uv.copy()
    owner = np.full(len(F), -1, dtype=np.int64)  # which part lays each face out (-1: first)
    local = np.arange(len(F))  # ... and the face's number there
    for k, part in enumerate(parts):
        taken = part.faces[part.keep]
        corner_uv[taken] = part.result.corner_uv[part.keep]
        owner[taken], local[taken] = k, np.flatnonzero(part.keep)
    n = topo.n_islands
    rep = first_rows(topo.face_island, n)  # a face of every new island
    sources = [(first, _Source(np.flatnonzero(owner[rep] < 0), first.face_island[rep[owner[rep] < 0]]))]
    for k, part in enumerate(parts):
        mine = np.flatnonzero(owner[rep] == k)
        sources.append((part.result, _Source(mine, part.result.face_island[local[rep[mine]]])))
    report = IslandReport.empty(n)
    eigenvalues, converged = np.zeros((n, 2)), np.zeros(n, dtype=bool)
    stats = replace(first.stats, refine_energy=list(first.stats.refine_energy))
    parent = first.face_island[rep]  # the island of ``first`` each new one comes from
    for result, source in sources:
        report.take_from(result.islands, source.islands, source.own)
        stats.refine_iterations = max(stats.refine_iterations, result.stats.refine_iterations)
        if result is not first and result.stats.iterations == 0:  # went on from a layout: no four steps ran
            _four_step_facts(report, first, parent, source.islands)
            eigenvalues[source.islands] = first.eigenvalues[parent[source.islands]]
            converged[source.islands] = first.converged[parent[source.islands]]
            continue
        eigenvalues[source.islands] = result.eigenvalues[source.own]
        converged[source.islands] = result.converged[source.own]
        stats.iterations = max(stats.iterations, result.stats.iterations)
        stats.refine_iterations = max(stats.refine_iterations, result.stats.refine_iterations)
    uv_split = np.zeros((len(topo.vertex_of), 2))
    uv_split[topo.corner_vertex.ravel()] = corner_uv.reshape(-1, 2)
    # an island whose input winding is inconsistent is oriented by the area of its faces
    # as given, which a part solved alone can weigh otherwise: its layout is then the
    # mirror image of what the whole's orientation asks, which every face would count as
    # folded; it is mirrored back
    area = np.bincount(topo.face_island, signed_double_areas(uv_split, topo.faces), minlength=n)
    uv_split[:, 0] = np.where(area[topo.vertex_island] < 0, -uv_split[:, 0], uv_split[:, 0])
    if options.pack:
        uv_split = pack_islands(uv_split, Islands(topo.vertex_island, n), options.margin, report.held)
    if options.refine:  # the combined layout's energy, as the refinement measures it
        area = report.refine_area.sum()
        stats.refine_energy.append(float(safe_divide(report.refine_energy.sum(), area)))
    unit = unit_of(V)
    result = assemble(V, F, topo, uv_split / unit, unit, report, eigenvalues, converged, stats, first.timings)
    result.timings = replace(first.timings, merge=first.timings.merge + time.perf_counter() - t0)
    return result


def _four_step_facts(report: IslandReport, first: Parametrization, parent: np.ndarray, islands: np.ndarray) -> None:
    """The four steps' facts of ``islands`` laid out by a solve that went on from ``first``'s
    layout: those of the island of ``first`` each comes from (its counts go to the first
    of its pieces, once)."""
    came = parent[islands]
    report.change[islands] = first.islands.change[came]
    report.clipped[islands] = first.islands.clipped[came]
    once = np.zeros(len(islands), dtype=bool)
    once[np.unique(came, return_index=True)[1]] = True
    report.extra_vertex[islands] = np.where(once, first.islands.extra_vertex[came], 0)
    report.regularized[islands] = np.where(once, first.islands.regularized[came], 0)


def carried_warnings(first: Parametrization, result: Parametrization) -> list[SolverWarning]:
    """``result``'s warnings, with what ``first`` (the search's first solve, or the result
    it went on from) said about the topology, extra cuts and charts in place of what
    :func:`combine` says again. An island named by ``first`` is named as the island of
    ``result`` that holds its lowest-numbered face."""
    lowest = first_rows(first.face_island, first.n_islands)
    kept = [
        replace(w, first=(int(result.face_island[lowest[w.first[0]]]),)) if w.element == "island" and w.first else w
        for w in first.warnings
        if w.kind in _DECIDED
    ]
    return kept + [w for w in result.warnings if w.kind not in _DECIDED]
