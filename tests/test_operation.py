"""The operation between reading and writing (isoparam_addon/operation), in plain Python: it
imports no Blender module; a mesh is solved, retried as Blender's unwrap takes it, refused
with words, cancelled, packed by Fill Shapes or left to Blender's packer, and reported."""

import pkgutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import isoparam_addon.operation as operation
from isoparam_addon.operation import messages
from isoparam_addon.operation.options import DEFAULTS, OperatorOptions
from isoparam_addon.operation.record import RunRecord
from isoparam_addon.operation.selection import Selection
from isoparam_addon.operation.unwrap import Input, blender_packs, fills_shapes, solve_all, solve_one
from isoparam_addon.solver import ErrorKind, InvalidMeshError, metrics
from isoparam_eval import meshes as ex

ROOT = Path(__file__).resolve().parent.parent


def _selection(V, F, name="mesh", loops=None, poly=None) -> Selection:
    """A selection of triangles ``F`` over ``V`` as mesh_io would read it (corners
    ``loops``, faces ``poly``; by default every triangle a face of its own)."""
    t = len(F)
    loops = np.arange(3 * t).reshape(t, 3) if loops is None else loops
    corners = int(loops.max()) + 1
    return Selection(
        name=name,
        V=np.asarray(V, dtype=np.float64),
        F=np.asarray(F, dtype=np.int64),
        tri_loops=loops,
        tri_poly=np.arange(t) if poly is None else poly,
        vert_ids=np.arange(len(V)),
        seams=np.zeros((0, 2), np.int64),
        diagonals=np.zeros((0, 2), np.int64),
        uv=np.zeros((corners, 2), np.float32),
        locked=np.zeros(corners, bool),
        pinned=np.zeros(corners, bool),
        face_material=np.zeros(t, np.int64),
        uv_name="UVMap",
    )


def _go_on(fraction, stage):
    return True


def test_the_operation_imports_no_blender_module():
    names = [f"isoparam_addon.operation.{m.name}" for m in pkgutil.iter_modules(operation.__path__)]
    assert {"isoparam_addon.operation.unwrap", "isoparam_addon.operation.messages"} <= set(names)
    code = (
        f"import importlib, sys\nfor name in {names}: importlib.import_module(name)\n"
        "print(sorted(m for m in sys.modules if m.split('.')[0] in {'bpy', 'bmesh', 'mathutils'} "
        "or m.startswith('isoparam_addon.blender')))"
    )
    done = subprocess.run([sys.executable, "-c", code], cwd=ROOT, capture_output=True, text=True, check=True)
    assert done.stdout.strip() == "[]"


def test_two_meshes_are_solved_packed_together_and_reported():
    V, F = ex.suzanne_closed()
    Vs, Fs, _ = ex.real_mesh("spot")
    inputs = [Input(None, _selection(V, F, "suzanne"), None), Input(None, _selection(Vs, Fs, "spot"), None)]
    seen: list[tuple[float, str]] = []
    record = RunRecord()
    outcome = solve_all(inputs, DEFAULTS, lambda f, stage: seen.append((f, stage)) or True, record)
    assert outcome.ok and outcome.packed  # Fill Shapes, the default
    assert [s.sel.name for s in outcome.solved] == ["suzanne", "spot"]
    fractions = [f for f, _ in seen]
    assert fractions == sorted(fractions) and fractions[-1] > 0.95  # the pack's share comes last
    assert any(stage.startswith("'spot': ") for _, stage in seen)
    assert record.solve > 0 and record.pack > 0 and len(record.solver) == 2
    uv = np.concatenate([s.corner_uv.reshape(-1, 2) for s in outcome.solved])
    assert np.isfinite(uv).all() and uv.min() >= 0.0 and uv.max() <= 1.0
    assert not blender_packs(outcome.solved, DEFAULTS, outcome.packed)
    budget = 2 * (DEFAULTS.max_stretch**2 + DEFAULTS.max_stretch**-2)  # 4.22
    for s in outcome.solved:  # charted within the budget (charts at their best scales, weighed by area)
        sd, area = metrics.island_energy(s.sel.V, s.sel.F, s.corner_uv, s.island, s.n_islands)
        assert s.n_islands >= 2 and (sd * area).sum() / area.sum() <= budget and not s.warnings
    operation.unwrap.report(outcome.solved, record)
    level, text = record.reports[0]
    assert level == "INFO" and text.startswith("Isometric Unwrap: ") and " on 2 meshes" in text
    assert any("'suzanne': " in n for n in record.notes)  # the charts it cut


