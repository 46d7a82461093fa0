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
