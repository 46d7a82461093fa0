"""The default Isometric Unwrap, and xatlas beside it, on every mesh of a folder.

The folder is by default the corpus of public real meshes named in
``isoparam_eval.corpus.MANIFEST`` (scans open and closed, CAD parts, quad and low-poly
models, many parts, high genus; see docs/corpus.md), cached in ``$ISOPARAM_CORPUS`` or
``~/.cache/isoparam-corpus``; ``--fill`` copies it there first (from ``/work/.mirror``
when that has the repositories, else from GitHub). Any folder of OBJ, OFF, PLY and STL
files works the same way.

Each mesh is unwrapped whole, no seams marked (or, with ``--seams smart``, the seams of
Smart UV Project's islands, Blender's own, and no xatlas), in edit mode through the
operator with its default options (as ``scripts/real_meshes.py`` does, its measures too),
and by xatlas from the same arrays. One markdown row per mesh: its topology (vertices used by
faces, Euler characteristic, boundary loops, edges with three faces or more, parts
connected through vertices), then per method the charts (UV islands), the symmetric
Dirichlet energy per island at its best scale (area-weighted; 4 is isometric), the
worst stretch (Linf), flipped faces, islands overlapping themselves, the seam length as
a share of all edge length, and the time (median of ``--repeat`` runs).

The summary names the meshes whose mean SD is above 4.25, and those with an island
above it (with seams marked an island is what the artist's seams bound, and the budget
is its own; with none, every chart's, and one beyond it is warned of).
The table goes to stdout, Blender's log (the operator's reports) to stderr. A mesh
whose reading or unwrap raises gets its error in its row, and the run goes on.
The exit status is 1 if any mesh raised, or got a flipped face or an island overlapping
itself from Isometric Unwrap (xatlas's results are reported, not judged). Run it through
the benchmark environment (bpy and xatlas):

    bash scripts/bench.sh scripts/corpus.py --fill                     # fill the cache, then run it all
    bash scripts/bench.sh scripts/corpus.py /work/corpus-cache --repeat 1 --only fertility truck
    bash scripts/bench.sh scripts/corpus.py my_meshes/ --no-xatlas
    bash scripts/bench.sh scripts/corpus.py --seams smart --repeat 1   # Smart UV Project's islands
"""

from __future__ import annotations

import argparse
import os
import sys
import time
from pathlib import Path

DEFAULT_FOLDER = Path(os.environ.get("ISOPARAM_CORPUS") or Path.home() / ".cache" / "isoparam-corpus")
SD_LIMIT = 4.25  # a mean symmetric Dirichlet energy above this is listed in the summary

HEAD = (
    "| mesh | vertices | χ | boundary loops | non-manifold edges | parts "
    "| charts | SD | Linf | flips | overlapping | seam % | s "
    "| xatlas charts | SD | flips | s |"
)


def _cell(text: str) -> str:
    """An error message fit for a table cell: one line, no pipes, not too long."""
    text = " ".join(str(text).split()).replace("|", "/")
    return text if len(text) <= 160 else text[:157] + "..."