def test_blender_packs_what_fill_shapes_does_not():
    V, F = ex.suzanne_closed()
    inp = Input(None, _selection(V, F), None)
    boxes = OperatorOptions(pack_shape="AABB")
    outcome = solve_all([inp], boxes, _go_on, RunRecord())
    assert outcome.ok and not outcome.packed
    assert not fills_shapes(outcome.solved, boxes) and blender_packs(outcome.solved, boxes, outcome.packed)
    assert not blender_packs(outcome.solved, OperatorOptions(pack=False), False)
    held = outcome.solved[0]
    held.held = np.ones_like(held.held)  # a pinned island stays where it is: Blender's packer
    assert not fills_shapes([held], DEFAULTS) and blender_packs([held], DEFAULTS, False)
    held.corner_uv = held.corner_uv * 1e9  # beyond FAR_UV: no packer
    assert not fills_shapes([held], DEFAULTS) and not blender_packs([held], DEFAULTS, False)


def test_a_bad_mesh_ends_the_run_with_words_and_nothing_solved():
    V, F = ex.suzanne_closed()
    V = V.copy()
    V[3] = np.nan
    inputs = [
        Input(None, _selection(ex.suzanne_closed()[0], F, "good"), None),
        Input(None, _selection(V, F, "bad"), None),
    ]
    outcome = solve_all(inputs, DEFAULTS, _go_on, RunRecord())
    assert not outcome.ok and not outcome.cancelled
    assert outcome.error.startswith("Isometric Unwrap: 'bad': ") and outcome.error.endswith("Nothing was changed")
    assert "invalid (NaN or infinite) coordinates" in outcome.error


def test_a_cancel_ends_the_run():
    V, F = ex.suzanne_closed()
    outcome = solve_all([Input(None, _selection(V, F), None)], DEFAULTS, lambda f, stage: f < 0.2, RunRecord())
    assert outcome.cancelled and not outcome.ok and not outcome.solved


def _quad_with_a_flap():
    """A unit quad (corners 0-3, one face, split along 0-2) with a triangle face (1, 0, 2)
    folded over its first half: Blender's triangles repeat one, which the solver refuses;
    split along 1-3, the quad and the flap make a disk."""
    V = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]], dtype=np.float64)
    F = np.array([[0, 1, 2], [0, 2, 3], [1, 0, 2]])
    loops = np.array([[0, 1, 2], [0, 2, 3], [4, 5, 6]])
    return _selection(V, F, "quad", loops=loops, poly=np.array([0, 0, 1]))


def test_a_quad_whose_diagonal_another_face_takes_is_split_the_other_way():
    solved, _ = solve_one(Input(None, _quad_with_a_flap(), None), DEFAULTS, _go_on)
    assert {tuple(sorted(f)) for f in solved.sel.F[:2].tolist()} == {(0, 1, 3), (1, 2, 3)}
    assert solved.n_islands == 1 and np.isfinite(solved.corner_uv).all()
    assert not any("cut apart" in w for w in solved.warnings)  # (the flap folded flat is warned as stretched)


def test_overlapping_faces_are_named_in_the_message():
    # two faces whose triangulations share a triangle (n-gons the other diagonal cannot fix)
    sel = _selection(np.zeros((6, 3)), np.array([[0, 1, 2], [0, 2, 3], [0, 3, 4], [2, 1, 0], [0, 2, 5]]))
    sel.tri_poly = np.array([0, 0, 0, 1, 1])
    err = InvalidMeshError(
        ErrorKind.DUPLICATE_FACE, "1 face repeats the vertices of an earlier face (first: face 3)", "face", [3]
    )
    text = messages.describe(err, sel)
    assert "faces 0 and 1 share three vertices" in text and "Delete or dissolve one of the two faces" in text


@pytest.mark.parametrize("pixels", [0, 4])
def test_the_record_reads_back_from_json(pixels):
    record = RunRecord(finished=True, coverage=0.5, pack=0.01 * pixels)
    record.report("INFO", "words")
    assert RunRecord.from_json(record.to_json()) == record


def test_a_pack_margin_too_wide_for_the_islands_is_reported():
    # 300 separate triangles, 0.1 of the square between each two: the gaps alone would
    # need about three squares, so Fill Shapes keeps what it can and the run says so
    rng = np.random.default_rng(5)
    V = (rng.uniform(0, 1, (300, 1, 3)) + np.array([[0, 0, 0], [0.1, 0, 0], [0, 0.1, 0]])[None]).reshape(-1, 3)
    F = np.arange(900).reshape(300, 3)
    record = RunRecord()
    outcome = solve_all([Input(None, _selection(V, F), None)], OperatorOptions(margin=0.05), _go_on, record)
    assert outcome.ok and outcome.packed and outcome.solved[0].n_islands == 300
    assert any("pack margin 0.05 is too wide for 300 islands" in w for w in outcome.solved[0].warnings)
    kept = solve_all([Input(None, _selection(V, F), None)], OperatorOptions(margin=0.01), _go_on, RunRecord())
    assert not any("pack margin" in w for w in kept.solved[0].warnings)
