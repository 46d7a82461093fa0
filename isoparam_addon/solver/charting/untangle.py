"""Beyond the paper: islands that overlap themselves are cut where their overlapping parts
are least apart.

An island laid out near-isometrically can fold over its own boundary (a strip that winds
more than a turn, an island with a hole opened by a slit): two places of the model then
share texels. No flip shows it; :mod:`.overlap` finds it exactly. Here every such island
is cut in two by the shortest seam that separates its overlapping layers: a minimum cut
(:mod:`.mincut`) between the two sides of the island, the faces clearly nearer to the one
or to the other layer of its largest overlap. The two parts
are solved again, alone (:func:`.resolve.solve_islands`), and put back
(:func:`.resolve.combine`); parts that still overlap are cut again, a few rounds at most.
All overlapping islands are cut in one flow problem: they are disconnected, so one flow
separates each.
"""

from __future__ import annotations

import time

import numpy as np
import scipy.sparse as sp
from scipy.sparse import csgraph

from ..errors import counted
from ..mesh.islands import first_rows
from ..options import Options, Problem
from ..progress import geometric, stage
from ..report import SolverWarning, WarningKind, warning
from ..result import Parametrization
from .mincut import FaceGraph, face_graph, minimum_cut, without_chips
from .resolve import carried_warnings, cut_further, pairs

__all__ = ["cut_apart", "separating_cuts", "without_overlaps"]

_ROUNDS = 6  # cut, solve again, check: at most this many times
_BAND = 0.5  # a face twice as near to one layer as to the other is on its side of the cut


def without_overlaps(first: Parametrization, problem: Problem, options: Options) -> Parametrization:
    """``first`` with every island that overlaps itself cut in two and solved again, until
    none does or ``_ROUNDS`` rounds have been tried (what is left is warned about)."""
    result = first
    t0 = time.perf_counter()
    for k in range(1, _ROUNDS + 1):  # a handful of rounds, each one solve of the islands cut
        bad = np.flatnonzero(result.islands.crossings > 0)
        if not bad.size:
            break
        new = separating_cuts(result, problem, bad, every_group=True)
        if not len(new):
            break
        with stage(f"round {k}" if k > 1 else "", *geometric(k)):
            result = cut_further(result, problem, new, bad, options)
        result.stats.overlap_cuts += len(new)
    if result is not first:
        whose = first.face_island[first_rows(result.face_island, result.n_islands)]  # each piece's island
        apart = np.flatnonzero(np.bincount(whose, minlength=first.n_islands) > 1)
        pieces = result.face_island[first_rows(first.face_island, first.n_islands)[apart]]
        result.warnings = carried_warnings(first, result) + cut_apart(pieces)
    result.timings.untangle = first.timings.untangle + time.perf_counter() - t0
    result.timings.total = first.timings.total + result.timings.untangle
    return result


def separating_cuts(
    result: Parametrization,
    problem: Problem,
    bad: np.ndarray,
    graph: FaceGraph | None = None,
    every_group: bool = False,
) -> np.ndarray:
    """For every island in ``bad`` (those of ``result`` that overlap themselves), the mesh
    edges (k, 2 vertex pairs) of the shortest cut between the two layers of its largest
    overlap (``result.cut_edges`` and the problem's seams are cut already; ``graph``, if
    given, is their :func:`.mincut.face_graph`).

    ``every_group``: between the layers of every group of overlaps, with the pieces that
    hold no group's largest overlap left cut off. The repair after a solve
    (:func:`without_overlaps`) parts them so in one round where one group per round, its
    chips joined back, takes a round per group (8 rounds on the bunny's Smart UV islands,
    against 2); charting's check parts one group per round, so that no chart is chipped."""
    mine = np.isin(result.face_island, bad)
    if graph is None:  # (of the islands in question alone)
        seams = np.vstack([pairs(problem.seams), result.cut_edges])
        faces = np.flatnonzero(mine)
        graph = face_graph(result.vertices, result.faces, result.face_island, seams, problem.inner_edges, faces)
    graph = graph.among(mine)
    found = result.overlaps(bad)
    i, j = found.pairs
    if not len(i):
        return np.zeros((0, 2), dtype=np.int64)
    m = len(result.faces)
    # the two faces of an overlap lie in different layers of the island: colour the faces
    # of every group of overlaps (the pairs linked through shared faces) by the parity of
    # their distance from the group's largest overlap, and cut between the two colours
    area = found.pair_area
    pair_graph = sp.coo_matrix((np.ones(len(i)), (i, j)), shape=(m, m)).tocsr()
    group = csgraph.connected_components(pair_graph, directed=False)[1][i]
    if every_group:
        return _between_layers(graph, i, j, area, group, m, chips=True)
    # per island, its largest group of overlaps alone (by area): a small group beside it
    # would be parted by a cut round a few faces; it is parted in a round of its own
    island = result.face_island[i]
    group_area = np.bincount(group, area)
    order = np.lexsort((group, -group_area[group], island))
    largest = group[order[np.unique(island[order], return_index=True)[1]]]
    mine = np.isin(group, largest)
    return _between_layers(graph, i[mine], j[mine], area[mine], group[mine], m, chips=False)


