"""Real models through the operator, as an artist brings them (../shared/meshes; spot is
vendored in tests/data)."""

import re

import numpy as np
import pytest

from isoparam_addon.solver import metrics
from isoparam_eval import meshes as ex

from .conftest import bpy, corner_uvs, corner_verts, edit, object_mode, positions, triangles


def imported(path):
    """The OBJ file as Blender imports it, in edit mode with every face selected."""
    if not path.exists():
        pytest.skip(f"{path} is not on this machine (../shared/meshes)")
    bpy.ops.wm.obj_import(filepath=str(path))
    ob = bpy.context.selected_objects[0]
    bpy.context.view_layer.objects.active = ob
    edit(ob)
    return ob


def test_a_model_with_edges_of_three_faces_unwraps_as_blender_does(scene, capfd):
    # beetle.obj: 47 edges shared by more than two faces; all of Blender's methods unwrap it
    ob = imported(ex.SHARED / "beetle.obj")
    capfd.readouterr()
    assert bpy.ops.uv.isometric_unwrap() == {"FINISHED"}
    text = capfd.readouterr().out
    object_mode()
    assert "edges are shared by more than two faces (first: edge between vertices" in text
    assert "Select > Select All by Trait > Non Manifold shows them" in text
    tri = triangles(ob)
    V, F, uv = positions(ob), corner_verts(ob)[tri], corner_uvs(ob)[tri].astype(np.float64)
    pieces = metrics.per_island(V, F, uv)
    assert pieces.flipped.sum() == 0 and pieces.mean_symmetric_dirichlet < 4.1


def test_a_closed_model_unwraps_without_folds(scene):
    ob = imported(ex.SPOT)
    assert bpy.ops.uv.isometric_unwrap() == {"FINISHED"}
    object_mode()
    tri = triangles(ob)
    V, F, uv = positions(ob), corner_verts(ob)[tri], corner_uvs(ob)[tri].astype(np.float64)
    assert np.isfinite(uv).all() and metrics.per_island(V, F, uv).flipped.sum() == 0


def test_an_island_that_would_overlap_itself_is_cut_apart_through_the_operator(scene, capfd):
    from isoparam_eval.blender import add_mesh

    V, F = ex.helical_ribbon()
    ob = add_mesh("ribbon", V, F)
    edit(ob)
    assert bpy.ops.uv.isometric_unwrap(split_overlaps=False) == {"FINISHED"}
    object_mode()
    tri = triangles(ob)
    Vb, Fb = positions(ob), corner_verts(ob)[tri]
    assert metrics.self_overlaps(Vb, Fb, corner_uvs(ob)[tri].astype(np.float64)).islands == 1
    edit(ob)
    capfd.readouterr()
    assert bpy.ops.uv.isometric_unwrap() == {"FINISHED"}  # Cut Overlaps is on by default
    assert "overlaps itself" not in capfd.readouterr().out
    object_mode()
    uv = corner_uvs(ob)[tri].astype(np.float64)
    assert metrics.self_overlaps(Vb, Fb, uv).islands == 0 and metrics.per_island(Vb, Fb, uv).flipped.sum() == 0


# what the solver met on the way, which an artist cannot act on: the debug log's, not the report's
_SOLVER_WORDS = re.compile(r"\b(steps?|four-step|fans?|restart\w*|converg\w*|degenerate|subspace|eigen\w*)\b", re.I)


@pytest.mark.parametrize("name", [*ex.REAL, "nefertiti"])
def test_a_default_unwrap_reports_in_the_artists_words(scene, name, capfd):
    from isoparam_addon.blender.record import last_record

    ob = imported(ex.SPOT if name == "spot" else ex.SHARED / f"{name}.obj")
    capfd.readouterr()
    assert bpy.ops.uv.isometric_unwrap() == {"FINISHED"}
    printed = capfd.readouterr().out
    said = [line for line in printed.splitlines() if "Isometric Unwrap" in line]
    assert said and said == [line for line in said if not _SOLVER_WORDS.search(line)]
    run = last_record(bpy.context)
    assert not [w for w in run.notes + run.warnings if _SOLVER_WORDS.search(w)]
    object_mode()
    assert ob.data.uv_layers.active is not None
