"""Step 3 (solver/steps/embed.py): the elimination plan's solves, the pinned least-squares
basis, degenerate null spaces, and islands that converge at their own pace."""

import numpy as np
import pytest

from isoparam_addon.solver import parametrize
from isoparam_addon.solver.mesh.halfedges import unique_edges
from isoparam_eval import meshes as ex


@pytest.mark.parametrize("trans", ["N", "T"])
def test_column_parallel_solves_match_one_solve(trans):
    # large enough to go through the helper thread; unsymmetric so that trans matters
    import scipy.sparse as sp
    from scipy.sparse.linalg import splu

    from isoparam_addon.solver import _parallel

    n = _parallel.PARALLEL_FROM + 17
    rng = np.random.default_rng(5)
    A = sp.diags([4.0 + rng.random(n), -1.0 - rng.random(n - 1), -rng.random(n - 3)], [0, 1, -3], format="csc")
    lu = splu(A)
    b = rng.standard_normal((n, 5))
    x = _parallel.solve_columns(lu, b, trans=trans)
    y = lu.solve(b, trans=trans)
    assert np.abs(x - y).max() <= 1e-12 * np.abs(y).max()
    assert np.array_equal(x, _parallel.solve_columns(lu, b, trans=trans))  # deterministic
    At = A.T if trans == "T" else A
    assert np.abs(At @ x - b).max() < 1e-12


@pytest.mark.parametrize("n_islands", [1, 3])
def test_pinned_least_squares_match_dense_algebra(n_islands):
    # Step 3's operator against dense linear algebra: M_FF^{-1} b and the pinned
    # least-squares basis, on islands whose L has the sparsity of the mesh and no structure
    import scipy.sparse as sp

    from isoparam_addon.solver.mesh.islands import Islands
    from isoparam_addon.solver.steps.embed import _AnchoredLeastSquares, plan_elimination

    rng = np.random.default_rng(11)
    Vs, Fs, off = [], [], 0
    for i in range(n_islands):
        V, F = ex.peaks(6 + 2 * i)
        Vs.append(V + [5.0 * i, 0, 0])
        Fs.append(F + off)
        off += len(V)
    V, F = np.vstack(Vs), np.vstack(Fs)
    n = len(V)
    label = np.repeat(np.arange(n_islands), [len(v) for v in Vs])
    islands = Islands(label, n_islands)
    edges = unique_edges(F)
    # I - W with random affine weights over each vertex's neighbours
    r, c = np.concatenate([edges[:, 0], edges[:, 1]]), np.concatenate([edges[:, 1], edges[:, 0]])
    w = rng.random(len(r)) + 0.5
    w /= np.bincount(r, w, minlength=n)[r]
    L = (sp.identity(n) - sp.csr_matrix((w, (r, c)), shape=(n, n))).tocsr()
    plan = plan_elimination(V, edges, islands)
    pls = _AnchoredLeastSquares(L, islands, plan)

    Ld = L.toarray()
    pins = plan.anchors.ravel()
    free = np.setdiff1d(np.arange(n), pins)
    M_FF = Ld[:, free].T @ Ld[:, free]
    b = rng.standard_normal((n, 2))
    x = pls.solve_mff(b)
    expect = np.linalg.solve(M_FF, b[free])
    assert np.abs(x[free] - expect).max() < 1e-9 * np.abs(expect).max()
    assert np.all(x[pins] == 0.0)
    # h_k = argmin ||L x|| with x = e_k on the pins (every island's k-th pin at once)
    for k in range(3):
        e = np.zeros(n)
        e[plan.anchors[:, k]] = 1.0
        h = e.copy()
        h[free] = -np.linalg.solve(M_FF, Ld[:, free].T @ (Ld @ e))
        assert np.abs(pls.H[:, k] - h).max() < 1e-9


