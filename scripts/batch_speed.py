"""Files per minute of the batch job, run by run: local processes against a Dask cluster.

Each mode unwraps the same files into a fresh folder with the operator's defaults (OBJ
out); the modes run interleaved, round after round, so that the machine's drift touches
each alike, and the table gives the median wall time of ``--repeat`` rounds (the process
start, bpy imports and, for Dask, the cluster's start included: what a user waits for).

    python scripts/batch_speed.py                                   # ../shared/meshes
    python scripts/batch_speed.py models/*.obj --modes "--jobs 1" "--scheduler local:2" --repeat 5
"""

from __future__ import annotations

import argparse
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from isoparam_eval import meshes as ex

SCRIPT = Path(__file__).resolve().parent / "batch_unwrap.py"
MODES = ["--jobs 1", "--jobs 2", "--scheduler local:1", "--scheduler local:2"]


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("files", nargs="*", type=Path, help="meshes (default: those of ../shared/meshes)")
    ap.add_argument("--modes", nargs="+", default=MODES, help="batch_unwrap options per mode")
    ap.add_argument("--repeat", type=int, default=3)
    args = ap.parse_args(argv)
    files = args.files or sorted(ex.SHARED.glob("*.obj")) or [ex.SPOT]
    seconds: dict[str, list[float]] = {m: [] for m in args.modes}
    with tempfile.TemporaryDirectory() as tmp:
        for r in range(args.repeat):
            for mode in args.modes:
                out = Path(tmp) / "out"
                shutil.rmtree(out, ignore_errors=True)
                t0 = time.perf_counter()
                done = subprocess.run(
                    [sys.executable, str(SCRIPT), *map(str, files), "-o", str(out), *mode.split()],
                    capture_output=True,
                    text=True,
                )
                seconds[mode].append(time.perf_counter() - t0)
                if done.returncode != 0:
                    print(f"{mode}: exit {done.returncode}\n{done.stderr[-2000:]}", file=sys.stderr)
                    return 1
                print(f"round {r + 1}, {mode}: {seconds[mode][-1]:.1f} s", file=sys.stderr)
    base = statistics.median(seconds[args.modes[0]])
    print(f"{len(files)} files, median of {args.repeat} rounds\n")
    print("| mode | wall time (s) | files per minute | against the first |")
    print("|---|---|---|---|")
    for mode in args.modes:
        t = statistics.median(seconds[mode])
        print(f"| `{mode}` | {t:.1f} | {60 * len(files) / t:.1f} | {base / t:.2f}x |")
    return 0


if __name__ == "__main__":
    sys.exit(main())
