"""Time and memory against size, no seams: the bunny split 4-to-1 zero, one and two times
(1x, 4x, 16x faces) and the paper's surface at 1000 x 1000 (1M vertices), Isometric Unwrap
(the operator, default options) beside Blender's Angle Based and xatlas.

Every run is a process of its own, so that its peak memory (the resident set's high-water
mark, ``ru_maxrss``) is its own; "memory" is that peak less the process's resident size
once the mesh was built, just before the method ran: what the method added at most (an
earlier peak, bpy's start or the mesh's making, counts where the method stays below it).
Runs go size by size; ``--repeat`` runs each (median). Every row measured is kept in
``--store`` (a long series can be run a piece at a time; ``--again`` measures anew); the
table and a PNG (seconds and memory against faces) show every row kept. Angle Based and
xatlas run up to ``--others-faces`` (Angle Based took 347 s at 278k faces).

    bash scripts/bench.sh scripts/scaling.py                      # 1x, 4x, 16x (the others to 4x)
    bash scripts/bench.sh scripts/scaling.py --cases bunny1 bunny4 --methods isoparam ANGLE_BASED
    bash scripts/bench.sh scripts/scaling.py --cases peaks1000 --methods isoparam
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
CASES = ["bunny1", "bunny4", "bunny16", "peaks1000"]
METHODS = ["isoparam", "ANGLE_BASED", "xatlas"]


def split(V: np.ndarray, F: np.ndarray):
    """Every triangle split in four at its edges' midpoints (the surface unchanged)."""
    e = np.sort(np.concatenate([F[:, [0, 1]], F[:, [1, 2]], F[:, [2, 0]]]), axis=1)
    n, m = len(V), len(F)
    key, inv = np.unique(e[:, 0] * n + e[:, 1], return_inverse=True)
    a, b, c = (n + inv.ravel()[k * m : (k + 1) * m] for k in range(3))
    corners = [(F[:, 0], a, c), (a, F[:, 1], b), (c, b, F[:, 2]), (a, b, c)]
    F2 = np.concatenate([np.stack(t, axis=1) for t in corners])
    return np.vstack([V, (V[key // n] + V[key % n]) / 2.0]), F2


def mesh(case: str):
    from isoparam_eval import meshes as ex

    if case == "peaks1000":
        return ex.peaks(1000)
    V, F, _ = ex.real_mesh("stanford-bunny")
    for _ in range({"bunny1": 0, "bunny4": 1, "bunny16": 2}[case]):
        V, F = split(V, F)
    return V, F


def _peak_mb() -> float:
    """The process's peak resident set so far (MB)."""
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0  # (kilobytes on Linux)


def _resident_mb() -> float:
    """The process's resident set now (MB; Linux's /proc, else the peak so far)."""
    try:
        for line in Path("/proc/self/status").read_text().splitlines():
            if line.startswith("VmRSS:"):
                return float(line.split()[1]) / 1024.0
    except OSError:
        pass
    return _peak_mb()


def child(case: str, method: str) -> dict:
    """One run of ``method`` on ``case`` in this process: seconds, peak memory added (MB)."""
    V, F = mesh(case)
    if method == "xatlas":
        import xatlas

        before = _resident_mb()
        t = time.perf_counter()
        xatlas.parametrize(V.astype(np.float32), F.astype(np.uint32))
    else:
        from isoparam_eval.blender import METHODS as RUN
        from isoparam_eval.blender import add_mesh, bpy, edit

        if method == "isoparam":
            import isoparam_addon

            isoparam_addon.register()
        bpy.ops.wm.read_homefile(use_empty=True)
        edit(add_mesh("m", V, F))
        before = _resident_mb()
        t = time.perf_counter()
        RUN[method]()
    seconds = time.perf_counter() - t
    return dict(seconds=seconds, memory=_peak_mb() - before, vertices=len(V), faces=len(F))


def plot(rows: list[dict], path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, 2, figsize=(11, 4.2))
    for method, marker in zip(METHODS, "o^s"):
        pts = sorted((r["faces"], r["seconds"], r["memory"]) for r in rows if r["method"] == method)
        if not pts:
            continue
        f, s, mem = zip(*pts)
        axes[0].plot(f, s, marker=marker, label=method)
        axes[1].plot(f, mem, marker=marker, label=method)
    for ax, label in zip(axes, ["seconds", "peak memory added (MB)"]):
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.set_xlabel("faces")
        ax.set_ylabel(label)
        ax.grid(True, which="both", alpha=0.3)
        ax.legend()
    axes[0].set_title("No seams: time against size")
    axes[1].set_title("... and memory")
    fig.tight_layout()
    fig.savefig(path, dpi=110)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--cases", nargs="+", default=CASES[:3], choices=CASES)
    ap.add_argument("--methods", nargs="+", default=METHODS, choices=METHODS)
    ap.add_argument("--repeat", type=int, default=1)
    ap.add_argument("--others-faces", type=int, default=300_000, help="Angle Based and xatlas up to this many faces")
    ap.add_argument("--store", type=Path, default=ROOT / "out" / "scaling.json", help="rows kept from run to run")
    ap.add_argument("--again", action="store_true", help="measure again what the store holds")
    ap.add_argument("--png", type=Path, default=ROOT / "docs" / "img" / "scaling.png")
    ap.add_argument("--child", nargs=2, metavar=("CASE", "METHOD"), help=argparse.SUPPRESS)
    args = ap.parse_args(argv)
    if args.child:
        print(json.dumps(child(*args.child)))
        return 0
    # every row measured is kept, so that a long series can be run a piece at a time
    stored = json.loads(args.store.read_text()) if args.store.exists() else []
    rows = [r for r in stored if not (args.again and r["case"] in args.cases and r["method"] in args.methods)]
    for case in args.cases:
        for method in args.methods:
            if method != "isoparam" and len(mesh(case)[1]) > args.others_faces:
                continue
            if any(r["case"] == case and r["method"] == method for r in rows):
                continue
            runs = []
            for _ in range(args.repeat):
                done = subprocess.run(
                    [sys.executable, __file__, "--child", case, method], capture_output=True, text=True, cwd=ROOT
                )
                if done.returncode != 0:
                    print(f"{case} {method}: exit {done.returncode}\n{done.stderr[-2000:]}", file=sys.stderr)
                    return 1
                runs.append(json.loads(done.stdout.strip().splitlines()[-1]))
            r = dict(runs[0], seconds=float(np.median([x["seconds"] for x in runs])), method=method, case=case)
            r["memory"] = float(np.median([x["memory"] for x in runs]))
            rows.append(r)
            args.store.parent.mkdir(parents=True, exist_ok=True)
            args.store.write_text(json.dumps(rows, indent=1))
            print(f"{case} {method}: {r['seconds']:.1f} s", file=sys.stderr, flush=True)
    rows.sort(key=lambda r: (r["faces"], METHODS.index(r["method"])))
    print("| mesh | vertices | faces | method | seconds | against the smallest | memory added (MB) |")
    print("|---|---|---|---|---|---|---|")
    first: dict[str, float] = {}
    for r in rows:
        first.setdefault(r["method"], r["seconds"])
        print(
            f"| {r['case']} | {r['vertices']:,} | {r['faces']:,} | {r['method']} | {r['seconds']:.2f} | "
            f"{r['seconds'] / first[r['method']]:.1f}x | {r['memory']:.0f} |"
        )
    plot(rows, args.png)
    png = args.png.resolve()
    print(f"\n![time and memory against size]({png.relative_to(ROOT) if png.is_relative_to(ROOT) else png})")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
