"""Fuzzing: variants of closed and open meshes, solved as the operator solves them (no
seams, charts, refinement, overlaps cut apart), must give UVs with no exception, no
folded face and no island overlapping itself.

The variants are those of real input: shapes of genus 0 to several (voxel sets, with
the non-manifold edges and bow-ties touching voxels make), open parts, irregular
remeshing (edge flips: slivers, high valences), coarse decimation (vertex clustering),
holes punched, noise, quads (their diagonals given), copies, renumbering. Each seed
draws its own mix, the same on every run.
"""

import numpy as np
import pytest

from isoparam_addon.operation.options import DEFAULTS
from isoparam_addon.solver import metrics, parametrize
from isoparam_eval import meshes as ex
from isoparam_eval import variants as va

OPERATOR = DEFAULTS.solver_options()


def variant(seed: int):
    """A mesh (V, F, inner_edges or None) drawn from ``seed``."""
    rng = np.random.default_rng(seed)
    kind = ["voxels", "sphere", "torus", "peaks", "annulus", "spot"][seed % 6]
    inner = None
    if kind == "voxels":
        V, F, inner = va.voxels(va.voxel_blob(rng, size=3 + seed % 2), quads=True)
    elif kind == "sphere":
        V, F = ex.sphere(2)
    elif kind == "torus":
        V, F = ex.torus(nu=24, nv=10)
    elif kind == "peaks":
        V, F = ex.peaks(25, z_scale=rng.uniform(0.3, 1.5))
    elif kind == "annulus":
        V, F = ex.annulus(n_radial=5, n_around=30)
        V[:, 2] = 0.3 * np.sin(3 * np.arctan2(V[:, 1], V[:, 0]))
    else:
        V, F, _ = ex.load_obj(ex.SPOT)
        V, F = va.cluster(V, F, 0.08)  # decimated to a few hundred vertices
    if inner is None and rng.random() < 0.5:
        V, F = va.edge_flips(V, F, rng, share=0.4)
    if rng.random() < 0.4:
        V, F = va.punched(V, F, rng, holes=int(rng.integers(1, 4)))
    if rng.random() < 0.5:
        V, F = va.noisy(V, F, rng, scale=0.15)
    if rng.random() < 0.3:
        n = len(V)
        V, F = va.copies(V, F, 2)
        inner = None if inner is None else np.vstack([inner, inner + n])
    p = rng.permutation(len(V))
    new = np.empty_like(p)
    new[p] = np.arange(len(p))
    V, F = V[p], new[F][rng.permutation(len(F))]
    return V, F, None if inner is None else new[inner]


@pytest.mark.slow
@pytest.mark.parametrize("seed", range(24))
def test_a_variant_is_unwrapped_without_folds_or_overlaps(seed):
    V, F, inner = variant(seed)
    r = parametrize(V, F, inner_edges=inner, options=OPERATOR)
    assert np.isfinite(r.corner_uv).all()
    label = metrics.uv_islands(F, r.corner_uv)
    assert metrics.flipped(V, F, r.corner_uv, label) == 0
    assert metrics.self_overlaps(V, F, r.corner_uv, label).islands == 0
