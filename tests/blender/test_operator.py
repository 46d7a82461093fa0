"""uv.isometric_unwrap through the real bpy module: values, selection, seams, pins, undo."""

import logging

import bmesh
import numpy as np
import pytest

from isoparam_addon.operation.options import DEFAULTS
from isoparam_addon.solver import metrics, parametrize
from isoparam_addon.solver.geometry import corner_signed_areas
from isoparam_addon.solver.overlap import overlapping_faces
from isoparam_eval import meshes as ex
from isoparam_eval.layouts import islands_overlapping

from .conftest import (
    add_mesh,
    bpy,
    corner_uvs,
    corner_verts,
    edit,
    object_mode,
    positions,
    set_uvs_and_pins,
    snapshot,
    triangles,
)


def unwrap(**kw):
    return bpy.ops.uv.isometric_unwrap(**kw)


def triangle_uvs(ob):
    """(V, F, corner UVs (t, 3, 2)) of the object's loop triangles."""
    tri = triangles(ob)
    return positions(ob), corner_verts(ob)[tri], corner_uvs(ob)[tri].astype(np.float64)


def tube(n_around=24, n_up=6, quads=True):
    """An open cylinder (two boundary loops) of quads, and the edges along one ruling."""
    a, z = np.meshgrid(np.arange(n_around) * 2 * np.pi / n_around, np.linspace(0, 1.5, n_up), indexing="ij")
    V = np.stack([np.cos(a), np.sin(a), z], -1).reshape(-1, 3)
    faces = [
        [i * n_up + j, ((i + 1) % n_around) * n_up + j, ((i + 1) % n_around) * n_up + j + 1, i * n_up + j + 1]
        for i in range(n_around)
        for j in range(n_up - 1)
    ]  # building a test mesh
    return V, faces


def mark_seams(ob, pairs):
    me = ob.data
    ev = np.empty(2 * len(me.edges), dtype=np.int32)
    me.attributes[".edge_verts"].data.foreach_get("value", ev)
    ev = np.sort(ev.reshape(-1, 2), axis=1)
    want = {tuple(sorted(p)) for p in pairs}
    flags = np.array([tuple(e) in want for e in ev.tolist()])  # test set-up on a small mesh
    me.edges.foreach_set("use_seam", flags)


def select_faces(ob, sel):
    """Select exactly these faces (and their vertices and edges), in object mode."""
    me = ob.data
    me.polygons.foreach_set("select", sel)
    cv = corner_verts(ob)
    start = np.empty(len(me.polygons), dtype=np.int32)
    me.polygons.foreach_get("loop_start", start)
    count = np.diff(np.append(start, len(cv)))
    vsel = np.zeros(len(me.vertices), dtype=bool)
    vsel[cv[np.repeat(sel, count)]] = True
    me.vertices.foreach_set("select", vsel)
    ev = np.empty(2 * len(me.edges), dtype=np.int32)
    me.edges.foreach_get("vertices", ev)
    ev = ev.reshape(-1, 2)
    me.edges.foreach_set("select", vsel[ev[:, 0]] & vsel[ev[:, 1]])
    bpy.context.tool_settings.mesh_select_mode = (False, False, True)


def unwrapped(name, V, F):
    """A new mesh object unwrapped once: the object, a copy of its corner UVs (k, 2) and
    each corner's vertex (k,), back in object mode."""
    ob = add_mesh(name, V, F)
    edit(ob)
    unwrap()
    object_mode()
    return ob, corner_uvs(ob).copy(), corner_verts(ob)


def test_operator_is_listed_in_the_unwrap_menus():
    menu = bpy.types.IMAGE_MT_uvs_unwrap
    names = [f.__name__ for f in menu._dyn_ui_initialize()]
    assert "_menu_draw" in names
    if bpy.app.version < (4, 3, 0):  # pragma: no cover - the wheel under test is 5.0
        assert "_menu_draw" in [f.__name__ for f in bpy.types.VIEW3D_MT_uv_map._dyn_ui_initialize()]


def test_poll_needs_a_mesh_in_edit_mode(scene):
    ob = add_mesh("peaks", *ex.peaks(9))
    bpy.context.view_layer.objects.active = ob
    assert not bpy.ops.uv.isometric_unwrap.poll()
    edit(ob)
    assert bpy.ops.uv.isometric_unwrap.poll()


@pytest.mark.parametrize("refine", [0, 100])
def test_peaks_through_the_operator_matches_the_solver(scene, refine):
    V, F = ex.peaks(41)
    ob = add_mesh("peaks", V, F)
    edit(ob)
    assert unwrap(refine=refine, charts=False) == {"FINISHED"}  # (one island, as the solver's default)
    object_mode()
    Vb, Fb, cuv = triangle_uvs(ob)
    ours = metrics.distortion(Vb, Fb, cuv)
    ref = parametrize(V, F, refine=refine).distortion()
    assert ours.edge_rms == pytest.approx(ref.edge_rms, rel=1e-4)
    assert ours.stretch_linf == pytest.approx(ref.stretch_linf, rel=1e-3)
    assert ours.flipped == 0
    assert cuv.min() >= 0 and cuv.max() <= 1  # packed into the UV square


def test_s_surface_is_exact_through_the_operator(scene):
    V, F, _ = ex.s_surface(50, 12)
    ob = add_mesh("S", V, F)
    edit(ob)
    assert unwrap() == {"FINISHED"}
    object_mode()
    assert metrics.edge_rms(*triangle_uvs(ob)) < 1e-5  # UVs are float32


