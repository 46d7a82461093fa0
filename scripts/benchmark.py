"""Solver benchmark: time per step and peak memory from 1k to 1M vertices.

Each size runs in its own subprocess (so peak RSS belongs to that size alone), warms
up once, then reports the median of ``--repeat`` runs per step. The growth exponent is
the slope of log(total time) against log(vertices) between consecutive sizes and over
the whole range.

    python scripts/benchmark.py                     # peaks grids, 1k .. 1M
    python scripts/benchmark.py --sizes 1e3 1e5 --repeat 7 --mesh s_random
    python scripts/benchmark.py --refine 100        # with refinement (at most 100 iterations)
    python scripts/benchmark.py --mesh peaks_box --sizes 1e5 --extra-cuts 4   # a closed island beside
"""

from __future__ import annotations

import argparse
import json
import resource
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent

STEPS = [
    ("topology", "topology"),
    ("local", "step 1 (local MDS)"),
    ("weights", "step 2 (weights)"),
    ("embedding.factorization", "step 3: LU"),
    ("embedding.pinned_basis", "step 3: pinned basis"),
    ("embedding.iterations", "step 3: iterations"),
    ("align", "step 4 + placement"),
    ("refine", "refinement"),
    ("extra_cuts", "extra cuts (tries + merge)"),
    ("total", "total"),
]


def make_mesh(kind: str, n_target: int):
    """Vertices, faces and the edges automatic cuts avoid (polygon diagonals, or None)."""
    from isoparam_eval import meshes as ex

    if kind == "peaks_box":  # a disk beside a closed island (the box's cut is grown by extra cuts)
        (Vp, Fp, _), (Vb, Fb, D) = make_mesh("peaks", n_target), ex.box(8)
        return np.vstack([Vp, Vb + [5.0, 0.0, 0.0]]), np.vstack([Fp, Fb + len(Vp)]), D + len(Vp)
    if kind == "peaks":
        k = max(3, int(round(np.sqrt(n_target))))
        return (*ex.peaks(k), None)
    if kind == "s_regular":
        w = max(3, int(round(np.sqrt(n_target / 4.7))))
        return (*ex.s_surface(max(3, int(round(n_target / w))), w)[:2], None)
    if kind == "s_random":
        return (*ex.s_surface_random(int(n_target), seed=0)[:2], None)
    if kind == "cylinder":  # exactly developable
        rulings = max(3, int(round(np.sqrt(n_target))))
        per = max(3, int(round(n_target / rulings)))
        return (*ex.cylinder_strips(rulings, (per, per + 1), seed=0)[:2], None)
    raise ValueError(kind)


