"""One solve, top to bottom: topology, the paper's four steps, refinement, placement.

Each stage is a sub-package: the topology (:mod:`.mesh`), Sun & Hancock's method
(:mod:`.steps`: :mod:`.local`, :mod:`.weights`, :mod:`.embed`, :mod:`.align`), which lays
out every island of the mesh at once, then the refinement (:mod:`.refinement`) and the
pins (:mod:`.pins`), which go beyond the paper, and the placement (:mod:`.placement`).

Two pieces of work need no weights and run beside Steps 1-3 on large meshes (SuperLU
and numpy release the GIL): Step 3's elimination plan, and the refinement's factored
proxy, which needs the plan's order.
"""

from __future__ import annotations

import time

import numpy as np

from ._parallel import background
from .geometry import edge_lengths
from .layout.pins import Pins, layout_on_pins, pins_on_islands
from .layout.placement import place
from .mesh.halfedges import unit_of
from .mesh.islands import Islands
from .mesh.topology import Topology, build_topology
from .options import Options, Problem
from .progress import stage
from .refinement.descent import Refinement, refine, unfolded
from .refinement.proxy import Proxy, quadratic_proxy
from .report import IslandReport, Stats, Timings
from .result import Parametrization, assemble
from .steps.align import fit_rotation_scale, orient
from .steps.embed import Embedding, plan_elimination, spectral_embedding
from .steps.local import local_flattening
from .steps.weights import Flagged, reconstruction_weights

__all__ = ["solve", "topology_of"]

_BACKGROUND_FROM = 20_000  # vertices; below this a second thread costs more than it saves


class _Clock:
    """Seconds per step: :meth:`lap` adds the time since the last lap to a step."""

    def __init__(self):
        self.start = self.last = time.perf_counter()
        self.timings = Timings()

    def lap(self, step: str) -> None:
        now = time.perf_counter()
        setattr(self.timings, step, getattr(self.timings, step) + now - self.last)
        self.last = now


def solve(problem: Problem, options: Options, built: tuple | None = None) -> Parametrization:
    """Parametrize ``problem`` with ``options`` (see :func:`.parametrize`); ``built``, if
    given, is what :func:`topology_of` returned for it, not built again."""
    clock = _Clock()
    with stage("topology", 0.0, 0.05):
        V, F, topo = built or topology_of(problem, options)
    unit = unit_of(V)  # work in units of a power of two near the mesh's size (exact)
    X = V[topo.vertex_of] / unit
    islands = Islands(topo.vertex_island, topo.n_islands)
    pins = None if problem.pins is None else pins_on_islands(topo, problem.pins, islands, unit, len(V))
    clock.lap("topology")
    with background(len(X) > _BACKGROUND_FROM) as worker:
        plan = worker.submit(plan_elimination, X, topo.he.edge_vertices, islands)
        if options.refine:
            proxy = worker.submit(_proxy, X, topo.faces, islands, None if pins is None else pins.shaping, plan)
        if problem.start is None:
            Y, emb, clipped, flagged = _four_steps(X, topo, islands, options, plan, clock)
        else:  # a layout to go on from (a search that cut it further): no four steps
            Y, emb, clipped, flagged = _started(problem.start / unit, topo, islands)
        plan = plan.result()
        proxy = proxy.result() if options.refine else None
        clock.lap("refine")  # waiting for the proxy, if it outlasted Step 3
    order = np.concatenate([plan.free_order, plan.anchors.ravel()])

    def refined(seed: np.ndarray, fixed: np.ndarray | None) -> Refinement:
        return refine(
            X,
            topo.faces,
            seed,
            islands,
            topo.he.twin,
            iterations=options.refine,
            tol=options.refine_tol,
            pinned=fixed,
            order=order,
            proxy=proxy,
        )

    solve_refined = refined if options.refine else None
    held = reached = None
    info = None
    with stage("refinement", 0.32, 0.97):
        if solve_refined is None and options.unfold:  # folded islands laid out again, fold-free
            info = unfolded(X, topo.faces, Y, islands, topo.he.twin, order)
            Y = info.uv
        if pins is not None:
            Y, shaped, reached, held = layout_on_pins(Y, topo.faces, islands, pins, solve_refined)
            info = shaped if shaped is not None else info
        elif solve_refined is not None:
            info = solve_refined(Y, None)
            Y = info.uv
    clock.lap("refine")
    with stage("placement", 0.97, 1.0):
        placed = place(Y, islands, pack=options.pack, margin=options.margin, held=held)
    clock.lap("placement")
    report = _island_report(islands, emb, clipped, flagged, pins, held, reached, info, unit)
    return _result(V, F, topo, placed, unit, emb, report, info, clock)


def topology_of(problem: Problem, options: Options):
    """:func:`.topology.build_topology` of ``problem``: ``(V, F, topo)``. A closed island's
    cut loops all meet at its root: never a pinned vertex if it can be helped."""
    return build_topology(
        problem.vertices,
        problem.faces,
        problem.seams,
        options.split_nonmanifold,
        problem.inner_edges,
        problem.pinned_vertices(),
    )


