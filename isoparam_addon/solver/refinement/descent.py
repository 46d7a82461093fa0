"""Beyond the paper: isometric refinement of a layout, without folds.

The four-step layout is exact on developable surfaces, but on curved ones it shrinks the
curved regions and grows the flat ones, and on non-developable random triangulations
it can fold. Here it seeds the minimisation of the *symmetric Dirichlet* energy
(Smith & Schaefer 2015),

    E = sum_f A_f (||J_f||^2 + ||J_f^{-1}||^2),        E >= 4 sum_f A_f, equality iff isometric,

over the UVs, J_f being the Jacobian of face f's map from its 3D triangle to UV. E is
infinite for a collapsed triangle, so a descent that starts without folds never creates
one: every step is capped below the first time any triangle would degenerate (the root
of det J_f(t), a quadratic in the step t).

**Start.** A seed that folds cannot be repaired by a barrier energy; nor can a descent
from a seed with crushed faces spend its iterations well. Such an island starts instead
from the lowest-energy fold-free layout among the seed, a conformal map and a Tutte
embedding (see :mod:`.seeds`).

**Descent.** Local/global steps, then L-BFGS whose initial inverse Hessian is a factored
quadratic proxy. From a start near isometric (the four-step layout of a near-developable
island) this is one ARAP step (Liu et al. 2008; it also repairs a start whose energy
overflows, and more of them cost an iteration each and saved L-BFGS none) and the proxy is
the cotangent Laplacian (the Hessian of the Dirichlet part, Kovalsky et al. 2016). A start
far from it (crushed faces: a Tutte embedding of a closed surface opened by one short cut)
has curvature there that the cotangent proxy underestimates by orders of magnitude, and
L-BFGS with it crawls; such an island takes SLIM steps (Rabinovich et al. 2017), and its
proxy is a Laplacian re-weighted per face from its singular values as in SLIM, factored
again when its energy has fallen by 30% since, or every 20 iterations, to the end of its
descent: near isometric its few crushed faces are still where the cotangent proxy errs
most, and a proxy weighted as it was many iterations before caps each step at a face about
to collapse. An iteration costs one pair of triangular solves, a dozen sparse products and
the line search. A descent still going after ``_SECOND_ORDER_AFTER`` iterations (most
islands stop sooner) is one whose steps are capped (crushed faces, contact), or one that
starts far from its optimum, and whose end would follow rounding: from there its proxy is
the energy's projected Hessian with the barrier's curvature (:mod:`.second_order`), built
again every ``_SECOND_ORDER_EVERY`` iterations.

**Stopping.** An island stops when its energy fell by less than ``tol`` (relative) over
the last 5 iterations, or, within the first 5, by less than a hundredth of that over the
last one, or when no step along a descent direction lowers it; the
iteration cap is a safety net, not the usual exit. A step that a face about to collapse
(or contact) cut short does not stop an island by the last iteration's test: its small
decrease measures the cap, not the distance to the optimum (islands far from isometric
stopped at up to 1.5 times their optimum's energy whenever a capped step came at the
wrong moment, which rounding decides).

Islands are independent problems and are treated as such: each has its own start, ARAP
acceptance, step length, line search, L-BFGS memory, proxy weights and stopping test
(per-island dot products are one ``bincount``), so a hard island neither holds back nor
stops the rest; once the islands still descending hold at most a quarter of the rows,
they go on alone with a proxy of their own.

**Left as they are.** An unpinned island whose start is within ``tol`` of the isometric
energy (``4 * area``) is not refined: no descent can lower it by more than its stopping
test would see (most islands of seams marked by Smart UV Project, developable ones).

**Contact.** Every island's boundary is kept from crossing itself (:mod:`.contact`): a
barrier between boundary vertices and edges near each other joins the energy, and a step
stops short of the first time a vertex would meet an edge. An island whose start does
not overlap itself never comes to. Contact is watched where it is likely or met: from the
start on islands whose boundary touches itself there (the banks of a cut laid out as one)
or whose start is far from isometric (it moves far), and on the others once a step would
cross their boundary; such an island starts again from its
start with the barrier (a descent that met contact unwatched has pressed parts of its
boundary together, where a barrier added then holds them out of shape). Until then a
step is only tested for crossings at its end: the pair lists, distances and barrier of
every boundary at every step cost more than the rest of an iteration.

Pins are Dirichlet constraints: pinned vertices keep their UV and the others adapt.

Here is the descent; the per-face kernels it calls are :mod:`.per_face`'s, the proxy
:mod:`.proxy`'s, the start :mod:`.start`'s and the contact it watches :mod:`.watch`'s.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field

import numpy as np

from ..geometry import det2, dirichlet_parts, safe_divide, signed_double_areas
from ..mesh.halfedges import unique_edges
from ..mesh.islands import Islands, Labelled
from ..mesh.ordering import nested_dissection
from ..progress import tick
from .contact import Contact
from .per_face import FaceFrames, layout_energy, max_step, slim_weights, symmetric_dirichlet
from .proxy import Proxy, quadratic_proxy
from .second_order import SecondOrderProxy, second_order_proxy
from .start import start_layout
from .watch import ContactWatch

__all__ = ["Refinement", "refine", "unfolded"]

_MEMORY = 8  # L-BFGS pairs
_HANDOVER = 0.25  # once the islands still descending hold at most this share of the rows: own factor
_WINDOW = 5  # iterations over which the stopping test measures the decrease
_CRUSHED = 2.0  # an island that starts above this times the isometric energy gets the re-weighted proxy
_NEAR = 1.1  # ... and takes SLIM steps, not ARAP steps, until it is below this times the isometric energy
_REFRESH_DROP = 0.7  # factor the re-weighted proxy again once a far island's energy fell this much
_REFRESH_EVERY = 20  # ... or after this many iterations
_HALVINGS = 20  # a push of banks apart that folds a face is halved at most this many times, then not made
_SLIM_STEPS = 30  # at most this many SLIM steps from a start far from isometric
_HALFWAY = 100  # progress: the iteration count reported as half of the refinement (it stops when converged)
_SLIM_DROP = 0.3  # ... each lowering the energy by this much (relative)
_SECOND_ORDER_AFTER = 20  # a descent still going after this many iterations takes the second-order proxy ...
_SECOND_ORDER_EVERY = 10  # ... built again every this many iterations ...
_SECOND_ORDER_ROWS = 60_000  # ... while the rows still descending are at most this many (its factor is over 2n)


@dataclass
class Refinement:
    """What :func:`refine` did.

    Attributes
    ----------
    uv : (n, 2) float64
    energy : list of float
        Symmetric Dirichlet per unit area (4 = isometric) after each iteration, the
        seed's first; then, if islands were scaled onto their pins after the last
        iteration (:meth:`rescale`), the layout's as returned (which can be higher).
    iterations : int
        Descent iterations.
    arap_iterations : int
    proxies : int
        Times the proxy was re-weighted and factored again.
    restarted_conformal, restarted_tutte : (n_islands,) bool
        Islands whose seed folded, by the layout that replaced it: a conformal map, or a
        Tutte embedding where that folded too.
    folded : int
        Faces still folded at the end: 0 unless an island's seed folded and could not be
        replaced (it has pins, or even its Tutte embedding folded).
    island_energy, island_area : (n_islands,) float64
        At the end, per island: the energy (``sum_f A_f E_f``) and the 3D area of its
        faces that were refined or left as they started near isometric (0 for islands
        left alone because they fold or have nothing free), so that the last ``energy``
        is ``island_energy.sum() / island_area.sum()``.
    island_parts : ((n_islands,), (n_islands,)) float64
        ``island_energy`` split into its ``sum_f A_f ||J_f||^2`` and
        ``sum_f A_f ||J_f^{-1}||^2`` parts, which a uniform scale of the layout changes
        by ``s^2`` and ``1 / s^2`` (see :meth:`rescale`).
    seconds : float
    """

    uv: np.ndarray
    restarted_conformal: np.ndarray
    restarted_tutte: np.ndarray
    island_energy: np.ndarray
    island_area: np.ndarray
    island_parts: tuple[np.ndarray, np.ndarray]
    energy: list[float] = field(default_factory=list)
    iterations: int = 0
    arap_iterations: int = 0
    proxies: int = 0
    folded: int = 0
    seconds: float = 0.0

    def rescale(self, which: np.ndarray, scale: np.ndarray) -> None:
        """Account for islands ``which`` (k,) bool of ``uv`` having been scaled by
        ``scale`` (k,) (and turned and moved, which change nothing) after the last
        iteration: their energies become those of the layout as it now is, and ``energy``
        gets one more entry, the whole layout's."""
        s2 = np.where(which, scale, 1.0) ** 2
        d, i = self.island_parts[0] * s2, self.island_parts[1] / s2
        self.island_parts = (d, i)
        self.island_energy = np.where(which, d + i, self.island_energy)
        self.energy.append(float(safe_divide(self.island_energy.sum(), self.island_area.sum())))


