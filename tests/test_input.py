"""Bad input: one exception family, a message with the count and first offender, no
modification of the caller's arrays. Hard but valid input: solved, never NaN."""

import subprocess
import sys

import numpy as np
import pytest

from isoparam_addon.solver import ErrorKind, InvalidMeshError, IsoparamError, WarningKind, metrics, parametrize
from isoparam_eval import meshes as ex


def square():
    V = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]], dtype=float)
    F = np.array([[0, 1, 2], [0, 2, 3]])
    return V, F


def raises(kind, V, F, match, **kw):
    V0, F0 = (np.array(x, copy=True) if isinstance(x, np.ndarray) else None for x in (V, F))
    with pytest.raises(InvalidMeshError, match=match) as info:
        parametrize(V, F, **kw)
    assert info.value.kind is kind
    assert isinstance(info.value, IsoparamError) and isinstance(info.value, ValueError)
    if isinstance(V, np.ndarray):
        np.testing.assert_array_equal(V, V0)  # nothing modified in place, NaNs included
    if isinstance(F, np.ndarray):
        np.testing.assert_array_equal(F, F0)
    return info.value


def test_empty_mesh():
    raises(ErrorKind.EMPTY, np.zeros((0, 3)), np.zeros((0, 3), dtype=int), "empty mesh: 0 vertices and 0 faces")
    V, _ = square()
    raises(ErrorKind.EMPTY, V, np.zeros((0, 3), dtype=int), "0 faces")


def test_wrong_shapes_and_dtypes():
    V, F = square()
    raises(ErrorKind.SHAPE, V[:, :2], F, r"vertices must have shape \(n, 3\)")
    raises(ErrorKind.SHAPE, V, F[:, :2], r"faces must have shape \(m, 3\)")
    raises(ErrorKind.SHAPE, V, F + 0.5, "integer indices")


def test_ragged_and_non_numeric_input():
    V, F = square()
    raises(ErrorKind.SHAPE, [[0, 0, 0], [1, 0], [1, 1, 0], [0, 1, 0]], F, "vertices must be an array of numbers")
    raises(ErrorKind.SHAPE, V, [[0, 1, 2], [0, 2]], "faces must be an array of numbers")
    raises(ErrorKind.SHAPE, [["a", "b", "c"]] * 4, F, "vertices must be an array of numbers")
    raises(ErrorKind.SHAPE, V + 5j, F, "vertices must be an array of numbers: complex")  # not dropped to real


def test_bad_pins():
    V, F = square()
    mask, uv = np.zeros((2, 3), dtype=bool), np.zeros((2, 3, 2))
    raises(ErrorKind.SHAPE, V, F, r"pins must be \(\(m, 3\) bool", pins=(mask[:1], uv))
    raises(ErrorKind.SHAPE, V, F, r"pins must be .*with m = 2", pins=(mask, [[[0, 0]] * 3, [[0, 0]] * 2]))
    raises(ErrorKind.SHAPE, V, F, r"pins must be", pins=mask)
    mask[1, 2] = mask[0, 1] = True
    uv[1, 2] = np.nan
    uv[0, 0] = np.inf  # not pinned: ignored
    message = r"1 face has pinned corners with non-finite UVs \(first: face 1\)"
    err = raises(ErrorKind.NON_FINITE_PIN, V, F, message, pins=(mask, uv))
    assert err.indices.tolist() == [1]


def test_non_finite_coordinates_name_count_and_first():
    V, F = square()
    V[2, 1] = np.nan
    V[3, 0] = np.inf
    err = raises(ErrorKind.NON_FINITE, V, F, r"2 vertices have non-finite coordinates \(first: vertex 2\)")
    assert err.indices.tolist() == [2, 3] and err.element == "vertex"


def test_index_out_of_range():
    V, F = square()
    F[1, 2] = 7
    err = raises(ErrorKind.INDEX_RANGE, V, F, r"1 face indexes a vertex outside 0..3 \(first: face 1\)")
    assert err.indices.tolist() == [1]
    F[1, 2] = -1
    raises(ErrorKind.INDEX_RANGE, V, F, "first: face 1")


def test_repeated_vertex_in_a_face():
    V, F = square()
    F[0] = [0, 1, 1]
    raises(ErrorKind.REPEATED_VERTEX, V, F, r"1 face uses the same vertex twice \(first: face 0\)")


