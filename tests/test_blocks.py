"""Per-island dense algebra (solver/blocks.py) against a plain loop over islands."""

import numpy as np
import pytest

from isoparam_addon.solver.blocks import Islands

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
