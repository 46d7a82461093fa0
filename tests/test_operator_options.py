"""The operator's preset (isoparam_addon/operator_options.py) without Blender: it imports
no bpy, and the solver options it derives carry its values. (That the redo panel's
defaults are the preset's is tests/blender/test_operator_options.py's.)"""

import subprocess
import sys
from dataclasses import fields
from pathlib import Path

import pytest

from isoparam_addon.operator_options import DEFAULTS, OperatorOptions
from isoparam_addon.solver import Options

ROOT = Path(__file__).resolve().parent.parent
CHANGED = OperatorOptions(refine=0, charts=False, chart_disks=True, max_stretch=1.5, extra_cuts=0, split_overlaps=False)


def test_the_preset_imports_no_blender_module():
    blender = "{'bpy', 'bmesh', 'mathutils'}"
    code = f"import sys, isoparam_addon.operator_options\nprint(sorted({blender} & set(sys.modules)))"
    done = subprocess.run([sys.executable, "-c", code], cwd=ROOT, capture_output=True, text=True, check=True)
    assert done.stdout.strip() == "[]"


@pytest.mark.parametrize("opts", [DEFAULTS, CHANGED], ids=["defaults", "changed"])
def test_the_solver_is_given_the_operators_values(opts):
    solver = opts.solver_options()
    shared = {f.name for f in fields(OperatorOptions)} & {f.name for f in fields(Options)}
    assert shared >= {"refine", "charts", "chart_disks", "max_stretch", "extra_cuts", "split_overlaps"}
    for name in shared - {"pack", "margin"}:  # (the operator packs and spaces islands in UV space itself)
        assert getattr(solver, name) == getattr(opts, name), name
    assert solver.pack and solver.unfold and solver.split_nonmanifold
