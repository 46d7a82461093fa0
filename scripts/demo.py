"""The demo: unwrap the embedded peaks and S-surface meshes and show the result.

Writes a markdown table and PNGs (UV layouts, checker views) into ``out/demo/``.
Run through ``bash scripts/demo.sh``, which sets up the environment first.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))
sys.path.insert(0, str(Path(__file__).resolve().parent))

from figures import layout_and_checker  # noqa: E402

from isoparam_addon.solver import examples as ex  # noqa: E402
from isoparam_addon.solver import parametrize  # noqa: E402

MESHES = {  # file name: (title, mesh)
    "peaks": ("peaks 41x41 (z/3)", lambda: ex.peaks(41)),
    "s_regular": ("S-surface, regular 600", lambda: ex.s_surface(50, 12)[:2]),
    "s_random": ("S-surface, random 600", lambda: ex.s_surface_random(600, 3)[:2]),
}


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--out", default="out/demo", help="output folder")
    args = ap.parse_args(argv)
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    rows = [
        "| mesh | vertices | time (ms) | residual variance | edge RMS | L2 stretch | Linf stretch | flips |",
        "|---|---|---|---|---|---|---|---|",
    ]
    for slug, (name, make) in MESHES.items():
        V, F = make()
        parametrize(V, F)  # warm-up
        times = []
        for _ in range(5):  # median of five runs
            t = time.perf_counter()
            r = parametrize(V, F)
            times.append(time.perf_counter() - t)
        d = r.distortion()
        rows.append(
            f"| {name} | {len(V)} | {1e3 * np.median(times):.1f} | {d['residual_variance']:.3e} | "
            f"{d['edge_rms']:.3g} | {d['stretch_l2']:.3f} | {d['stretch_linf']:.2f} | {d['flipped']} |"
        )
        layout_and_checker(out / f"{slug}.png", V, F, {"isoparam": (r.corner_uv, r.flipped)})
    table = "\n".join(rows)
    (out / "results.md").write_text(table + "\n")
    print(table)
    print(f"\nwrote {out.resolve()}/results.md and PNG layouts + checker views beside it")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