def unfolded(X, faces, uv, islands: Islands, he_twin, order=None) -> Refinement:
    """The layout ``uv`` (n, 2) with no descent, but every island that folds a face laid out
    again as the refinement would start it (the lowest-energy fold-free layout among it,
    a conformal map and a Tutte embedding, see :func:`.start.start_layout`): the layout without
    refinement (``refine=0``). An island stays as it is if neither map is fold-free (or
    their solve fails); islands that only crush faces, and faces without 3D area, are
    left as they are."""
    t0 = time.perf_counter()
    k = islands.n
    zero, none = np.zeros(k), np.zeros(k, dtype=bool)
    out = Refinement(np.asarray(uv, dtype=np.float64), none, none, zero, zero, (zero, zero))
    folds = signed_double_areas(out.uv, faces) <= 0
    if folds.any():
        frames = FaceFrames(X, faces)
        per_face = Islands.labelled(islands.label[faces[:, 0]], k)
        folded = per_face.sum(folds & ~frames.degenerate) > 0
        if folded.any():
            no_pins = np.zeros(len(X), dtype=bool)
            out.uv, _, out.restarted_conformal, out.restarted_tutte = start_layout(
                X, faces, out.uv, he_twin, islands, frames, per_face, no_pins, order, folded
            )
        out.folded = int((signed_double_areas(out.uv, faces) <= 0).sum())
    out.seconds = time.perf_counter() - t0
    return out


# ---------------------------------------------------------------- what the descent learns


