"""isoparam against Blender's own unwrap, in one Blender process.

For every mesh, each method unwraps the whole mesh in edit mode through its operator:
``uv.isometric_unwrap`` with its default refinement and without (``refine=0``, the
paper's method), and ``uv.unwrap`` with ANGLE_BASED, CONFORMAL and MINIMUM_STRETCH (SLIM,
10 iterations). End to end: mesh I/O, solve, packing. Times are medians of ``--repeat``
runs; the built-ins run ``--slow-repeat`` times on meshes above 20k vertices (SLIM
takes minutes there). Distortion is measured on the UVs each method wrote
(solver/metrics.py): edge error and L2/Linf stretch at the best scale for the whole layout,
and the symmetric Dirichlet energy per island at each island's best scale (area-weighted),
so that no method is judged on how its islands were scaled against each other; the scale
spread (largest over smallest island scale) shows that scaling apart. With ``--render``,
checker-textured Cycles renders of every method go side by side into one PNG per mesh.

    python scripts/compare_blender.py                      # the issue-4 set, incl. a 100k peaks
    python scripts/compare_blender.py --meshes peaks41 --repeat 7 --render
    python scripts/compare_blender.py --io                 # mesh read/write speed, 1M corners

Writes ``out/compare/results.md`` (and .json) and prints the tables.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

import numpy as np

import isoparam_addon
from isoparam_addon.blender import mesh_io
from isoparam_addon.solver import metrics
from isoparam_eval import meshes as ex
from isoparam_eval.blender import METHODS, add_mesh, available, bpy, edit, read_uvs, render, suzanne

ROOT = Path(__file__).resolve().parent.parent

MESHES = {  # name: (title, () -> (V, F, seams or None))
    "peaks41": ("peaks 41x41, z/3", lambda: (*ex.peaks(41), None)),
    "peaks100k": ("peaks 316x316, z/3", lambda: (*ex.peaks(316), None)),
    "s_random": ("S-surface, random Delaunay 600", lambda: (*ex.s_surface_random(600, 3)[:2], None)),
    "cap": ("spherical cap (K > 0)", lambda: (*ex.spherical_cap(30), None)),
    "saddle": ("saddle z = 0.6 (x^2 - y^2) (K < 0)", lambda: (*ex.saddle(61, 0.6), None)),
    "suzanne": ("Suzanne, subdivided twice, seams from Smart UV Project", lambda: suzanne(2)),
    "suzanne_noseams": ("Suzanne, subdivided twice, no seams", lambda: (*suzanne(2)[:2], None)),
    "cube": ("closed cube, 6x6 quads per side, no seams", lambda: _cube()),
    "suzanne4": ("Suzanne, subdivided 4 times, seams from Smart UV Project", lambda: suzanne(4)),
    "peaks100k_suzanne": ("peaks 316x316 beside Suzanne subdivided twice, no seams", lambda: _peaks_suzanne()),
}


def _peaks_suzanne():
    """A disk beside closed islands (Suzanne's head and eyes, cut open automatically)."""
    Vp, Fp = ex.peaks(316)
    Vs, Fs, _ = suzanne(2)
    return np.vstack([Vp, Vs + [5.0, 0.0, 0.0]]), np.vstack([Fp, Fs + len(Vp)]), None


def _cube():
    V, F, _ = ex.box(6)
    return V, F, None


DEFAULT_MESHES = ["peaks41", "s_random", "cap", "saddle", "suzanne", "peaks100k"]
DEFAULT_METHODS = ["isoparam", "isoparam, Refinement 0", "MINIMUM_STRETCH", "ANGLE_BASED", "CONFORMAL"]


def measure(name, V, F, seams, methods, repeat, slow_repeat, render_dir=None):
    rows = {}
    for method in methods:
        bpy.ops.wm.read_homefile(use_empty=True)
        ob = add_mesh(name, V, F, seams)
        edit(ob)
        slow = not method.startswith("isoparam") and len(V) > 20_000
        runs = slow_repeat if slow else repeat
        if not slow:
            METHODS[method]()  # warm-up
        times = []
        for _ in range(runs):  # timed runs, end to end through the operator
            t = time.perf_counter()
            METHODS[method]()
            times.append(time.perf_counter() - t)
        bpy.ops.object.mode_set(mode="OBJECT")
        Ft, cuv = read_uvs(ob)
        d = metrics.distortion(V, Ft, cuv)
        per = metrics.per_island(V, Ft, cuv)
        rows[method] = dict(
            seconds=float(np.median(times)),
            runs=runs,
            **d.asdict(),
            islands=per.n_islands,
            island_sd=per.mean_symmetric_dirichlet,
            scale_spread=per.scale_spread,
        )
        print(
            f"  {name:10s} {method:32s} {rows[method]['seconds']:8.3f} s  edge RMS {d.edge_rms:.4f}  "
            f"L2 {d.stretch_l2:.4f}  SD per island {per.mean_symmetric_dirichlet:.4f}  flips {d.flipped}",
            file=sys.stderr,
            flush=True,
        )
        if render_dir is not None:
            render(ob, render_dir / f"{name}_{method.split()[0].strip(',')}_{len(rows)}.png", samples=16)
    return rows


def table(title, n_vertices, rows):
    ours = rows.get("isoparam", {}).get("seconds")
    paper = rows.get("isoparam, Refinement 0", {}).get("seconds")
    lines = [
        f"### {title} ({n_vertices:,} vertices)",
        "",
        "| method | time (s) | runs | time / isoparam | time / isoparam without refinement "
        "| relative RMS edge error | L2 stretch | Linf stretch | islands | symmetric Dirichlet per island "
        "| island scale spread | flips |",
        "|---|---|---|---|---|---|---|---|---|---|---|---|",
    ]
    for method, r in rows.items():
        ratio = f"{r['seconds'] / ours:.1f}" if ours else "-"
        ratio0 = f"{r['seconds'] / paper:.1f}" if paper else "-"
        lines.append(
            f"| {method} | {r['seconds']:.3f} | {r['runs']} | {ratio} | {ratio0} | {r['edge_rms']:.4f} | "
            f"{r['stretch_l2']:.4f} | {r['stretch_linf']:.2f} | {r['islands']} | {r['island_sd']:.4f} | "
            f"{r['scale_spread']:.2f} | {r['flipped']} |"
        )
    return "\n".join(lines)


def io_benchmark(repeat: int) -> str:
    """Read (selection, seams, UVs, triangles) and write UVs of a 1M-corner mesh."""
    bpy.ops.wm.read_homefile(use_empty=True)
    V, F = ex.peaks(409)  # 167k vertices, 333k triangles, 1.0M corners
    ob = add_mesh("io", V, F)
    ob.data.uv_layers.new(name="UVMap")
    reads, writes = [], []
    for _ in range(repeat):  # timed runs
        t = time.perf_counter()
        sel = mesh_io.read_selection(ob, world_space=False, uv_selection_locks=False)
        reads.append(time.perf_counter() - t)
        t = time.perf_counter()
        mesh_io.write_uvs(ob.data, "UVMap", sel.uv)
        writes.append(time.perf_counter() - t)
    corners = len(ob.data.loops)
    return (
        f"### mesh I/O ({corners:,} corners, median of {repeat})\n\n| step | seconds |\n|---|---|\n"
        f"| read positions, faces, selection, seams, pins, UVs, triangles | {np.median(reads):.3f} |\n"
        f"| write UVs | {np.median(writes):.4f} |"
    )


def main(argv=None) -> int:
    argv = sys.argv[sys.argv.index("--") + 1 :] if "--" in sys.argv else argv
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--meshes", nargs="+", default=DEFAULT_MESHES, choices=list(MESHES))
    ap.add_argument("--methods", nargs="+", default=DEFAULT_METHODS, choices=list(METHODS))
    ap.add_argument("--repeat", type=int, default=5)
    ap.add_argument("--slow-repeat", type=int, default=1, help="runs of the built-ins on meshes above 20k vertices")
    ap.add_argument("--render", action="store_true", help="checker renders side by side (meshes below 20k)")
    ap.add_argument("--io", action="store_true", help="benchmark mesh I/O instead")
    ap.add_argument("--out", default="out/compare")
    args = ap.parse_args(argv)
    isoparam_addon.register()
    out = ROOT / args.out
    out.mkdir(parents=True, exist_ok=True)
    if args.io:
        text = io_benchmark(args.repeat)
        (out / "io.md").write_text(text + "\n")
        print(text)
        return 0
    parts, data = [], {}
    for name in args.meshes:
        title, make = MESHES[name]
        V, F, seams = make()
        shots = out / "renders" if args.render and len(V) <= 20_000 else None
        if shots:
            shots.mkdir(exist_ok=True)
        methods = [m for m in args.methods if available(m)]  # (MINIMUM_STRETCH: Blender 4.3 on)
        rows = measure(name, V, F, seams, methods, args.repeat, args.slow_repeat, shots)
        data[name] = rows
        parts.append(table(title, len(V), rows))
        if shots:
            import matplotlib

            matplotlib.use("Agg")
            import matplotlib.pyplot as plt

            fig, axes = plt.subplots(1, len(rows), figsize=(3.6 * len(rows), 3.2))
            for k, (ax, method) in enumerate(zip(np.atleast_1d(axes), rows), start=1):
                ax.imshow(plt.imread(shots / f"{name}_{method.split()[0].strip(',')}_{k}.png"))
                ax.set_title(method, fontsize=8)
                ax.axis("off")
            fig.suptitle(title)
            fig.tight_layout()
            fig.savefig(out / f"{name}_renders.png", dpi=100)
            plt.close(fig)
    text = "\n\n".join(parts)
    (out / "results.md").write_text(text + "\n")
    (out / "results.json").write_text(json.dumps(data, indent=1))
    print(text)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
