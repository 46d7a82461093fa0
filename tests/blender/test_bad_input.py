"""Every bad-input path: an ERROR report, CANCELLED, and the mesh byte-for-byte as it was."""

import numpy as np
import pytest

from isoparam_addon.blender import mesh_io
from isoparam_eval import meshes as ex

from .conftest import add_mesh, bpy, corner_uvs, edit, object_mode, set_uvs_and_pins, snapshot


def run_and_capture(ob):
    """Run the operator in edit mode; return (result, error text) and leave object mode."""
    edit(ob)
    try:
        result = bpy.ops.uv.isometric_unwrap()
        message = ""
    except RuntimeError as exc:  # bpy turns an ERROR report into a RuntimeError
        result, message = {"CANCELLED"}, str(exc)
    object_mode()
    return result, message


def prepared(V, F):
    """A mesh with existing UVs, so that 'unchanged' covers them too."""
    ob = add_mesh("bad", V, F)
    edit(ob)
    bpy.ops.uv.unwrap(method="CONFORMAL")
    object_mode()
    return ob


def pin_at_nan(ob, corners):
    """Pin these corners (object mode), their UVs NaN, and nothing else."""
    pins = np.zeros(len(ob.data.loops), dtype=bool)
    pins[corners] = True
    uv = corner_uvs(ob)
    uv[corners] = np.nan
    set_uvs_and_pins(ob, uv, pins)


def not_a_manifold(case):
    """peaks with a third face on an edge, or a face given twice (Blender unwraps both)."""
    V, F = ex.peaks(9)
    V, F = V.copy(), F.tolist()
    if case == "three_faces_on_an_edge":
        V = np.vstack([V, [[0.0, 0.0, 5.0]]])
        a, d = F[20][0], F[20][2]  # a cell's diagonal: already shared by two faces
        F.append([a, d, len(V) - 1])
    else:
        F.append(list(F[3][::-1]))
    return V, F


@pytest.mark.parametrize(
    "case, expect",
    [
        ("three_faces_on_an_edge", "1 edge is shared by more than two faces (first: edge between vertices"),
        ("duplicate_face", "1 face repeats the vertices of an earlier face (first: face 128)"),
    ],
)
def test_what_blender_unwraps_though_not_a_manifold_is_unwrapped_and_warned(scene, case, expect, capfd):
    ob = prepared(*not_a_manifold(case))
    edit(ob)
    capfd.readouterr()
    assert bpy.ops.uv.isometric_unwrap() == {"FINISHED"}
    text = capfd.readouterr().out
    object_mode()
    assert expect in text
    uv = corner_uvs(ob)
    assert np.isfinite(uv).all() and uv.min() >= 0.0 and uv.max() <= 1.0


@pytest.mark.parametrize(
    "case, expect",
    [
        ("non_finite", "non-finite coordinates"),
        ("non_finite_pin", "pinned corners with non-finite UVs (first: face 5). Clear the pins"),
    ],
)
def test_bad_meshes_are_reported_and_left_untouched(scene, case, expect):
    V, F = ex.peaks(9)
    ob = prepared(V, F)
    if case == "non_finite":
        me = ob.data
        pos = np.empty(3 * len(me.vertices), np.float32)
        me.attributes["position"].data.foreach_get("vector", pos)
        pos[3 * 7] = np.nan
        me.attributes["position"].data.foreach_set("vector", pos)
        me.update()
    if case == "non_finite_pin":  # face 5's first corner pinned at a NaN UV
        pin_at_nan(ob, [ob.data.polygons[5].loop_start])
    before = snapshot(ob)
    result, message = run_and_capture(ob)
    assert result == {"CANCELLED"}
    assert expect in message and "Nothing was changed" in message
    assert snapshot(ob) == before