@dataclass
class _Memory:
    """The L-BFGS memory of a descent: its last ``_MEMORY`` curvature pairs ``(s, y, rho)``
    ((n, 2), (n, 2), (n_islands,); rho 0 where an island forgot them) and per island the
    scale ``gamma`` of the proxy, from its last good pair."""

    islands: Islands
    pairs: list[tuple[np.ndarray, np.ndarray, np.ndarray]]
    gamma: np.ndarray

    @classmethod
    def empty(cls, islands: Islands) -> _Memory:
        return cls(islands, [], np.ones(islands.n))

    def direction(
        self, g: np.ndarray, active: np.ndarray, proxy: Proxy | SecondOrderProxy
    ) -> tuple[np.ndarray, np.ndarray]:
        """The L-BFGS direction (n, 2) from the gradient ``g`` (n, 2) for the ``active``
        islands, and its slope per island."""
        islands = self.islands
        q = np.where(islands.spread(active), g, 0.0)
        alphas = []
        for s_k, y_k, rho in reversed(self.pairs):
            a_k = rho * islands.dot(s_k, q)
            alphas.append(a_k)
            q -= islands.spread(a_k) * y_k
        r = proxy.solve(q) * islands.spread(self.gamma)
        for a_k, (s_k, y_k, rho) in zip(reversed(alphas), self.pairs):
            r += islands.spread(a_k - rho * islands.dot(y_k, r)) * s_k
        p = -r
        slope = islands.dot(g, p)
        lost = active & (slope >= 0)
        if lost.any():  # not a descent direction: those islands forget and use the proxy
            self.forget(lost)
            p = np.where(islands.spread(lost), -proxy.solve(np.where(islands.spread(lost), g, 0.0)), p)
            slope = islands.dot(g, p)
        return np.where(islands.spread(active), p, 0.0), slope

    def learn(
        self, s: np.ndarray, y: np.ndarray, step: _Step, proxy: Proxy | SecondOrderProxy, per_face: Labelled
    ) -> None:
        """Remember the pair of the ``step`` taken, ``s`` (n, 2), and the change of the
        gradient along it, ``y`` (n, 2), for the islands where it curves up, and scale
        their proxy to the curvature seen along it, ``s^T H s / s^T y``."""
        islands = self.islands
        sy, ss = islands.dot(s, y), islands.dot(s, s)
        good = (step.t > 0) & (sy > 1e-12 * ss)
        if not good.any():
            return
        s, y = np.where(islands.spread(good), s, 0.0), np.where(islands.spread(good), y, 0.0)
        rho = np.where(good, 1.0 / np.where(good, sy, 1.0), 0.0)
        self.pairs = [*self.pairs, (s, y, rho)][-_MEMORY:]
        sHs = proxy.curvature(islands, per_face, s, step.t, step.dJ)
        self.gamma = np.where(good, sHs / np.where(good, sy, 1.0), self.gamma)

    def forget(self, which: np.ndarray) -> None:
        """Forget the pairs and the scale of the islands ``which`` (n_islands,) bool."""
        self.pairs = [(s, y, np.where(which, 0.0, rho)) for s, y, rho in self.pairs]
        self.gamma = np.where(which, 1.0, self.gamma)

    def subset(self, which: np.ndarray, rows: np.ndarray, islands: Islands) -> _Memory:
        """The memory of the islands ``which`` (n_islands,) bool alone: their ``rows``, as
        ``islands``."""
        return _Memory(islands, [(s[rows], y[rows], rho[which]) for s, y, rho in self.pairs], self.gamma[which])


@dataclass
class _Reweighting:
    """When the proxy is re-weighted: the islands that descend with the re-weighted proxy
    (``far``: a start far from isometric), and per island its energy when its weights
    were last set (``energy``) and the iteration (``at``)."""

    far: np.ndarray
    energy: np.ndarray
    at: np.ndarray

    @classmethod
    def starting(cls, far: np.ndarray) -> _Reweighting:
        return cls(far, np.full(len(far), np.inf), np.zeros(len(far), dtype=np.int64))

    def due(self, which: np.ndarray, E: np.ndarray, iteration: int) -> np.ndarray:
        """The islands of ``which`` that re-weight whose energy ``E`` fell by
        ``_REFRESH_DROP`` since their weights were set, or that ``_REFRESH_EVERY``
        iterations went by since."""
        fell = E < _REFRESH_DROP * self.energy
        return which & self.far & (fell | (iteration - self.at >= _REFRESH_EVERY))

    def set(self, which: np.ndarray, E: np.ndarray, iteration: int) -> None:
        """The weights of the islands ``which`` were set at energies ``E`` in ``iteration``."""
        self.energy = np.where(which, E, self.energy)
        self.at = np.where(which, iteration, self.at)

    def subset(self, which: np.ndarray, done: int) -> _Reweighting:
        """That of the islands ``which`` alone, counting iterations from ``done``."""
        return _Reweighting(self.far[which], self.energy[which], self.at[which] - done)


@dataclass
class _Step:
    """A step the line search found: per island its length ``t`` (0: none) along ``p``
    (n, 2), and there the Jacobians ``J``, energies ``E``, derivatives dE/dJ ``G`` and
    the barrier's gradient ``gb`` (n, 2); ``dJ``, the Jacobians of ``p``; ``capped``,
    the islands whose longest step tried was cut below 1 (a face about to collapse, or
    its boundary about to touch itself)."""

    p: np.ndarray
    t: np.ndarray
    J: tuple
    E: np.ndarray
    G: list
    dJ: tuple  # noqa: N815 - paper-style, as J: the Jacobians of p
    gb: np.ndarray
    capped: np.ndarray  # (n_islands,) bool


# ---------------------------------------------------------------- the descent's state


