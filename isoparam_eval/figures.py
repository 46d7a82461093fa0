"""Pictures for the demo and the benchmarks: UV layouts and checker-textured views (PNG).

matplotlib only, headless (Agg). The checker view colours each face by the checker
square under its UV centroid, so it needs faces smaller than a square; the Blender demo
renders the real thing with Cycles.
"""

from __future__ import annotations

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from matplotlib.collections import PolyCollection  # noqa: E402
from mpl_toolkits.mplot3d.art3d import Poly3DCollection  # noqa: E402


def _corner(F, uv):
    uv = np.asarray(uv)
    return uv if uv.ndim == 3 else uv[F]


def draw_layout(ax, F, uv, flipped=None, title=""):
    """Triangles of a UV layout; folded ones in red."""
    cuv = _corner(F, uv)
    colors = "none" if flipped is None else np.where(np.asarray(flipped), "#d62728", "none")
    ax.add_collection(PolyCollection(cuv, facecolors=colors, edgecolors="k", linewidths=0.15))
    ax.autoscale()
    ax.set_aspect("equal")
    ax.set_title(title, fontsize=9)
    ax.set_xticks([])
    ax.set_yticks([])


def draw_stretch(ax, F, uv, rgba, title=""):
    """A UV layout with every face filled by its stretch colour (``rgba`` (m, 4), the
    viewport's colours from isoparam_addon.solver.metrics.stretch_colours), with the colour key."""
    cuv = _corner(F, uv)
    ax.add_collection(PolyCollection(cuv, facecolors=rgba, edgecolors=(0, 0, 0, 0.15), linewidths=0.1))
    ax.autoscale()
    ax.set_aspect("equal")
    ax.set_title(title, fontsize=9)
    ax.set_xticks([])
    ax.set_yticks([])
    ax.set_facecolor("#d8d8d8")


def stretch_key(fig, ax, colours):
    """Colour bar for :func:`draw_stretch`: ``colours`` maps distortion (k,) to RGBA (k, 4)."""
    from matplotlib.cm import ScalarMappable
    from matplotlib.colors import ListedColormap, LogNorm

    cmap = ListedColormap(colours(2.0 ** np.linspace(0.0, 1.0, 256)))
    bar = fig.colorbar(ScalarMappable(LogNorm(1.0, 2.0), cmap), ax=ax, fraction=0.05, pad=0.02)
    bar.set_ticks([1.0, 1.25, 1.5, 2.0], labels=["1 (true scale)", "1.25", "1.5", "2+"])
    bar.set_label("stretch max(s1, 1/s2)", fontsize=8)


def checker_colors(F, uv, squares=12):
    """Face colours from a checker in UV space, squares sized to the layout's extent."""
    cuv = _corner(F, uv)
    c = cuv.mean(axis=1)
    size = max(np.ptp(cuv.reshape(-1, 2), axis=0).max(), 1e-300) / squares
    k = (np.floor(c[:, 0] / size) + np.floor(c[:, 1] / size)).astype(int) % 2
    return np.where(k[:, None] == 1, [0.92, 0.92, 0.92], [0.15, 0.35, 0.75])


def draw_checker(ax, V, F, uv, title="", squares=12, elev=35, azim=-60):
    """The mesh in 3D, each face coloured by the checker square under its UV centroid."""
    col = checker_colors(F, uv, squares)
    ax.add_collection3d(Poly3DCollection(V[F], facecolors=col, edgecolors="none", linewidths=0))
    lo, hi = V.min(axis=0), V.max(axis=0)
    mid, half = (lo + hi) / 2, (hi - lo).max() / 2
    ax.set_xlim(mid[0] - half, mid[0] + half)
    ax.set_ylim(mid[1] - half, mid[1] + half)
    ax.set_zlim(mid[2] - half, mid[2] + half)
    ax.view_init(elev=elev, azim=azim)
    ax.set_axis_off()
    ax.set_title(title, fontsize=9)


def layout_and_checker(path, V, F, layouts: dict, squares=12):
    """One row per method: its UV layout and its checker view, saved to ``path``."""
    n = len(layouts)
    fig = plt.figure(figsize=(8, 3.6 * n))
    for i, (name, (uv, flipped)) in enumerate(layouts.items()):
        draw_layout(fig.add_subplot(n, 2, 2 * i + 1), F, uv, flipped, f"{name}: UV layout")
        draw_checker(fig.add_subplot(n, 2, 2 * i + 2, projection="3d"), V, F, uv, f"{name}: checker", squares)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def draw_packed(ax, cuv, island, title=""):
    """A packed layout (corner UVs (t, 3, 2)) in the unit square, each island filled in a
    colour of its own, with the coverage in the title."""
    from isoparam_addon.solver import metrics

    colours = plt.cm.tab20(np.asarray(island) % 20)
    ax.add_collection(PolyCollection(cuv, facecolors=colours, edgecolors="none"))
    ax.add_patch(plt.Rectangle((0, 0), 1, 1, fill=False, edgecolor="k", linewidth=0.6))
    ax.set_xlim(-0.02, 1.02)
    ax.set_ylim(-0.02, 1.02)
    ax.set_aspect("equal")
    ax.set_title(f"{title}: {metrics.coverage(cuv):.0%}", fontsize=9)
    ax.set_xticks([])
    ax.set_yticks([])


def packed_side_by_side(path, rows: dict):
    """One row per mesh (``rows``: name -> {method: (corner UVs, island per face)}), one
    column per method, saved as a PNG at ``path``."""
    methods = list(next(iter(rows.values())))
    fig, axes = plt.subplots(len(rows), len(methods), figsize=(3 * len(methods), 3 * len(rows)), squeeze=False)
    for r, (name, layouts) in enumerate(rows.items()):
        for c, method in enumerate(methods):
            cuv, island = layouts[method]
            draw_packed(axes[r, c], cuv, island, f"{name}, {method}")
    fig.tight_layout()
    fig.savefig(path, dpi=90)
    plt.close(fig)
