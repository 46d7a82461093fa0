"""The demo: unwrap the embedded peaks and S-surface meshes in Blender five ways, and spot.

In one Blender process (bpy), each mesh is unwrapped through the operators: Isometric
Unwrap with its default refinement and without it (the paper's method), and Blender's
MINIMUM_STRETCH, ANGLE_BASED and CONFORMAL. Then spot the cow (a real model, closed, no
seams marked; public domain, Keenan Crane) by Isometric Unwrap, Smart UV Project and
Unwrap (Conformal). Writes to ``out/demo/``:

* ``results.md``: time (median of runs), residual variance of edge lengths, relative RMS
  edge error, L2 / Linf stretch, flips;
* ``<mesh>_layouts.png``: the UV layouts side by side (folded triangles in red);
* ``<mesh>_stretch.png``: the same layouts as stretch heat maps, in the colours of the
  viewport's Show UV Stretch;
* ``<mesh>_renders.png``: the checker-textured renders (Cycles, CPU) side by side;
* ``spot_renders.png`` and ``spot_layouts.png``: spot by the three one-click methods, the
  seams each made drawn on the model in red, and their UV layouts.

Run through ``bash scripts/demo.sh``, which sets up the environment first.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np

import isoparam_addon
from isoparam_addon.solver import metrics
from isoparam_eval import meshes as ex
from isoparam_eval.blender import (
    METHODS,
    add_mesh,
    add_seam_lines,
    available,
    bpy,
    edit,
    read_uvs,
    render,
    seams_of_islands,
)
from isoparam_eval.figures import draw_layout, draw_stretch, stretch_key

ROOT = Path(__file__).resolve().parent.parent

MESHES = {  # file stem: (title, mesh, camera elevation)
    "peaks": ("peaks 41x41, z/3 (1681 vertices)", lambda: ex.peaks(41), 0.9),
    "s_regular": ("S-surface, regular (600 vertices)", lambda: ex.s_surface(50, 12)[:2], 0.35),
    "s_random": ("S-surface, random Delaunay (600 vertices)", lambda: ex.s_surface_random(600, 3)[:2], 0.35),
}
ORDER = [
    m
    for m in ["isoparam", "isoparam, Refinement 0", "MINIMUM_STRETCH", "ANGLE_BASED", "CONFORMAL"]
    if available(m)  # (MINIMUM_STRETCH: Blender 4.3 on)
]
SPOT_ORDER = {"isoparam": "Isometric Unwrap", "SMART_UV": "Smart UV Project", "CONFORMAL": "Unwrap (Conformal)"}
TABLE_HEAD = [
    "| mesh | method | time (ms) | residual variance (best scale) | edge RMS | L2 stretch | Linf stretch | flips |",
    "|---|---|---|---|---|---|---|---|",
]
TABLE_NOTE = [
    "",
    "Linf is Sander et al.'s worst stretch (the largest singular value of the UV-to-3D map) at the",
    "layout's best scale; the heat maps' 'worst' is max(sigma1, 1/sigma2) per face at the scale that",
    "gives the UVs the mesh's area (as Show UV Stretch colours it), so the two differ.",
]


def scaled_residual_variance(V, F, cuv) -> float:
    """The paper's residual variance after the best global scale (Blender packs into [0, 1])."""
    l3, l2 = metrics.uv_edge_lengths(V, F, cuv)
    s = float((l2 * l3).sum() / max((l2 * l2).sum(), 1e-300))
    return float(np.var(s * l2 - l3))


def main(argv=None) -> int:
    """Unwrap every mesh of MESHES every way of ORDER, then spot; write the table and figures."""
    args = _parse(argv)
    out = (ROOT / args.out).resolve()
    out.mkdir(parents=True, exist_ok=True)
    isoparam_addon.register()
    lines = list(TABLE_HEAD)
    for stem, (title, make, elevation) in MESHES.items():
        V, F = make()
        layouts, rows = _unwrap_every_way(out, args, stem, title, V, F, elevation)
        lines += rows
        _save_layouts(out, stem, title, layouts)
        _save_stretch(out, stem, title, V, layouts)
        if not args.no_render:
            _save_renders(out, stem, title)
    lines += _spot(out, args)
    _report(out, lines + TABLE_NOTE)
    return 0