def _between_layers(graph: FaceGraph, i, j, area, group, m: int, chips: bool) -> np.ndarray:
    """The cut between the two layers of every ``group`` of overlapping face pairs ``i``,
    ``j`` (each of ``area``): the faces coloured by the parity of their distance (in
    overlaps) from the group's largest overlap. ``chips``: pieces that hold no largest
    overlap's face are left cut off (else they join a neighbour, :func:`.mincut.without_chips`)."""
    pair_graph = sp.coo_matrix((np.ones(len(i)), (i, j)), shape=(m, m)).tocsr()
    order = np.lexsort((-area, group))
    best = order[np.unique(group[order], return_index=True)[1]]  # each group's largest overlap
    hops = csgraph.dijkstra(pair_graph, directed=False, unweighted=True, indices=i[best], min_only=True)
    reached = np.isfinite(hops)
    parity = np.where(reached, hops, 0).astype(np.int64) % 2
    source, sink = _sides(graph, reached & (parity == 0), reached & (parity == 1))
    # each side whole: a face of one side cut off inside the other would be a chip
    source, sink = _holding(graph, source, i[best]), _holding(graph, sink, j[best])
    cut = minimum_cut(graph, source, sink)
    return cut if chips else without_chips(graph, cut, np.concatenate([i[best], j[best]]))


def _holding(graph: FaceGraph, faces: np.ndarray, seeds: np.ndarray) -> np.ndarray:
    """The faces (m,) bool of ``faces`` joined to one of ``seeds`` (k,) through ``faces``."""
    keep = faces[graph.f] & faces[graph.g]
    m = graph.n_faces
    G = sp.coo_matrix((np.ones(int(keep.sum()), dtype=np.int8), (graph.f[keep], graph.g[keep])), shape=(m, m))
    _, label = csgraph.connected_components(G, directed=False)
    return faces & np.isin(label, label[seeds[faces[seeds]]])


def _sides(graph: FaceGraph, layer: np.ndarray, other: np.ndarray):
    """The faces (m,) bool on the side of one layer (over the surface, at most ``1 -
    _BAND`` times as far from it as from the other), and those on the other's side: the
    cut goes between, where a face is about as near to both.

    Between the layers' faces alone, the cheapest cut would often go round the smaller
    set: where the banks of a cut touch near its end, it chips those few faces off, the
    rest closes onto itself a little further on, and so on for every round. Between the
    two sides of the island the cut parts it where the layers part."""
    G = graph.distances()
    near = csgraph.dijkstra(G, directed=False, indices=np.flatnonzero(layer), min_only=True)
    far = csgraph.dijkstra(G, directed=False, indices=np.flatnonzero(other), min_only=True)
    return layer | (near < (1.0 - _BAND) * far), other | (far < (1.0 - _BAND) * near)


def cut_apart(pieces: np.ndarray) -> list[SolverWarning]:
    """The note on the islands that overlapped themselves and were cut apart
    (:func:`without_overlaps`): ``pieces`` (k,) int64, per such island the result's island that
    holds its lowest-numbered face."""
    n = len(pieces)
    if not n:
        return []
    template = (
        f"{counted(n, 'island', 'islands')} overlapped {'itself' if n == 1 else 'themselves'} in UV space and "
        f"{'was' if n == 1 else 'were'} cut apart (first: {{first}})"
    )
    return [warning(WarningKind.CUT_APART, n, "island", pieces[0], template)]
