"""isoparam's refinement against libigl's SLIM on the same cut, on real meshes.

For every mesh (no seams: every closed or holed part is cut open by isoparam, into charts
unless ``--no-charts``), the solver runs with the operator's defaults; then libigl's SLIM
(Rabinovich et al. 2017, symmetric Dirichlet) runs on exactly the islands isoparam
returned, each from its Tutte embedding, to convergence (at most ``--slim-iterations``,
stopping when an iteration lowers the energy by less than ``--slim-tol``, relative).
Distortion is measured per island at each
island's best scale (solver.metrics.per_island). Times are medians of ``--repeat`` runs;
SLIM's includes its precomputation, not the energy evaluations of the stopping test.

``--noise`` also solves the input multiplied by (1 + 1e-12 noise) and reports how much the
symmetric Dirichlet energy moved.

libigl is a benchmark-only dependency (``pip install libigl``), never the add-on's:

    python scripts/refinement_vs_slim.py                       # every mesh of ../shared/meshes and Suzanne
    python scripts/refinement_vs_slim.py --meshes spot homer --no-charts --extra-cuts 0 --noise
"""

from __future__ import annotations

import argparse
import time
from dataclasses import replace

import numpy as np

from isoparam_addon.operation.options import DEFAULTS
from isoparam_addon.solver import metrics, parametrize
from isoparam_addon.solver.mesh.islands import Islands
from isoparam_addon.solver.mesh.topology import build_topology
from isoparam_addon.solver.refinement.per_face import FaceFrames, layout_energy
from isoparam_eval import meshes as ex


def slim_on_islands(V, F, cut_edges, iterations: int, tol: float):
    """SLIM on every island of the mesh cut along ``cut_edges``: corner UVs (m, 3, 2), the
    seconds SLIM took (precomputation and iterations), and its largest iteration count."""
    import igl

    _, _, topo = build_topology(V, F, cut_edges, True)
    X = V[topo.vertex_of]
    out = np.zeros((len(F), 3, 2))
    seconds, most = 0.0, 0
    order = np.argsort(topo.face_island, kind="stable")
    starts = np.searchsorted(topo.face_island[order], np.arange(topo.n_islands + 1))
    for i in range(topo.n_islands):  # SLIM takes one disk at a time (evaluation code)
        f = order[starts[i] : starts[i + 1]]
        used, local = np.unique(topo.faces[f], return_inverse=True)
        Fl = local.reshape(-1, 3).astype(np.int32)
        Xi = np.asfortranarray(X[used])
        frames = FaceFrames(Xi, Fl.astype(np.int64))
        t0 = time.perf_counter()
        bnd = igl.boundary_loop(Fl)
        uv = igl.harmonic(Xi, Fl, bnd, igl.map_vertices_to_circle(Xi, bnd), 1)
        data = igl.slim_precompute(
            Xi, Fl, np.asfortranarray(uv), igl.SYMMETRIC_DIRICHLET, np.zeros(0, np.int32), np.zeros((0, 2)), 0.0
        )
        seconds += time.perf_counter() - t0
        last, k = np.inf, 0
        for k in range(iterations):  # noqa: B007 - SLIM's iterations, one call each to test convergence
            t0 = time.perf_counter()
            uv = igl.slim_solve(data, 1)
            seconds += time.perf_counter() - t0
            e = _energy(frames, uv[:, :2])
            if last - e < tol * e:
                break
            last = e
        most = max(most, k + 1)
        out[f] = uv[:, :2][np.searchsorted(used, topo.corner_vertex[f])]
    return out, seconds, most


def _energy(frames: FaceFrames, uv) -> float:
    """The island's symmetric Dirichlet energy per unit area (inf if a face folds)."""
    one_island = Islands.labelled(np.zeros(len(frames.area), dtype=np.int64), 1)
    return float(layout_energy(frames, one_island, uv)[0] / frames.area.sum())


def load(name: str):
    if name == "suzanne":
        return ex.suzanne_closed()
    V, F, _ = ex.real_mesh(name)
    return V, F


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--meshes", nargs="+", default=[*ex.REAL, "suzanne"])
    ap.add_argument(
        "--refine", type=int, default=DEFAULTS.refine, help="the refinement's iteration cap (the operator's default)"
    )
    ap.add_argument("--extra-cuts", type=int, default=DEFAULTS.extra_cuts, help="with --no-charts")
    ap.add_argument("--no-charts", action="store_true", help="one island per part, opened by its shortest cut")
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--slim-iterations", type=int, default=200)
    ap.add_argument("--slim-tol", type=float, default=1e-6)
    ap.add_argument("--noise", action="store_true", help="also solve the input times (1 + 1e-12 noise)")
    args = ap.parse_args(argv)
    print(
        "| mesh | vertices | islands | isoparam SD | SLIM SD | SD / SLIM | isoparam s | SLIM s | SLIM / isoparam "
        "| refine iterations | SLIM iterations | flips | Linf |" + (" noise: SD change |" if args.noise else "")
    )
    print("|---" * (13 + args.noise) + "|")
    for name in args.meshes:
        V, F = load(name)
        options = replace(
            DEFAULTS.solver_options(), refine=args.refine, extra_cuts=args.extra_cuts, charts=not args.no_charts
        )
        solve = lambda V=V, F=F, options=options: parametrize(V, F, options=options)  # noqa: E731
        times, r = [], None
        for _ in range(args.repeat):  # timed solves
            t0 = time.perf_counter()
            r = solve()
            times.append(time.perf_counter() - t0)
        assert r is not None
        ours = metrics.per_island(r.vertices, r.faces, r.corner_uv, r.face_island)
        slim_uv, slim_s, slim_its = slim_on_islands(
            r.vertices, r.faces, r.cut_edges, args.slim_iterations, args.slim_tol
        )
        theirs = metrics.per_island(r.vertices, r.faces, slim_uv, r.face_island)
        t = float(np.median(times))
        row = (
            f"| {name} | {len(V):,} | {r.n_islands} | {ours.mean_symmetric_dirichlet:.4f} | "
            f"{theirs.mean_symmetric_dirichlet:.4f} | "
            f"{ours.mean_symmetric_dirichlet / theirs.mean_symmetric_dirichlet:.4f} "
            f"| {t:.2f} | {slim_s:.2f} | {slim_s / t:.1f} | {r.stats.refine_iterations} | {slim_its} | "
            f"{int(r.flipped.sum())} | {ours.worst_stretch:.2f} |"
        )
        if args.noise:
            rng = np.random.default_rng(0)
            noisy = parametrize(V * (1 + 1e-12 * rng.standard_normal(V.shape)), F, options=options)
            e = metrics.per_island(noisy.vertices, noisy.faces, noisy.corner_uv, noisy.face_island)
            row += f" {abs(e.mean_symmetric_dirichlet / ours.mean_symmetric_dirichlet - 1):.1e} |"
        print(row, flush=True)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