def _parse(argv):
    """The command line's options."""
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--out", default="out/demo")
    ap.add_argument("--repeat", type=int, default=5, help="timed runs per method")
    ap.add_argument("--samples", type=int, default=16, help="Cycles samples per render")
    ap.add_argument("--no-render", action="store_true")
    return ap.parse_args(argv)


def _unwrap_every_way(out: Path, args, stem: str, title: str, V, F, elevation: float):
    """One mesh by every method of ORDER: its layouts (Ft, cuv, folded, distortion) by method, and its table rows."""
    layouts, rows = {}, []
    for method in ORDER:
        ob, seconds = _timed_unwrap(stem, V, F, method, args.repeat)
        Ft, cuv = read_uvs(ob)
        d = metrics.distortion(V, Ft, cuv)
        layouts[method] = (Ft, cuv, _folded(cuv, d.flipped), d)
        rows.append(
            f"| {title} | {method} | {1e3 * seconds:.1f} | "
            f"{scaled_residual_variance(V, Ft, cuv):.3e} | {d.edge_rms:.3f} | {d.stretch_l2:.3f} | "
            f"{d.stretch_linf:.2f} | {d.flipped} |"
        )
        if not args.no_render:
            render(ob, out / f"render_{stem}_{ORDER.index(method)}.png", elevation, args.samples)
        print(f"{title:45s} {method:16s} done", file=sys.stderr, flush=True)
    return layouts, rows


def _timed_unwrap(stem: str, V, F, method: str, repeat: int):
    """The mesh in a fresh scene, unwrapped by ``method``: the object and the median seconds of ``repeat`` runs."""
    bpy.ops.wm.read_homefile(use_empty=True)
    ob = add_mesh(stem, V, F)
    edit(ob)
    METHODS[method]()  # warm-up
    times = []
    for _ in range(repeat):  # timed runs through the operator
        t = time.perf_counter()
        METHODS[method]()
        times.append(time.perf_counter() - t)
    bpy.ops.object.mode_set(mode="OBJECT")
    return ob, np.median(times)


def _folded(cuv, flipped: int):
    """Faces (m,) bool folded against the layout's usual orientation (none when ``flipped`` is 0)."""
    if not flipped:
        return np.zeros(len(cuv), dtype=bool)
    q1, q2 = cuv[:, 1] - cuv[:, 0], cuv[:, 2] - cuv[:, 0]
    signed = q1[:, 0] * q2[:, 1] - q1[:, 1] * q2[:, 0]
    return np.sign(signed) != np.sign(np.median(signed))


def _save_layouts(out: Path, stem: str, title: str, layouts: dict) -> None:
    """Write ``<stem>_layouts.png``: the UV layouts side by side, folded triangles in red."""
    fig, axes = plt.subplots(1, len(ORDER), figsize=(4.2 * len(ORDER), 4.4))
    for ax, method in zip(axes, ORDER):
        Ft, cuv, folded, d = layouts[method]
        draw_layout(ax, Ft, cuv, folded, f"{method}\nedge RMS {d.edge_rms:.3f}, L2 {d.stretch_l2:.2f}")
    fig.suptitle(title)
    fig.tight_layout()
    fig.savefig(out / f"{stem}_layouts.png", dpi=100)
    plt.close(fig)


def _save_stretch(out: Path, stem: str, title: str, V, layouts: dict) -> None:
    """Write ``<stem>_stretch.png``: the layouts as stretch heat maps, in the viewport's colours (Show UV Stretch)."""
    fig, axes = plt.subplots(1, len(ORDER), figsize=(4.4 * len(ORDER), 4.4))
    for ax, method in zip(axes, ORDER):
        Ft, cuv, _, _ = layouts[method]
        d, (worst, mean, _) = metrics.face_stretch(V, Ft, cuv)
        rgba = metrics.stretch_colours(d)
        draw_stretch(ax, Ft, cuv, rgba, f"{method}\nstretch worst {worst:.2f}, mean {mean:.3f}")
    stretch_key(fig, axes[-1], metrics.stretch_colours)
    fig.suptitle(f"{title}: stretch per face in UV space")
    fig.tight_layout()
    fig.savefig(out / f"{stem}_stretch.png", dpi=100)
    plt.close(fig)