class _Descent:
    """The state of one refinement: the layout, its Jacobians, per-island energies and
    gradient, which islands still descend, and what it learns as it goes: the L-BFGS
    memory, the proxy and its re-weighting, the contact it watches."""

    def __init__(self, X, faces, x, islands: Islands, pinned, proxy: Proxy, tol, out: Refinement, contact=None):
        self.X, self.faces, self.islands, self.pinned, self.tol, self.out = X, faces, islands, pinned, tol, out
        self.watch = ContactWatch(contact, islands.n)
        self.proxy: Proxy | SecondOrderProxy = proxy
        self.frames = proxy.frames
        self.area = proxy.frames.area
        self.per_face = Islands.labelled(islands.label[faces[:, 0]], islands.n)
        self.x = x
        self.memory = _Memory.empty(islands)
        self.history: list[np.ndarray] = []  # per-island energies of the last iterations
        self.fixed = np.flatnonzero(pinned)

    def begin(
        self,
        active: np.ndarray,
        settle: bool = True,
        watched: np.ndarray | None = None,
        start: np.ndarray | None = None,
    ) -> None:
        """Start descending the ``active`` islands (the others are left as they are).

        ``settle``: an unpinned island whose start is within the tolerance of the
        isometric energy (``4 * area``) is left as it is too: no descent can lower its
        energy by more than the stopping test would see (most of the islands of seams
        marked by Smart UV Project).
        ``watched`` (n_islands,) bool: the islands whose contact is followed from the
        start (default: those whose boundary touches itself there, :meth:`.Contact.touching`,
        and those far from isometric). ``start`` (n, 2): where an island watched anew
        starts again (default: here)."""
        self.island_area = self.per_face.sum(self.area)
        self.settled = np.zeros(self.islands.n, dtype=bool)
        if settle:
            E = layout_energy(self.frames, self.per_face, self.x)
            self.settled = active & ~self.pinned_island() & (E <= (1.0 + self.tol) * 4.0 * self.island_area)
            active = active & ~self.settled
        # what the islands left as they are add to the layout's energy per unit area
        self.settled_energy = float(np.where(self.settled, E, 0.0).sum()) if settle else 0.0
        self.settled_area = float(self.island_area[self.settled].sum())
        self.set_active(active)
        self.x = self.watch.begin(self.x, active, self.pinned_island(), lambda x, y: _fold_free(self, x, y))
        self.start = self.x if start is None else start
        self.J = self.frames.jacobians(self.x)
        self.E, self.G = self.energies(self.J)
        if watched is None and self.watch.on:
            # a start far from isometric moves its boundary far: contact is likely met
            far = self.E > _CRUSHED * 4.0 * self.island_area
            watched = far | self.watch.touching(self.x, active)
        self.watch.watched = np.zeros(self.islands.n, dtype=bool) if watched is None else watched
        self.Eb, self.gb = self.watch.barrier(self.x, self.watch.near(self.x, None, None, active))
        self.E = self.E + self.Eb
        self.trace = [self.E]  # per island, the start's energy and each ARAP step's
        # a start far from isometric (crushed faces) descends with the re-weighted proxy; a
        # start near it (the four-step layout of a near-developable island) with the
        # cotangent one, whose descent neither needs the re-weighting nor carries rounding
        # of the start as far
        self.reweighting = _Reweighting.starting(active & (self.E > _CRUSHED * 4.0 * self.island_area))

    def pinned_island(self) -> np.ndarray:
        """Islands (n_islands,) bool with a pinned vertex (their layout is the pins')."""
        return np.bincount(self.islands.label, self.pinned, minlength=self.islands.n) > 0

    def evaluate(self) -> None:
        """The energies ``E`` (the barrier's ``Eb`` included), dE/dJ ``G`` and the barrier's
        gradient ``gb`` at the Jacobians ``J`` of the layout ``x``."""
        self.E, self.G = self.energies(self.J)
        self.Eb, self.gb = self.watch.barrier(self.x, self.watch.near(self.x, None, None, self.active))
        self.E = self.E + self.Eb

    def watch_pending(self) -> bool:
        """Watch the contact of the islands whose step was refused for crossing while it
        was not watched, from their start again, as if it had been watched from there (a
        descent that met contact unwatched has pressed parts of the boundary together,
        where a barrier added then holds the island out of shape, and stops it). Returns
        whether an island was (its layout, energy and barrier are then new)."""
        newly = self.watch.watch_pending(self.active)
        if not newly.any():
            return False
        self.x = np.where(self.islands.spread(newly), self.start, self.x)
        self.J = self.frames.jacobians(self.x)
        self.evaluate()
        # what they learnt and how far they went belong to the descent left
        self.memory.forget(newly)
        self.history = [np.where(newly, np.inf, h) for h in self.history]
        return True

    def mean_energy(self, E: np.ndarray) -> float:
        """The energy per unit area of the islands refined (per-island ``E``) and of
        those left as they are."""
        return float(safe_divide(E.sum() + self.settled_energy, self.live_area + self.settled_area))

    def set_active(self, active: np.ndarray) -> None:
        self.active = active
        self.live_face = self.per_face.expand(active) * np.ones(len(self.faces), dtype=bool)
        self.live_area = float(self.area[self.live_face].sum())
        self.every_face_live = bool(self.live_face.all())

    def energies(self, J):
        """Per-island energy (0 for islands left alone: they may hold folds) and the
        per-face derivatives dE/dJ."""
        with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
            e, G = symmetric_dirichlet(*J, self.area)
        return self.per_face.sum(e if self.every_face_live else np.where(self.live_face, e, 0.0)), G

    def gradient(self, G) -> np.ndarray:
        fr = self.frames
        if not self.every_face_live:
            G = [np.where(self.live_face, Gk, 0.0) for Gk in G]
        g = np.stack([fr.DxT @ G[0] + fr.DyT @ G[1], fr.DxT @ G[2] + fr.DyT @ G[3]], axis=1)
        if self.watch.on:
            g += self.gb
        g[self.pinned] = 0.0
        return g

    def refresh(self, iteration: int, which: np.ndarray | None = None) -> None:
        """Re-weigh the proxy of the islands ``which`` (n_islands,) bool, by default of the
        active ones that are due (:meth:`_Reweighting.due`)."""
        if which is None:
            which = self.reweighting.due(self.active, self.E, iteration)
        if not which.any():
            return
        mine = self.per_face.expand(which) * np.ones(len(self.faces), dtype=bool)
        weights = np.where(mine, slim_weights(self.J), self.proxy.weights)
        quadratic = self.proxy.quadratic if isinstance(self.proxy, SecondOrderProxy) else self.proxy
        self.proxy = quadratic.reweighted(self.islands, weights, which)
        self.reweighting.set(which, self.E, iteration)
        self.memory.forget(which)  # their curvature pairs describe the old proxy's error
        self.out.proxies += 1

    def step(self, step: _Step, g: np.ndarray) -> np.ndarray:
        """Move to the ``step`` found from where the gradient was ``g``, and learn its
        curvature pair; returns the new gradient."""
        x_new = self.x + self.islands.spread(step.t) * step.p
        self.gb = step.gb
        g_new = self.gradient(step.G)  # rows of islands that did not move are not used again
        self.memory.learn(x_new - self.x, g_new - g, step, self.proxy, self.per_face)
        self.x, self.J, self.E = x_new, step.J, step.E
        return g_new


