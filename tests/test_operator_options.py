"""The operator's preset (isoparam_addon/operation/options.py) without Blender: the solver
options it derives carry its values. (That it imports no bpy is tests/test_operation.py's;
that the redo panel's defaults are the preset's, tests/blender/test_operator_options.py's.)"""

from dataclasses import fields
from pathlib import Path

import pytest

from isoparam_addon.operation.options import DEFAULTS, OperatorOptions
from isoparam_addon.solver import Options

ROOT = Path(__file__).resolve().parent.parent
CHANGED = OperatorOptions(refine=0, charts=False, chart_disks=True, max_stretch=1.5, extra_cuts=0, split_overlaps=False)


@pytest.mark.parametrize("opts", [DEFAULTS, CHANGED], ids=["defaults", "changed"])
def test_the_solver_is_given_the_operators_values(opts):
    solver = opts.solver_options()
    shared = {f.name for f in fields(OperatorOptions)} & {f.name for f in fields(Options)}
    assert shared >= {"refine", "charts", "chart_disks", "max_stretch", "extra_cuts", "split_overlaps"}
    for name in shared - {"pack", "margin"}:  # (the operator packs and spaces islands in UV space itself)
        assert getattr(solver, name) == getattr(opts, name), name
    assert solver.pack and solver.unfold and solver.split_nonmanifold
