"""Nested-dissection ordering: a permutation on any input, and less fill than the alternatives."""

import numpy as np
import pytest
import scipy.sparse as sp
from scipy.sparse.linalg import splu

import isoparam_addon.solver.mesh.ordering as ordering
from isoparam_eval import meshes as ex

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
    monkeypatch.setattr(ordering, "_FLOW_ABOVE", 10**9)  # planes alone
    V, F = MESHES["c_strip"]()
    E, A = _pattern(len(V), F)
    chosen = _fill(A, ordering.nested_dissection(V, E))
    monkeypatch.setattr(ordering, "_COMPARE_ABOVE", 10**9)  # only the axis of largest variance
    single = _fill(A, ordering.nested_dissection(V, E))
    assert chosen < 0.88 * single


def test_minimum_cuts_shrink_the_separators_of_an_irregular_strip(monkeypatch):
    # random heights on every ruling: long slivers join a vertex to many across them,
    # shortcuts that a plane does not see and a minimum cut does
    V, F = ex.cylinder_strips(150, (150, 151), seed=1)[:2]
    E, A = _pattern(len(V), F)
    with_flow = _fill(A, ordering.nested_dissection(V, E))
    monkeypatch.setattr(ordering, "_FLOW_ABOVE", 10**9)
    planes = _fill(A, ordering.nested_dissection(V, E))
    assert with_flow < 0.9 * planes  # measured: 0.855


@pytest.mark.parametrize("name", sorted(MESHES))
@pytest.mark.parametrize("hops", [1, 2, 4])
def test_minimum_separator_separates_and_is_never_larger_than_the_planes(name, hops):
    V, F = MESHES[name]()
    E, _ = _pattern(len(V), F)
    ea, eb = E[:, 0], E[:, 1]
    rng = np.random.default_rng(3)
    for normal in rng.normal(size=(4, 3)):  # a few arbitrary planes through the centroid
        h = (V - V.mean(axis=0)) @ (normal / np.linalg.norm(normal))
        side = h > 0
        cut = side[ea] != side[eb]
        sep = np.zeros(len(V), dtype=bool)
        sep[np.where(side[ea[cut]], ea[cut], eb[cut])] = True  # the side-1 ends of cut edges
        dom = np.zeros(len(V), dtype=np.int64)
        new_side, new_sep = ordering._min_separator(side, sep, dom, np.array([True]), ea, eb, hops)
        free = ~new_sep[ea] & ~new_sep[eb]
        assert not (free & (new_side[ea] != new_side[eb])).any()  # it separates
        assert 0 < new_sep.sum() <= sep.sum()
        assert min(new_side[~new_sep].sum(), (~new_side[~new_sep]).sum()) > 0  # both sides kept
        far = np.abs(h) > np.abs(h[sep]).max() + hops * np.linalg.norm(V[ea] - V[eb], axis=1).max()
        assert np.array_equal(new_side[far], side[far])  # beyond the band nothing moves


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
