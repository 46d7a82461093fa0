"""isoparam against Blender's own unwrap, in one Blender process.

For every mesh, each method unwraps the whole mesh in edit mode through its operator
(``uv.isometric_unwrap``; ``uv.unwrap`` with ANGLE_BASED, CONFORMAL, MINIMUM_STRETCH),
end to end: mesh I/O, solve, packing. Times are medians of ``--repeat`` runs (the slow
built-ins run fewer times on large meshes, see ``--slow-repeat``). Distortion is
measured on the UVs each method wrote, scale-normalised (solver/metrics.py).

    python scripts/compare_blender.py                       # peaks 41x41 and 100k
    python scripts/compare_blender.py --meshes peaks41 --repeat 7
    python scripts/compare_blender.py --io                  # mesh read/write speed, 1M corners

Writes ``out/compare/<name>.md`` (and .json) and prints the table.
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))
os.environ.setdefault("BLENDER_USER_RESOURCES", tempfile.mkdtemp(prefix="isoparam-compare-"))

import bpy  # noqa: E402

import isoparam_addon  # noqa: E402
from isoparam_addon.blender import mesh_io  # noqa: E402
from isoparam_addon.solver import examples as ex  # noqa: E402
from isoparam_addon.solver import metrics  # noqa: E402

MESHES = {
    "peaks41": lambda: ex.peaks(41),
    "peaks100k": lambda: ex.peaks(316),
    "s_regular": lambda: ex.s_surface(50, 12)[:2],
    "s_random": lambda: ex.s_surface_random(600, 3)[:2],
}

METHODS = {
    "isoparam": lambda: bpy.ops.uv.isometric_unwrap(),
    "ANGLE_BASED": lambda: bpy.ops.uv.unwrap(method="ANGLE_BASED", margin=0.001),
    "CONFORMAL": lambda: bpy.ops.uv.unwrap(method="CONFORMAL", margin=0.001),
    "MINIMUM_STRETCH": lambda: bpy.ops.uv.unwrap(method="MINIMUM_STRETCH", iterations=10, margin=0.001),
}


def add_object(name, V, F):
    me = bpy.data.meshes.new(name)
    me.vertices.add(len(V))
    me.vertices.foreach_set("co", np.asarray(V, dtype=np.float32).ravel())
    me.loops.add(3 * len(F))
    me.loops.foreach_set("vertex_index", np.asarray(F, dtype=np.int32).ravel())
    me.polygons.add(len(F))
    me.polygons.foreach_set("loop_start", np.arange(0, 3 * len(F), 3, dtype=np.int32))
    me.update(calc_edges=True)
    ob = bpy.data.objects.new(name, me)
    bpy.context.scene.collection.objects.link(ob)
    return ob


def edit(ob):
    for o in bpy.context.scene.objects:
        o.select_set(o is ob)
    bpy.context.view_layer.objects.active = ob
    bpy.ops.object.mode_set(mode="EDIT")
    bpy.ops.mesh.select_all(action="SELECT")


def read_uvs(ob):
    me = ob.data
    me.calc_loop_triangles()
    tri = np.empty(3 * len(me.loop_triangles), np.int32)
    me.loop_triangles.foreach_get("loops", tri)
    tri = tri.reshape(-1, 3)
    uv = np.empty(2 * len(me.loops), np.float32)
    me.uv_layers.active.uv.foreach_get("vector", uv)
    cv = np.empty(len(me.loops), np.int32)
    me.attributes[".corner_vert"].data.foreach_get("value", cv)
    return cv[tri], uv.reshape(-1, 2)[tri].astype(np.float64)


def measure(name, V, F, methods, repeat, slow_repeat):
    rows = {}
    for method in methods:
        bpy.ops.wm.read_homefile(use_empty=True)
        ob = add_object(name, V, F)
        edit(ob)
        slow = method != "isoparam" and len(V) > 20_000
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
        rows[method] = dict(seconds=float(np.median(times)), runs=runs, **d)
        print(
            f"  {name:10s} {method:16s} {rows[method]['seconds']:8.3f} s  edge RMS {d['edge_rms']:.4f}  "
            f"L2 {d['stretch_l2']:.3f}  flips {d['flipped']}",
            file=sys.stderr,
            flush=True,
        )
    return rows


def table(name, n_vertices, rows):
    ours = rows.get("isoparam", {}).get("seconds")
    lines = [
        f"### {name} ({n_vertices:,} vertices)",
        "",
        "| method | time (s) | runs | x isoparam time | relative RMS edge error | L2 stretch | Linf stretch "
        "| symmetric Dirichlet | flips |",
        "|---|---|---|---|---|---|---|---|---|",
    ]
    for method, r in rows.items():
        ratio = f"{r['seconds'] / ours:.1f}" if ours else "-"
        lines.append(
            f"| {method} | {r['seconds']:.3f} | {r['runs']} | {ratio} | {r['edge_rms']:.4f} | "
            f"{r['stretch_l2']:.3f} | {r['stretch_linf']:.2f} | {r['symmetric_dirichlet']:.3f} | "
            f"{r['flipped']} |"
        )
    return "\n".join(lines)


def io_benchmark(repeat: int) -> str:
    """Read (selection, seams, UVs, triangles) and write UVs of a 1M-corner mesh."""
    bpy.ops.wm.read_homefile(use_empty=True)
    V, F = ex.peaks(409)  # 167k vertices, 333k triangles, 1.0M corners
    ob = add_object("io", V, F)
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
        f"### mesh I/O ({corners:,} corners)\n\n| step | median (s) |\n|---|---|\n"
        f"| read positions, faces, selection, seams, pins, UVs, triangles | {np.median(reads):.3f} |\n"
        f"| write UVs | {np.median(writes):.3f} |"
    )


def main(argv=None) -> int:
    argv = sys.argv[sys.argv.index("--") + 1 :] if "--" in sys.argv else argv
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--meshes", nargs="+", default=["peaks41", "peaks100k"], choices=list(MESHES))
    ap.add_argument("--methods", nargs="+", default=["isoparam", "ANGLE_BASED", "CONFORMAL"], choices=list(METHODS))
    ap.add_argument("--repeat", type=int, default=5)
    ap.add_argument("--slow-repeat", type=int, default=1, help="runs of the built-ins on meshes above 20k vertices")
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
        V, F = MESHES[name]()
        rows = measure(name, V, F, args.methods, args.repeat, args.slow_repeat)
        data[name] = rows
        parts.append(table(name, len(V), rows))
    text = "\n\n".join(parts)
    stem = "_".join(args.meshes)
    (out / f"{stem}.md").write_text(text + "\n")
    (out / f"{stem}.json").write_text(json.dumps(data, indent=1))
    print(text)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