def test_cylinder_cut_by_one_seam_is_exact(scene):
    V, faces = tube()
    ob = add_mesh("tube", V, faces)
    mark_seams(ob, [(j, j + 1) for j in range(5)])  # the ruling at angle 0
    edit(ob)
    assert unwrap() == {"FINISHED"}
    object_mode()
    Vb, Fb, cuv = triangle_uvs(ob)
    assert metrics.edge_rms(Vb, Fb, cuv) < 1e-5
    assert len(np.unique(metrics.uv_islands(Fb, cuv))) == 1


def test_two_seams_make_two_islands(scene):
    V, faces = tube()
    ob = add_mesh("tube", V, faces)
    mark_seams(ob, [(j, j + 1) for j in range(5)] + [(12 * 6 + j, 12 * 6 + j + 1) for j in range(5)])
    edit(ob)
    assert unwrap() == {"FINISHED"}
    object_mode()
    Vb, Fb, cuv = triangle_uvs(ob)
    assert len(np.unique(metrics.uv_islands(Fb, cuv))) == 2
    assert metrics.edge_rms(Vb, Fb, cuv) < 1e-5


@pytest.mark.parametrize("shape", ["AABB", "CONVEX", "CONCAVE"])
def test_pack_shapes(scene, shape):
    V, faces = tube()
    ob = add_mesh("tube", V, faces)
    mark_seams(ob, [(j, j + 1) for j in range(5)] + [(12 * 6 + j, 12 * 6 + j + 1) for j in range(5)])
    edit(ob)
    assert unwrap(pack_shape=shape) == {"FINISHED"}
    object_mode()
    Vb, Fb, cuv = triangle_uvs(ob)
    label = metrics.uv_islands(Fb, cuv)
    assert len(np.unique(label)) == 2 and cuv.min() >= 0 and cuv.max() <= 1
    assert metrics.edge_rms(Vb, Fb, cuv) < 1e-5
    if shape == "AABB":  # bounding boxes side by side
        a, b = (cuv[label == k].reshape(-1, 2) for k in np.unique(label))
        assert (a.max(0) <= b.min(0) + 1e-6).any() or (b.max(0) <= a.min(0) + 1e-6).any()


@pytest.mark.parametrize("margin", [DEFAULTS.margin, 0.5, 1.0])
def test_a_single_island_gets_the_margin_blenders_pack_gives_it(scene, margin):
    # with Blender's shapes one island is fitted into [0, 1] by the add-on (Blender's pack
    # would cost 0.17 s at 100k vertices); packing the result again must not move it. A
    # margin of 0.5 or more used to collapse the island to a point.
    V, F = ex.peaks(15)
    ob = add_mesh("peaks", V, F)
    edit(ob)
    assert unwrap(margin=margin, charts=False, pack_shape="AABB") == {"FINISHED"}  # (charts would cut the peaks)
    object_mode()
    ours = corner_uvs(ob).copy()
    assert ours.min() > 0 and ours.max() < 1 and np.ptp(ours, axis=0).min() > 0.5
    edit(ob)
    bpy.ops.uv.pack_islands(margin=margin, rotate=False, scale=True)
    object_mode()
    assert np.abs(corner_uvs(ob) - ours).max() < 1e-5


def test_quads_and_ngons_get_one_uv_per_corner(scene):
    # a quad grid with an octagon n-gon in its middle replaced
    n = 6
    x, y = np.meshgrid(np.arange(n), np.arange(n), indexing="xy")
    V = np.stack([x.ravel(), y.ravel(), np.zeros(n * n)], 1).astype(float)
    faces = [
        [j * n + i, j * n + i + 1, (j + 1) * n + i + 1, (j + 1) * n + i] for j in range(n - 1) for i in range(n - 1)
    ]  # building a test mesh
    ob = add_mesh("grid", V, faces)
    edit(ob)
    bpy.ops.mesh.select_all(action="DESELECT")
    bpy.ops.mesh.select_all(action="SELECT")
    bpy.ops.mesh.dissolve_faces()  # one big n-gon with every vertex on its boundary
    bpy.ops.mesh.select_all(action="SELECT")
    assert unwrap() == {"FINISHED"}
    object_mode()
    assert len(ob.data.polygons) == 1 and len(ob.data.polygons[0].vertices) == 20
    Vb, Fb, cuv = triangle_uvs(ob)
    assert metrics.edge_rms(Vb, Fb, cuv) < 1e-5
    # the same vertex has the same UV in every triangle it appears in
    uv = corner_uvs(ob)
    cv = corner_verts(ob)
    for v in np.unique(cv)[:5]:
        assert len(np.unique(uv[cv == v], axis=0)) == 1


