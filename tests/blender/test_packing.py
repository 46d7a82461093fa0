"""What the pack gives an artist: islands fitted by their shapes (Fill Shapes, the
default), margins in texture pixels, and the share of the texture the unwrap covers, said
in the report (real bpy; Blender's packer for its shapes and for pinned islands)."""

import numpy as np
import pytest

from isoparam_addon.blender.record import last_record
from isoparam_addon.solver import metrics
from isoparam_eval import meshes as ex
from isoparam_eval.blender import corner_uvs, read_uvs, set_uvs_and_pins
from isoparam_eval.layouts import islands_overlapping, least_gap

from .conftest import add_mesh, bpy, edit, object_mode


def _unwrapped(V, F, **options):
    ob = add_mesh("m", V, F)
    edit(ob)
    assert bpy.ops.uv.isometric_unwrap(**options) == {"FINISHED"}
    object_mode()
    return read_uvs(ob)


def _boxes_apart(F, cuv) -> float:
    """The least gap between the bounding boxes of two UV islands (negative: they overlap)."""
    label = metrics.uv_islands(F, cuv)
    boxes = [
        (cuv[label == i].reshape(-1, 2).min(0), cuv[label == i].reshape(-1, 2).max(0)) for i in range(label.max() + 1)
    ]
    gaps = [
        max(b_lo[0] - a_hi[0], a_lo[0] - b_hi[0], b_lo[1] - a_hi[1], a_lo[1] - b_hi[1])
        for k, (a_lo, a_hi) in enumerate(boxes)
        for b_lo, b_hi in boxes[k + 1 :]
    ]
    return min(gaps)


@pytest.mark.parametrize("shape", ["ISOPARAM", "AABB"])
@pytest.mark.parametrize("pixels, size", [(8, 256), (4, 2048)])
def test_a_margin_in_pixels_keeps_islands_that_far_from_the_border_and_twice_from_each_other(
    scene, pixels, size, shape
):
    V, F, _ = ex.load_obj(ex.SPOT)  # closed: four charts
    Ft, cuv = _unwrapped(V, F, margin_pixels=pixels, texture_size=size, pack_shape=shape)
    m = pixels / size
    p = cuv.reshape(-1, 2)
    label = metrics.uv_islands(Ft, cuv)
    assert label.max() + 1 > 1
    assert p.min() >= m - 1e-5 and p.max() <= 1 - m + 1e-5
    assert np.isclose(p.min(axis=0), m, atol=1e-4).any()  # (the margin, not more: the pack fills up to it)
    if shape == "AABB":  # Blender's Bounding Box: boxes that far apart
        assert _boxes_apart(Ft, cuv) >= 2 * m - 1e-5
    else:  # Fill Shapes: the shapes that far apart (float32 UVs: 1e-5), boxes may interlock
        assert islands_overlapping(cuv, label) == 0
        assert least_gap(cuv, label, spacing=m / 2) >= 2 * m - 1e-5


def test_fill_shapes_covers_more_than_bounding_box_and_says_so(scene):
    V, F, _ = ex.load_obj(ex.SPOT)
    cover = {}
    for shape in ("AABB", "ISOPARAM"):
        bpy.ops.wm.read_homefile(use_empty=True)
        Ft, cuv = _unwrapped(V, F, pack_shape=shape)
        cover[shape] = metrics.coverage(cuv)
        assert last_record(bpy.context).coverage == pytest.approx(cover[shape], abs=1e-6)
        assert islands_overlapping(cuv, metrics.uv_islands(Ft, cuv)) == 0
    assert cover["ISOPARAM"] > 1.2 * cover["AABB"]


def test_pinned_islands_stay_and_the_rest_is_packed_by_blenders_packer(scene):
    # Fill Shapes packs everything anew: with an island pinned, Blender's packer (which
    # leaves pinned islands where they are) packs instead
    V, F, _ = ex.load_obj(ex.SPOT)
    ob = add_mesh("m", V, F)
    edit(ob)
    assert bpy.ops.uv.isometric_unwrap() == {"FINISHED"}
    object_mode()
    Ft, cuv = read_uvs(ob)
    label = metrics.uv_islands(Ft, cuv)
    me = ob.data
    pins = np.zeros(len(me.loops), dtype=bool)
    me.calc_loop_triangles()
    tri = np.empty(3 * len(me.loop_triangles), np.int32)
    me.loop_triangles.foreach_get("loops", tri)
    pins[tri.reshape(-1, 3)[label == 0].ravel()] = True
    set_uvs_and_pins(ob, corner_uvs(ob), pins)
    before = cuv[label == 0]
    edit(ob)
    assert bpy.ops.uv.isometric_unwrap() == {"FINISHED"}
    object_mode()
    _, after = read_uvs(ob)
    assert np.allclose(after[label == 0], before, atol=1e-6)  # the pinned island stayed
    assert last_record(bpy.context).pack > 0


def test_one_island_is_fitted_with_the_same_margin_in_pixels(scene):
    V, F, _ = ex.s_surface(30, 8)  # one open island: fitted into the square without Blender's pack
    Ft, cuv = _unwrapped(V, F, margin_pixels=16, texture_size=512)
    p = cuv.reshape(-1, 2)
    m = 16 / 512
    assert metrics.uv_islands(Ft, cuv).max() == 0
    assert p.min() >= m - 1e-5 and p.max() <= 1 - m + 1e-5
    assert np.isclose(p.min(axis=0), m, atol=1e-6).all() and np.isclose(p.max(), 1 - m, atol=1e-6)


def test_the_report_says_how_much_of_the_texture_is_covered(scene, capfd):
    V, F, _ = ex.load_obj(ex.SPOT)
    capfd.readouterr()
    Ft, cuv = _unwrapped(V, F)
    printed = capfd.readouterr().out
    covered = metrics.coverage(cuv)
    assert 0.2 < covered < 1.0
    assert last_record(bpy.context).coverage == pytest.approx(covered, abs=1e-6)  # (as packed, read back)
    assert f"coverage {covered:.0%}" in printed


def test_coverage_is_the_uv_area_over_the_square_that_holds_it():
    square = np.array([[[0, 0], [1, 0], [1, 1]], [[0, 0], [1, 1], [0, 1]]], dtype=np.float64)
    assert metrics.coverage(square) == pytest.approx(1.0)
    assert metrics.coverage(3.0 * square + 5.0) == pytest.approx(1.0)  # the square that holds it
    half = square.copy()
    half[..., 0] *= 0.5  # a 0.5 x 1 rectangle in a 1 x 1 square
    assert metrics.coverage(half) == pytest.approx(0.5)
    assert metrics.coverage(half, half + [0.5, 0.0]) == pytest.approx(1.0)  # layouts together
    assert metrics.coverage(np.zeros((0, 3, 2))) == 0.0
