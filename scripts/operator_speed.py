"""Isometric Unwrap beside Blender's unwraps, end to end through the operators, in one process.

Cases: every mesh of ``../shared/meshes`` with the seams of Smart UV Project's islands
(spot: its artist's seams), and a 100k-vertex peaks surface as one island. Each method
runs on a fresh copy of the mesh in edit mode; the runs are interleaved (isoparam,
CONFORMAL, ANGLE_BASED, MINIMUM_STRETCH, isoparam, ...) so that the machine's drift
touches every method alike; the table has the median of ``--repeat`` runs, isoparam's
ratio against CONFORMAL and ANGLE_BASED, and where isoparam's time went (mesh reading,
the solver's steps, writing, Blender's pack). A PNG plots time against vertex count.
MINIMUM_STRETCH (SLIM, ~100 s a run at 100k) runs above 50k vertices only with ``--slow``.

    bash scripts/bench.sh scripts/operator_speed.py                    # every case, 3 runs
    bash scripts/bench.sh scripts/operator_speed.py --cases homer peaks100k --repeat 5
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import numpy as np

from isoparam_eval import meshes as ex
from isoparam_eval.blender import METHODS, add_mesh, bpy, edit, smart_uv_seams

ROOT = Path(__file__).resolve().parent.parent
BLENDER = ["CONFORMAL", "ANGLE_BASED", "MINIMUM_STRETCH"]
CASES = [*ex.REAL, "peaks100k"]


def case(name: str):
    """(V, F, seams, what the seams are) of a benchmark case."""
    if name == "peaks100k":
        V, F = ex.peaks(317)
        return V, F, None, "none (one island)"
    V, F, artist = ex.real_mesh(name)
    if name == "spot" and artist is not None and len(artist):
        return V, F, artist, "artist's"
    return V, F, smart_uv_seams(V, F), "Smart UV"


def timed(method: str, V, F, seams):
    """Seconds of one operator call on a fresh mesh, and for isoparam where they went (the
    :class:`~isoparam_addon.blender.record.RunRecord` the operator left)."""
    bpy.ops.wm.read_homefile(use_empty=True)
    ob = add_mesh("m", V, F, seams)
    edit(ob)
    t = time.perf_counter()
    METHODS[method]()
    seconds = time.perf_counter() - t
    if method != "isoparam":
        return seconds, None
    from isoparam_addon.blender.record import last_record

    return seconds, last_record(bpy.context)


def breakdown(runs) -> str:
    """Median seconds of the parts of isoparam's runs: read, topology, steps 1-4,
    refinement, charts and overlap cuts, placement, write, pack."""

    def med(f):
        return float(np.median([f(r) for r in runs]))

    def solver(field):
        return med(lambda r: sum(getattr(t, field) for t in r.solver))

    steps = med(lambda r: sum(t.local + t.weights + t.embedding + t.align for t in r.solver))
    cuts = med(lambda r: sum(t.charts + t.untangle + t.extra_cuts for t in r.solver))
    other = med(lambda r: r.solve - sum(t.total for t in r.solver))  # the operator's own solve-side work
    return (
        f"{med(lambda r: r.read):.3f} | {solver('topology'):.3f} | {steps:.3f} | {solver('refine'):.3f} | "
        f"{cuts:.3f} | {solver('placement') + other:.3f} | {med(lambda r: r.write):.3f} | {med(lambda r: r.pack):.3f}"
    )


def plot(rows, path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(7, 4.5))
    for method, marker in zip(["isoparam", *BLENDER], "o^sD"):
        pts = sorted((r["vertices"], r["times"][method]) for r in rows if r["times"][method] == r["times"][method])
        ax.plot(*zip(*pts), marker=marker, linestyle="none", label=method)
    for r in rows:
        ax.annotate(
            r["name"], (r["vertices"], r["times"]["isoparam"]), fontsize=7, xytext=(4, 4), textcoords="offset points"
        )
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_xlabel("vertices")
    ax.set_ylabel("operator seconds (median)")
    ax.set_title("Unwrap end to end (Smart UV seams; spot: its seams; peaks: one island)")
    ax.legend()
    ax.grid(True, which="both", alpha=0.3)
    fig.tight_layout()
    fig.savefig(path, dpi=110)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--cases", nargs="+", default=CASES, choices=CASES)
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--slow", action="store_true", help="run MINIMUM_STRETCH above 50k vertices too (~100 s a run)")
    ap.add_argument("--png", type=Path, default=ROOT / "docs" / "img" / "operator_speed.png")
    args = ap.parse_args(argv)
    import isoparam_addon

    isoparam_addon.register()
    methods = ["isoparam", *BLENDER]
    print(
        "| mesh | seams | vertices | isoparam s | CONFORMAL s | ANGLE_BASED s | MINIMUM_STRETCH s | "
        "isoparam / CONFORMAL | isoparam / ANGLE_BASED | read | topology | steps 1-4 | refine | "
        "charts + overlap cuts | placement | write | pack |"
    )
    print("|" + "---|" * 17)
    rows = []
    for name in args.cases:
        V, F, seams, kind = case(name)
        here = [m for m in methods if args.slow or m != "MINIMUM_STRETCH" or len(V) <= 50_000]
        for method in here:  # warm-up: imports, caches
            timed(method, V, F, seams)
        times = {m: [float("nan")] for m in methods}
        times.update({m: [] for m in here})
        runs = []
        for _ in range(args.repeat):  # interleaved
            for method in here:
                seconds, run = timed(method, V, F, seams)
                times[method].append(seconds)
                if run is not None:
                    runs.append(run)
        med = {m: float(np.median(t)) for m, t in times.items()}
        rows.append(dict(name=name, vertices=len(V), times=med))
        print(
            f"| {name} | {kind} | {len(V):,} | {med['isoparam']:.3f} | {med['CONFORMAL']:.3f} | "
            f"{med['ANGLE_BASED']:.3f} | {med['MINIMUM_STRETCH']:.3f} | {med['isoparam'] / med['CONFORMAL']:.2f} | "
            f"{med['isoparam'] / med['ANGLE_BASED']:.2f} | {breakdown(runs)} |",
            flush=True,
        )
    args.png.parent.mkdir(parents=True, exist_ok=True)
    plot(rows, args.png)
    print(f"\n{args.repeat} interleaved runs per method, median; plot: {args.png}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
