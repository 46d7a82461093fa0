"""The demo: unwrap the embedded peaks and S-surface meshes in Blender, four ways.

In one Blender process (bpy), each mesh is unwrapped with Isometric Unwrap and with
Blender's ANGLE_BASED, CONFORMAL and MINIMUM_STRETCH through their operators. Writes
to ``out/demo/``:

* ``results.md``: time (median of runs), residual variance of edge lengths, relative RMS
  edge error, L2 / Linf stretch, flips;
* ``<mesh>_layouts.png``: the four UV layouts side by side (folded triangles in red);
* ``<mesh>_renders.png``: the four checker-textured renders (Cycles, CPU) side by side.

Run through ``bash scripts/demo.sh``, which sets up the environment first.
"""

from __future__ import annotations

import argparse
import os
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "scripts"))
os.environ.setdefault("BLENDER_USER_RESOURCES", tempfile.mkdtemp(prefix="isoparam-demo-"))

import bpy  # noqa: E402
import matplotlib.pyplot as plt  # noqa: E402
from compare_blender import METHODS, add_object, edit, read_uvs  # noqa: E402
from figures import draw_layout  # noqa: E402

import isoparam_addon  # noqa: E402
from isoparam_addon.solver import examples as ex  # noqa: E402
from isoparam_addon.solver import metrics  # noqa: E402

MESHES = {  # file stem: (title, mesh, camera elevation)
    "peaks": ("peaks 41x41, z/3 (1681 vertices)", lambda: ex.peaks(41), 0.9),
    "s_regular": ("S-surface, regular (600 vertices)", lambda: ex.s_surface(50, 12)[:2], 0.35),
    "s_random": ("S-surface, random Delaunay (600 vertices)", lambda: ex.s_surface_random(600, 3)[:2], 0.35),
}
ORDER = ["isoparam", "MINIMUM_STRETCH", "ANGLE_BASED", "CONFORMAL"]


def scaled_residual_variance(V, F, cuv) -> float:
    """The paper's residual variance after the best global scale (Blender packs into [0, 1])."""
    l3, l2 = metrics.edge_lengths(V, F, cuv)
    s = float((l2 * l3).sum() / max((l2 * l2).sum(), 1e-300))
    return float(np.var(s * l2 - l3))


def checker_material():
    mat = bpy.data.materials.new("checker")
    if bpy.app.version < (5, 0, 0):  # always on from 5.0
        mat.use_nodes = True
    nodes, links = mat.node_tree.nodes, mat.node_tree.links
    bsdf = next(n for n in nodes if n.type == "BSDF_PRINCIPLED")
    coords = nodes.new("ShaderNodeTexCoord")
    checker = nodes.new("ShaderNodeTexChecker")
    checker.inputs["Scale"].default_value = 24.0
    checker.inputs["Color1"].default_value = (0.92, 0.92, 0.92, 1.0)
    checker.inputs["Color2"].default_value = (0.08, 0.25, 0.65, 1.0)
    links.new(coords.outputs["UV"], checker.inputs["Vector"])
    links.new(checker.outputs["Color"], bsdf.inputs["Base Color"])
    return mat