def _fold_free(d: _Descent, before: np.ndarray, after: np.ndarray) -> np.ndarray:
    """``after`` (banks pushed apart from ``before``) with the push of every vertex of a face
    it would fold (one unfolded in ``before``) halved, again until none folds, and after
    ``_HALVINGS`` put back (on a sliver every corner lies on the other edges, and pushed
    apart whole they cross; kept apart a little, two copies of a slit's vertex do not
    meet, where the barrier between them would be infinite). Only where the push ends
    counts (the start is taken from there, not stepped to)."""
    faces = d.faces
    unfolded = signed_double_areas(before, faces) > 0
    step = after - before
    share = np.ones(len(before))
    for k in range(_HALVINGS + 1):
        x = before + share[:, None] * step
        folds = unfolded & (signed_double_areas(x, faces) <= 0)
        if not folds.any():
            return x
        share[faces[folds].ravel()] *= 0.5 if k < _HALVINGS else 0.0
    return before + share[:, None] * step  # (vertices put back cannot fold what was not)


# ---------------------------------------------------------------- ARAP and SLIM steps


def _local_global(desc: _Descent, steps: int) -> None:
    """Local/global steps before the descent: large moves, one factored solve each.

    An island near isometric takes ARAP steps (Liu et al. 2008) with the proxy as it
    is, each taken whole if it folds nothing and lowers the energy, at most ``steps``
    and until one does not. An island far from it (a crushed start) takes SLIM steps
    (Rabinovich et al. 2017): the proxy re-weighted at every step, the step cut back
    to fold nothing and to lower the energy, while each lowers it by ``_SLIM_DROP``
    or more, at most ``_SLIM_STEPS``.
    """
    fr, islands, per_face, watch = desc.frames, desc.islands, desc.per_face, desc.watch
    stepping = desc.active.copy()
    for k in range(max(steps, _SLIM_STEPS)):  # local/global steps
        tick()
        desc.watch_pending()
        far = stepping & desc.reweighting.far & (desc.E > _NEAR * 4.0 * desc.island_area)
        stepping &= far | (k < steps)
        if not stepping.any():
            break
        if far.any():
            desc.refresh(0, which=far)
        p = np.where(islands.spread(stepping), _global_step(desc) - desc.x, 0.0)
        dJ = fr.jacobians(p)
        t = np.where(far, np.minimum(1.0, 0.9 * per_face.min(max_step(desc.J, dJ, 1.0 / 0.9))), 1.0)
        t = np.where(stepping, t, 0.0)
        near, meet = watch.near_step(desc.x, p, t, t > 0)
        t = np.minimum(t, 0.9 * watch.first_contact(desc.x, p, meet))  # (no boundary crosses on the way)
        followed = watch.followed(p, t)
        for _ in range(40):  # halvings of the far islands' steps, until each lowers the energy
            Jt = tuple(j + per_face.expand(t) * dj for j, dj in zip(desc.J, dJ))
            Et, Gt = desc.energies(Jt)
            folds = per_face.sum(det2(*Jt) <= 0) > 0
            xt = desc.x + islands.spread(t) * p
            Eb, gb = watch.barrier(xt, near)
            Et = Et + Eb
            folds |= watch.refused(xt, (t > 0) & ~folds & (Et < desc.E) & ~followed)
            worse = (t > 0) & (folds | ~(Et < desc.E))
            if not (worse & far).any():
                break
            t = np.where(worse & far, 0.5 * t, t)
        take = (t > 0) & ~worse
        if not take.any():
            break
        dropped = Et < (1.0 - _SLIM_DROP) * desc.E
        desc.x = np.where(islands.spread(take), desc.x + islands.spread(t) * p, desc.x)
        desc.gb = np.where(islands.spread(take), gb, desc.gb)
        desc.Eb = np.where(take, Eb, desc.Eb)
        desc.J = tuple(np.where(per_face.expand(take), jt, j) for jt, j in zip(Jt, desc.J))
        desc.G = [np.where(per_face.expand(take), gt, gk) for gt, gk in zip(Gt, desc.G)]
        desc.E = np.where(take, Et, desc.E)
        stepping = take & (~far | dropped)  # an island that declines, or slows down, stops
        desc.trace.append(desc.E)
        desc.out.arap_iterations += 1