def test_duplicate_face():
    V, F = square()
    F = np.vstack([F, [2, 0, 1]])
    raises(
        ErrorKind.DUPLICATE_FACE,
        V,
        F,
        r"1 face repeats the vertices of an earlier face \(first: face 2\)",
        split_nonmanifold=False,
    )


def test_edge_shared_by_three_faces():
    V = np.array([[0, 0, 0], [1, 0, 0], [0.5, 1, 0], [0.5, -1, 0], [0.5, 0, 1]], dtype=float)
    F = np.array([[0, 1, 2], [1, 0, 3], [0, 1, 4]])
    err = raises(
        ErrorKind.NON_MANIFOLD_EDGE,
        V,
        F,
        r"1 edge is shared by more than two faces \(first: edge \(0, 1\)\)",
        split_nonmanifold=False,
    )
    assert err.edges.tolist() == [[0, 1]]


def test_bow_tie_vertex():
    V = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [-1, 0, 0], [0, -1, 0]], dtype=float)
    F = np.array([[0, 1, 2], [0, 3, 4]])
    err = raises(
        ErrorKind.NON_MANIFOLD_VERTEX,
        V,
        F,
        r"1 vertex joins faces that share no edge .*\(first: vertex 0\)",
        split_nonmanifold=False,
    )
    assert err.indices.tolist() == [0]


def test_what_is_not_a_manifold_is_split_as_blender_does_and_warned():
    # a repeated face, an edge of three faces, a bow-tie: the default splits them (each
    # piece exact), says so, and names the first of each
    V = np.array([[0, 0, 0], [1, 0, 0], [0.5, 1, 0], [0.5, -1, 0], [0.5, 0, 1], [0, -2, 0], [1, -2, 0]], float)
    F = np.array([[0, 1, 2], [1, 0, 3], [0, 1, 4], [3, 5, 6], [2, 0, 1]])
    r = parametrize(V, F)
    kinds = {w.kind: w for w in r.warnings}
    assert kinds[WarningKind.DUPLICATE_FACES].text.startswith(
        "1 face repeats the vertices of an earlier face (first: face 4)"
    )
    assert kinds[WarningKind.NON_MANIFOLD_EDGES].text.startswith(
        "1 edge is shared by more than two faces (first: edge (0, 1))"
    )
    assert kinds[WarningKind.BOWTIES].count == 1 and kinds[WarningKind.BOWTIES].first == (3,)
    # each face on its own: the three around the edge, the repeated one, the bow-tie's wing
    assert r.n_islands == 5 and np.isfinite(r.corner_uv).all() and not r.flipped.any()
    l3, l2 = metrics.uv_edge_lengths(V, F, r.corner_uv)
    np.testing.assert_allclose(l2, l3, rtol=1e-12)


def test_bad_seams():
    V, F = square()
    raises(ErrorKind.SEAM, V, F, "seams must be an", seams=np.array([0.5, 1.5]))
    raises(ErrorKind.SEAM, V, F, r"1 seam indexes a vertex outside", seams=np.array([[0, 9]]))
    raises(ErrorKind.SEAM, V, F, "inner_edges must be an", inner_edges=np.array([0.5, 1.5]))
    raises(ErrorKind.SEAM, V, F, r"1 inner_edge indexes a vertex outside", inner_edges=np.array([[0, 9]]))


def test_seam_pairs_that_are_not_edges_are_ignored():
    V, F = square()
    r = parametrize(V, F, seams=np.array([[1, 3]]))  # the other diagonal
    assert r.n_islands == 1


def test_inputs_are_not_modified_on_success():
    V, F = ex.peaks(15)
    V0, F0 = V.copy(), F.copy()
    parametrize(V, F)
    np.testing.assert_array_equal(V, V0)
    np.testing.assert_array_equal(F, F0)


def test_lists_and_other_dtypes_are_accepted():
    V, F = square()
    r = parametrize(V.astype(np.float32).tolist(), F.astype(np.uint32))
    assert r.uv.shape == (4, 2) and r.uv.dtype == np.float64


