"""The linear prediction of how a chart will stretch (solver/charting/stress.py): exact where the
surface is flat, right to first order where it is curved, and smooth in the mesh."""

import numpy as np
import pytest

from isoparam_addon.solver import metrics, parametrize
from isoparam_addon.solver.charting import stress
from isoparam_addon.solver.mesh.topology import build_topology
from isoparam_eval import meshes as ex


def _predicted(V, F):
    _, _, topo = build_topology(V, F, None, True, None, None)
    X = np.asarray(V, dtype=np.float64)[topo.vertex_of]
    boundary = np.zeros(len(X), dtype=bool)
    h = np.flatnonzero(topo.he.twin < 0)
    boundary[topo.faces.ravel()[h]] = True
    return stress.predict(X, topo.faces, boundary, topo.face_island, topo.n_islands), X, topo, boundary


@pytest.mark.parametrize("mesh", [lambda: ex.plane_random(300, 1), lambda: ex.cylinder_strips(20, (4, 9), seed=1)])
def test_a_developable_chart_is_predicted_isometric(mesh):
    V, F, _ = mesh()
    prediction = _predicted(V, F)[0]
    assert np.abs(prediction.energy() - 4.0).max() < 1e-9
    assert np.abs(prediction.trace).max() < 1e-6


@pytest.mark.parametrize("polar", [0.3, 0.5, 0.7])
def test_a_spherical_cap_is_predicted_as_the_refinement_lays_it_out(polar):
    # to first order in the strain: the cap's excess over isometric, as the refinement
    # reaches it (measured: within 1-2%; the prediction grows past it as the cap deepens);
    # a tolerance below the shallow cap's excess (1e-4), so that it is refined at all
    V, F = ex.spherical_cap(20, max_polar=polar)
    prediction, X, _, boundary = _predicted(V, F)
    refined = parametrize(V, F, refine=1000, refine_tol=1e-6)
    sd = metrics.per_island(V, F, refined.corner_uv, refined.face_island).mean_symmetric_dirichlet
    assert prediction.energy()[0] - 4.0 == pytest.approx(sd - 4.0, rel=0.05)
    # the middle is squeezed, the rim stretched
    centre = np.argmin(np.linalg.norm(X[:, :2], axis=1))
    assert prediction.trace[centre] < 0 < prediction.trace[boundary].mean()


def test_a_slit_opens_at_the_rim_of_a_cap_and_presses_at_its_centre():
    # across a radial cut the hoop strain pulls at the rim and pushes in the middle
    V, F = ex.spherical_cap(20, max_polar=0.6)
    prediction, X, topo, _ = _predicted(V, F)
    r = np.linalg.norm(X[:, :2], axis=1)
    order = np.argsort(r)
    centre, outer = order[0], order[np.searchsorted(r[order], 0.8 * r.max())]
    edges = topo.he.edge_vertices
    radial = edges[np.isin(edges, [centre, outer]).any(axis=1)]
    strain = stress.normal_stress(X, topo.faces, prediction.phi, radial)
    at_centre = np.isin(radial, centre).any(axis=1)
    assert (strain[at_centre] < 0).all() and np.median(strain[~at_centre]) > 0


def test_the_prediction_is_smooth_in_the_mesh():
    # a fixed number of linear steps, no stopping test: a 1e-12 change of the input moves
    # it by a millionth at most (measured: 3e-8), where decisions read it on a grid of 1/64
    V, F = ex.peaks(41, z_scale=1.0)
    p0 = _predicted(V, F)[0]
    rng = np.random.default_rng(3)
    p1 = _predicted(V * (1 + 1e-12 * rng.standard_normal(V.shape)), F)[0]
    assert np.abs(p1.energy() - p0.energy()).max() < 1e-6 * (p0.energy().max() - 4.0)
    assert np.abs(p1.trace - p0.trace).max() < 1e-6 * np.abs(p0.trace).max()


def test_charts_predicted_alone_are_predicted_as_among_the_others():
    from isoparam_addon.solver.charting.charts import _predicted as predicted_alone
    from isoparam_addon.solver.charting.charts import _Split

    # two caps side by side, two islands: the second predicted alone
    V1, F1 = ex.spherical_cap(14, 0.6)[:2]
    V2, F2 = ex.spherical_cap(12, 0.8)[:2]
    V = np.vstack([V1, V2 + [3.0, 0.0, 0.0]])
    F = np.vstack([F1, F2 + len(V1)])
    both, X, topo, boundary = _predicted(V, F)
    assert topo.n_islands == 2
    order = np.arange(len(X))
    charts = _Split(topo.face_island, 2, boundary, order)
    whole = predicted_alone(X, topo.faces, charts, np.ones(2, dtype=bool))
    np.testing.assert_allclose(whole.excess, both.excess, rtol=1e-8)  # (another elimination order)
    alone = predicted_alone(X, topo.faces, charts, np.array([False, True]))
    assert alone.excess[0] == 0.0 and alone.area[0] == 0.0
    np.testing.assert_allclose(alone.excess[1], both.excess[1], rtol=1e-4)
    np.testing.assert_allclose(alone.area[1], both.area[1], rtol=1e-12)
    on = np.zeros(len(X), dtype=bool)
    on[topo.faces[topo.face_island == 1].ravel()] = True
    assert (alone.phi[~on] == 0).all()
    np.testing.assert_allclose(alone.phi[on], both.phi[on], atol=1e-4 * np.abs(both.phi[on]).max())
