"""How much of the texture each unwrap covers, and what the pack costs, in one Blender process.

For every mesh of ``../shared/meshes`` and Suzanne, with no seams and with Smart UV
Project's seams: Isometric Unwrap with its defaults (Fill Shapes, isoparam's own packer),
the same islands packed again by Blender's packer with each shape (Bounding Box, Convex
Hull, Exact Shape; rotation on, same margin) and by xatlas's packer (``add_uv_mesh``,
padding 1 texel at 1024), and, with no seams, xatlas (``pip install xatlas``, benchmark
environment only) with its own charts and packer. Coverage is the UV area of all faces
over the area of the square that holds them (``metrics.coverage``); pack times are medians
of ``--repeat`` runs, the operator's with Fill Shapes and with Bounding Box (the build
before Fill Shapes packed the same way) interleaved.

xatlas packs into an atlas of its own width and height and writes UVs divided by each, so
that on a square texture its charts are stretched by the atlas's aspect (up to 11% here).
Its coverage is measured with the charts at their true shape (texels: u times width, v
times height, in the square of the longer side), the figure a square texture gets; the
figure of the UVs as written (stretched) is printed beside it.

    bash scripts/bench.sh scripts/packing.py
    bash scripts/bench.sh scripts/packing.py --meshes spot homer --repeat 5 --seams smart
    bash scripts/bench.sh scripts/packing.py --figure docs/img/packing.png --meshes spot homer

``--figure``: the layouts side by side (Fill Shapes, Exact Shape, xatlas with no seams),
one row per mesh and seams.
"""

from __future__ import annotations

import argparse
import time

import numpy as np

import isoparam_addon
from isoparam_addon.blender.record import last_record
from isoparam_addon.solver import metrics
from isoparam_eval import meshes as ex
from isoparam_eval.blender import add_mesh, bpy, edit, read_uvs, smart_uv_seams

SHAPES = ("AABB", "CONVEX", "CONCAVE")
MESHES = [*ex.REAL, "nefertiti", "suzanne"]


def _mesh(name: str):
    if name == "suzanne":
        return ex.suzanne_closed()
    V, F, _ = ex.real_mesh(name) if name in ex.REAL else ex.load_obj(ex.SHARED / f"{name}.obj")
    return V, F


def _true_shape(atlas, uvs: np.ndarray) -> np.ndarray:
    """xatlas's UVs (divided by the atlas's width and height) back in texels' proportions,
    in the square of the atlas's longer side."""
    return uvs.astype(np.float64) * np.array([atlas.width, atlas.height]) / max(atlas.width, atlas.height)


def _xatlas(V, F, repeat: int):
    """xatlas's charts and packer: coverage at true shape, as written, seconds, layout."""
    import xatlas

    times = []
    for _ in range(repeat):
        t = time.perf_counter()
        atlas = xatlas.Atlas()
        atlas.add_mesh(V.astype(np.float32), F.astype(np.uint32))
        atlas.generate()
        times.append(time.perf_counter() - t)
    vmapping, indices, uvs = atlas[0]
    cuv = _true_shape(atlas, uvs)[indices]
    written = metrics.coverage(uvs[indices].astype(np.float64))
    return metrics.coverage(cuv), written, float(np.median(times)), (cuv, metrics.uv_islands(vmapping[indices], cuv))


def _xatlas_packer(cuv: np.ndarray, island: np.ndarray, repeat: int) -> tuple[float, float]:
    """The islands ``cuv`` (t, 3, 2) packed by xatlas's packer (corners of one island at
    one UV are one vertex): coverage at true shape, median seconds of the pack."""
    import xatlas

    corners = np.column_stack([np.repeat(island, 3).astype(np.float64), cuv.reshape(-1, 2)])
    points, index = np.unique(corners, axis=0, return_inverse=True)
    options = xatlas.PackOptions()
    options.padding, options.resolution = 1, 1024
    times = []
    for _ in range(repeat):
        atlas = xatlas.Atlas()
        atlas.add_uv_mesh(points[:, 1:].astype(np.float32), index.reshape(-1, 3).astype(np.uint32))
        t = time.perf_counter()
        atlas.generate(pack_options=options)
        times.append(time.perf_counter() - t)
    _, indices, uvs = atlas[0]
    return metrics.coverage(_true_shape(atlas, uvs)[indices]), float(np.median(times))