def _save_renders(out: Path, stem: str, title: str) -> None:
    """Write ``<stem>_renders.png``: the checker renders of every method side by side."""
    fig, axes = plt.subplots(1, len(ORDER), figsize=(4.2 * len(ORDER), 3.5))
    for ax, method in zip(axes, ORDER):
        ax.imshow(plt.imread(out / f"render_{stem}_{ORDER.index(method)}.png"))
        ax.set_title(method, fontsize=10)
        ax.axis("off")
    fig.suptitle(f"{title}: checker texture through each method's UVs (Cycles)")
    fig.tight_layout()
    fig.savefig(out / f"{stem}_renders.png", dpi=100)
    plt.close(fig)


def _report(out: Path, lines: list[str]) -> None:
    """Write the table to ``results.md`` and print it, with the list of files written."""
    table = "\n".join(lines)
    (out / "results.md").write_text(table + "\n")
    print(table)
    print(
        f"\nwrote {out}/results.md, *_layouts.png (UV layouts), *_stretch.png (stretch heat maps in UV"
        " space), *_renders.png (checker renders) and spot_renders.png / spot_layouts.png (spot, no seams:"
        " renders with the seams in red, and the layouts)"
    )


def _spot(out: Path, args) -> list[str]:
    """Spot, closed and without seams, by the three one-click methods: their table rows,
    and (unless ``--no-render``) renders with the seams on the model, and the layouts."""
    V, F, _ = ex.load_obj(ex.SPOT)
    V = V[:, [0, 2, 1]] * [1.0, -1.0, 1.0]  # the file's y up -> Blender's z up
    rows, layouts = [], {}
    for k, (method, title) in enumerate(SPOT_ORDER.items()):
        bpy.ops.wm.read_homefile(use_empty=True)
        ob = add_mesh("spot", V, F)
        edit(ob)
        t = time.perf_counter()
        METHODS[method]()
        seconds = time.perf_counter() - t
        bpy.ops.object.mode_set(mode="OBJECT")
        Ft, cuv = read_uvs(ob)
        label = metrics.uv_islands(Ft, cuv)
        per = metrics.per_island(V, Ft, cuv, label)
        seams = seams_of_islands(ob)
        l3, _ = metrics.uv_edge_lengths(V, Ft, cuv)
        every = metrics.uv_edge_lengths(V, Ft, np.zeros_like(cuv))[0].sum()
        failed = per.n_islands == len(Ft)  # every face alone: Unwrap failed (on a closed mesh)
        layouts[title] = (Ft, cuv, per, failed)
        rows.append(
            f"| spot, closed, no seams (2930 vertices) | {title} | {1e3 * seconds:.0f} | islands {per.n_islands} | "
            f"seams {100 * (l3.sum() - every) / every:.1f}% of edge length | symmetric Dirichlet per island "
            f"{per.mean_symmetric_dirichlet:.3f} | Linf {per.worst_stretch:.2f} | {int(per.flipped.sum())} |"
        )
        if not args.no_render:
            if not failed:
                add_seam_lines(ob, seams, radius=0.004)
            render(ob, out / f"render_spot_{k}.png", 0.3, 2 * args.samples, (640, 480), 1.3, checker=12, distance=1.15)
        print(f"spot {title:20s} done", file=sys.stderr, flush=True)
    fig, axes = plt.subplots(1, len(layouts), figsize=(4.2 * len(layouts), 4.4))
    for ax, (title, (Ft, cuv, per, failed)) in zip(axes, layouts.items()):
        draw_layout(
            ax,
            Ft,
            cuv,
            None,
            f"{title}\n" + ("failed: every UV on one point" if failed else f"{per.n_islands} islands"),
        )
    fig.suptitle("spot, closed, no seams: UV layouts")
    fig.tight_layout()
    fig.savefig(out / "spot_layouts.png", dpi=100)
    plt.close(fig)
    if not args.no_render:
        fig, axes = plt.subplots(1, len(layouts), figsize=(4.2 * len(layouts), 3.5))
        for k, (ax, (title, (_, _, per, failed))) in enumerate(zip(axes, layouts.items())):
            ax.imshow(plt.imread(out / f"render_spot_{k}.png"))
            ax.set_title(f"{title}: " + ("failed (closed mesh)" if failed else f"{per.n_islands} islands"), fontsize=11)
            ax.axis("off")
        fig.suptitle("spot, closed, no seams marked: a checker through each method's UVs, seams in red")
        fig.tight_layout()
        fig.savefig(out / "spot_renders.png", dpi=100)
        plt.close(fig)
    return rows


if __name__ == "__main__":
    raise SystemExit(main())