def _global_step(desc: _Descent) -> np.ndarray:
    """The layout whose Jacobians are closest to the rotations closest to the current
    ones, in the proxy's norm (pinned vertices stay)."""
    fr = desc.frames
    a, b, c, d = desc.J
    # the rotation closest to each Jacobian: (cos, sin) along (a + d, c - b), no
    # trigonometry; weighted as the proxy weighs each face
    w = desc.proxy.weights * desc.area
    cs, sn = a + d, c - b
    h = np.hypot(cs, sn)
    flat = h == 0  # arctan2(0, 0) = 0: the identity
    h = w / np.where(flat, 1.0, h)
    cs = np.where(flat, w, cs * h)
    sn = sn * h
    rhs = 2.0 * np.stack([fr.DxT @ cs - fr.DyT @ sn, fr.DxT @ sn + fr.DyT @ cs], axis=1)
    if desc.fixed.size:
        rhs -= desc.proxy.H[:, desc.fixed] @ desc.x[desc.fixed]
    y = desc.proxy.solve(rhs)
    y[desc.pinned] = desc.x[desc.pinned]
    return y


# ---------------------------------------------------------------- L-BFGS steps


def _line_search(d: _Descent, p: np.ndarray, slope: np.ndarray) -> _Step:
    """Backtracking (Armijo) island by island along ``p`` (n, 2), of slope ``slope`` per
    island, from the longest step that folds nothing (capped at 1). The step is 0 where
    none lowered the energy; those islands stop."""
    per_face, islands, watch = d.per_face, d.islands, d.watch
    dJ = d.frames.jacobians(p)
    t = np.where(d.active, np.minimum(1.0, 0.9 * per_face.min(max_step(d.J, dJ, 1.0 / 0.9))), 0.0)
    searching = d.active.copy()
    Jt: tuple | None = None
    Gt: list = []
    Et = d.E
    gb = d.gb
    near, meet = watch.near_step(d.x, p, t, searching)
    t = np.minimum(t, 0.9 * watch.first_contact(d.x, p, meet))  # (no boundary crosses on the way)
    capped = t < 1.0
    followed = watch.followed(p, t)
    while searching.any():
        f = None if Jt is None else per_face.members(searching)
        if Jt is None or f is None or 2 * len(f) > len(d.area):
            Jt = tuple(j + per_face.expand(t) * dj for j, dj in zip(d.J, dJ))
            E_all, Gt_ = d.energies(Jt)
            # (an island done searching keeps its energy: its barrier is added below only
            # while it searches)
            Et = np.where(searching, E_all, Et)
            Gt = list(Gt_)
        else:  # few faces still searching: evaluate only theirs, the rest stands
            tf = t[per_face.label[f]]
            Jf = [np.take(j, f) + tf * np.take(dj, f) for j, dj in zip(d.J, dJ)]
            with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
                ef, Gf = symmetric_dirichlet(Jf[0], Jf[1], Jf[2], Jf[3], np.take(d.area, f))
            for k in range(4):
                Jt[k][f], Gt[k][f] = Jf[k], Gf[k]
            Et = np.where(searching, np.bincount(per_face.label[f], ef, minlength=islands.n), Et)
        lower = Et <= d.E + 1e-4 * t * slope
        crossed = np.zeros(islands.n, dtype=bool)
        if watch.on:
            xt = d.x + islands.spread(np.where(searching, t, 0.0)) * p
            Eb, gb_t = watch.barrier(xt, near)
            Et = np.where(searching, Et + Eb, Et)
            lower = Et <= d.E + 1e-4 * t * slope
            gb = np.where(islands.spread(searching), gb_t, gb)
            crossed = watch.refused(xt, searching & lower & ~followed)
            # an island not watched stays where it is, to be watched from there
            t[crossed & ~watch.watched] = 0.0
            searching &= ~(crossed & ~watch.watched)
        searching &= ~lower | crossed
        t[searching] *= 0.5
        gone = searching & (t < 1e-12)
        t[gone] = 0.0
        d.active &= ~gone  # no decrease along a descent direction: as far as it goes
        searching &= ~gone
    assert Jt is not None
    # every island that moved was last evaluated at its final step; the others stay
    still = per_face.expand(t == 0)
    Jt = tuple(np.where(still, j, jt) for j, jt in zip(d.J, Jt))
    gb = np.where(islands.spread(t == 0), d.gb, gb)
    return _Step(p, t, Jt, np.where(t == 0, d.E, Et), Gt, dJ, gb, capped)


# ---------------------------------------------------------------- the stopping test


def _converged(desc: _Descent, capped: np.ndarray) -> None:
    """Stop the islands whose energy fell by less than ``tol`` over the last
    ``_WINDOW`` iterations, or, before the descent has taken that many, by less than
    ``tol / 100`` over the last one (an island that was converged when the descent
    began) unless that step was ``capped`` (n_islands,) bool: cut short by a face about
    to collapse or by contact, its small decrease measures the cap, not the distance to
    the optimum. Later, one poor step (a direction the L-BFGS memory got wrong) does not
    stop an island far from its optimum: the window judges."""
    last = desc.history[-1] if desc.history else None
    desc.history = [*desc.history, desc.E][-(_WINDOW + 1) :]
    pending = desc.watch.pending
    if last is not None and len(desc.history) <= _WINDOW:
        desc.active &= ~(last - desc.E < 0.01 * desc.tol * desc.E) | pending | capped
    if len(desc.history) > _WINDOW:
        desc.active &= ~(desc.history[0] - desc.E < desc.tol * desc.E) | pending