def run_one(kind: str, n_target: int, repeat: int, refine: int = 0, extra_cuts: int = 0) -> dict:
    """Measure one size in this process and return a JSON-able dict."""
    from isoparam_addon.solver import metrics, parametrize

    V, F, inner = make_mesh(kind, n_target)
    options = dict(refine=refine, extra_cuts=extra_cuts, inner_edges=inner)
    parametrize(V, F, **options)  # warm-up: imports, page faults of a fresh process
    rows = []
    for _ in range(repeat):
        t = time.perf_counter()
        r = parametrize(V, F, **options)
        wall = time.perf_counter() - t
        rows.append(dict(r.timings, wall=wall))
    med = {k: float(np.median([row.get(k, 0.0) for row in rows])) for k in rows[0]}
    edge = metrics.edge_rms(V, F, r.corner_uv)
    return {
        "mesh": kind,
        "vertices": len(V),
        "faces": len(F),
        "repeat": repeat,
        "median": med,
        "iterations": r.stats.iterations,
        "refine_iterations": r.stats.refine_iterations,
        "edge_rms": edge,
        "flipped": int(r.flipped.sum()),
        "peak_rss_gib": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 2**20,
    }


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--mesh", default="peaks", choices=["peaks", "s_regular", "s_random", "cylinder", "peaks_box"])
    ap.add_argument("--sizes", nargs="+", type=float, default=[1e3, 1e4, 1e5, 1e6])
    ap.add_argument("--repeat", type=int, default=5, help="timed runs per size (1M uses min(repeat, 3))")
    ap.add_argument("--out", default="out/benchmark", help="folder for the markdown table and JSON")
    ap.add_argument("--refine", type=int, default=0, help="refinement iterations (0: the paper's method)")
    ap.add_argument("--extra-cuts", type=int, default=0, help="extra cuts for islands cut open automatically")
    ap.add_argument("--child", nargs=5, help=argparse.SUPPRESS)
    args = ap.parse_args(argv)
    if args.child:
        kind, n, rep, refine, extra = args.child
        print(json.dumps(run_one(kind, int(float(n)), int(rep), int(refine), int(extra))))
        return 0
    results = []
    for n in args.sizes:
        rep = args.repeat if n < 5e5 else min(args.repeat, 3)
        child = [args.mesh, str(int(n)), str(rep), str(args.refine), str(args.extra_cuts)]
        cmd = [sys.executable, __file__, "--child", *child]
        out = subprocess.run(cmd, capture_output=True, text=True, check=True)
        res = json.loads(out.stdout.strip().splitlines()[-1])
        results.append(res)
        print(
            f"{res['vertices']:>9} vertices: {res['median']['total']:.3f} s, peak {res['peak_rss_gib']:.2f} GiB",
            file=sys.stderr,
            flush=True,
        )
    header = "| step (median s) | " + " | ".join(f"{r['vertices']:,}" for r in results) + " |"
    lines = [header, "|---|" + "---|" * len(results)]
    for key, label in STEPS:
        if (key == "refine" and not args.refine) or (key == "extra_cuts" and not args.extra_cuts):
            continue
        lines.append(f"| {label} | " + " | ".join(f"{r['median'].get(key, 0.0):.3f}" for r in results) + " |")
    lines.append("| runs | " + " | ".join(str(r["repeat"]) for r in results) + " |")
    lines.append("| step-3 iterations | " + " | ".join(str(r["iterations"]) for r in results) + " |")
    if args.refine:
        lines.append("| refinement iterations | " + " | ".join(str(r["refine_iterations"]) for r in results) + " |")
    lines.append("| peak RSS (GiB) | " + " | ".join(f"{r['peak_rss_gib']:.2f}" for r in results) + " |")
    lines.append("| relative RMS edge error | " + " | ".join(f"{r['edge_rms']:.2e}" for r in results) + " |")
    lines.append("| flipped triangles | " + " | ".join(str(r["flipped"]) for r in results) + " |")
    nv = np.array([r["vertices"] for r in results], dtype=float)
    tt = np.array([r["median"]["total"] for r in results])
    growth = ""
    if len(nv) > 1:
        local = np.diff(np.log(tt)) / np.diff(np.log(nv))
        overall = np.polyfit(np.log(nv), np.log(tt), 1)[0]
        growth = (
            "growth exponent of total time: "
            + ", ".join(f"{g:.2f}" for g in local)
            + f" between consecutive sizes; {overall:.2f} fitted over all"
        )
    table = "\n".join(lines) + ("\n\n" + growth if growth else "")
    stem = args.mesh + (f"_refine{args.refine}" if args.refine else "")
    stem += f"_cuts{args.extra_cuts}" if args.extra_cuts else ""
    title = f"mesh: {args.mesh}" + (f", refine={args.refine}" if args.refine else "")
    title += f", extra_cuts={args.extra_cuts}" if args.extra_cuts else ""
    print(f"{title}\n\n{table}")
    out = ROOT / args.out
    out.mkdir(parents=True, exist_ok=True)
    (out / f"{stem}.md").write_text(f"{title}\n\n{table}\n")
    (out / f"{stem}.json").write_text(json.dumps(results, indent=1))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
