"""Nested-dissection ordering: a permutation on any input, and less fill than the alternatives."""

import numpy as np
import pytest
import scipy.sparse as sp
from scipy.sparse.linalg import splu

import isoparam_addon.solver.ordering as ordering
from isoparam_addon.solver import examples as ex

MESHES = {
    "c_strip": lambda: ex.cylinder_strips(100, (100, 101), seed=0)[:2],  # a 3/4 cylinder: C-shaped
    "peaks": lambda: ex.peaks(100),
    "s_random": lambda: ex.s_surface_random(10_000, seed=0)[:2],
}


def _pattern(n, F):
    """Edges and a nonsingular matrix with the mesh's 1-ring pattern (graph Laplacian + I)."""
    E = np.unique(np.sort(np.concatenate([F[:, [0, 1]], F[:, [1, 2]], F[:, [2, 0]]]), axis=1), axis=0)
    A = sp.coo_matrix((np.full(len(E), -1.0), (E[:, 0], E[:, 1])), shape=(n, n))
    A = (A + A.T).tocsr()
    return E, (A + sp.diags(1.0 - np.asarray(A.sum(axis=1)).ravel())).tocsc()


def _fill(A, order=None):
    if order is None:
        lu = splu(A, permc_spec="COLAMD")
    else:
        lu = splu(A[order][:, order].tocsc(), permc_spec="NATURAL", diag_pivot_thresh=0.0)
    return lu.L.nnz + lu.U.nnz


@pytest.mark.parametrize("name", sorted(MESHES))
def test_order_is_a_permutation_with_less_fill_than_colamd(name):
    V, F = MESHES[name]()
    E, A = _pattern(len(V), F)
    order = ordering.nested_dissection(V, E)
    assert np.array_equal(np.sort(order), np.arange(len(V)))
    assert _fill(A, order) < 0.9 * _fill(A)


def test_comparing_planes_cuts_a_curved_strip_across(monkeypatch):
    # planes normal to the axes cross the C-shaped strip twice; its principal axis once
    V, F = MESHES["c_strip"]()
    E, A = _pattern(len(V), F)
    chosen = _fill(A, ordering.nested_dissection(V, E))
    monkeypatch.setattr(ordering, "_COMPARE_ABOVE", 10**9)  # only the axis of largest variance
    single = _fill(A, ordering.nested_dissection(V, E))
    assert chosen < 0.88 * single


@pytest.mark.parametrize("fraction", [1.0, 0.5])
def test_coincident_points_still_give_a_permutation(fraction):
    # a domain whose points all coincide cannot be cut by any plane: it is halved by index
    V, F = ex.peaks(30)
    V = V.copy()
    V[: int(fraction * len(V))] = 0.0
    E, A = _pattern(len(V), F)
    order = ordering.nested_dissection(V, E)
    assert np.array_equal(np.sort(order), np.arange(len(V)))
    assert _fill(A, order) < 0.5 * len(V) ** 2  # still sparse: the halves are real domains


def test_order_does_not_depend_on_scale_even_near_overflow():
    V, F = ex.peaks(40)
    E, _ = _pattern(len(V), F)
    order = ordering.nested_dissection(V, E)
    for scale in (2.0**531, 2.0**-660):  # ~1e160 and ~1e-199: exact in binary, squares would overflow/underflow
        assert np.array_equal(ordering.nested_dissection(V * scale, E), order)


def test_many_small_islands_beside_a_large_one():
    rng = np.random.default_rng(7)
    Vs, Fs = [ex.peaks(60)[0]], [ex.peaks(60)[1]]
    for _ in range(300):  # small separate grids scattered around the large one
        v, f = ex.peaks(4)
        Vs.append(0.05 * v + rng.uniform(-20, 20, 3))
        Fs.append(f + sum(len(x) for x in Vs[:-1]))
    V, F = np.concatenate(Vs), np.concatenate(Fs)
    E, A = _pattern(len(V), F)
    order = ordering.nested_dissection(V, E)
    assert np.array_equal(np.sort(order), np.arange(len(V)))
    assert _fill(A, order) < 0.9 * _fill(A)


def test_leaf_must_be_positive():
    V, F = ex.peaks(10)
    E, _ = _pattern(len(V), F)
    with pytest.raises(ValueError, match="leaf"):
        ordering.nested_dissection(V, E, leaf=0)
