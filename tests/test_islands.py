"""Per-island reductions and dense algebra (solver/mesh/islands.py) against plain loops over islands."""

import numpy as np
import pytest

from isoparam_addon.solver.mesh.islands import Islands

# every size class of the small islands' groups, an empty island, and large islands
SIZES = [1, 2, 3, 4, 5, 17, 0, 600, 1024, 1, 1025, 3000, 33]


@pytest.fixture
def islands():
    return Islands(np.repeat(np.arange(len(SIZES)), SIZES), len(SIZES))


def _loop(islands, fn):
    return np.stack([fn(islands.rows(i)) for i in range(islands.n)])


@pytest.mark.parametrize("strided", [False, True])
def test_gram_apply_and_sum_equal_a_loop_over_islands(islands, strided):
    rng = np.random.default_rng(7)
    n = len(islands.label)
    A = rng.standard_normal((n, 9 if strided else 4))[:, :4]  # a column slice: strided rows
    B = rng.standard_normal((n, 3))
    T = rng.standard_normal((islands.n, 4, 2))
    gram = _loop(islands, lambda r: A[r].T @ B[r])
    np.testing.assert_allclose(islands.gram(A, B), gram, rtol=1e-12, atol=1e-12)
    small = gram.copy()
    small[islands.large] = 0.0
    np.testing.assert_allclose(islands.gram(A, B, large=False), small, rtol=1e-12, atol=1e-12)
    applied = np.concatenate([A[islands.rows(i)] @ T[i] for i in range(islands.n)])
    np.testing.assert_allclose(islands.apply(A, T), applied, rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(islands.sum(B), _loop(islands, lambda r: B[r].sum(axis=0)), atol=1e-11)
    assert islands.gram(A, B)[SIZES.index(0)].tolist() == np.zeros((4, 3)).tolist()


def test_per_island_values_spread_over_the_rows_of_their_islands():
    label = np.repeat([0, 2, 3], [3, 5, 1])  # island 1 has no rows
    islands = Islands(label, 4)
    for per_island in (np.array([1.5, -2.0, 3.0, 4.0]), np.array([True, False, False, True])):
        spread = islands.spread(per_island)
        assert spread.shape == (9, 2) and spread.dtype == per_island.dtype
        np.testing.assert_array_equal(spread, np.broadcast_to(per_island[label][:, None], (9, 2)))


@pytest.mark.parametrize("n", [1, 4])
def test_labelled_rows_in_any_order_reduce_as_a_loop_would(n, rng):
    label = rng.integers(0, max(n - 1, 1), size=50)  # with several islands, the last has no rows
    islands = Islands.labelled(label, n)
    x, y = rng.standard_normal(50), rng.standard_normal((50, 2))
    for i in range(n):
        mine = label == i
        assert islands.sum(x)[i] == pytest.approx(x[mine].sum(), abs=1e-12)
        assert islands.min(x)[i] == (x[mine].min() if mine.any() else np.inf)
        assert islands.max(x)[i] == (x[mine].max() if mine.any() else -np.inf)
        np.testing.assert_allclose(islands.sum(y)[i], y[mine].sum(axis=0), atol=1e-12)
    which = np.arange(n) % 2 == 0
    got = islands.members(which)
    assert np.array_equal(np.sort(got), np.flatnonzero(which[label]))
    assert np.all(np.diff(label[got]) >= 0)  # island by island
    np.testing.assert_array_equal(islands.expand(np.arange(n) * 1.0) * np.ones(50), label * 1.0 if n > 1 else 0.0)