# ---------------------------------------------------------------- the refinement


@dataclass
class _Carry:
    """The state handed to the islands that go on alone (see :func:`_go_on_alone`): what
    the descent learnt (its memory, the ``history`` of energies, the re-weighting and the
    proxy's face ``weights``), the islands whose contact is ``watched``, and where they
    started."""

    memory: _Memory
    history: list[np.ndarray]
    reweighting: _Reweighting
    weights: np.ndarray
    watched: np.ndarray
    start: np.ndarray
    iterations: int = 0  # the descent's iterations before the hand-over


def refine(
    X: np.ndarray,
    faces: np.ndarray,
    uv: np.ndarray,
    islands: Islands,
    he_twin: np.ndarray | None,
    *,
    iterations: int = 1000,
    tol: float | np.ndarray = 2e-4,
    arap: int = 1,
    pinned: np.ndarray | None = None,
    order: np.ndarray | None = None,
    proxy: Proxy | None = None,
    carry: _Carry | None = None,
    no_overlaps: bool = True,
) -> Refinement:
    """Lower the symmetric Dirichlet energy of a layout without folding it.

    Parameters
    ----------
    X : (n, 3) float64
    faces : (m, 3) int64
        Oriented faces (counter-clockwise in a good layout).
    uv : (n, 2) float64
        The seed, in mesh units, islands counter-clockwise.
    islands : Islands
    he_twin : (3m,) int64
        Twin half-edges of ``faces`` (boundary loops for the Tutte start).
    iterations : int
        At most this many descent steps (a safety net: islands stop when converged).
    tol : float or (n_islands,) float
        An island stops when its energy fell by less than this (its own, given per
        island), relative, over the last ``_WINDOW`` iterations.
    arap : int
        ARAP steps before the descent, on islands near isometric (see
        :func:`_local_global`); one by default (see the module docstring).
    pinned : (n,) bool, optional
        Vertices that keep their UV.
    order : (n,) int64, optional
        Fill-reducing order for the factorizations (e.g. the nested dissection of Step 3).
    proxy : Proxy, optional
        A cotangent proxy built beforehand by :func:`quadratic_proxy`; used if its pins
        are ours.
    carry : _Carry, optional
        The state of the refinement these islands are handed over from: the descent
        goes on where it was, with no new start and no ARAP.
    no_overlaps : bool
        Keep every island's boundary from crossing itself (see :mod:`.contact`): an
        island whose start does not overlap itself never comes to.

    Returns
    -------
    Refinement
    """
    t0 = time.perf_counter()
    pinned = np.zeros(len(X), dtype=bool) if pinned is None else pinned
    d = _set_up(X, faces, uv, islands, he_twin, tol, arap, pinned, order, proxy, carry, no_overlaps)
    d = _descend(d, iterations, 0 if carry is None else carry.iterations)
    return _finish(d, t0)


def _set_up(
    X: np.ndarray,
    faces: np.ndarray,
    uv: np.ndarray,
    islands: Islands,
    he_twin: np.ndarray | None,
    tol: float | np.ndarray,
    arap: int,
    pinned: np.ndarray,
    order: np.ndarray | None,
    proxy: Proxy | None,
    carry: _Carry | None,
    no_overlaps: bool,
) -> _Descent:
    """The descent of :func:`refine` ready to iterate: its proxy, each island's start (or,
    handed over, where the ``carry`` left it), the islands left as they are, then the
    ARAP and SLIM steps; ``d.out.energy`` holds the energy at the start and after each."""
    k = islands.n
    if carry is not None:
        proxy = quadratic_proxy(X, faces, islands, pinned, order, weights=carry.weights)
    elif proxy is None or not np.array_equal(proxy.pinned, pinned):
        proxy = quadratic_proxy(X, faces, islands, pinned, order)
    none = np.zeros(k, dtype=bool)
    out = Refinement(
        np.array(uv, dtype=np.float64, copy=True), none, none, np.zeros(k), np.zeros(k), (np.zeros(k), np.zeros(k))
    )
    per_face = Islands.labelled(islands.label[faces[:, 0]], k)
    x, stuck = out.uv, none
    contact = Contact.of(X, faces, islands.label, k) if no_overlaps else None
    if carry is None:
        crossed = None if contact is None else contact.crossing
        x, stuck, out.restarted_conformal, out.restarted_tutte = start_layout(
            X, faces, out.uv, he_twin, islands, proxy.frames, per_face, pinned, order, crossed=crossed
        )
    # islands that still fold, with nothing free or with no 3D area are left as they are
    d = _Descent(X, faces, x, islands, pinned, proxy, tol, out, contact)
    d.begin(
        ~stuck & (np.bincount(islands.label, ~pinned, minlength=k) > 0) & ~_without_area(proxy.frames, per_face),
        settle=carry is None,
        watched=None if carry is None else carry.watched,
        start=None if carry is None else carry.start,
    )
    if carry is None:
        _local_global(d, arap)
        _leave_endless(d)
    else:  # the descent goes on where it was
        d.memory, d.history, d.reweighting = carry.memory, carry.history, carry.reweighting
    out.energy += [d.mean_energy(e) for e in d.trace]
    return d


def _without_area(frames: FaceFrames, per_face: Labelled) -> np.ndarray:
    """Per island (n_islands,) bool: every face of it collapsed in 3D. No layout of such an
    island is more or less isometric than another: it keeps its start, and its energy,
    which only the faces' stand-in sizes give, is not reported."""
    return per_face.sum(~frames.degenerate) == 0