def test_unselected_faces_keep_their_uvs(scene):
    ob, before, _ = unwrapped("peaks", *ex.peaks(21))
    me = ob.data
    sel = np.zeros(len(me.polygons), dtype=bool)
    sel[: len(sel) // 2] = True
    select_faces(ob, sel)
    edit(ob, select_all=False)
    assert unwrap(pack=False) == {"FINISHED"}
    object_mode()
    after = corner_uvs(ob)
    loop_poly = np.repeat(np.arange(len(me.polygons)), 3)
    keep = ~sel[loop_poly]
    assert np.array_equal(after[keep].tobytes(), before[keep].tobytes())
    assert not np.allclose(after[~keep], before[~keep])


def test_pinned_uvs_hold(scene):
    V, F = ex.peaks(21)
    ob, uv, cv = unwrapped("peaks", V, F)
    # move two corner vertices' UVs somewhere and pin them
    pinned_verts = [0, 20]
    target = {0: (0.1, 0.2), 20: (0.7, 0.3)}
    for v in pinned_verts:
        uv[cv == v] = target[v]
    set_uvs_and_pins(ob, uv, np.isin(cv, pinned_verts))
    edit(ob)
    assert unwrap() == {"FINISHED"}
    object_mode()
    after = corner_uvs(ob)
    for v in pinned_verts:
        assert np.array_equal(after[cv == v], np.tile(np.float32(target[v]), (int((cv == v).sum()), 1)))
    # the island was fitted to the pins: its shape is the isometric layout
    ref = parametrize(V, F, refine=100).distortion().edge_rms
    assert metrics.edge_rms(*triangle_uvs(ob)) == pytest.approx(ref, rel=1e-3)


def test_a_vertex_pinned_to_different_uvs_keeps_every_pin_and_is_reported_so(scene, capfd):
    # the solver holds such a vertex at the mean of its pins; the operator writes each
    # pinned corner back on its own UV, so its warning must say that, not the solver's
    V, F = ex.peaks(11)
    ob, uv, cv = unwrapped("peaks", V, F)
    uv[np.flatnonzero(cv == 60)[0]] += (0.05, 0.0)  # one corner of an interior vertex moved
    pins = np.isin(cv, [0, 10, 60, 120])
    set_uvs_and_pins(ob, uv, pins)
    edit(ob)
    capfd.readouterr()
    assert unwrap() == {"FINISHED"}
    out = capfd.readouterr()
    object_mode()
    assert np.array_equal(corner_uvs(ob)[pins].tobytes(), uv[pins].tobytes())
    text = out.out + out.err
    assert "1 pinned vertex has corners pinned to different UVs: each corner stays on its pin" in text
    assert "held at their mean" not in text


def test_one_pin_keeps_the_islands_old_turn(scene):
    # three islands (packing turns islands); turn one by hand, pin one of its vertices where
    # it is and unwrap again: the island moves onto its pin turned as it was, not in the
    # solver's frame (before: turned back by a quarter turn)
    V, F = ex.peaks(9)
    parts = [add_mesh(f"p{k}", V + [3.0 * k, 0.0, 0.0], F) for k in range(3)]
    bpy.ops.object.select_all(action="DESELECT")
    for ob in parts:
        ob.select_set(True)
    bpy.context.view_layer.objects.active = parts[0]
    bpy.ops.object.join()
    ob = bpy.context.active_object
    edit(ob)
    unwrap(charts=False)  # (charts would cut the peaks)
    object_mode()
    uv = corner_uvs(ob).copy()
    cv = corner_verts(ob)
    mine = cv < len(V)  # the first island's corners
    centre = uv[mine].mean(axis=0)
    uv[mine] = centre + (uv[mine] - centre) @ np.array([[0.0, 1.0], [-1.0, 0.0]])  # a quarter turn
    set_uvs_and_pins(ob, uv, cv == 40)  # pinned: the centre vertex of the first island
    edit(ob)
    assert unwrap(charts=False) == {"FINISHED"}
    object_mode()
    after = corner_uvs(ob).astype(np.float64)
    a = uv[mine] - uv[cv == 40][0]
    b = after[mine] - after[cv == 40][0]
    turn = np.degrees(np.arctan2((a[:, 0] * b[:, 1] - a[:, 1] * b[:, 0]).sum(), (a * b).sum(axis=1).sum()))
    assert abs(turn) < 0.01
    assert np.array_equal(after[cv == 40], uv[cv == 40])


def test_two_objects_in_edit_mode(scene):
    V1, F1, _ = ex.s_surface(30, 8)
    V2, F2 = ex.peaks(15)
    a = add_mesh("S", V1, F1)
    b = add_mesh("peaks", V2, F2, location=(5, 0, 0))
    edit(a, b)
    assert len(bpy.context.objects_in_mode_unique_data) == 2
    assert unwrap() == {"FINISHED"}
    object_mode()
    uv_a, uv_b = corner_uvs(a), corner_uvs(b)
    assert np.ptp(uv_a, axis=0).min() > 0.05 and np.ptp(uv_b, axis=0).min() > 0.05
    assert metrics.edge_rms(*triangle_uvs(a)) < 1e-5
    # packed together: no face of one overlaps a face of the other in UV space (Fill
    # Shapes fits islands by their shapes: their boxes may interlock)
    ta, tb = triangle_uvs(a)[2], triangle_uvs(b)[2]
    assert islands_overlapping(np.concatenate([ta, tb]), np.repeat([0, 1], [len(ta), len(tb)])) == 0


def select_uvs(ob, picked):
    """Select exactly the UVs of these corners (edit mode), test set-up on a small mesh."""
    bm = bmesh.from_edit_mesh(ob.data)
    uvl = bm.loops.layers.uv.active
    for f in bm.faces:
        for loop in f.loops:
            if hasattr(loop, "uv_select_vert_set"):  # 5.0
                loop.uv_select_vert_set(bool(picked[loop.index]))
            else:  # 4.2 - 4.5
                loop[uvl].select = bool(picked[loop.index])
    bmesh.update_edit_mesh(ob.data)


def in_uv_editor(call):
    area = bpy.context.screen.areas[0]
    area.type = "IMAGE_EDITOR"
    area.ui_type = "UV"
    region = next(r for r in area.regions if r.type == "WINDOW")
    with bpy.context.temp_override(area=area, region=region, space_data=area.spaces.active):
        assert bpy.context.space_data.type == "IMAGE_EDITOR"
        return call()


@pytest.mark.parametrize("pack", [False, True])
def test_uv_editor_without_sync_select_keeps_unselected_uvs_and_the_selection(scene, pack):
    # found by fuzzing: with Pack on the packer moved the island, unselected UVs and all,
    # since only real pins keep an island in place, and switching sync select on and off
    # for it rewrote the UV selection (5.0)
    V, F = ex.peaks(9)
    ob = add_mesh("peaks", V, F)
    picked = V[corner_verts(ob), 0] > 0.1  # UVs of the vertices right of the middle
    edit(ob)
    bpy.ops.uv.unwrap()
    settings = bpy.context.scene.tool_settings
    settings.use_uv_select_sync = False
    try:
        select_uvs(ob, picked)
        object_mode()
        before = corner_uvs(ob).copy()
        state = {k: v for k, v in snapshot(ob).items() if "select" in k or k.startswith((".vs.", ".es.", ".pn."))}
        edit(ob, select_all=False)
        assert in_uv_editor(lambda: unwrap(pack=pack)) == {"FINISHED"}
        object_mode()
        after = corner_uvs(ob)
        assert np.array_equal(after[~picked], before[~picked])
        assert not np.allclose(after[picked], before[picked])
        # one island, still in one piece: every vertex has one UV (the packer, acting on the
        # faces whose UVs are all selected, moved only those: the island tore at the edge)
        cv = corner_verts(ob)
        keys = np.unique(np.column_stack([cv, after.view(np.int32)]), axis=0)
        assert len(keys) == len(V)
        assert {k: v for k, v in snapshot(ob).items() if k in state or k.startswith(".pn.")} == state
    finally:
        settings.use_uv_select_sync = True


def selection_and_pins(ob):
    """The mesh and UV selection attributes and the pins, as raw bytes (object mode)."""
    return {k: v for k, v in snapshot(ob).items() if "select" in k or k.startswith((".vs.", ".es.", ".pn."))}


@pytest.mark.parametrize("where", ["3D viewport", "UV editor"])
def test_without_sync_select_the_pack_keeps_the_uv_selection_of_every_object(scene, where):
    # the pack runs with sync select on; switching it on and off rewrote the UV selection
    # from the mesh selection (5.0), where Blender's own unwrap leaves it as it was: on the
    # objects unwrapped, and (fuzzing) on one in edit mode with no face selected
    V, F = ex.peaks(9)
    a = add_mesh("seamed", V, F)
    mark_seams(a, [(i, i + 1) for i in range(36, 44)])  # two islands: the pack runs
    b = add_mesh("idle", V, F, location=(5, 0, 0))
    picked = V[corner_verts(a), 0] > 0.1
    edit(a, b)
    bpy.ops.uv.unwrap()
    object_mode()
    settings = bpy.context.scene.tool_settings
    settings.use_uv_select_sync = False  # in object mode: set in edit mode, it selects every UV
    try:
        edit(a, b, select_all=False)
        select_uvs(a, picked)
        select_uvs(b, picked)
        bm = bmesh.from_edit_mesh(b.data)
        for f in bm.faces:  # test set-up on a small mesh: nothing of b to unwrap
            f.select_set(False)
        bmesh.update_edit_mesh(b.data)
        object_mode()
        state = {ob.name: selection_and_pins(ob) for ob in (a, b)}
        before = corner_uvs(a).copy()
        edit(a, b, select_all=False)
        assert (in_uv_editor(unwrap) if where == "UV editor" else unwrap()) == {"FINISHED"}
        object_mode()
        assert not np.allclose(corner_uvs(a)[picked], before[picked])  # unwrapped and packed
        assert {ob.name: selection_and_pins(ob) for ob in (a, b)} == state
    finally:
        settings.use_uv_select_sync = True


@pytest.mark.parametrize("pack", [False, True])
def test_an_unselected_uv_that_is_not_finite_is_kept_and_holds_nothing(scene, pack, capfd):
    # fuzzing: the UV editor locks the corners whose UVs are not selected; one holding a NaN
    # UV (a broken import) was handed to the solver as a pin and refused as "pinned corners
    # with non-finite UVs" with nothing pinned. uv.unwrap keeps it and unwraps the rest.
    V, F = ex.peaks(9)
    ob = add_mesh("peaks", V, F)
    picked = V[corner_verts(ob), 0] > 0.1
    edit(ob)
    bpy.ops.uv.unwrap()
    object_mode()
    settings = bpy.context.scene.tool_settings
    settings.use_uv_select_sync = False
    try:
        uv = corner_uvs(ob).copy()
        bad = np.flatnonzero(~picked)[0]
        uv[bad] = (np.nan, 0.5)
        set_uvs_and_pins(ob, uv, np.zeros(len(uv), dtype=bool))
        edit(ob, select_all=False)
        select_uvs(ob, picked)
        assert in_uv_editor(lambda: unwrap(pack=pack)) == {"FINISHED"}
        object_mode()
        after = corner_uvs(ob)
        assert np.isnan(after[bad, 0]) and after[bad, 1] == 0.5
        keep = ~picked
        keep[bad] = False
        assert np.array_equal(after[keep], uv[keep])
        assert np.isfinite(after[picked]).all() and not np.allclose(after[picked], uv[picked])
        if pack:  # Blender's packer would spread the NaN over the islands it packs
            assert "not packed" in "".join(capfd.readouterr())
    finally:
        settings.use_uv_select_sync = True


def test_the_pack_runs_when_the_active_object_has_no_uv_map(scene):
    # found by fuzzing: the active object in edit mode had no face selected and no UV map,
    # so uv.pack_islands' poll failed and the operator raised with the other's UVs written
    a = add_mesh("no_uvs", *ex.peaks(5))
    V, F = ex.peaks(9)
    b = add_mesh("seamed", V, F, location=(5, 0, 0))
    mark_seams(b, [(i, i + 1) for i in range(36, 44)])  # a seam across the middle row: two islands
    assert len(a.data.uv_layers) == 0
    edit(a, b)
    bm = bmesh.from_edit_mesh(a.data)
    for f in bm.faces:  # test set-up on a small mesh: nothing of the active object selected
        f.select_set(False)
    bmesh.update_edit_mesh(a.data)
    assert unwrap() == {"FINISHED"}
    object_mode()
    uv = corner_uvs(b)
    assert np.isfinite(uv).all() and uv.min() >= 0.0 and uv.max() <= 1.0 and np.ptp(uv, axis=0).min() > 0.3


@pytest.mark.parametrize("operator", ["unwrap", "show_stretch"])
def test_the_edit_mode_set_and_the_selection_survive_the_operator(scene, operator):
    # the operator leaves edit mode for the bulk I/O; going back must not pull in a
    # selected object that was not in edit mode, nor drop a deselected one that was
    V, F = ex.peaks(5)
    a, b, c = (add_mesh(name, V, F, location=(5 * k, 0, 0)) for k, name in enumerate("ABC"))
    edit(a, b)
    b.select_set(False)  # B stays in edit mode, deselected (as from the outliner)
    c.select_set(True)  # C is selected, not in edit mode
    run = unwrap if operator == "unwrap" else bpy.ops.uv.isometric_show_stretch
    if operator == "show_stretch":
        unwrap()
    assert run() == {"FINISHED"}
    assert sorted(ob.name for ob in bpy.context.objects_in_mode) == ["A", "B"]
    assert [a.select_get(), b.select_get(), c.select_get()] == [True, False, True]
    assert bpy.context.view_layer.objects.active == a
    assert not c.data.uv_layers  # never touched


@pytest.mark.parametrize("operator", ["unwrap", "show_stretch"])
def test_hidden_and_unselectable_objects_stay_in_edit_mode(scene, operator):
    # an object hidden while in edit mode is not in context.objects_in_mode (not
    # unwrapped, as with uv.unwrap), and neither it nor an unselectable one could be
    # selected to re-enter edit mode: both used to leave edit mode
    V, F = ex.peaks(5)
    a, b, c = (add_mesh(name, V, F, location=(5 * k, 0, 0)) for k, name in enumerate("ABC"))
    for ob in (a, b, c):
        ob.data.uv_layers.new(name="UVMap")
    before_b = corner_uvs(b).copy()
    edit(a, b, c)
    b.hide_set(True)
    c.hide_select = True
    selected = [ob.select_get() for ob in (a, b, c)]
    run = unwrap if operator == "unwrap" else bpy.ops.uv.isometric_show_stretch
    assert run() == {"FINISHED"}
    assert [ob.mode for ob in (a, b, c)] == ["EDIT", "EDIT", "EDIT"]
    assert b.hide_get() and c.hide_select and not a.hide_get()
    assert [ob.select_get() for ob in (a, b, c)] == selected
    assert bpy.context.view_layer.objects.active == a
    object_mode()
    assert np.array_equal(corner_uvs(b), before_b)  # hidden: not unwrapped
    if operator == "unwrap":
        assert np.ptp(corner_uvs(c), axis=0).min() > 0.05  # unselectable but visible: unwrapped


def test_undo_restores_the_previous_uvs_and_seams(scene):
    # Headless Blender records no edit-mode undo steps (measured: ed.undo() in edit mode
    # goes back to the last global step), so the step is pushed in object mode.
    V, F = ex.peaks(21)
    ob = add_mesh("peaks", V, F)
    edit(ob)
    bpy.ops.uv.unwrap(method="CONFORMAL")
    object_mode()
    before = corner_uvs(ob).copy()
    bpy.ops.ed.undo_push(message="before isometric unwrap")
    edit(ob)
    assert unwrap(mark_seams=True, chart_disks=True) == {"FINISHED"}  # the peaks are cut into charts
    object_mode()
    assert not np.allclose(corner_uvs(ob), before)
    seams = np.zeros(len(ob.data.edges), dtype=bool)
    ob.data.edges.foreach_get("use_seam", seams)
    assert seams.any()
    bpy.ops.ed.undo_push(message="after isometric unwrap")
    bpy.ops.ed.undo()
    ob = bpy.data.objects["peaks"]
    assert np.array_equal(corner_uvs(ob), before)
    ob.data.edges.foreach_get("use_seam", seams)
    assert not seams.any()
    bpy.ops.ed.redo()
    assert not np.allclose(corner_uvs(bpy.data.objects["peaks"]), before)


def test_unwrap_in_place_keeps_islands_where_they_were(scene):
    V, F = ex.peaks(21, z_scale=0.1)  # (within Max Stretch as one island: not charted)
    ob = add_mesh("peaks", V, F)
    edit(ob)
    bpy.ops.uv.unwrap(method="CONFORMAL")
    object_mode()
    before = corner_uvs(ob).astype(np.float64)
    edit(ob)
    assert unwrap(pack=False) == {"FINISHED"}
    object_mode()
    after = corner_uvs(ob).astype(np.float64)
    assert np.allclose(after.mean(axis=0), before.mean(axis=0), atol=1e-4)
    Vb, Fb, cuv_after = triangle_uvs(ob)
    cuv_before = before[triangles(ob)]
    uv_area = lambda c: 0.5 * np.abs(np.cross(c[:, 1] - c[:, 0], c[:, 2] - c[:, 0])).sum()  # noqa: E731
    assert uv_area(cuv_after) == pytest.approx(uv_area(cuv_before), rel=1e-4)  # same texel density


def _overlapping_triangles(ob) -> int:
    """Pairs of the object's triangles (not sharing a vertex) that overlap in UV, any islands,
    beyond touching: each triangle shrunk by 0.1% about its centroid first (islands placed
    in place onto old islands that touched, as Smart UV Project's do with no margin, may
    touch again to within their fit's rounding)."""
    _, F, cuv = triangle_uvs(ob)
    centre = cuv.mean(axis=1, keepdims=True)
    return len(overlapping_faces(centre + 0.999 * (cuv - centre), F, np.zeros(len(F), dtype=np.int64))[0])


@pytest.mark.parametrize("primitive", ["monkey", "cube", "uv_sphere"])
@pytest.mark.parametrize("before", ["its own UVs", "Smart UV Project"])
def test_unwrap_in_place_does_not_put_charts_on_top_of_each_other(scene, primitive, before):
    # a closed mesh is cut into charts that its old UVs do not have: those cut from one old
    # island go there side by side, those across old islands beside the rest (they were
    # each fitted onto the old UVs of their own faces, and landed on each other)
    getattr(bpy.ops.mesh, f"primitive_{primitive}_add")()
    ob = bpy.context.object
    edit(ob)
    if before == "Smart UV Project":
        bpy.ops.uv.smart_project()
    assert unwrap(pack=False) == {"FINISHED"}
    object_mode()
    assert _overlapping_triangles(ob) == 0


def test_charts_cut_from_one_old_island_stay_in_its_box(scene):
    # Blender's cube comes with one island of UVs (a net); as a closed part it is cut into
    # charts, which go into that island's box side by side, not each onto its own faces
    bpy.ops.mesh.primitive_cube_add()
    ob = bpy.context.object
    before = corner_uvs(ob).astype(np.float64)
    edit(ob)
    assert unwrap(pack=False) == {"FINISHED"}
    object_mode()
    after = corner_uvs(ob).astype(np.float64)
    _, F, cuv = triangle_uvs(ob)
    assert metrics.uv_islands(F, cuv).max() + 1 > 1  # charts
    assert np.all(after.min(axis=0) >= before.min(axis=0) - 1e-6)
    assert np.all(after.max(axis=0) <= before.max(axis=0) + 1e-6)
    assert _overlapping_triangles(ob) == 0


def test_unwrapping_in_place_again_keeps_every_chart_where_it_is(scene):
    bpy.ops.mesh.primitive_monkey_add()
    ob = bpy.context.object
    edit(ob)
    assert unwrap() == {"FINISHED"}
    object_mode()
    before = corner_uvs(ob).astype(np.float64)
    edit(ob)
    assert unwrap(pack=False) == {"FINISHED"}
    object_mode()
    assert np.abs(corner_uvs(ob) - before).max() < 1e-5


@pytest.mark.parametrize("world_scale", [False, True])
def test_unwrap_in_place_on_a_mesh_with_no_uvs_yet(scene, world_scale):
    # nothing to keep in place: the island is laid out as a fresh unwrap, in [0, 1]
    # unless True World Scale asks for mesh units (it used to stay in mesh units always)
    V, F = ex.peaks(21)
    ob = add_mesh("peaks", 100 * V, F)  # 600 units across
    edit(ob)
    assert unwrap(pack=False, world_scale=world_scale) == {"FINISHED"}
    object_mode()
    uv = corner_uvs(ob)
    if world_scale:
        assert np.ptp(uv, axis=0).max() > 100
    else:
        assert uv.min() >= 0 and uv.max() <= 1 and np.ptp(uv, axis=0).max() == pytest.approx(1, abs=1e-6)
    assert metrics.edge_rms(*triangle_uvs(ob)) < 0.3


def test_the_active_shape_key_is_unwrapped(scene):
    # edit mode shows the active shape key, and Blender's unwrap flattens it: here a
    # strip bent into a half cylinder (developable) over a Basis stretched 3x along x
    nu, nv = 17, 5
    s, t = np.meshgrid(np.linspace(0, 8, nu), np.linspace(0, 2, nv))  # u fastest, as grid_faces
    F = ex.grid_faces(nu, nv)
    radius = 8 / np.pi
    bent = np.stack([radius * np.sin(s / radius), t, radius * (1 - np.cos(s / radius))], -1).reshape(-1, 3)
    basis = np.stack([3 * s, t, 0 * s], -1).reshape(-1, 3)
    ob = add_mesh("keyed", basis, F)
    ob.shape_key_add(name="Basis")
    ob.shape_key_add(name="Bent").data.foreach_set("co", bent.ravel())
    ob.active_shape_key_index = 1
    edit(ob)
    assert unwrap() == {"FINISHED"}
    object_mode()
    tri = triangles(ob)
    uv = corner_uvs(ob)[tri].astype(np.float64)
    assert metrics.edge_rms(bent, corner_verts(ob)[tri], uv) < 1e-5
    assert metrics.edge_rms(basis, corner_verts(ob)[tri], uv) > 0.1


def test_true_world_scale_follows_the_object_transform(scene):
    V, F, _ = ex.s_surface(30, 8)
    ob = add_mesh("S", V, F)
    ob.scale = (2.0, 2.0, 2.0)
    edit(ob)
    assert unwrap(world_scale=True, pack=False) == {"FINISHED"}
    object_mode()
    Vb, Fb, cuv = triangle_uvs(ob)
    l3, l2 = metrics.uv_edge_lengths(2.0 * Vb, Fb, cuv)
    np.testing.assert_allclose(l2, l3, rtol=1e-5)


def test_true_world_scale_keeps_the_digits_of_a_small_object_far_from_the_origin(scene):
    # found by fuzzing: world positions included the object's location, so a mesh scaled
    # by 1e-12 at (3, 4, 0) kept only ~4 of its digits (at 1e-20 it became a single point
    # and the unwrap gave non-finite UVs); the location does not change an unwrap
    V, F, _ = ex.s_surface(30, 8)
    ob = add_mesh("S", V, F)
    ob.scale = (1e-12, 1e-12, 1e-12)
    ob.location = (3.0, 4.0, 0.0)
    edit(ob)
    assert unwrap(world_scale=True, pack=False) == {"FINISHED"}
    object_mode()
    Vb, Fb, cuv = triangle_uvs(ob)
    assert metrics.edge_rms(1e-12 * Vb, Fb, cuv) < 1e-5  # (edge_rms fits the scale)
    l3, l2 = metrics.uv_edge_lengths(1e-12 * Vb, Fb, cuv)
    assert np.median(l2 / l3) == pytest.approx(1.0, rel=1e-5)  # world units: 1e-12 of the mesh's


def image_material(name, width, height):
    mat = bpy.data.materials.new(name)
    if bpy.app.version < (5, 0, 0):  # pragma: no cover - always on in 5.0
        mat.use_nodes = True
    node = mat.node_tree.nodes.new("ShaderNodeTexImage")
    node.image = bpy.data.images.new(name, width, height)
    mat.node_tree.nodes.active = node
    return mat


def test_correct_aspect_squeezes_u_for_a_wide_image(scene):
    V, F, _ = ex.s_surface(30, 8)
    results = {}
    for correct in (False, True):
        bpy.ops.wm.read_homefile(use_empty=True)
        ob = add_mesh("S", V, F)
        ob.data.materials.append(image_material("wide", 256, 128))
        edit(ob)
        unwrap(correct_aspect=correct, pack=False, world_scale=True)
        object_mode()
        results[correct] = corner_uvs(ob).astype(np.float64)
    # the layout is only rotated by the solver; compare the extents of the two axes
    ext_plain = np.sort(np.ptp(results[False], axis=0))
    ext_fixed = np.ptp(results[True], axis=0)
    assert np.prod(ext_fixed) == pytest.approx(np.prod(ext_plain) / 2, rel=1e-3)


def squeeze(uv_quad, xy_quad):
    """Ratio of the singular values of the affine map from a planar quad's first triangle
    to its UVs: 1 without aspect correction, the image aspect with it, whatever rotation
    the packer chose."""
    J = (uv_quad[1:3] - uv_quad[0]).T @ np.linalg.inv((xy_quad[1:3] - xy_quad[0]).T)
    sig = np.linalg.svd(J, compute_uv=False)
    return sig[0] / sig[1]


@pytest.mark.parametrize(("active", "selected"), [(0, range(16)), (12, range(16)), (12, range(8)), (3, range(8, 16))])
def test_correct_aspect_takes_one_image_per_object_as_blender_does(scene, active, selected):
    # a plane whose lower half shows a 2:1 image and upper half a square one: Blender's
    # unwrap corrects the whole object for the active face's image, selected or not; a
    # per-face correction used to tear the island where the materials meet
    import bmesh

    V = np.stack(np.meshgrid(np.arange(5.0), np.arange(5.0)) + [np.zeros((5, 5))], -1).reshape(-1, 3)
    quads = [[5 * j + i, 5 * j + i + 1, 5 * j + i + 6, 5 * j + i + 5] for j in range(4) for i in range(4)]
    ratios = {}
    for method in ("blender", "isoparam"):
        bpy.ops.wm.read_homefile(use_empty=True)
        ob = add_mesh("plane", V, quads)
        ob.data.materials.append(image_material("wide", 256, 128))
        ob.data.materials.append(image_material("square", 128, 128))
        ob.data.polygons.foreach_set("material_index", np.repeat([0, 1], 8).astype(np.int32))
        edit(ob, select_all=False)
        bpy.ops.mesh.select_all(action="DESELECT")
        bm = bmesh.from_edit_mesh(ob.data)
        bm.faces.ensure_lookup_table()
        for i in selected:  # test set-up on 16 faces
            bm.faces[i].select_set(True)
        bm.faces.active = bm.faces[active]
        bmesh.update_edit_mesh(ob.data)
        if method == "blender":
            bpy.ops.uv.unwrap(method="CONFORMAL", correct_aspect=True)
        else:
            assert unwrap(correct_aspect=True) == {"FINISHED"}
        object_mode()
        uv, cv = corner_uvs(ob).astype(np.float64), corner_verts(ob)
        rows = np.repeat(np.isin(np.arange(16), list(selected)), 4)
        per_vertex = np.zeros((len(V), 2))
        per_vertex[cv[rows]] = uv[rows]
        assert np.abs(per_vertex[cv[rows]] - uv[rows]).max() < 1e-6  # one UV per vertex: no tear
        first = 4 * selected[0]
        ratios[method] = squeeze(uv[first : first + 4], V[cv[first : first + 4], :2])
    assert ratios["isoparam"] == pytest.approx(2.0 if active < 8 else 1.0, rel=1e-3)
    assert ratios["isoparam"] == pytest.approx(ratios["blender"], rel=1e-3)


@pytest.mark.parametrize("primitive", ["cube", "cylinder", "cone"])
@pytest.mark.parametrize("charts", [False, True])
def test_automatic_cuts_of_closed_polygon_meshes_follow_mesh_edges(scene, primitive, charts):
    # the cut used to run along quad and n-gon diagonals, which exist only after
    # triangulation: a face corner then needed two UVs and the written triangles folded
    # (the charts' cells and cuts, too, keep to the faces' edges)
    getattr(bpy.ops.mesh, f"primitive_{primitive}_add")()
    ob = bpy.context.object
    edit(ob)
    assert unwrap(charts=charts) == {"FINISHED"}
    object_mode()
    uv = corner_uvs(ob).astype(np.float64)[triangles(ob)]
    e1, e2 = uv[:, 1] - uv[:, 0], uv[:, 2] - uv[:, 0]
    area = 0.5 * (e1[:, 0] * e2[:, 1] - e1[:, 1] * e2[:, 0])
    assert (area > 0).all()


def test_extra_cuts_open_a_closed_cube_towards_its_corners(scene):
    # a subdivided cube with no seams: the shortest cut that opens it squeezes the faces
    # around its corners; the default Extra Cuts run paths to them, along quad edges
    bpy.ops.mesh.primitive_cube_add()
    ob = bpy.context.object
    edit(ob)
    bpy.ops.mesh.subdivide(number_cuts=5)
    measured = {}
    for cuts in (0, 4):
        assert unwrap(extra_cuts=cuts, charts=False) == {"FINISHED"}
        object_mode()
        V, F, uv = triangle_uvs(ob)
        measured[cuts] = metrics.distortion(V, F, uv)
        assert measured[cuts].flipped == 0  # a cut along a quad's diagonal would fold it
        edit(ob)
    # measured on bpy 5.0.1: area distortion 0.290 -> 0.053, symmetric Dirichlet 4.65 -> 4.06
    assert measured[4].area_distortion < 0.25 * measured[0].area_distortion
    assert measured[4].symmetric_dirichlet < 4.2 < measured[0].symmetric_dirichlet


def test_charts_cut_a_closed_mesh_and_mark_seams_keeps_the_cuts(scene, capfd):
    bpy.ops.mesh.primitive_uv_sphere_add()  # closed, no seams
    ob = bpy.context.object
    edit(ob)
    capfd.readouterr()
    assert unwrap(mark_seams=True) == {"FINISHED"}
    text = capfd.readouterr().out
    object_mode()
    V, F, cuv = triangle_uvs(ob)
    charts = len(np.unique(metrics.uv_islands(F, cuv)))
    seams = np.zeros(len(ob.data.edges), dtype=bool)
    ob.data.edges.foreach_get("use_seam", seams)
    assert charts > 1 and seams.any()
    assert f"1 island was cut into {charts} charts (1 not a disk" in text
    assert metrics.distortion(V, F, cuv).flipped == 0
    # the marked seams are the charts: unwrapped again along them, charts off, the same islands
    edit(ob)
    assert unwrap(charts=False) == {"FINISHED"}
    object_mode()
    V, F, again = triangle_uvs(ob)
    assert len(np.unique(metrics.uv_islands(F, again))) == charts
    assert metrics.distortion(V, F, again).flipped == 0


def test_refinement_0_folds_no_triangle_of_a_closed_mesh(scene):
    # the paper's four-step layout folds on some of Suzanne's charts; with Refinement 0 the
    # operator lays those out by a conformal map instead, so that charts and overlap cuts
    # work on a fold-free layout, and cut it into a few dozen islands at most
    bpy.ops.mesh.primitive_monkey_add()
    ob = bpy.context.object
    edit(ob)
    assert unwrap(refine=0) == {"FINISHED"}
    object_mode()
    _, F, cuv = triangle_uvs(ob)
    assert (corner_signed_areas(cuv) <= 0).sum() == 0
    assert metrics.uv_islands(F, cuv).max() + 1 < 60


@pytest.mark.parametrize("refine", [0, DEFAULTS.refine])
def test_what_the_four_steps_met_is_a_debug_detail_once_refined(scene, refine, caplog):
    # a band round a sphere: its four-step layout folds; with refinement, which starts it
    # from a conformal map, the result is what counts (no fold): the solver's own fact goes
    # to the debug log, not the report; without, it is the layout's own story, a warning
    # in the artist's words
    from isoparam_addon.blender.record import last_record

    V, F = ex.sphere_band()
    edit(add_mesh("band", V, F))
    with caplog.at_level(logging.DEBUG, logger="isoparam"):
        assert unwrap(refine=refine) == {"FINISHED"}
    run = last_record(bpy.context)
    assert [d for d in run.details if "four-step layout folded" in d]
    assert any("four-step layout folded" in r.getMessage() and r.levelno == logging.DEBUG for r in caplog.records)
    said = run.notes + run.warnings
    assert not [text for text in said if "four-step" in text or "step" in text.split()]
    warned = [text for text in run.warnings if "laid out with angles kept instead" in text]
    assert len(warned) == (0 if refine else 1)
    if not refine:
        assert "Refinement above 0" in warned[0]