def test_uvs_beyond_the_uv_maps_range_are_an_error(scene):
    # found by fuzzing: True World Scale on a mesh 1e39 across gave FINISHED with inf UVs
    # (the layout is finite in float64; Blender's UV map is float32)
    V, F = ex.peaks(9)
    ob = prepared(V * 1e37, F)
    ob.scale = (100.0, 100.0, 100.0)
    before = snapshot(ob)
    edit(ob)
    with pytest.raises(RuntimeError, match="beyond the range of Blender's UV map.*Nothing was changed"):
        bpy.ops.uv.isometric_unwrap(world_scale=True, pack=False)
    object_mode()
    assert snapshot(ob) == before


def test_far_pins_are_kept_and_the_pack_is_skipped(scene, capfd):
    # found by fuzzing: a pin at (1e8, 1e8) crashed Blender's packer (Convex Hull) and NaN-ed
    # every packed island at 1e20; the operator now leaves such a layout unpacked, and says so
    V, F = ex.peaks(9)
    ob = prepared(V, F)
    me = ob.data
    pins = np.zeros(len(me.loops), dtype=bool)
    pins[me.polygons[0].loop_start] = True
    uv = corner_uvs(ob)
    uv[pins] = 1e8
    set_uvs_and_pins(ob, uv, pins)
    edit(ob)
    capfd.readouterr()
    assert bpy.ops.uv.isometric_unwrap(pack_shape="CONVEX") == {"FINISHED"}
    text = capfd.readouterr().out
    object_mode()
    after = corner_uvs(ob)
    assert "not packed: UVs beyond 1e+06" in text
    assert np.isfinite(after).all() and np.array_equal(after[pins], uv[pins])


@pytest.mark.parametrize("value", [np.nan, np.inf, 3e38])
def test_unwrapping_in_place_over_broken_old_uvs_lays_the_island_out_anew(scene, value):
    V, F = ex.peaks(9)
    ob = prepared(V, F)
    uv = corner_uvs(ob)
    uv[0] = value  # an unpinned corner: its old UV is about to be replaced
    ob.data.uv_layers.active.uv.foreach_set("vector", uv.ravel())
    edit(ob)
    assert bpy.ops.uv.isometric_unwrap(pack=False, charts=False) == {"FINISHED"}  # (one island)
    object_mode()
    after = corner_uvs(ob)
    assert np.isfinite(after).all() and after.min() >= 0.0 and after.max() <= 1.0


@pytest.mark.parametrize(
    "case",
    ["a triangle on a quad's diagonal", "two quads on three vertices", "loose seams on quads' diagonals"],
)
def test_quads_whose_diagonal_clashes_are_split_along_the_other(scene, case):
    # found by fuzzing: Blender's triangulation made these non-manifold ("edge shared by
    # more than two faces", "faces repeat the vertices"), where Blender's own unwrap works
    E, seams = [], ()
    if case == "a triangle on a quad's diagonal":
        V, F = [(0, 0, 0), (1, 0, 0), (1, 1, 0), (0, 1, 0), (0.5, 0.5, 1)], [(0, 1, 2, 3), (0, 2, 4)]
    elif case == "two quads on three vertices":
        V, F = [(0, 0, 0), (1, 0, 0), (1, 1, 0), (0, 1, 0), (1.2, 1.3, 0.5)], [(0, 1, 2, 3), (0, 1, 2, 4)]
    else:
        V = [(x, y, 0.1 * x * x - 0.2 * y * y) for y in range(4) for x in range(4)]  # curved
        F = [(4 * j + i, 4 * j + i + 1, 4 * j + i + 5, 4 * j + i + 4) for j in range(3) for i in range(3)]
        E, seams = [(0, 5), (5, 10)], {(0, 5), (5, 10)}
    me = bpy.data.meshes.new("m")
    me.from_pydata(V, E, F)
    me.update()
    ob = bpy.data.objects.new("m", me)
    bpy.context.scene.collection.objects.link(ob)
    me.edges.foreach_set("use_seam", [tuple(sorted(e.vertices)) in seams for e in me.edges])  # a small test mesh
    edit(ob)
    assert bpy.ops.uv.isometric_unwrap() == {"FINISHED"}
    object_mode()
    uv = corner_uvs(ob)
    assert np.isfinite(uv).all() and np.ptp(uv, axis=0).min() > 0.1
    if case == "loose seams on quads' diagonals":  # ignored, as by Blender: one island, uncut
        cv = np.empty(len(me.loops), dtype=np.int32)
        me.attributes[".corner_vert"].data.foreach_get("value", cv)
        assert len(np.unique(np.column_stack([cv, uv.view(np.int32)]), axis=0)) == len(V)


