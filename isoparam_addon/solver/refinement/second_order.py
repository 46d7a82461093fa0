"""The descent's second-order proxy, for descents that go on past a few dozen iterations.

L-BFGS starts each step from the quadratic proxy (:mod:`.proxy`), a Laplacian that knows
neither the energy's curvature where faces are crushed nor the contact barrier's. Where
a descent goes on for long, that is why: its steps are capped by a face about to collapse
or by the boundary about to touch itself, a thousandth of their length at a time, and
where it stops then follows rounding (another BLAS or numpy build, 1e-12 of noise).
There the proxy becomes the energy's own Hessian, made positive semi-definite per face
(projected Newton: Teran et al. 2005; the per-face blocks,
:func:`.per_face.dirichlet_hessians`), with the barrier's curvature along
each close pair's normal (:meth:`.Contact.normal_curvature`): the direction then slides
along contact rather than into it. It couples u and v, so it is factored over the 2n
coordinates of the rows still descending, interleaved in the proxy's elimination order,
and built again every few iterations (see :mod:`.descent`).

That order is Step 3's nested dissection of the mesh. The barrier couples vertices the
mesh does not (the banks of cuts, a boundary pressed against itself, far apart in that
order): where its pairs hold more than ``_CONTACT_SHARE`` of the entries (a CAD part cut
open along many loops: half of them and more), the factor is ordered by SuperLU's
minimum degree on the matrix itself, which fills 3-12 times less there (and more than
the nested dissection where the barrier holds few entries: docs/benchmarks.md).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
import scipy.sparse as sp
from scipy.sparse.linalg import splu

from ..mesh.islands import Islands
from .per_face import BlockPattern, FaceFrames, dirichlet_hessians
from .proxy import Proxy

__all__ = ["SecondOrderProxy", "second_order_proxy"]

_MIX = 1e-4  # the quadratic proxy's share in it: the energy's Hessian leaves turns (and crushed faces) free
_CONTACT_SHARE = 0.01  # the share of the entries the barrier's pairs hold above which minimum degree orders


@dataclass
class SecondOrderProxy:
    """The descent's proxy ``H`` over the coordinates ``coords`` (u, v interleaved, in the
    proxy's elimination order) of the rows still descending, factored, and the
    ``quadratic`` proxy it stands in for (built again from, and what is handed on,
    :func:`.descent._go_on_alone`); ``pattern``: where the blocks of the faces ``live``
    land in ``H``, for the next build over the same faces."""

    H: sp.csr_matrix
    coords: np.ndarray
    lu: Any
    quadratic: Proxy
    pattern: BlockPattern
    live: np.ndarray

    @property
    def frames(self) -> FaceFrames:
        return self.quadratic.frames

    @property
    def weights(self) -> np.ndarray:
        return self.quadratic.weights

    @property
    def pinned(self) -> np.ndarray:
        return self.quadratic.pinned

    def solve(self, g: np.ndarray) -> np.ndarray:
        """``H^{-1} g`` on the rows factored (n, 2), zero on the others."""
        flat = np.zeros(g.size)
        flat[self.coords] = self.lu.solve(np.ascontiguousarray(g.reshape(-1)[self.coords]))
        return flat.reshape(-1, 2)

    def curvature(self, islands: Islands, per_face, s: np.ndarray, t: np.ndarray, dJ) -> np.ndarray:
        """Per island, ``s^T H s`` of a step ``s`` (n, 2) (zero off the rows factored)."""
        Hs = np.zeros(s.size)
        Hs[self.coords] = self.H @ s.reshape(-1)[self.coords]
        return islands.dot(s, Hs.reshape(-1, 2))


def second_order_proxy(
    proxy: Proxy | SecondOrderProxy, J, live_face: np.ndarray, rows: np.ndarray, contact=None
) -> SecondOrderProxy:
    """The second-order proxy at the Jacobians ``J`` of the faces ``live_face`` (m,) bool,
    over the free vertices of ``rows`` (n,) bool (those of the live faces' islands), with
    the barrier's ``contact`` curvature (a sparse (2n, 2n) matrix, or None) added; ``proxy``
    the quadratic one (or a second-order one, whose quadratic proxy is taken). Only the
    live faces and rows are built: an iteration's cost follows the rows still descending."""
    fr = proxy.frames
    n = len(proxy.pinned)
    live = np.flatnonzero(live_face & rows[fr.faces[:, 0]])  # (the faces of islands since stopped add nothing)
    quadratic = proxy.quadratic if isinstance(proxy, SecondOrderProxy) else proxy
    free = quadratic.perm[rows[quadratic.perm]]
    coords = np.stack([2 * free, 2 * free + 1], axis=1).ravel()
    k = len(coords)
    pattern = None  # (kept from the last build over the same faces and coordinates)
    if (
        isinstance(proxy, SecondOrderProxy)
        and np.array_equal(proxy.coords, coords)
        and np.array_equal(proxy.live, live)
    ):
        pattern = proxy.pattern
    if pattern is None:  # each live face's corners, numbered among ``free`` (len(free): pinned)
        local = np.full(n, len(free), dtype=np.int64)
        local[free] = np.arange(len(free))
        pattern = BlockPattern.of(local[fr.faces[live]], len(free) + 1, width=2)
    P = dirichlet_hessians(tuple(j[live] for j in J), fr.area[live])
    # (a, b, c, d) of a face from its corners' (u0, v0, u1, v1, u2, v2)
    B = np.zeros((len(live), 4, 6))
    dx, dy = fr.dx[live], fr.dy[live]
    B[:, 0, 0::2], B[:, 1, 0::2], B[:, 2, 1::2], B[:, 3, 1::2] = dx, dy, dx, dy
    blocks = B.transpose(0, 2, 1) @ P @ B
    mixed = sp.kron((_MIX * quadratic.H + 2.0 * sp.diags(quadratic.whisper))[free][:, free], sp.eye(2), format="csr")
    H = pattern.matrix(blocks)[:k, :k] + mixed
    pairs = 0
    if contact is not None:
        C = contact[coords][:, coords]
        pairs = C.nnz
        H = H + C
    H = H.tocsr()
    if pairs > _CONTACT_SHARE * H.nnz:  # (symmetric: one order for rows and columns, no pivoting)
        lu = splu(H.tocsc(), permc_spec="MMD_AT_PLUS_A", diag_pivot_thresh=0.0, options={"SymmetricMode": True})
    else:
        lu = splu(H.tocsc(), permc_spec="NATURAL", diag_pivot_thresh=0.0)
    return SecondOrderProxy(H, coords, lu, quadratic, pattern, live)
