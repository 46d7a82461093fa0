"""The default Isometric Unwrap, and xatlas beside it, on every mesh of a folder.

The folder is by default the corpus of public real meshes named in
``isoparam_eval.corpus.MANIFEST`` (scans open and closed, CAD parts, quad and low-poly
models, many parts, high genus; see docs/corpus.md), cached in ``$ISOPARAM_CORPUS`` or
``~/.cache/isoparam-corpus``; ``--fill`` copies it there first (from ``/work/.mirror``
when that has the repositories, else from GitHub). Any folder of OBJ, OFF, PLY and STL
files works the same way.

Each mesh is unwrapped whole, no seams marked, in edit mode through the operator with
its default options (as ``scripts/real_meshes.py`` does, its measures too), and by
xatlas from the same arrays. One markdown row per mesh: its topology (vertices used by
faces, Euler characteristic, boundary loops, edges with three faces or more, parts
connected through vertices), then per method the charts (UV islands), the symmetric
Dirichlet energy per island at its best scale (area-weighted; 4 is isometric), the
worst stretch (Linf), flipped faces, islands overlapping themselves, the seam length as
a share of all edge length, and the time (median of ``--repeat`` runs).

The table goes to stdout, Blender's log (the operator's reports) to stderr. A mesh
whose reading or unwrap raises gets its error in its row, and the run goes on.
The exit status is 1 if any mesh raised, or got a flipped face or an island overlapping
itself from Isometric Unwrap (xatlas's results are reported, not judged). Run it through
the benchmark environment (bpy and xatlas):

    bash scripts/bench.sh scripts/corpus.py --fill                     # fill the cache, then run it all
    bash scripts/bench.sh scripts/corpus.py /work/corpus-cache --repeat 1 --only fertility truck
    bash scripts/bench.sh scripts/corpus.py my_meshes/ --no-xatlas
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


def _unwrap(V, F, repeat: int, with_xatlas: bool) -> tuple[list[str], list[str], dict | None]:
    """The isoparam and xatlas cells of one mesh's row, and isoparam's measures (None if
    it raised)."""
    from real_meshes import measure, run_operator, run_xatlas  # beside this script (imports bpy)

    try:
        t, Ft, cuv = run_operator("isoparam", V, F, None, repeat)
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
    failed, over = [], []
    for path in files:  # one mesh at a time, each in a fresh scene
        try:
            V, F = corpus.load_mesh(path)
            facts = corpus.topology(F)
        except Exception as e:  # an unreadable file is a finding too
            print(f"| {path.stem} | **{type(e).__name__}: {_cell(str(e))}** |" + " - |" * 15, file=table, flush=True)
            failed.append(path.stem)
            continue
        ours, theirs, m = _unwrap(V, F, args.repeat, not args.no_xatlas)
        if m is None or m["flips"] or m["overlapping"]:
            failed.append(path.stem)
        if m is not None and m["sd"] > SD_LIMIT:
            over.append(f"{path.stem} ({m['sd']:.2f})")
        topo = [facts.vertices, facts.euler, facts.boundary_loops, facts.non_manifold_edges, facts.components]
        print("| " + " | ".join([path.stem, *map(str, topo), *ours, *theirs]) + " |", file=table, flush=True)
    print(
        f"\n{len(files)} meshes in {time.perf_counter() - start:.0f} s; "
        f"{len(over)} over SD {SD_LIMIT}: {', '.join(over) or 'none'}; "
        f"{len(failed)} raised, flipped or overlapping: {', '.join(failed) or 'none'}",
        file=table,
        flush=True,
    )
    return 1 if failed else 0


if __name__ == "__main__":
    raise SystemExit(main())
