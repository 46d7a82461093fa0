"""isoparam beside Blender's unwrap methods and xatlas on real meshes, in one Blender process.

For every mesh of ``../shared/meshes`` (and Suzanne) and every seam mode, each method
unwraps the whole mesh in edit mode through its operator, end to end (mesh I/O, solve,
packing); xatlas (``pip install xatlas``, benchmark environment only) and Blender's Smart
UV Project make their own charts from the mesh alone (no-seam mode only). Seam modes:

* ``smart``: the seams of Smart UV Project's islands (Blender's one-click charts);
* ``none``: no seams (closed parts are cut open by each method as it can);
* ``artist``: spot's own UV map's seams.

Per method: time (median of ``--repeat`` runs, same process), islands, symmetric
Dirichlet energy per island at each island's best scale (area-weighted mean; 4 =
isometric), worst stretch (Linf, per island at its area scale), flipped faces, islands
that overlap themselves (with their crossing boundary edges and the share of UV area
covered twice), and the seam length (3D length of the mesh edges whose two sides have
different UVs) as a share of all edges. Run it through the benchmark environment:

    bash scripts/bench.sh scripts/real_meshes.py                        # every mesh, smart and none
    bash scripts/bench.sh scripts/real_meshes.py --meshes spot homer --seams none --methods isoparam xatlas
    bash scripts/bench.sh scripts/real_meshes.py --seams none --repeat 1 --pictures docs/img/no_seams
"""

from __future__ import annotations

import argparse
import tempfile
import time
from pathlib import Path

import numpy as np

from isoparam_addon.solver import metrics
from isoparam_eval import meshes as ex
from isoparam_eval.blender import (
    METHODS,
    add_mesh,
    add_seam_lines,
    bpy,
    edit,
    read_uvs,
    render,
    seams_of_islands,
    smart_uv_seams,
)

ALL = ["isoparam", "ANGLE_BASED", "CONFORMAL", "SMART_UV", "xatlas"]


def mesh(name: str, seams: str):
    """(V, F, seams or None) of a real mesh in a seam mode; None if the mode does not apply."""
    if name == "suzanne":
        V, F = ex.suzanne_closed()
        artist = None
    else:
        V, F, artist = ex.real_mesh(name)
    if seams == "artist":
        return (V, F, artist) if artist is not None and len(artist) else None
    if seams == "smart":
        return V, F, smart_uv_seams(V, F)
    return V, F, None


def measure(V, Ft, cuv) -> dict:
    """The measures of a layout ``cuv`` (t, 3, 2) of triangles ``Ft`` (t, 3)."""
    label = metrics.uv_islands(Ft, cuv)
    per = metrics.per_island(V, Ft, cuv, label)
    over = metrics.self_overlaps(V, Ft, cuv, label)
    uv_area = float(np.abs(0.5 * np.cross(cuv[:, 1] - cuv[:, 0], cuv[:, 2] - cuv[:, 0])).sum())
    l3, _ = metrics.uv_edge_lengths(V, Ft, cuv)
    every = metrics.uv_edge_lengths(V, Ft, np.zeros((len(Ft), 3, 2)))[0].sum()  # each edge once
    return dict(
        islands=int(label.max()) + 1,
        sd=per.mean_symmetric_dirichlet,
        worst=float(np.nanmax(per.symmetric_dirichlet, initial=4.0)),
        linf=per.worst_stretch,
        flips=int(per.flipped.sum()),
        overlapping=over.islands,
        crossings=int(over.crossings.sum()),
        covered_twice=100.0 * over.share(uv_area),
        seam=100.0 * (l3.sum() - every) / every,  # UV edges counted per side: the extra is the seams
    )


def run_operator(method: str, V, F, seams, repeat: int):
    times = []
    ob = None
    for _ in range(repeat):  # timed runs through the operator, each on a fresh mesh
        bpy.ops.wm.read_homefile(use_empty=True)
        ob = add_mesh("m", V, F, seams)
        edit(ob)
        t = time.perf_counter()
        METHODS[method]()
        times.append(time.perf_counter() - t)
        bpy.ops.object.mode_set(mode="OBJECT")
    Ft, cuv = read_uvs(ob)
    return float(np.median(times)), Ft, cuv