def _unwrap(V, F, repeat: int, with_xatlas: bool, smart: bool) -> tuple[list[str], list[str], dict | None]:
    """The isoparam and xatlas cells of one mesh's row, and isoparam's measures (None if
    it raised); ``smart``: with Smart UV Project's seams."""
    from real_meshes import measure, run_operator, run_xatlas  # beside this script (imports bpy)

    from isoparam_eval.blender import smart_uv_seams

    try:
        t, Ft, cuv = run_operator("isoparam", V, F, smart_uv_seams(V, F) if smart else None, repeat)
        m = measure(V, Ft, cuv)
        ours = [
            str(m["islands"]),
            f"{m['sd']:.3f}",
            f"{m['linf']:.2f}",
            str(m["flips"]),
            str(m["overlapping"]),
            f"{m['seam']:.1f}",
            f"{t:.2f}",
        ]
    except Exception as e:  # any failure is a finding: report it in the row and go on
        m = None
        ours = [f"**{type(e).__name__}: {_cell(str(e))}**"] + ["-"] * 6
    theirs = ["-"] * 4
    if with_xatlas:
        try:
            t, Ft, cuv = run_xatlas(V, F, repeat)
            x = measure(V, Ft, cuv)
            theirs = [str(x["islands"]), f"{x['sd']:.3f}", str(x["flips"]), f"{t:.2f}"]
        except Exception as e:  # reported, not judged
            theirs = [f"{type(e).__name__}: {_cell(str(e))}"] + ["-"] * 3
    return ours, theirs, m


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("folder", nargs="?", type=Path, default=DEFAULT_FOLDER, help=f"default: {DEFAULT_FOLDER}")
    ap.add_argument("--fill", action="store_true", help="first copy the corpus's meshes into the folder")
    ap.add_argument("--no-xatlas", action="store_true", help="Isometric Unwrap only")
    ap.add_argument("--repeat", type=int, default=3, help="timed runs per method and mesh (median)")
    ap.add_argument("--only", nargs="+", metavar="NAME", help="only these meshes (file names without suffix)")
    ap.add_argument("--seams", choices=["none", "smart"], default="none", help="smart: Smart UV Project's islands")
    args = ap.parse_args(argv)

    from isoparam_eval import corpus

    if args.fill:
        corpus.fill_cache(args.folder)
    files = sorted(p for p in args.folder.glob("*") if p.suffix.lower() in corpus.MESH_SUFFIXES)
    if args.only:
        missing = sorted(set(args.only) - {p.stem for p in files})
        if missing:
            print(f"not in {args.folder}: {', '.join(missing)}", file=sys.stderr)
            return 2
        files = [p for p in files if p.stem in args.only]
    if not files:
        print(f"no OBJ, OFF, PLY or STL file in {args.folder} (fill it with --fill)", file=sys.stderr)
        return 2

    # the table to stdout; Blender's log (the operator's reports, printed by C) to stderr
    table = os.fdopen(os.dup(1), "w")
    os.dup2(2, 1)
    sys.stdout = sys.stderr
    import isoparam_addon

    isoparam_addon.register()
    print(HEAD, file=table)
    print("|" + "---|" * (HEAD.count("|") - 1), file=table, flush=True)
    start = time.perf_counter()
    failed, over, island_over = [], [], []
    for path in files:  # one mesh at a time, each in a fresh scene
        try:
            V, F = corpus.load_mesh(path)
            facts = corpus.topology(F)
        except Exception as e:  # an unreadable file is a finding too
            print(f"| {path.stem} | **{type(e).__name__}: {_cell(str(e))}** |" + " - |" * 15, file=table, flush=True)
            failed.append(path.stem)
            continue
        smart = args.seams == "smart"
        ours, theirs, m = _unwrap(V, F, args.repeat, not (args.no_xatlas or smart), smart)
        if m is None or m["flips"] or m["overlapping"]:
            failed.append(path.stem)
        if m is not None and m["sd"] > SD_LIMIT:
            over.append(f"{path.stem} ({m['sd']:.2f})")
        if m is not None and m["worst"] > SD_LIMIT:
            island_over.append(f"{path.stem} ({m['worst']:.2f})")
        topo = [facts.vertices, facts.euler, facts.boundary_loops, facts.non_manifold_edges, facts.components]
        print("| " + " | ".join([path.stem, *map(str, topo), *ours, *theirs]) + " |", file=table, flush=True)
    print(
        f"\n{len(files)} meshes in {time.perf_counter() - start:.0f} s; "
        f"{len(over)} over SD {SD_LIMIT}: {', '.join(over) or 'none'}; "
        f"{len(island_over)} with an island over it: {', '.join(island_over) or 'none'}; "
        f"{len(failed)} raised, flipped or overlapping: {', '.join(failed) or 'none'}",
        file=table,
        flush=True,
    )
    return 1 if failed else 0


if __name__ == "__main__":
    raise SystemExit(main())
