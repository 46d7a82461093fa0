"""The distortion measures on layouts with known answers."""

import numpy as np
import pytest

from isoparam_addon.solver import metrics
from isoparam_addon.solver.geometry import triangles
from isoparam_eval import meshes as ex


@pytest.fixture
def flat():
    V, F, U = ex.plane_random(200, 1)
    V = np.column_stack([U, np.zeros(len(U))])
    return V, F, U


def test_isometric_layout(flat):
    V, F, U = flat
    d = metrics.distortion(V, F, U)
    assert d.residual_variance < 1e-30 and d.edge_rms < 1e-14 and d.one_minus_r2 < 1e-14
    assert d.stretch_l2 == pytest.approx(1) and d.stretch_linf == pytest.approx(1)
    assert d.symmetric_dirichlet == pytest.approx(4)
    assert d.area_distortion < 1e-12 and d.angle_distortion < 1e-12 and d.angle_error_deg < 1e-10
    assert d.flipped == 0


def test_uniform_scale_is_normalised_where_documented(flat):
    V, F, U = flat
    d = metrics.distortion(V, F, 3 * U)
    assert d.edge_rms < 1e-14 and d.stretch_l2 == pytest.approx(1)
    assert d.symmetric_dirichlet == pytest.approx(4) and d.area_distortion < 1e-12
    # the paper's residual variance is in mesh units: it sees the scale
    l3, _ = metrics.uv_edge_lengths(V, F, U)
    assert d.residual_variance == pytest.approx(np.var(2 * l3))


def test_anisotropic_stretch_has_the_analytic_values(flat):
    V, F, U = flat
    d = metrics.distortion(V, F, U * [2.0, 1.0])
    # sigma = (2, 1) up to scale: at equal area sigma' = (sqrt2, 1/sqrt2), Sander's map is the inverse
    assert d.stretch_l2 == pytest.approx(np.sqrt(1.25))
    assert d.stretch_linf == pytest.approx(np.sqrt(2))
    assert d.symmetric_dirichlet == pytest.approx(5.0)  # min over s of 5 s^2 + 1.25 / s^2
    assert d.angle_distortion == pytest.approx(np.log(2))
    assert d.area_distortion < 1e-12


def test_flips_count_folded_and_collapsed_faces():
    V, F = ex.peaks(7)
    uv = V[:, :2].copy()
    assert metrics.flipped(V, F, uv) == 0
    centre = 3 * 7 + 3
    uv[centre] += [1.5, 0.0]  # drag a vertex over its right neighbour: its right faces fold
    a, b, c = uv[F[:, 0]], uv[F[:, 1]], uv[F[:, 2]]
    signed = (b[:, 0] - a[:, 0]) * (c[:, 1] - a[:, 1]) - (b[:, 1] - a[:, 1]) * (c[:, 0] - a[:, 0])
    assert 0 < (signed < 0).sum() == metrics.flipped(V, F, uv) < 6
    uv = V[:, :2].copy()
    uv[centre] = uv[centre + 1]  # collapse onto a neighbour: two faces lose all area
    assert metrics.flipped(V, F, uv) == 2
    # a whole island mirrored is not folded
    assert metrics.flipped(V, F, V[:, :2] * [-1, 1]) == 0


def test_seam_edges_count_once_per_side():
    V, F, _ = ex.s_surface(6, 3)
    cuv = V[F][:, :, :2].copy()
    l3, l2 = metrics.uv_edge_lengths(V, F, cuv)
    assert len(l3) == 5 * 3 + 6 * 2 + 5 * 2  # rows, columns, diagonals: every edge once
    cuv[0] += 10.0  # detach face 0: its interior edges now count once per side
    l3b, _ = metrics.uv_edge_lengths(V, F, cuv)
    assert len(l3b) > len(l3)


def test_stretch_summary_has_the_analytic_values_and_combines_by_area():
    V = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]], dtype=np.float64)
    F = np.array([[0, 1, 2], [0, 2, 3]])
    true = V[F][:, :, :2]
    wide = true * [2.0, 1.0]  # u doubled: after the area-preserving scale, sigma = (sqrt 2, 1/sqrt 2)
    a, b = metrics.face_stretch(V, F, true)[1], metrics.face_stretch(2 * V, F, 2 * wide)[1]  # areas 1 and 4
    assert a.worst == pytest.approx(1.0) and a.mean == pytest.approx(1.0) and a.area == pytest.approx(1.0)
    assert b.worst == pytest.approx(np.sqrt(2)) and b.mean == pytest.approx(np.sqrt(2)) and b.area == pytest.approx(4.0)
    both = metrics.combine_stretch([a, b])
    assert both.worst == pytest.approx(np.sqrt(2))
    assert both.mean == pytest.approx((1.0 + 4.0 * np.sqrt(2)) / 5.0)  # weighted by 3D area


def test_a_needle_is_flat_whichever_corner_comes_first_and_left_out_of_the_stretch():
    # a unit right triangle, and a needle beside it whose first side is 1e-8 long: in the
    # plane, laid out as it is (isometric), every measure is 1
    V = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [1 + 1e-8, 0, 0]], dtype=np.float64)
    needle = np.array([1, 3, 2])
    for turn in range(3):
        F = np.array([[0, 1, 2], np.roll(needle, turn)])
        assert triangles(V, F).collapsed.tolist() == [False, True]
        assert metrics.stretch(V, F, V[:, :2]) == pytest.approx((1.0, 1.0))
        assert metrics.symmetric_dirichlet(V, F, V[:, :2]) == pytest.approx(4.0)
