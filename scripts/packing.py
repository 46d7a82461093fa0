"""How much of the texture each unwrap covers, and what the pack costs, in one Blender process.

For every mesh of ``../shared/meshes`` and Suzanne, no seams: Isometric Unwrap with its
defaults (Blender's pack, Bounding Box shape), the same islands packed again by Blender's
packer with the Convex Hull and Exact Shape shapes (rotation on, same margin), and xatlas
(``pip install xatlas``, benchmark environment only) with its own charts and packer.
Coverage is the UV area of all faces over the area of the square that holds them
(``metrics.coverage``); pack times are medians of ``--repeat`` runs.

    bash scripts/bench.sh scripts/packing.py
    bash scripts/bench.sh scripts/packing.py --meshes spot homer --repeat 5
"""

from __future__ import annotations

import argparse
import time

import numpy as np

import isoparam_addon
from isoparam_addon.blender import unwrap
from isoparam_addon.solver import metrics
from isoparam_eval import meshes as ex
from isoparam_eval.blender import add_mesh, bpy, edit, read_uvs

SHAPES = ("CONVEX", "CONCAVE")
MESHES = [*ex.REAL, "nefertiti", "suzanne"]


def _mesh(name: str):
    if name == "suzanne":
        return ex.suzanne_closed()
    V, F, _ = ex.real_mesh(name) if name in ex.REAL else ex.load_obj(ex.SHARED / f"{name}.obj")
    return V, F


def _xatlas(V, F, repeat: int):
    import xatlas

    times = []
    for _ in range(repeat):
        t = time.perf_counter()
        vmapping, indices, uvs = xatlas.parametrize(V.astype(np.float32), F.astype(np.uint32))
        times.append(time.perf_counter() - t)
    return metrics.coverage(uvs[indices].astype(np.float64)), float(np.median(times))


def measure(name: str, repeat: int) -> dict:
    V, F = _mesh(name)
    bpy.ops.wm.read_homefile(use_empty=True)
    ob = add_mesh("m", V, F)
    edit(ob)
    assert bpy.ops.uv.isometric_unwrap() == {"FINISHED"}
    row = {"mesh": name, "charts": None, "ours": unwrap.last_run.coverage, "ours_pack": unwrap.last_run.pack}
    bpy.ops.object.mode_set(mode="OBJECT")
    Ft, cuv = read_uvs(ob)
    row["charts"] = int(metrics.uv_islands(Ft, cuv).max()) + 1
    for shape in SHAPES:
        times = []
        for _ in range(repeat):
            edit(ob)
            t = time.perf_counter()
            bpy.ops.uv.pack_islands(shape_method=shape, rotate=True, margin=0.001)
            times.append(time.perf_counter() - t)
            bpy.ops.object.mode_set(mode="OBJECT")
        row[shape] = metrics.coverage(read_uvs(ob)[1])
        row[shape + "_s"] = float(np.median(times))
    row["xatlas"], row["xatlas_s"] = _xatlas(V, F, repeat)
    return row


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--meshes", nargs="+", default=MESHES)
    ap.add_argument("--repeat", type=int, default=3)
    args = ap.parse_args(argv)
    isoparam_addon.register()
    print("| mesh, no seams | charts | isoparam, boxes | pack s | Convex Hull | s | Exact Shape | s | xatlas | s |")
    print("|---|---|---|---|---|---|---|---|---|---|")
    for name in args.meshes:
        r = measure(name, args.repeat)
        print(
            f"| {name} | {r['charts']} | {r['ours']:.2f} | {r['ours_pack']:.2f} | {r['CONVEX']:.2f} | "
            f"{r['CONVEX_s']:.2f} | {r['CONCAVE']:.2f} | {r['CONCAVE_s']:.2f} | {r['xatlas']:.2f} | "
            f"{r['xatlas_s']:.2f} |",
            flush=True,
        )
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
