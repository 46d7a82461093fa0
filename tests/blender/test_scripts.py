"""The scripts people run (demo, paper reproduction, comparison) still run, end to end, in
their quickest settings: a change of the solver's records must not leave them broken."""

import os
import subprocess
import sys
from pathlib import Path

from .conftest import bpy  # noqa: F401 - skips this module without bpy

ROOT = Path(__file__).resolve().parents[2]


def _run(script: str, *args) -> str:
    done = subprocess.run(
        [sys.executable, str(ROOT / "scripts" / script), *map(str, args)],
        capture_output=True,
        text=True,
        timeout=900,
        cwd=ROOT,
        env={**os.environ, "PYTHONPATH": os.pathsep.join([str(ROOT), os.environ.get("PYTHONPATH", "")])},
    )
    assert done.returncode == 0, done.stdout[-2000:] + done.stderr[-2000:]
    return done.stdout


def test_the_demo_runs(tmp_path):
    out = _run("demo.py", "--no-render", "--repeat", "1", "--out", tmp_path)
    assert "| spot, closed, no seams (2930 vertices) | Isometric Unwrap |" in out
    for name in ("results.md", "peaks_layouts.png", "peaks_stretch.png", "spot_layouts.png"):
        assert (tmp_path / name).exists(), name


def test_the_paper_reproduction_runs(tmp_path):
    _run("reproduce_paper.py", "--quick", "--out", tmp_path)
    assert (tmp_path / "results.md").exists()


def test_the_comparison_with_blender_runs(tmp_path):
    out = _run("compare_blender.py", "--meshes", "peaks41", "--repeat", "1", "--out", tmp_path)
    assert "| isoparam | " in out and "| CONFORMAL | " in out


def test_the_profile_charges_the_whole_solve_to_its_stages():
    import re

    for extra in ((), ("--operator",)):
        out = _run("profile.py", "tests/data/spot.obj", *extra)
        total = float(re.search(r"seams none: ([0-9.]+) s", out).group(1))
        steps = out.split("| step (every solve) |")[1].split("\n\n")[0]
        seconds = [float(m) for m in re.findall(r"^\| [^|]+ \| ([0-9.]+) \|", steps, re.M)]
        assert "| refinement |" in steps and "| embedding |" in steps
        # every second from the first report to the last belongs to a stage (none lost)
        assert 0.8 * total <= sum(seconds) <= total + 0.01