def test_zero_area_and_sliver_faces_give_finite_uvs():
    V, F = ex.peaks(21)
    V = V.copy()
    # collapse one face to a segment (zero area) and one edge to a point (coincident vertices)
    a, b, c = F[100]
    V[c] = 0.5 * (V[a] + V[b])
    d, e, _ = F[300]
    V[e] = V[d]
    r = parametrize(V, F)
    assert np.isfinite(r.uv).all() and np.isfinite(r.corner_uv).all()
    dist = r.distortion()
    assert np.isfinite(dist.edge_rms) and dist.edge_rms < 0.5


def test_island_of_one_triangle_is_laid_out_exactly():
    V = np.array([[0, 0, 0], [3, 0, 0], [0, 4, 0.0]])
    r = parametrize(V, np.array([[0, 1, 2]]))
    d = np.linalg.norm(r.uv[[1, 2, 0]] - r.uv, axis=1)
    np.testing.assert_allclose(d, [3, 5, 4], rtol=1e-12)
    assert not r.flipped.any()


def test_zero_area_island_does_not_give_nan():
    V = np.array([[0, 0, 0], [1, 0, 0], [2, 0, 0], [3, 0, 0.0]])
    F = np.array([[0, 1, 2], [1, 3, 2]])
    r = parametrize(V, F)
    assert np.isfinite(r.uv).all()


@pytest.mark.parametrize("corners", [[[5, 5, 0], [6, 5, 0], [7, 5, 0]], [[5, 5, 0], [5, 5, 0], [7, 5, 0]]])
def test_an_island_with_no_area_keeps_its_lengths_and_is_not_called_far_from_isometric(corners):
    # found on ogre with Smart UV Project's seams: single faces with no 3D area were
    # restarted, refined to a sliver of area and reported "far from isometric (distortion
    # 3.6e6) ... mark seams to cut it", which no seam can do
    from isoparam_addon.operation.options import DEFAULTS

    V, F = ex.peaks(11)
    n = len(V)
    r = parametrize(np.vstack([V, corners]), np.vstack([F, [[n, n + 1, n + 2]]]), options=DEFAULTS.solver_options())
    assert not [w for w in r.warnings if w.kind is WarningKind.FAR_FROM_ISOMETRIC]
    uv = r.corner_uv[-1]
    lengths = np.linalg.norm(np.asarray(corners, dtype=float) - np.roll(corners, -1, axis=0), axis=1)
    np.testing.assert_allclose(np.linalg.norm(uv - np.roll(uv, -1, axis=0), axis=1), lengths, atol=1e-4)
    assert not r.flipped.any()


@pytest.mark.parametrize("refine", [0, 100])
def test_islands_collapsed_to_a_point_or_a_line_give_finite_uvs_and_leave_other_islands_alone(refine):
    # all-coincident points made 0/0 weights (NaN in L, then a LinAlgError in Step 3) and
    # a zero refinement proxy (SuperLU: "Factor is exactly singular")
    V, F = ex.peaks(11)
    n = len(V)
    alone = parametrize(V, F, pack=False, refine=refine)
    cases = [
        (np.zeros((3, 3)), np.array([[0, 1, 2]])),
        (np.zeros((4, 3)), np.array([[0, 1, 2], [0, 2, 3]])),
        (np.vstack([V, np.full((3, 3), 0.25)]), np.vstack([F, [[n, n + 1, n + 2]]])),
        # islands with interior vertices: their fans' MDS was 0/0 (NaN), and Step 3's LU
        # raised "Factor is exactly singular"
        (np.vstack([V, np.full_like(V, 0.25)]), np.vstack([F, F + n])),
        (np.vstack([V, V[:, [0]] * [1.0, 2.0, 0.0] + 5.0]), np.vstack([F, F + n])),  # on a line
    ]
    for Vc, Fc in cases:
        r = parametrize(Vc, Fc, pack=False, refine=refine)
        assert np.isfinite(r.uv).all() and np.isfinite(r.corner_uv).all()
        assert any("degenerate" in w.text for w in r.warnings)
    np.testing.assert_allclose(r.uv[:n], alone.uv, atol=1e-9)