def _leave_endless(d: _Descent) -> None:
    """Leave alone the islands whose energy is still infinite after ARAP (a face whose det
    J squared underflows): a descent from there would compute inf - inf."""
    endless = d.active & ~np.isfinite(d.E)
    if not endless.any():
        return
    d.set_active(d.active & ~endless)
    d.evaluate()
    d.trace = [np.where(endless, 0.0, e) for e in d.trace]


def _descend(d: _Descent, iterations: int, done: int = 0) -> _Descent:
    """At most ``iterations`` L-BFGS steps of the descent ``d`` from where it is (``done``
    taken before it was handed over), until every island stopped; once the islands still
    descending hold at most ``_HANDOVER`` of the rows, they go on alone
    (:func:`_go_on_alone`)."""
    g = d.gradient(d.G)
    for it in range(1, (iterations if d.active.any() else 0) + 1):  # quasi-Newton steps, each one factored solve
        tick(it / (it + _HALFWAY))
        if d.watch_pending():
            g = d.gradient(d.G)
        if not _second_order(d, done + it):
            d.refresh(it)
        p, slope = d.memory.direction(g, d.active, d.proxy)
        step = _line_search(d, p, slope)
        if not (step.t > 0).any() and not d.watch.pending.any():
            break
        g = d.step(step, g)
        _converged(d, step.capped)
        d.out.energy.append(d.mean_energy(d.E))
        d.out.iterations = it
        if not d.active.any():
            break
        if it < iterations and d.islands.size[d.active].sum() <= _HANDOVER * len(d.X):
            _go_on_alone(d, iterations - it, it)
            break
    return d


def _second_order(d: _Descent, iteration: int) -> bool:
    """Whether the descent ``d`` takes the second-order proxy (:mod:`.second_order`) at its
    ``iteration``: from ``_SECOND_ORDER_AFTER`` on, while the rows still descending are at
    most ``_SECOND_ORDER_ROWS``; built again every ``_SECOND_ORDER_EVERY`` iterations, the
    L-BFGS pairs (which describe the old proxy's error) forgotten then."""
    if iteration < _SECOND_ORDER_AFTER or d.islands.size[d.active].sum() > _SECOND_ORDER_ROWS:
        return False
    if isinstance(d.proxy, SecondOrderProxy) and (iteration - _SECOND_ORDER_AFTER) % _SECOND_ORDER_EVERY:
        return True
    contact = d.watch.normal_curvature(d.x, d.active & d.watch.watched)
    d.proxy = second_order_proxy(d.proxy, d.J, d.live_face, d.active[d.islands.label], contact)
    d.memory.forget(d.active)
    d.out.proxies += 1
    return True


def _finish(d: _Descent, t0: float) -> Refinement:
    """What the descent ``d`` did, begun at ``t0``."""
    out = d.out
    out.uv = d.x
    # (islands left as they are: 0; faces with no 3D area are not measured, as in :mod:`.metrics`)
    counted = (d.live_face | d.per_face.expand(d.settled)) & ~d.frames.degenerate
    out.island_area = d.per_face.sum(np.where(counted, d.area, 0.0))
    with np.errstate(divide="ignore", invalid="ignore"):
        fro, inv, _ = dirichlet_parts(*d.frames.jacobians(d.x))  # from x: a hand-over leaves J behind
    out.island_parts = (
        d.per_face.sum(np.where(counted, d.area * fro, 0.0)),
        d.per_face.sum(np.where(counted, d.area * inv, 0.0)),
    )
    out.island_energy = out.island_parts[0] + out.island_parts[1]  # (the barrier left out)
    out.folded = int((signed_double_areas(d.x, d.faces) <= 0).sum())
    out.seconds = time.perf_counter() - t0
    return out


def _go_on_alone(d: _Descent, iterations: int, done: int) -> None:
    """:func:`refine` for the active islands of ``d`` alone, from where they are, with
    their part of the L-BFGS state and of the proxy's weights, a nested-dissection order
    of their own and their own factorizations (the proxy's blocks are what they are in
    the whole, so the descent goes on as it would have); their result goes into ``d``
    and ``d.out``."""
    active, islands = d.active, d.islands
    rows, sub = islands.subset(active)
    index = np.full(len(d.X), -1, dtype=np.int64)
    index[rows] = np.arange(len(rows))
    f = d.per_face.members(active)
    F_sub = index[d.faces[f]]
    X_sub = np.take(d.X, rows, axis=0)
    carry = _Carry(
        memory=d.memory.subset(active, rows, sub),
        history=[h[active] for h in d.history],
        reweighting=d.reweighting.subset(active, done),
        weights=d.proxy.weights[f],
        watched=(d.watch.watched | d.watch.pending)[active],
        start=d.start[rows],
        iterations=done,
    )
    order = nested_dissection(X_sub, unique_edges(F_sub))
    result = refine(
        X_sub,
        F_sub,
        d.x[rows],
        sub,
        None,
        iterations=iterations,
        tol=d.tol if np.ndim(d.tol) == 0 else d.tol[active],
        arap=0,
        pinned=d.pinned[rows],
        order=order,
        carry=carry,
    )
    d.x = d.x.copy()
    d.x[rows] = result.uv
    E = d.E.copy()
    E[active] = result.island_energy
    # the energy over every live face: the islands handed over, the others as they stopped
    rest = float(E[~active].sum())
    sub_area = float(d.area[f].sum())
    d.out.energy += [d.mean_energy(np.array([rest + e * sub_area])) for e in result.energy[1:]]
    d.out.iterations = done + result.iterations
    d.out.proxies += result.proxies
    d.E = E
