"""The solver of two revisions of this repository, side by side on the same meshes.

Each revision is checked out in a temporary git worktree; every run is a fresh process of
this Python with that tree first on ``sys.path``, and the runs alternate (old, new, old,
new, ...) so that the machine's drift touches both alike. The solver runs with the
operator's options, no seams (the defaults of the isoparam_addon this Python imports,
given to both as keywords: an older revision may have no preset to read); the table
gives per mesh and revision the median seconds, the charts (islands) and the symmetric
Dirichlet energy per island at its best scale (area-weighted), and the ratio of the
medians.

    python scripts/compare_revisions.py c975a22 HEAD --meshes spot fandisk homer --repeat 3
    python scripts/compare_revisions.py HEAD~1 --peaks 317    # peaks 317x317 (z/3) too
    python scripts/compare_revisions.py HEAD~1 --meshes /path/to/beast.obj
    python scripts/compare_revisions.py HEAD~1 --meshes /path/to/corpus/adis16480.stl
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import tempfile
from dataclasses import asdict
from pathlib import Path

import numpy as np

from isoparam_addon.operation.options import DEFAULTS
from isoparam_addon.solver.options import Options

ROOT = Path(__file__).resolve().parent.parent

_RUN = r"""
import json, sys, time
import numpy as np
from isoparam_addon.solver import metrics, parametrize
from isoparam_eval import meshes as ex
name = sys.argv[1]
if name.startswith("peaks"):
    V, F = ex.peaks(int(name[5:]))
elif name == "suzanne":
    V, F = ex.suzanne_closed()
elif name.endswith(".obj"):  # a mesh of one's own, by its path
    V, F = ex.load_obj(name)[:2]
elif name.lower().endswith((".off", ".ply", ".stl")):  # (the corpus's other formats)
    from isoparam_eval.corpus import load_mesh
    V, F = load_mesh(name)
else:
    V, F = ex.real_mesh(name)[:2] if name in ex.REAL else ex.load_obj(ex.SHARED / f"{name}.obj")[:2]
t = time.perf_counter()
r = parametrize(V, F, **json.loads(sys.argv[2]))
t = time.perf_counter() - t
sd = metrics.per_island(V, F, r.corner_uv, r.face_island).mean_symmetric_dirichlet
print(json.dumps({"s": t, "islands": int(r.n_islands), "sd": float(sd)}))
"""


def _operator_keywords() -> str:
    """The solver options the operator's defaults set apart from the solver's, as JSON."""
    ours, theirs = asdict(DEFAULTS.solver_options()), asdict(Options())
    return json.dumps({name: value for name, value in ours.items() if value != theirs[name]})


def _run(tree: Path, mesh: str) -> dict:
    done = subprocess.run(
        [sys.executable, "-c", f"import sys; sys.path.insert(0, {str(tree)!r})\n" + _RUN, mesh, _operator_keywords()],
        cwd=tree,
        capture_output=True,
        text=True,
        check=True,
    )
    return json.loads(done.stdout.strip().splitlines()[-1])


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("old", help="the revision to compare against")
    ap.add_argument("new", nargs="?", default=None, help="the revision to compare (default: the working tree)")
    ap.add_argument("--meshes", nargs="+", default=["spot", "fandisk", "homer", "suzanne", "stanford-bunny"])
    ap.add_argument("--peaks", nargs="*", type=int, default=[], help="peaks surfaces of these sizes (z/3)")
    ap.add_argument("--repeat", type=int, default=3)
    args = ap.parse_args(argv)
    meshes = [*args.meshes, *(f"peaks{n}" for n in args.peaks)]
    with tempfile.TemporaryDirectory(prefix="isoparam-compare-") as tmp:
        trees = {}
        for label, rev in (("old", args.old), ("new", args.new)):
            if rev is None:
                trees[label] = ROOT
                continue
            path = Path(tmp) / label
            subprocess.run(
                ["git", "worktree", "add", "--detach", str(path), rev], cwd=ROOT, check=True, capture_output=True
            )
            (path.parent / "shared").exists() or (path.parent / "shared").symlink_to(ROOT.parent / "shared")
            trees[label] = path
        try:
            print("| mesh | old s | new s | new / old | old charts / SD | new charts / SD |")
            print("|---|---|---|---|---|---|")
            for mesh in meshes:
                runs: dict[str, list[dict]] = {"old": [], "new": []}
                for _ in range(args.repeat):  # interleaved
                    for label in ("old", "new"):
                        runs[label].append(_run(trees[label], mesh))
                med = {k: float(np.median([r["s"] for r in v])) for k, v in runs.items()}
                quality = [f"{v[-1]['islands']} / {v[-1]['sd']:.3f}" for v in runs.values()]
                ratio = med["new"] / med["old"]
                print(
                    f"| {mesh} | {med['old']:.2f} | {med['new']:.2f} | {ratio:.2f} | {' | '.join(quality)} |",
                    flush=True,
                )
        finally:
            for path in trees.values():
                if path != ROOT:
                    subprocess.run(["git", "worktree", "remove", "--force", str(path)], cwd=ROOT, capture_output=True)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
