"""A run of Isometric Unwrap returns its record (:func:`unwrap.run`); the operator reports
its words and leaves it on the window manager, where scripts read it back (real bpy)."""

import json

import numpy as np
import pytest

from isoparam_addon.blender import record, unwrap
from isoparam_addon.operation.options import OperatorOptions
from isoparam_addon.solver import Timings
from isoparam_eval import meshes as ex

from .conftest import add_mesh, bpy, corner_uvs, edit, object_mode, set_uvs_and_pins


def _box(name="box"):
    ob = add_mesh(name, *ex.box(4)[:2])
    edit(ob)
    return ob


def test_the_operator_reports_the_records_words_and_leaves_the_record_for_scripts(scene, capfd):
    _box()
    assert record.last_record(bpy.context) is None  # (nothing run since the file was loaded)
    capfd.readouterr()
    assert bpy.ops.uv.isometric_unwrap() == {"FINISHED"}
    printed = capfd.readouterr().out
    run = record.last_record(bpy.context)
    assert run.finished and run.reports
    for level, text in run.reports:  # what the operator said, word for word
        assert f"{level.capitalize()}: {text}" in printed
    assert run.reports[0] == ("INFO", run.reports[0][1]) and run.reports[0][1].startswith("Isometric Unwrap: ")
    assert len(run.solver) == 1 and isinstance(run.solver[0], Timings) and run.solver[0].total > 0
    assert 0 < run.read + run.solve + run.write <= run.total and 0 < run.coverage < 1
    # plain JSON too, for a script that does not import the add-on (an installed extension)
    assert json.loads(bpy.context.window_manager.isoparam_run_record)["coverage"] == run.coverage
    assert not hasattr(unwrap, "last_run")  # no module-level record


def test_a_refused_run_leaves_its_record_with_the_error(scene):
    _box()
    bpy.ops.mesh.select_all(action="DESELECT")
    with pytest.raises(RuntimeError, match="no faces selected"):  # (bpy.ops raises on an ERROR report)
        bpy.ops.uv.isometric_unwrap()
    run = record.last_record(bpy.context)
    assert not run.finished
    assert [level for level, _ in run.reports] == ["ERROR"] and "no faces selected" in run.reports[0][1]


def test_a_script_can_run_the_unwrap_and_get_its_record_without_the_operator(scene):
    ob = _box()
    assert bpy.ops.uv.isometric_unwrap() == {"FINISHED"}
    by_operator = record.last_record(bpy.context)
    object_mode()
    expected = corner_uvs(ob).copy()
    set_uvs_and_pins(ob, np.zeros_like(expected), np.zeros(len(expected), dtype=bool))  # (for run to change)
    edit(ob)
    run = unwrap.run(bpy.context, OperatorOptions())
    assert run.finished
    # the same words, but for the seconds at the end of the first
    assert [level for level, _ in run.reports] == [level for level, _ in by_operator.reports]
    assert run.reports[0][1].rsplit(", ", 1)[0] == by_operator.reports[0][1].rsplit(", ", 1)[0]
    assert run.reports[1:] == by_operator.reports[1:]
    object_mode()
    assert np.allclose(corner_uvs(ob), expected, rtol=0, atol=1e-6)
    # the operator's record stays the operator's: run() returns its own and stores nothing
    assert record.last_record(bpy.context) == by_operator


def test_the_record_survives_its_json(scene):
    _box()
    assert bpy.ops.uv.isometric_unwrap(refine=0, mark_seams=True) == {"FINISHED"}
    run = record.last_record(bpy.context)
    assert record.RunRecord.from_json(run.to_json()) == run
    assert record.RunRecord.from_json(json.dumps({"coverage": 0.5, "later": 1})).coverage == 0.5


def test_loading_a_file_clears_the_record(scene):
    _box()
    assert bpy.ops.uv.isometric_unwrap() == {"FINISHED"}
    assert record.last_record(bpy.context) is not None
    bpy.ops.wm.read_homefile(use_empty=True)
    assert record.last_record(bpy.context) is None


def test_unregistering_the_addon_removes_the_property_and_registering_brings_it_back(scene):
    import isoparam_addon

    isoparam_addon.unregister()
    try:
        assert not hasattr(bpy.context.window_manager, "isoparam_run_record")
    finally:
        isoparam_addon.register()
    _box()
    assert bpy.ops.uv.isometric_unwrap() == {"FINISHED"}
    assert record.last_record(bpy.context).finished