@pytest.mark.parametrize("grid", [15, 35])  # the small-island and the large-island (SVD) Ritz paths
def test_a_null_space_of_more_than_two_dimensions_gives_a_null_pair_and_stops(grid):
    # L reproduces 1, x, y and z of a curved mesh (3D affine weights over the 2-ring), so
    # every pair in span(x, y, z) is a lowest eigenvector pair of M. Two Smart UV islands
    # of a subdivided Suzanne have such a null space. Step 3 must return a pair inside it
    # and stop, not wander inside it until max_iter (and the bordered matrix is singular
    # to rounding there, so a careless solve also returns vectors outside it).
    import scipy.sparse as sp

    from isoparam_addon.solver.mesh.islands import Islands
    from isoparam_addon.solver.steps.embed import spectral_embedding

    V, F = ex.peaks(grid)
    n = len(V)
    e = unique_edges(F)
    A = sp.csr_matrix((np.ones(2 * len(e)), (np.r_[e[:, 0], e[:, 1]], np.r_[e[:, 1], e[:, 0]])), shape=(n, n))
    A2 = (A @ A + A).tocsr()
    rows, cols, vals = [], [], []
    for i in range(n):  # building a test matrix
        nb = A2.indices[A2.indptr[i] : A2.indptr[i + 1]]
        nb = nb[nb != i]
        w = np.linalg.lstsq(np.vstack([np.ones(len(nb)), V[nb].T]), np.r_[1.0, V[i]], rcond=None)[0]
        rows += [i] * len(nb)
        cols += list(nb)
        vals += list(w)
    L = (sp.identity(n) - sp.csr_matrix((vals, (rows, cols)), shape=(n, n))).tocsr()
    assert np.abs(L @ np.c_[np.ones(n), V]).max() < 1e-12
    emb = spectral_embedding(L, V, Islands(np.zeros(n, dtype=np.int64), 1))
    assert emb.converged.all() and emb.iterations <= 3
    Y = emb.coords / np.linalg.norm(emb.coords, axis=0)
    assert np.abs(L @ Y).max() < 1e-10
    assert np.linalg.svd(Y, compute_uv=False).min() > 0.5  # two independent vectors


def test_an_island_that_converges_slowly_goes_on_alone(monkeypatch):
    # a closed box (cut open automatically; its symmetry gives Step 3 a slow pair: 38
    # iterations alone) beside a peaks disk (2 iterations): once the disk is done, the box
    # goes on with its own factorization, and ends where solving the box alone ends
    from isoparam_addon.solver.steps import embed

    (Vb, Fb, D), (Vp, Fp) = ex.box(8), ex.peaks(41)
    V = np.vstack([Vp, Vb + [5.0, 0.0, 0.0]])
    F, D = np.vstack([Fp, Fb + len(Vp)]), D + len(Vp)
    alone = parametrize(Vb, Fb, inner_edges=D - len(Vp))
    sizes = []
    inner = embed.spectral_embedding
    monkeypatch.setattr(embed, "spectral_embedding", lambda L, *a, **k: sizes.append(L.shape[0]) or inner(L, *a, **k))
    r = parametrize(V, F, inner_edges=D)
    assert r.converged.all() and alone.stats.iterations > 20
    box = r.face_island[-1]
    assert sizes == [alone.stats.split_vertices]  # the box's rows (once cut open) alone
    assert r.eigenvalues[box] == pytest.approx(alone.eigenvalues[0], rel=1e-6)
    assert r.stats.iterations < alone.stats.iterations
    # the layouts agree up to where the packing put them: Step 4 makes them unique up to a
    # rigid motion, and the box's turn is canonical (placement.canonical_turn)
    mine = r.face_island == box
    ours, theirs = r.corner_uv[mine].reshape(-1, 2), alone.corner_uv.reshape(-1, 2)
    assert np.abs((ours - ours.mean(axis=0)) - (theirs - theirs.mean(axis=0))).max() < 1e-6 * np.ptp(theirs)
    monkeypatch.setattr(embed, "_HANDOVER", 0.0)  # no hand-over: the same result
    kept = parametrize(V, F, inner_edges=D)
    assert np.abs(kept.corner_uv - r.corner_uv).max() < 1e-6 * np.abs(r.corner_uv).max()