def test_pinned_islands_collapsed_to_a_point_give_finite_uvs():
    # found by fuzzing the operator (six faces of it): every vertex on one point, pins
    # apart; the refinement started from an infinite energy and inf - inf made NaN UVs
    V = np.tile([-2.5353877544403076, 3.7179245948791504, 0.12965722382068634], (13, 1))
    F = np.array([[2, 0, 5], [6, 8, 3], [6, 3, 4], [11, 1, 12], [7, 9, 10], [7, 10, 8]])
    locked = np.array([[0, 0, 0], [0, 1, 1], [0, 1, 0], [0, 1, 0], [1, 1, 1], [1, 1, 0]], dtype=bool)
    old = np.zeros((6, 3, 2))
    old[locked] = [
        [0.57585835, 0.6572701],
        [0.55166495, 0.65832525],
        [0.55166495, 0.65832525],
        [0.7114335, 0.16781734],
        [0.60143036, 0.65705377],
        [0.5864351, 0.74666667],
        [0.5635054, 0.7434769],
        [0.60143036, 0.65705377],
        [0.5635054, 0.7434769],
    ]
    seams = [[2, 0], [0, 5], [3, 8]]
    r = parametrize(V, F, seams, split_nonmanifold=True, refine=100, pins=(locked, old))
    assert np.isfinite(r.uv).all() and np.isfinite(r.corner_uv).all()
    assert np.isfinite(r.stats.refine_energy[1:]).all()  # the seed's is infinite
    np.testing.assert_array_equal(r.corner_uv[locked], old[locked])


def test_a_face_collapsed_to_a_point_does_not_stop_the_refinement():
    # its gradient was 0/0: the island's energy NaN, no descent step ever accepted
    V, F = ex.peaks(21)
    V = V.copy()
    a, b, c = F[100]
    V[b] = V[c] = V[a]
    plain = parametrize(V, F).distortion().symmetric_dirichlet
    r = parametrize(V, F, refine=10)
    assert np.isfinite(r.stats.refine_energy).all() and r.stats.refine_iterations > 0
    assert r.distortion().symmetric_dirichlet < plain


@pytest.mark.parametrize("scale", [2.0**-600, 1e-150, 1e150, 2.0**600])
def test_extreme_coordinate_scales_scale_the_layout(scale):
    # squared lengths and their squares over- or underflowed beyond about 1e+-77
    V, F = ex.peaks(15)
    ref = parametrize(V, F)
    r = parametrize(V * scale, F)
    np.testing.assert_allclose(r.uv / scale, ref.uv, rtol=0, atol=1e-9 * np.ptp(ref.uv))


def test_unreferenced_vertices_get_zero_and_a_warning():
    V, F = square()
    V = np.vstack([V, [[5, 5, 5]]])
    r = parametrize(V, F)
    assert r.uv[4].tolist() == [0.0, 0.0]
    assert "1 vertex belongs to no face and was placed at (0, 0)" in [w.text for w in r.warnings]


def test_solver_imports_without_bpy():
    code = "import sys, isoparam_addon.solver, isoparam_addon.solver.metrics; print('bpy' in sys.modules)"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "False"


def test_coincident_vertices_do_not_stop_the_restart_of_a_folded_island():
    # two pairs of distinct vertices at one position: the Tutte restart's mean-value
    # weights had 1e-300 edge lengths and SuperLU raised "Factor is exactly singular"
    # (found by fuzzing; minimised from a noisy sphere beside a disk)
    V = np.array(
        [[0.88, -0.38, -0.52], [0.76, -0.33, -0.47], [0.91, -0.4, -0.53], [0.79, -0.36, -0.48],
         [0.79, -0.36, -0.48], [0.69, -0.32, -0.44], [0.76, -0.37, -0.47], [0.56, -0.31, -0.39],
         [0.56, -0.3, -0.39], [0.56, -0.31, -0.39], [0.51, -0.32, -0.37]]
    )  # fmt: skip
    F = np.array(
        [[1, 4, 0], [4, 1, 5], [7, 4, 5], [8, 7, 5], [3, 2, 0], [4, 3, 0], [6, 3, 4], [7, 6, 4],
         [3, 6, 2], [9, 10, 7], [9, 7, 8]]
    )  # fmt: skip
    r = parametrize(V, F, refine=100)
    assert np.isfinite(r.corner_uv).all()
    assert r.stats.restarted_tutte == 1 and not r.flipped.any()