def _layout(ob):
    """The object's corner UVs (t, 3, 2) and UV island of every triangle."""
    bpy.ops.object.mode_set(mode="OBJECT")
    Ft, cuv = read_uvs(ob)
    return cuv, metrics.uv_islands(Ft, cuv)


def measure(name: str, seams: str, repeat: int) -> dict:
    V, F = _mesh(name)
    S = smart_uv_seams(V, F) if seams == "smart" else None
    bpy.ops.wm.read_homefile(use_empty=True)
    ob = add_mesh("m", V, F, seams=S)
    edit(ob)
    op = {"ISOPARAM": [], "AABB": []}
    for _ in range(repeat):  # the operator with each default, interleaved
        for shape in op:
            t = time.perf_counter()
            assert bpy.ops.uv.isometric_unwrap(pack_shape=shape) == {"FINISHED"}
            seconds, run = time.perf_counter() - t, last_record(bpy.context)
            op[shape].append((seconds, run.pack, run.coverage))
    row = {"mesh": name, "seams": seams}
    for shape, runs in op.items():
        row["op_" + shape] = float(np.median([r[0] for r in runs]))
        row["pack_" + shape] = float(np.median([r[1] for r in runs]))
        row["cov_" + shape] = runs[-1][2]
    assert bpy.ops.uv.isometric_unwrap() == {"FINISHED"}
    cuv, island = _layout(ob)
    row["charts"] = int(island.max()) + 1
    row["layouts"] = {"Fill Shapes": (cuv, island)}
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
    row["layouts"]["Exact Shape"] = _layout(ob)
    row["packer"], row["packer_s"] = _xatlas_packer(cuv, island, repeat)
    row["xatlas"], row["written"], row["xatlas_s"] = float("nan"), float("nan"), float("nan")
    if seams == "none":
        row["xatlas"], row["written"], row["xatlas_s"], row["layouts"]["xatlas"] = _xatlas(V, F, repeat)
    return row


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--meshes", nargs="+", default=MESHES)
    ap.add_argument("--seams", nargs="+", default=["none", "smart"], choices=["none", "smart"])
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--figure", help="save the layouts side by side as this PNG")
    args = ap.parse_args(argv)
    figure = {}
    isoparam_addon.register()
    print(
        "| mesh | seams | islands | Fill Shapes | pack s | operator s (Bounding Box) | Bounding Box | s "
        "| Convex Hull | s | Exact Shape | s | xatlas's packer | s | xatlas | (as written) | s |"
    )
    print("|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|")
    for seams in args.seams:
        for name in args.meshes:
            if seams == "smart" and name == "nefertiti":  # (Smart UV Project's seams: a minute in Blender)
                continue
            r = measure(name, seams, args.repeat)
            figure[f"{name} ({seams})"] = r["layouts"]
            print(
                f"| {name} | {seams} | {r['charts']} | {r['cov_ISOPARAM']:.2f} | {r['pack_ISOPARAM']:.2f} | "
                f"{r['op_ISOPARAM']:.2f} ({r['op_AABB']:.2f}) | {r['AABB']:.2f} | {r['AABB_s']:.2f} | "
                f"{r['CONVEX']:.2f} | {r['CONVEX_s']:.2f} | {r['CONCAVE']:.2f} | {r['CONCAVE_s']:.2f} | "
                f"{r['packer']:.2f} | {r['packer_s']:.2f} | {r['xatlas']:.2f} | ({r['written']:.2f}) | "
                f"{r['xatlas_s']:.2f} |",
                flush=True,
            )
    if args.figure:
        from isoparam_eval.figures import packed_side_by_side

        rows = {k: v for k, v in figure.items() if "xatlas" in v} or figure
        packed_side_by_side(args.figure, {k: {m: v[m] for m in next(iter(rows.values()))} for k, v in rows.items()})
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
