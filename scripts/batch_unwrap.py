"""Unwrap many files with Isometric Unwrap, headless.

Inside Blender, on the open file:

    blender --background scene.blend --python scripts/batch_unwrap.py -- [--save | -o out.blend] [options]

With Blender as a Python module (``pip install bpy``), on any number of files:

    python scripts/batch_unwrap.py a.obj b.ply c.glb d.blend -o out_dir/ [options]
    python scripts/batch_unwrap.py in.obj -o out.obj

Formats in and out: .obj, .ply, .gltf/.glb, .blend (the output format follows the output
name, or ``--format``). Every mesh object is unwrapped on its own (``--together`` packs
all of a file's meshes into one UV square). A line per file tells what happened; the
exit status is 1 if any file failed, 2 for bad arguments.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
FORMATS = (".obj", ".ply", ".gltf", ".glb", ".blend")


def _ensure_addon():
    """The operator from an installed, enabled extension, or from this source tree."""
    import bpy

    if hasattr(bpy.types, "UV_OT_isometric_unwrap"):
        return
    import addon_utils

    for mod in addon_utils.modules():  # installed extensions whose id is isoparam
        if mod.__name__.endswith(".isoparam"):
            addon_utils.enable(mod.__name__, default_set=True)
            if hasattr(bpy.types, "UV_OT_isometric_unwrap"):
                return
    sys.path.insert(0, str(ROOT))
    import isoparam_addon

    isoparam_addon.register()


def _ensure_gltf():
    import addon_utils

    if not addon_utils.check("io_scene_gltf2")[1]:
        addon_utils.enable("io_scene_gltf2", default_set=True)


def load(path: Path) -> None:
    import bpy

    ext = path.suffix.lower()
    if ext == ".blend":
        bpy.ops.wm.open_mainfile(filepath=str(path))
        return
    bpy.ops.wm.read_homefile(use_empty=True)
    if ext == ".obj":
        bpy.ops.wm.obj_import(filepath=str(path))
    elif ext == ".ply":
        bpy.ops.wm.ply_import(filepath=str(path))
    elif ext in (".gltf", ".glb"):
        _ensure_gltf()
        bpy.ops.import_scene.gltf(filepath=str(path))
    else:
        raise ValueError(f"cannot read {ext} files (use one of {', '.join(FORMATS)})")


def save(path: Path) -> None:
    import bpy

    path.parent.mkdir(parents=True, exist_ok=True)
    ext = path.suffix.lower()
    if ext == ".blend":
        bpy.ops.wm.save_as_mainfile(filepath=str(path), copy=True)
    elif ext == ".obj":
        bpy.ops.wm.obj_export(filepath=str(path), export_uv=True, export_materials=False)
    elif ext == ".ply":
        bpy.ops.wm.ply_export(filepath=str(path), export_uv=True)
    elif ext in (".gltf", ".glb"):
        _ensure_gltf()
        bpy.ops.export_scene.gltf(filepath=str(path), export_format="GLB" if ext == ".glb" else "GLTF_SEPARATE")
    else:
        raise ValueError(f"cannot write {ext} files (use one of {', '.join(FORMATS)})")


def unwrap_scene(args) -> dict:
    """Unwrap the mesh objects of the current scene; returns a small report."""
    import bpy

    meshes = [ob for ob in bpy.context.scene.objects if ob.type == "MESH" and len(ob.data.polygons)]
    if args.objects:
        meshes = [ob for ob in meshes if ob.name in args.objects]
    if not meshes:
        raise RuntimeError("no mesh objects to unwrap")
    if bpy.context.object is not None and bpy.context.object.mode != "OBJECT":
        bpy.ops.object.mode_set(mode="OBJECT")
    groups = [meshes] if args.together else [[ob] for ob in meshes]
    for group in groups:  # one operator call per object (or one for all)
        for ob in bpy.context.scene.objects:
            ob.select_set(ob in group)
        bpy.context.view_layer.objects.active = group[0]
        bpy.ops.object.mode_set(mode="EDIT")
        bpy.ops.mesh.reveal()
        bpy.ops.mesh.select_all(action="SELECT")
        try:
            bpy.ops.uv.isometric_unwrap(
                pack=not args.in_place,
                margin=args.margin,
                world_scale=args.world_scale,
                correct_aspect=not args.no_aspect,
                charts=not args.no_charts,
                chart_disks=args.chart_disks,
                max_stretch=args.max_stretch,
                mark_seams=args.mark_seams,
                **({} if args.extra_cuts is None else {"extra_cuts": args.extra_cuts}),
            )
        finally:
            bpy.ops.object.mode_set(mode="OBJECT")
    return {"objects": len(meshes), "faces": sum(len(ob.data.polygons) for ob in meshes)}


def _progress(i: int, n: int, name: str, status: str) -> None:
    width = 24
    done = int(width * i / max(n, 1))
    print(f"\r[{'#' * done}{'.' * (width - done)}] {i}/{n} {name}: {status}", file=sys.stderr, flush=True)


def parse(argv):
    ap = argparse.ArgumentParser(
        prog="batch_unwrap", description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    ap.add_argument("inputs", nargs="*", type=Path, help="files to unwrap (none: the open .blend, inside Blender)")
    ap.add_argument("-o", "--out", type=Path, help="output file (one input) or folder (several inputs)")
    ap.add_argument("--format", choices=[f[1:] for f in FORMATS], help="output format when --out is a folder")
    ap.add_argument("--save", action="store_true", help="inside Blender: save the open file in place")
    ap.add_argument("--objects", nargs="+", help="only these objects")
    ap.add_argument("--together", action="store_true", help="pack all meshes of a file into one UV square")
    ap.add_argument("--in-place", action="store_true", help="keep every island where its old UVs were")
    ap.add_argument("--margin", type=float, default=0.001)
    ap.add_argument("--world-scale", action="store_true", help="one UV unit per world unit")
    ap.add_argument("--no-aspect", action="store_true", help="ignore image aspect ratios")
    ap.add_argument("--no-charts", action="store_true", help="cut islands open only as far as they must be")
    ap.add_argument("--chart-disks", action="store_true", help="also chart islands your seams bound")
    ap.add_argument("--max-stretch", type=float, default=1.18, help="the charts' stretch budget (default 1.18)")
    ap.add_argument("--mark-seams", action="store_true", help="mark the cuts made as seams")
    ap.add_argument(
        "--extra-cuts",
        type=int,
        help="with --no-charts: more cuts for islands cut open automatically (default: the operator's, 4)",
    )
    ap.add_argument("--report", type=Path, help="write the per-file report as JSON")
    return ap.parse_args(argv)


def output_for(args, path: Path | None, many: bool) -> Path | None:
    if args.out is None:
        return None
    if not many and args.out.suffix.lower() in FORMATS:
        return args.out
    fmt = "." + (args.format or (path.suffix.lstrip(".") if path else "blend"))
    stem = path.stem if path else "scene"
    return args.out / f"{stem}{fmt}"


def main(argv=None) -> int:
    if argv is None:
        argv = sys.argv[sys.argv.index("--") + 1 :] if "--" in sys.argv else sys.argv[1:]
    args = parse(argv)
    import bpy

    _ensure_addon()
    jobs: list[Path | None] = list(args.inputs)
    if not jobs:
        if not bpy.data.filepath:
            print("batch_unwrap: no input files, and no .blend is open", file=sys.stderr)
            return 2
        jobs = [None]  # the file Blender opened
    many = len(jobs) > 1
    report, failed = [], 0
    for i, path in enumerate(jobs):  # one file at a time
        name = path.name if path else Path(bpy.data.filepath).name
        t0 = time.perf_counter()
        _progress(i, len(jobs), name, "unwrapping")
        entry = {"file": str(path or bpy.data.filepath)}
        try:
            if path is not None:
                load(path)
            entry.update(unwrap_scene(args))
            target = output_for(args, path, many)
            if target is None and path is None and args.save:
                bpy.ops.wm.save_mainfile()
                target = Path(bpy.data.filepath)
            if target is not None:
                save(target)
                entry["output"] = str(target)
            entry.update(status="ok", seconds=round(time.perf_counter() - t0, 3))
        except Exception as exc:  # report and go on with the next file
            failed += 1
            entry.update(
                status="failed",
                error=str(exc).strip().splitlines()[-1][:500],
                seconds=round(time.perf_counter() - t0, 3),
            )
        report.append(entry)
        _progress(i + 1, len(jobs), name, entry["status"])
        print(json.dumps(entry))
    if args.report:
        args.report.write_text(json.dumps(report, indent=1))
    print(f"batch_unwrap: {len(jobs) - failed} of {len(jobs)} files unwrapped", file=sys.stderr)
    return 1 if failed else 0


if __name__ == "__main__":
    code = main()
    import bpy

    if not bpy.app.binary_path and bpy.app.version < (4, 3, 0):
        # bpy 4.2 as a Python module segfaults in its teardown after several glTF
        # exports (measured with 4.2.23); everything is written, so leave at once
        sys.stdout.flush()
        sys.stderr.flush()
        import os

        os._exit(code)
    sys.exit(code)