def _four_steps(X, topo: Topology, islands: Islands, options: Options, plan, clock: _Clock):
    """Sun & Hancock's four steps: the layout (n, 2), Step 3's embedding, the islands
    whose Step 4 scale was clipped and the vertices Step 2 flagged."""
    with stage("local flattening", 0.05, 0.1):
        patches = local_flattening(X, topo.faces, topo.fans)  # Step 1
    clock.lap("local")
    with stage("weights", 0.1, 0.15):
        L, flagged = reconstruction_weights(X, topo.faces, topo.he.twin, patches, len(X))  # Step 2
    clock.lap("weights")
    with stage("embedding", 0.15, 0.3):
        elimination = plan.result()
        emb = spectral_embedding(L, X, islands, tol=options.tol, max_iter=options.max_iter, plan=elimination)  # Step 3
    clock.lap("embedding")
    edges = topo.he.edge_vertices  # Step 4
    with stage("alignment", 0.3, 0.32):
        lengths = edge_lengths(X, edges)
        Y, _, clipped = fit_rotation_scale(emb.coords, edges, lengths, islands.label[edges[:, 0]], islands)
        Y = orient(Y, topo.faces, topo.face_island, islands)
    clock.lap("align")
    return Y, emb, clipped, flagged


def _started(corner_uv: np.ndarray, topo: Topology, islands: Islands):
    """The layout (n, 2) over the split vertices from corner UVs (m, 3, 2) given to go on
    from, and stand-ins for what the four steps would have said (nothing)."""
    # a vertex whose corners disagree (the banks of a cut glued back) starts at their mean
    corner = topo.corner_vertex.ravel()
    uv = np.asarray(corner_uv, dtype=np.float64).reshape(-1, 2)
    count = np.maximum(np.bincount(corner, minlength=len(topo.vertex_of)), 1)
    Y = np.stack([np.bincount(corner, uv[:, c], minlength=len(topo.vertex_of)) / count for c in range(2)], axis=1)
    k = islands.n
    emb = Embedding(Y, np.zeros((k, 2)), np.ones(k, dtype=bool), np.zeros(k), 0)
    none = np.zeros(0, dtype=np.int64)
    return Y, emb, np.zeros(k, dtype=bool), Flagged(none, none)


def _result(
    V, F, topo: Topology, placed, unit: float, emb: Embedding, report: IslandReport, info: Refinement | None, clock
) -> Parametrization:
    """The :class:`.Parametrization` of a solve from its layout over the split vertices,
    ``placed`` (in units of ``unit``)."""
    stats = Stats(vertices=len(V), faces=len(F), iterations=emb.iterations)
    if info is not None:
        stats.refine_iterations, stats.refine_energy = info.iterations, info.energy
    _embedding_timings(clock.timings, emb)
    result = assemble(V, F, topo, placed, unit, report, emb.eigenvalues, emb.converged, stats, clock.timings)
    clock.timings.total = time.perf_counter() - clock.start
    return result


def _proxy(X, faces, islands: Islands, pinned, plan) -> Proxy:
    """The refinement's factored proxy, in Step 3's elimination order (``plan`` is a future
    of the same one-worker pool, so it has finished when this task starts)."""
    plan = plan.result()
    return quadratic_proxy(X, faces, islands, pinned, np.concatenate([plan.free_order, plan.anchors.ravel()]))


def _island_report(
    islands: Islands,
    emb: Embedding,
    clipped,
    flagged: Flagged,
    pins: Pins | None,
    held,
    reached,
    info: Refinement | None,
    unit: float,
) -> IslandReport:
    """The per-island facts of one solve."""
    k = islands.n
    never = np.zeros(k, dtype=bool)
    return IslandReport(
        change=emb.change,
        clipped=clipped,
        extra_vertex=np.bincount(islands.label[flagged.extra_vertex], minlength=k),
        regularized=np.bincount(islands.label[flagged.regularized], minlength=k),
        held=never if held is None else held,
        one_point=never if pins is None else pins.one_point,
        pin_conflicts=np.zeros(k, dtype=np.int64)
        if pins is None
        else np.bincount(islands.label, pins.conflicts, minlength=k).astype(np.int64),
        shaped=never if pins is None else pins.shaped,
        reached=np.ones(k, dtype=bool) if reached is None else reached,
        conformal=never if info is None else info.restarted_conformal,
        tutte=never if info is None else info.restarted_tutte,
        # in mesh units: another solve of some of these islands has another unit
        refine_energy=np.zeros(k) if info is None else _squared(info.island_energy, unit),
        refine_area=np.zeros(k) if info is None else _squared(info.island_area, unit),
        crossings=np.zeros(k, dtype=np.int64),  # (measured on the layout placed)
    )


def _squared(x: np.ndarray, unit: float) -> np.ndarray:
    """Areas (and energies, which scale as areas) in mesh units: inf beyond float range."""
    with np.errstate(over="ignore"):
        return x * unit * unit


def _embedding_timings(timings: Timings, emb: Embedding) -> None:
    timings.embedding_ordering = emb.timings.ordering
    timings.embedding_factorization = emb.timings.factorization
    timings.embedding_pinned_basis = emb.timings.pinned_basis
    timings.embedding_iterations = emb.timings.iterations
