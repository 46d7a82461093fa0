"""Minimum cuts (solver/charting/mincut.py): a large flow runs coarse, then in a band along the
coarse cut, and finds the cut the whole flow finds."""

import numpy as np
import pytest

from isoparam_addon.solver.charting import mincut
from isoparam_eval import meshes as ex


def _cost(graph, side) -> float:
    return float(graph.cost[side[graph.f] != side[graph.g]].sum())


def _separates(graph, side, source, sink) -> bool:
    joined = mincut._joined(graph, side[graph.f] == side[graph.g], source)
    return bool(joined[source].all() and not joined[sink].any())


def test_a_large_flow_runs_coarse_then_in_a_band_and_finds_the_same_cut(monkeypatch):
    V, F = ex.peaks(100, z_scale=2.0)  # 19,602 faces: two discs far apart on a bumpy sheet
    graph = mincut.face_graph(V, F, np.zeros(len(F), dtype=np.int64), np.zeros((0, 2), dtype=np.int64))
    xy = graph.centroids[:, :2]
    lo, span = xy.min(axis=0), np.ptp(xy, axis=0)
    source = np.linalg.norm(xy - (lo + 0.2 * span), axis=1) < 0.1 * span[0]
    sink = np.linalg.norm(xy - (lo + 0.8 * span), axis=1) < 0.1 * span[0]
    whole = mincut._flow_side(graph, source, sink)  # (under _COARSE_FROM: one flow)
    banded = []
    original = mincut._banded_side
    monkeypatch.setattr(mincut, "_banded_side", lambda *a: banded.append(original(*a)) or banded[-1])
    monkeypatch.setattr(mincut, "_COARSE_FROM", 1000)
    side = mincut._flow_side(graph, source, sink)
    assert len(banded) == 1 and banded[0] is not None  # it ran coarse, then in the band
    assert _separates(graph, side, source, sink) and _separates(graph, whole, source, sink)
    assert _cost(graph, side) == pytest.approx(_cost(graph, whole), rel=1e-9)
    # and through the public search, region and all
    assert (mincut.source_side(graph, source, sink) == side).sum() > 0.99 * len(side)


def test_a_flow_over_a_narrowed_graph_runs_on_the_faces_its_edges_touch(monkeypatch):
    """A graph narrowed to a band keeps every face; the source and sink faces beyond the
    band take no part in the flow (each of Dinic's phases would visit them), and land on
    their own side: the same cut as the flow over the band's faces alone."""
    V, F = ex.peaks(40)
    graph = mincut.face_graph(V, F, np.zeros(len(F), dtype=np.int64), np.zeros((0, 2), dtype=np.int64))
    x = graph.centroids[:, 0]
    lo, hi = np.quantile(x, [0.4, 0.6])
    band = (x > lo) & (x < hi)
    narrowed = graph.among(band)
    source, sink = x < 0.5 * (lo + hi) - 0.05 * (hi - lo), x > 0.5 * (lo + hi) + 0.05 * (hi - lo)
    sizes = []
    flow = mincut.csgraph.maximum_flow
    monkeypatch.setattr(mincut.csgraph, "maximum_flow", lambda g, s, t: sizes.append(g.shape[0]) or flow(g, s, t))
    side = mincut._exact_side(narrowed, source, sink)
    # the band's faces that an edge joins to a face not on its own side, the source and the sink
    held = (source[narrowed.f] & source[narrowed.g]) | (sink[narrowed.f] & sink[narrowed.g])
    touched = np.zeros(len(F), dtype=bool)
    touched[narrowed.f[~held]] = touched[narrowed.g[~held]] = True
    assert sizes == [int(touched.sum()) + 2] and touched.sum() < band.sum()
    assert side[source & ~band].all() and not side[sink & ~band].any()
    # the band alone, renumbered, cut the same way
    index = np.cumsum(band) - 1
    alone = mincut.FaceGraph(index[narrowed.f], index[narrowed.g], narrowed.edges, narrowed.cost, graph.centroids[band])
    assert np.array_equal(side[band], mincut._exact_side(alone, source[band], sink[band]))
    assert _separates(narrowed, side, source & band, sink & band)
    assert 0 < side[band].sum() < band.sum()