def render(ob, path: Path, elevation: float, samples: int) -> None:
    """A checker-textured Cycles render (CPU) of ``ob``, framed from above at an angle."""
    scene = bpy.context.scene
    scene.render.engine = "CYCLES"
    scene.cycles.device = "CPU"
    scene.cycles.samples = samples
    scene.cycles.use_denoising = False
    scene.render.resolution_x, scene.render.resolution_y = 480, 360
    scene.render.film_transparent = False
    ob.data.materials.clear()
    ob.data.materials.append(checker_material())
    lo = np.array([min(v[i] for v in ob.bound_box) for i in range(3)])
    hi = np.array([max(v[i] for v in ob.bound_box) for i in range(3)])
    centre, radius = (lo + hi) / 2, float(np.linalg.norm(hi - lo)) / 2
    cam_data = bpy.data.cameras.new("cam")
    cam = bpy.data.objects.new("cam", cam_data)
    scene.collection.objects.link(cam)
    cam.location = centre + radius * np.array([1.3, -1.6, 2.2 * elevation + 0.4])
    target = bpy.data.objects.new("target", None)
    scene.collection.objects.link(target)
    target.location = centre
    track = cam.constraints.new("TRACK_TO")
    track.target = target
    scene.camera = cam
    sun = bpy.data.objects.new("sun", bpy.data.lights.new("sun", "SUN"))
    sun.data.energy = 3.0
    sun.rotation_euler = (0.6, 0.2, 0.8)
    scene.collection.objects.link(sun)
    if scene.world is None:
        scene.world = bpy.data.worlds.new("world")
    scene.world.color = (0.35, 0.35, 0.38)
    scene.render.filepath = str(path)
    bpy.ops.render.render(write_still=True)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--out", default="out/demo")
    ap.add_argument("--repeat", type=int, default=5, help="timed runs per method")
    ap.add_argument("--samples", type=int, default=16, help="Cycles samples per render")
    ap.add_argument("--no-render", action="store_true")
    args = ap.parse_args(argv)
    out = (ROOT / args.out).resolve()
    out.mkdir(parents=True, exist_ok=True)
    isoparam_addon.register()
    lines = [
        "| mesh | method | time (ms) | residual variance (best scale) | edge RMS | L2 stretch | Linf stretch | flips |",
        "|---|---|---|---|---|---|---|---|",
    ]
    for stem, (title, make, elevation) in MESHES.items():
        V, F = make()
        layouts = {}
        for method in ORDER:
            bpy.ops.wm.read_homefile(use_empty=True)
            ob = add_object(stem, V, F)
            edit(ob)
            METHODS[method]()  # warm-up
            times = []
            for _ in range(args.repeat):  # timed runs through the operator
                t = time.perf_counter()
                METHODS[method]()
                times.append(time.perf_counter() - t)
            bpy.ops.object.mode_set(mode="OBJECT")
            Ft, cuv = read_uvs(ob)
            d = metrics.distortion(V, Ft, cuv)
            folded = np.zeros(len(Ft), dtype=bool)
            if d["flipped"]:
                q1, q2 = cuv[:, 1] - cuv[:, 0], cuv[:, 2] - cuv[:, 0]
                signed = q1[:, 0] * q2[:, 1] - q1[:, 1] * q2[:, 0]
                folded = np.sign(signed) != np.sign(np.median(signed))
            layouts[method] = (Ft, cuv, folded, d)
            lines.append(
                f"| {title} | {method} | {1e3 * np.median(times):.1f} | "
                f"{scaled_residual_variance(V, Ft, cuv):.3e} | {d['edge_rms']:.3f} | {d['stretch_l2']:.3f} | "
                f"{d['stretch_linf']:.2f} | {d['flipped']} |"
            )
            if not args.no_render:
                render(ob, out / f"render_{stem}_{method}.png", elevation, args.samples)
            print(f"{title:45s} {method:16s} done", file=sys.stderr, flush=True)
        fig, axes = plt.subplots(1, len(ORDER), figsize=(4.2 * len(ORDER), 4.4))
        for ax, method in zip(axes, ORDER):
            Ft, cuv, folded, d = layouts[method]
            draw_layout(ax, Ft, cuv, folded, f"{method}\nedge RMS {d['edge_rms']:.3f}, L2 {d['stretch_l2']:.2f}")
        fig.suptitle(title)
        fig.tight_layout()
        fig.savefig(out / f"{stem}_layouts.png", dpi=100)
        plt.close(fig)
        if not args.no_render:
            fig, axes = plt.subplots(1, len(ORDER), figsize=(4.2 * len(ORDER), 3.5))
            for ax, method in zip(axes, ORDER):
                ax.imshow(plt.imread(out / f"render_{stem}_{method}.png"))
                ax.set_title(method, fontsize=10)
                ax.axis("off")
            fig.suptitle(f"{title}: checker texture through each method's UVs (Cycles)")
            fig.tight_layout()
            fig.savefig(out / f"{stem}_renders.png", dpi=100)
            plt.close(fig)
    table = "\n".join(lines)
    (out / "results.md").write_text(table + "\n")
    print(table)
    print(f"\nwrote {out}/results.md, *_layouts.png (UV layouts) and *_renders.png (checker renders)")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
