"""Mesh I/O against Blender's own (slow, item-by-item) collections."""

import numpy as np
import pytest

from isoparam_addon.blender import mesh_io
from isoparam_eval import meshes as ex

from .conftest import add_mesh, bpy, object_mode, triangles


def _reference(me):
    """Triangles, their faces and the faces' corner counts through RNA collections."""
    me.calc_loop_triangles()
    poly = np.empty(len(me.loop_triangles), dtype=np.int32)
    me.loop_triangles.foreach_get("polygon_index", poly)
    total = np.empty(len(me.polygons), dtype=np.int32)
    me.polygons.foreach_get("loop_total", total)
    return poly, total


def _mixed():
    """Two quads and three triangles in one mesh."""
    V = [[0, 0, 0], [1, 0, 0], [2, 0, 0], [0, 1, 0], [1, 1, 0.3], [2, 1, 0], [2.5, 0.5, 0], [1, 2, 0]]
    F = [[0, 1, 4, 3], [1, 2, 5, 4], [2, 6, 5], [3, 4, 7], [4, 5, 7]]
    return V, F


@pytest.mark.parametrize("kind", ["triangles", "quads", "mixed", "ngon", "two_corner_face"])
def test_triangles_match_blenders_loop_triangles(scene, kind):
    if kind == "triangles":
        ob = add_mesh("m", *ex.peaks(9))
    elif kind == "quads":
        bpy.ops.mesh.primitive_uv_sphere_add(segments=12, ring_count=7)  # quads and triangle fans
        ob = bpy.context.object
        object_mode()
    elif kind == "mixed":
        ob = add_mesh("m", *_mixed())
    elif kind == "ngon":
        bpy.ops.mesh.primitive_circle_add(vertices=9, fill_type="NGON")
        ob = bpy.context.object
        object_mode()
    else:  # a quad and a face of two corners (unvalidated): as many triangles as faces
        V = [[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0], [2, 0, 0], [2, 1, 0]]
        me = bpy.data.meshes.new("m")
        me.from_pydata(V, [], [(0, 1, 2, 3), (4, 5)])
        ob = bpy.data.objects.new("m", me)
        bpy.context.scene.collection.objects.link(ob)
    me = ob.data
    tri, poly, total = mesh_io.triangles(me)
    ref_poly, ref_total = _reference(me)
    np.testing.assert_array_equal(tri, triangles(ob))
    np.testing.assert_array_equal(poly, ref_poly)
    drawn = ref_total >= 3  # faces that have triangles
    np.testing.assert_array_equal(total[drawn], ref_total[drawn])
    assert tri.dtype == poly.dtype == total.dtype == np.int64
    # the two-corner face makes the counts of triangles and faces agree: the trap the
    # fast path must not fall into
    assert (kind in ("triangles", "two_corner_face")) == (len(tri) == len(me.polygons))