@pytest.mark.parametrize("other", ["triangle", "concave quad"])
def test_a_concave_quad_is_not_split_along_its_outside_diagonal(scene, other, capfd):
    # Blender splits a concave quad along its inside diagonal; a triangle on that diagonal
    # (or another concave quad split there) clashes, and the other diagonal runs outside
    # the quad: its triangles would overlap in 3D and fold the layout. The unwrap cuts the
    # two faces apart where they meet, as Blender's unwrap does, and names them.
    V = [(0, 0, 0), (1, 0, 0), (0.3, 0.3, 0), (0, 1, 0), (0.1, 0.1, 1), (0.8485, 0.8485, -0.5)]
    V[4] = (0.8485, 0.8485, 0.5) if other == "concave quad" else V[4]  # an arrowhead over 0 - 2
    F = [(0, 1, 2, 3), (0, 2, 4)] if other == "triangle" else [(0, 1, 2, 3), (0, 4, 2, 5)]
    me = bpy.data.meshes.new("concave")
    me.from_pydata(V, [], F)
    me.update()
    ob = bpy.data.objects.new("concave", me)
    bpy.context.scene.collection.objects.link(ob)
    edit(ob)
    bpy.ops.uv.unwrap(method="CONFORMAL")
    object_mode()
    edit(ob)
    capfd.readouterr()
    assert bpy.ops.uv.isometric_unwrap() == {"FINISHED"}
    message = capfd.readouterr().out
    object_mode()
    if other == "triangle":
        assert "faces 0 and 1 overlap: Blender splits face 0 along its diagonal between vertices 0 and 2" in message
        assert "which is a side of face 1: cut apart where they meet. Make face 0 convex" in message
    else:
        assert "faces 0 and 1 overlap: Blender splits both along their diagonal between vertices 0 and 2" in message
        assert "Make one of them convex" in message
    assert "Non Manifold" not in message  # Blender's mesh has no such edge: it would show nothing
    assert np.isfinite(corner_uvs(ob)).all()


def test_a_pinned_quad_is_counted_once(scene):
    # the solver counts triangles: a quad pinned at a NaN UV on both ends of its diagonal
    # was "2 faces have pinned corners" (fuzzing)
    V = [(x, y, 0.0) for y in range(3) for x in range(3)]
    F = [(3 * j + i, 3 * j + i + 1, 3 * j + i + 4, 3 * j + i + 3) for j in range(2) for i in range(2)]
    ob = prepared(V, F)
    me = ob.data
    me.calc_loop_triangles()
    tri = np.array([t.loops[:] for t in me.loop_triangles if t.polygon_index == 3])
    pin_at_nan(ob, np.intersect1d(tri[0], tri[1]))  # the two corners both triangles use
    before = snapshot(ob)
    result, message = run_and_capture(ob)
    assert result == {"CANCELLED"}
    assert "'bad': 1 face has pinned corners with non-finite UVs (first: face 3)" in message
    assert snapshot(ob) == before