def test_each_island_is_cut_in_its_own_region(monkeypatch):
    """Two islands in one graph, one to be cut between two discs, one between its two ends:
    the first region around the ends spans their island and separates them, the one
    around the discs must grow. The flows after the first run over the discs' island
    alone, and (the two alike, so that the costs scale the same) each island is cut as
    it is alone."""
    V, F = ex.peaks(50, z_scale=0.5)
    m = len(F)
    both_V, both_F = np.vstack([V, V + [100.0, 0.0, 0.0]]), np.vstack([F, F + len(V)])
    island = np.repeat([0, 1], m)
    graph = mincut.face_graph(both_V, both_F, island, np.zeros((0, 2), dtype=np.int64))
    xy = graph.centroids[:, :2] - [[100.0, 0.0]] * island[:, None]
    lo, span = xy.min(axis=0), np.ptp(xy, axis=0)
    discs = (island == 0) & (np.linalg.norm(xy - (lo + 0.3 * span), axis=1) < 0.1 * span[0])
    sink_discs = (island == 0) & (np.linalg.norm(xy - (lo + 0.7 * span), axis=1) < 0.1 * span[0])
    ends = (island == 1) & (xy[:, 0] < lo[0] + 0.05 * span[0])
    sink_ends = (island == 1) & (xy[:, 0] > lo[0] + 0.95 * span[0])
    source, sink = discs | ends, sink_discs | sink_ends
    flows = []
    flow_side = mincut._flow_side
    monkeypatch.setattr(mincut, "_flow_side", lambda g, s, t: flows.append((g.f, g.g)) or flow_side(g, s, t))
    side = mincut.source_side(graph, source, sink)
    assert len(flows) > 1 and all((island[f] == 0).all() and (island[g] == 0).all() for f, g in flows[1:])
    assert _separates(graph, side, source, sink)
    for k in (0, 1):
        mine = island == k
        index = np.cumsum(mine) - 1
        alone = graph.among(mine)
        alone = mincut.FaceGraph(index[alone.f], index[alone.g], alone.edges, alone.cost, graph.centroids[mine])
        assert np.array_equal(side[mine], mincut.source_side(alone, source[mine], sink[mine])), k


def _flow_over_every_edge(graph, source, sink) -> np.ndarray:
    """The faces the source reaches in the residual graph of one maximum flow over every
    edge of ``graph`` (capacities as :func:`mincut._exact_side` scales them)."""
    m = graph.n_faces
    typical = float(np.median(graph.cost))
    capacity = 1 + np.minimum(np.round(mincut._UNITS * graph.cost / typical), 1e6).astype(np.int64)
    big = int(min(capacity.sum() + 1, 1 << 30))
    S, T = m, m + 1
    rows = np.concatenate([graph.f, graph.g, np.full(source.sum(), S), np.flatnonzero(sink)])
    cols = np.concatenate([graph.g, graph.f, np.flatnonzero(source), np.full(sink.sum(), T)])
    caps = np.concatenate([capacity, capacity, np.full(source.sum(), big), np.full(sink.sum(), big)])
    G = mincut.sp.csr_matrix((caps.astype(np.int32), (rows, cols)), shape=(m + 2, m + 2))
    residual = (G - mincut.csgraph.maximum_flow(G, S, T).flow).tocsr()
    residual.data = (residual.data > 0).astype(np.int8)
    residual.eliminate_zeros()
    side = np.zeros(m + 2, dtype=bool)
    side[mincut.csgraph.breadth_first_order(residual, S, directed=True, return_predecessors=False)] = True
    return side[:m]


@pytest.mark.parametrize("layout", ["cells", "balls", "strips"])
def test_a_flow_leaves_out_the_joins_within_its_source_or_its_sink(layout):
    """No minimum cut crosses an edge between two source faces or two sink faces, so the
    flow runs without them (over the faces between the two sets only) and the source
    reaches the same faces as a flow over every edge."""
    V, F = ex.peaks(50, z_scale=1.5)
    graph = mincut.face_graph(V, F, np.zeros(len(F), dtype=np.int64), np.zeros((0, 2), dtype=np.int64))
    xy = graph.centroids[:, :2]
    lo, span = xy.min(axis=0), np.ptp(xy, axis=0)
    u, v = ((xy - lo) / span).T
    if layout == "cells":  # two cores, a band between them (the cells' boundaries)
        source, sink = u < 0.45, u > 0.55
    elif layout == "balls":  # two discs (a cut between the most squeezed and stretched places)
        source = np.hypot(u - 0.3, v - 0.4) < 0.15
        sink = np.hypot(u - 0.7, v - 0.6) < 0.15
    else:  # interleaved strips: many separate parts on each side
        source, sink = (np.floor(8 * u) % 2 == 0) & (v < 0.8), (np.floor(8 * u) % 2 == 1) & (v < 0.8)
        source &= (8 * u) % 1 < 0.6
        sink &= (8 * u) % 1 > 0.4
    side = mincut._exact_side(graph, source, sink)
    assert np.array_equal(side, _flow_over_every_edge(graph, source, sink))
    assert side[source].all() and not side[sink].any()
