"""Isometric Unwrap watched and stopped, through the real bpy module: the solve in a worker
thread (what the operator does when invoked from Blender's UI, :class:`background.Background`),
driven event by event as the modal operator drives it; Esc, or a cancel in any stage,
leaves the mesh exactly as it was.

(bpy as a module has no window, so the operator itself runs its synchronous path here:
``invoke`` falls back to ``execute``. These tests drive the same object the modal
operator delegates every event to, and read the record it concludes with, whose words the
operator reports.)
"""

import time

import numpy as np
import pytest

from isoparam_addon.blender import background, unwrap
from isoparam_addon.operation.options import OperatorOptions
from isoparam_eval import meshes as ex

from .conftest import add_mesh, bpy, corner_uvs, edit, object_mode, snapshot


def _drive(watch, first="TIMER"):
    """Events as Blender sends them to the modal operator: ``first``, then a timer tick
    every 10 ms until the run ends; then, as the operator does, the run's record."""
    answer = watch.on_event(bpy.context, first)
    for _ in range(30_000):
        if answer is None:
            return watch.conclude(bpy.context)
        assert answer == {"RUNNING_MODAL"}
        time.sleep(0.01)
        answer = watch.on_event(bpy.context, "TIMER")
    raise AssertionError("the background unwrap never ended")


_CANCELLED = [("INFO", "Isometric Unwrap cancelled: nothing was changed")]


def _unwrapped_mesh(name, V, F):
    """A mesh in edit mode whose UVs are an earlier unwrap's (so a change would show)."""
    ob = add_mesh(name, V, F)
    edit(ob)
    assert bpy.ops.uv.isometric_unwrap(refine=0, charts=False) == {"FINISHED"}
    return ob


def _state(ob):
    object_mode()
    state = snapshot(ob)
    edit(ob)
    return state


def test_a_background_unwrap_writes_what_the_operator_writes(scene):
    ob = _unwrapped_mesh("box", *ex.box(6)[:2])
    assert bpy.ops.uv.isometric_unwrap() == {"FINISHED"}
    object_mode()
    expected = corner_uvs(ob).copy()
    bpy.ops.object.select_all(action="DESELECT")
    edit(ob)
    watch = background.Background(bpy.context, OperatorOptions())
    run = _drive(watch)
    assert run.finished
    assert watch.job.fraction == 1.0
    assert run.reports[0][1].startswith("Isometric Unwrap: ") and run.reports[0][0] == "INFO"
    object_mode()
    # (two solves of one mesh agree to ~1e-12, not bit for bit: measured 3e-12 on this box)
    assert np.allclose(corner_uvs(ob), expected, rtol=0, atol=1e-6)


def test_esc_while_it_solves_cancels_and_leaves_the_mesh_exactly_as_it_was(scene):
    V, F, _ = ex.load_obj(ex.SPOT)
    ob = _unwrapped_mesh("spot", V, F)
    before = _state(ob)
    watch = background.Background(bpy.context, OperatorOptions())
    assert watch.running  # (spot takes tenths of a second: Esc comes while it solves)
    run = _drive(watch, first="ESC")
    assert not run.finished and run.reports == _CANCELLED
    assert not watch.running and watch.job.cancelled  # the solve itself stopped
    object_mode()
    assert snapshot(ob) == before


def test_events_that_could_edit_the_mesh_wait_and_looking_around_goes_through(scene):
    V, F, _ = ex.load_obj(ex.SPOT)
    _unwrapped_mesh("spot", V, F)
    watch = background.Background(bpy.context, OperatorOptions())
    assert watch.on_event(bpy.context, "MIDDLEMOUSE") == {"PASS_THROUGH"}
    if watch.running:  # a key that would edit the mesh is swallowed while it solves
        assert watch.on_event(bpy.context, "G") in ({"RUNNING_MODAL"}, None)
    assert _drive(watch).finished


def _stages(ob) -> list[str]:
    """The stages a background unwrap of ``ob`` passes through, in order."""
    seen = []

    class Recording(unwrap.Unwrap):
        def progressed(self, fraction, stage):
            seen.append(stage)
            return super().progressed(fraction, stage)

    original = unwrap.Unwrap
    unwrap.Unwrap = Recording
    try:
        assert _drive(background.Background(bpy.context, OperatorOptions())).finished
    finally:
        unwrap.Unwrap = original
    return list(dict.fromkeys(seen))


def test_a_cancel_in_any_stage_leaves_the_mesh_exactly_as_it_was(scene, monkeypatch):
    ob = _unwrapped_mesh("box", *ex.box(5)[:2])  # closed: charts, rounds, overlap checks
    stages = _stages(ob)
    assert {"start", "topology", "charting, refinement", "done"} <= set(stages)
    edit(ob)
    assert bpy.ops.uv.isometric_unwrap(refine=0, charts=False) == {"FINISHED"}
    before = _state(ob)
    for stop in stages:

        class StopIn(unwrap.Unwrap):
            def progressed(self, fraction, stage, stop=stop):
                if stage == stop:
                    self.cancel_requested = True  # as Esc does, from the event loop
                return super().progressed(fraction, stage)

        monkeypatch.setattr(unwrap, "Unwrap", StopIn)
        run = _drive(background.Background(bpy.context, OperatorOptions()))
        assert not run.finished and run.reports == _CANCELLED, stop
        object_mode()
        assert snapshot(ob) == before, stop
        edit(ob)


def test_with_nothing_selected_it_says_so_without_starting(scene):
    ob = add_mesh("box", *ex.box(3)[:2])
    edit(ob)
    bpy.ops.mesh.select_all(action="DESELECT")
    watch = background.Background(bpy.context, OperatorOptions())
    assert not watch.running
    assert watch.on_event(bpy.context, "TIMER") is None
    run = watch.conclude(bpy.context)
    assert not run.finished
    assert run.reports[0][0] == "ERROR" and "no faces selected" in run.reports[0][1]


@pytest.mark.parametrize("value", ["PRESS", "RELEASE"])
def test_only_pressing_esc_cancels(scene, value):
    V, F, _ = ex.load_obj(ex.SPOT)
    _unwrapped_mesh("spot", V, F)
    watch = background.Background(bpy.context, OperatorOptions())
    watch.on_event(bpy.context, "ESC", value)
    assert watch.job.cancel_requested == (value == "PRESS")
    _drive(watch)


def test_invoked_without_a_window_it_unwraps_in_one_go(scene):
    # background mode (batch, tests) has no window to watch a worker from: invoke runs
    # the synchronous path, with the same result as a script's call
    ob = _unwrapped_mesh("box", *ex.box(4)[:2])
    assert bpy.ops.uv.isometric_unwrap() == {"FINISHED"}
    object_mode()
    expected = corner_uvs(ob).copy()
    edit(ob)
    assert bpy.ops.uv.isometric_unwrap("INVOKE_DEFAULT") == {"FINISHED"}
    object_mode()
    assert np.array_equal(corner_uvs(ob), expected)