def test_the_message_names_mesh_elements(scene):
    V, F = ex.peaks(9)
    ob = prepared(V, F)
    me = ob.data
    pos = np.empty(3 * len(me.vertices), np.float32)
    me.attributes["position"].data.foreach_get("vector", pos)
    pos[3 * 40 + 2] = np.inf
    me.attributes["position"].data.foreach_set("vector", pos)
    me.update()
    _, message = run_and_capture(ob)
    assert "'bad': 1 vertex has non-finite coordinates (first: vertex 40)" in message


def test_empty_selection_is_an_error(scene):
    V, F = ex.peaks(9)
    ob = prepared(V, F)
    edit(ob)
    bpy.ops.mesh.select_all(action="DESELECT")
    object_mode()
    before = snapshot(ob)
    edit(ob, select_all=False)
    with pytest.raises(RuntimeError, match="no faces selected"):
        bpy.ops.uv.isometric_unwrap()
    object_mode()
    assert snapshot(ob) == before


def test_hidden_faces_are_not_unwrapped(scene):
    V, F = ex.peaks(9)
    ob = prepared(V, F)
    before = corner_uvs(ob).copy()
    edit(ob)
    bpy.ops.mesh.select_all(action="SELECT")
    bpy.ops.mesh.hide(unselected=False)  # hides everything: nothing visible to unwrap
    with pytest.raises(RuntimeError, match="no faces selected"):
        bpy.ops.uv.isometric_unwrap()
    object_mode()
    assert np.array_equal(corner_uvs(ob), before)


def test_faces_touching_at_a_vertex_are_separate_islands(scene):
    V = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [-1, 0, 0], [0, -1, 0]], dtype=float)
    ob = add_mesh("bowtie", V, [[0, 1, 2], [0, 3, 4]])
    edit(ob)
    assert bpy.ops.uv.isometric_unwrap() == {"FINISHED"}


def test_uv_selection_locks_unselected_uvs_when_asked(scene):
    # the UV editor with sync select off: what read_selection does with the UV selection
    V, F = ex.peaks(5)
    ob = prepared(V, F)
    me = ob.data
    attr = me.attributes.get(".uv_select_vert") or me.attributes.get(f".vs.{me.uv_layers.active.name}")
    assert attr is not None
    picked = np.zeros(len(me.loops), dtype=bool)
    picked[::2] = True
    attr.data.foreach_set("value", picked)
    sel = mesh_io.read_selection(ob, world_space=False, uv_selection_locks=True)
    assert np.array_equal(sel.locked, ~picked)
    sel = mesh_io.read_selection(ob, world_space=False, uv_selection_locks=False)
    assert not sel.locked.any()


@pytest.mark.parametrize("collapse", ["point", "line"])
def test_a_part_scaled_to_a_point_or_a_line_is_unwrapped_with_the_rest(scene, collapse):
    # an artist's "scale by 0": its fans' MDS was 0/0, and the operator failed with
    # "Factor is exactly singular"
    V, F = ex.peaks(9)
    flat = np.full_like(V, 3.0) if collapse == "point" else V[:, [0]] * [1.0, 2.0, 0.0] + 3.0
    ob = add_mesh("collapsed", np.vstack([V, flat]), np.vstack([F, F + len(V)]))
    edit(ob)
    assert bpy.ops.uv.isometric_unwrap() == {"FINISHED"}
    object_mode()
    uv = corner_uvs(ob)
    assert np.isfinite(uv).all()
    # the intact island is laid out as it is alone (to a scale: the packing differs)
    alone = add_mesh("alone", V, F)
    edit(alone)
    assert bpy.ops.uv.isometric_unwrap() == {"FINISHED"}
    object_mode()

    def spread(uv):  # of UV over 3D edge length
        c = uv[: 3 * len(F)].reshape(-1, 3, 2)
        r = np.linalg.norm(c - c[:, [1, 2, 0]], axis=2) / np.linalg.norm(V[F] - V[F][:, [1, 2, 0]], axis=2)
        return r.std() / r.mean()

    assert abs(spread(uv) - spread(corner_uvs(alone))) < 1e-3