def picture(path: Path, name: str, V, shots: dict) -> None:
    """One PNG per mesh: per method, a checker render with its seams in red (the edges
    between its UV islands) above its UV layout. ``shots``: method -> (Ft, corner UVs)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from isoparam_eval.figures import draw_layout

    fig, axes = plt.subplots(2, len(shots), figsize=(4.0 * len(shots), 7.2), squeeze=False)
    for k, (method, (Ft, cuv)) in enumerate(shots.items()):
        bpy.ops.wm.read_homefile(use_empty=True)
        ob = add_mesh("m", V, Ft)
        ob.data.uv_layers.new(name="UVMap").uv.foreach_set("vector", cuv.astype(np.float32).ravel())
        islands = metrics.uv_islands(Ft, cuv).max() + 1
        failed = islands == len(Ft)  # every face alone: Blender's unwrap failed on a closed part
        if not failed:
            lo, hi = V.min(axis=0), V.max(axis=0)
            add_seam_lines(ob, seams_of_islands(ob), radius=0.0025 * float(np.linalg.norm(hi - lo)))
        shot = Path(tempfile.mkdtemp()) / "render.png"
        render(ob, shot, 0.35, 16, (480, 360), 1.3, checker=12)
        axes[0, k].imshow(plt.imread(shot))
        axes[0, k].axis("off")
        axes[0, k].set_title(f"{method}: " + ("failed" if failed else f"{islands} islands"), fontsize=10)
        draw_layout(axes[1, k], Ft, cuv, None, "")
    fig.suptitle(f"{name}, no seams marked: checker and seams (red), UV layout")
    fig.tight_layout()
    fig.savefig(path, dpi=90)
    plt.close(fig)


def run_xatlas(V, F, repeat: int):
    import xatlas

    times = []
    for _ in range(repeat):  # timed runs
        t = time.perf_counter()
        vmapping, indices, uvs = xatlas.parametrize(V.astype(np.float32), F.astype(np.uint32))
        times.append(time.perf_counter() - t)
    return float(np.median(times)), vmapping[indices].astype(np.int64), uvs[indices].astype(np.float64)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--meshes", nargs="+", default=[*ex.REAL, "suzanne"])
    ap.add_argument("--seams", nargs="+", default=["smart", "none", "artist"], choices=["smart", "none", "artist"])
    ap.add_argument("--methods", nargs="+", default=ALL, choices=[*METHODS, "xatlas"])
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--pictures", type=Path, help="folder for a render-and-layout PNG per mesh (no-seam mode)")
    args = ap.parse_args(argv)
    import isoparam_addon

    isoparam_addon.register()
    head = (
        "| mesh | seams | method | s | islands | SD | Linf | flips | overlapping islands | crossings "
        "| covered twice % | seam % |"
    )
    print(head)
    print("|" + "---|" * (head.count("|") - 1))
    for seams in args.seams:
        for name in args.meshes:
            found = mesh(name, seams)
            if found is None:
                continue
            V, F, S = found
            shots = {}
            for method in args.methods:
                if method in ("xatlas", "SMART_UV"):
                    if seams != "none":
                        continue  # they make their own charts
                if method == "xatlas":
                    t, Ft, cuv = run_xatlas(V, F, args.repeat)
                else:
                    t, Ft, cuv = run_operator(method, V, F, S, args.repeat)
                m = measure(V, Ft, cuv)
                shots[method] = (Ft, cuv)
                print(
                    f"| {name} | {seams} | {method} | {t:.2f} | {m['islands']} | {m['sd']:.3f} | {m['linf']:.2f} | "
                    f"{m['flips']} | {m['overlapping']} | {m['crossings']} | {m['covered_twice']:.3f} | "
                    f"{m['seam']:.1f} |",
                    flush=True,
                )
            if args.pictures is not None and seams == "none":
                args.pictures.mkdir(parents=True, exist_ok=True)
                picture(args.pictures / f"{name}_none.png", name, V, shots)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
