"""Where the descent follows contact (:mod:`.contact`), and where it only tests a step's end.

Following contact on every boundary at every step (pair lists, distances, the barrier)
costs more than the rest of an iteration, so it is followed where it is likely or met:
from the start on islands whose boundary touches itself there or whose start is far from
isometric, and on the others once a step would cross their boundary (the descent then
starts them again, see :meth:`.descent._Descent.watch_pending`). Elsewhere a step is only
tested for crossings at its end.

The pairs followed are listed once and the list kept from step to step while it covers
them (a Verlet list, as molecular dynamics keeps neighbours); where a few vertices outrun
it (most steps move some parts of a boundary far more than the rest), only their pairs
are listed again.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .contact import Contact, Near

__all__ = ["ContactWatch"]


_RENEW = 0.5  # a list is renewed where vertices outran it while they are at most this share; else built anew


@dataclass(frozen=True)
class _VerletList:
    """Boundary pairs of the islands ``which`` (n_islands,) bool that may come within reach
    while each vertex stays within its ``allowance`` (n,) of where it was listed, ``at``
    (n, 2). A pair not listed is one whose distance there is at least its gap and the
    allowances of its vertex and its edge's ends, so it cannot act while each vertex stays
    within its allowance (the ends of an edge bound every point of it)."""

    pairs: Near
    at: np.ndarray
    which: np.ndarray
    allowance: np.ndarray

    def outrun(self, contact: Contact, x: np.ndarray, which: np.ndarray, motion: np.ndarray) -> np.ndarray:
        """The boundary vertices (n,) bool of the islands ``which`` that may leave their
        allowance on a step moving each vertex by ``motion`` (n,) from ``x``."""
        v = contact.edges[which[contact.edge_island], 0]  # (the boundary's vertices)
        drift = np.hypot(*(x[v] - self.at[v]).T)
        out = np.zeros(len(x), dtype=bool)
        out[v] = ~(drift + motion[v] <= self.allowance[v])  # (a vertex not a number: outrun)
        return out

    def renewed(self, contact: Contact, x: np.ndarray, moved: np.ndarray, allowance: np.ndarray) -> _VerletList:
        """The list with the vertices ``moved`` (n,) bool listed again from ``x`` with a new
        ``allowance`` (n,): their pairs (as the vertex or an end of the edge) found again,
        every other pair kept, as are the other vertices' places and allowances."""
        at = np.where(moved[:, None], x, self.at)
        allowance = np.where(moved, allowance, self.allowance)
        old = self.pairs
        ends = contact.edges[old.edge]
        keep = ~(moved[old.vertex] | moved[ends[:, 0]] | moved[ends[:, 1]])
        held = np.zeros_like(self.which)  # (their islands: pairs are of one island)
        held[contact.edge_island[contact.starting[moved]]] = True
        new = contact.near(at, self.which & held, allowance, moved)
        vertex, edge = np.concatenate([old.vertex[keep], new.vertex]), np.concatenate([old.edge[keep], new.edge])
        # in the order a list built anew has (by the vertex's edge, then the edge), so that
        # the barrier sums its pairs in one order however the list was made (both parts
        # are in that order already: a stable sort merges them)
        order = np.argsort(contact.starting[vertex] * len(contact.edges) + edge, kind="stable")
        pairs = Near(vertex[order], edge[order], np.concatenate([old.gap[keep], new.gap])[order])
        return _VerletList(pairs, at, self.which, allowance)


class ContactWatch:
    """The contact of a descent's islands: those whose contact is followed (``watched``),
    those whose step was refused for crossing while not watched (``pending``), those
    where it never is (``no_contact``: the boundary crosses itself at the start, or pins
    shape the island), and the list of pairs followed.

    Without a :class:`.Contact` (no overlaps kept off) no pair is followed, no barrier
    acts and no step is refused."""

    def __init__(self, contact: Contact | None, n_islands: int):
        self.contact = contact
        self.n_islands = n_islands
        self.no_contact = np.ones(n_islands, dtype=bool)
        self.watched = np.zeros(n_islands, dtype=bool)
        self.pending = np.zeros(n_islands, dtype=bool)
        self._list: _VerletList | None = None

    @property
    def on(self) -> bool:
        """Whether contact is kept at all (there is a :class:`.Contact`)."""
        return self.contact is not None

    def begin(self, x: np.ndarray, active: np.ndarray, pinned_island: np.ndarray, fold_free=None) -> np.ndarray:
        """The start ``x`` (n, 2) of the islands ``active`` with banks that touch pushed apart
        (:meth:`.Contact.separate`), as far as folds no face (``fold_free``: the layout
        between the one before and the one after that folds nothing); sets where contact
        is never followed."""
        if self.contact is None:
            return x
        apart = self.contact.separate(x, active & ~pinned_island)
        x = apart if fold_free is None else fold_free(x, apart)
        # no contact where the boundary crosses itself at the start (it can only be left
        # so), nor where pins shape the island (their copies of a seam vertex may meet)
        self.no_contact = self.contact.crossing(x, active) | pinned_island
        return x

    def touching(self, x: np.ndarray, which: np.ndarray) -> np.ndarray:
        """Islands (n_islands,) bool of ``which`` whose boundary touches itself in ``x``
        (:meth:`.Contact.touching`)."""
        if self.contact is None:
            return np.zeros(self.n_islands, dtype=bool)
        return self.contact.touching(x, which & ~self.no_contact)

    def near(self, x: np.ndarray, p: np.ndarray | None, t: np.ndarray | None, which: np.ndarray) -> Near:
        """The boundary pairs of the watched islands of ``which`` that may touch on a step
        ``t`` (per island) along ``p`` (n, 2) from ``x`` (None: no step); from the list kept
        while it covers them, else from a new one that allows for the next steps too."""
        if self.contact is None:
            return Near.none()
        which = which & ~self.no_contact & self.watched
        motion = np.zeros(len(x)) if p is None or t is None else self.contact.motion(p, t)
        allowance = self.contact.allowance(motion)
        kept = self._list
        if kept is not None and not (which & ~kept.which).any():
            moved = kept.outrun(self.contact, x, which, motion)
            if not moved.any():
                return kept.pairs
            if moved.sum() <= _RENEW * self.contact.n_vertices(which):
                self._list = kept.renewed(self.contact, x, moved, allowance)
                return self._list.pairs
        self._list = _VerletList(self.contact.near(x, which, allowance), x.copy(), which.copy(), allowance)
        return self._list.pairs

    def near_step(self, x: np.ndarray, p: np.ndarray, t: np.ndarray, which: np.ndarray) -> tuple[Near, Near]:
        """The pairs whose barrier can act on the step ``t`` along ``p`` from ``x``, and those
        that can meet on it (:meth:`near`, narrowed to the step)."""
        near = self.near(x, p, t, which)
        if self.contact is None:
            return near, near
        return self.contact.within(x, near, self.contact.motion(p, t))

    def first_contact(self, x: np.ndarray, p: np.ndarray, near: Near) -> np.ndarray:
        """Per island, the first step along ``p`` from ``x`` at which its boundary touches
        itself."""
        if self.contact is None:
            return np.full(self.n_islands, np.inf)
        return self.contact.first_contact(x, p, near, self.n_islands)

    def followed(self, p: np.ndarray, t: np.ndarray) -> np.ndarray:
        """Islands (n_islands,) bool along whose step ``t`` along ``p`` contact is followed
        (the others' steps are tested for crossings at their end)."""
        if self.contact is None:
            return np.ones(self.n_islands, dtype=bool)
        return self.contact.followed(self.contact.motion(p, t), self.n_islands) & self.watched

    def crossing(self, x: np.ndarray, which: np.ndarray) -> np.ndarray:
        """Islands (n_islands,) bool of ``which`` whose boundary crosses itself in ``x``
        (where a long step went past what :meth:`first_contact` follows)."""
        if self.contact is None:
            return np.zeros(self.n_islands, dtype=bool)
        return self.contact.crossing(x, which & ~self.no_contact)

    def refused(self, x: np.ndarray, which: np.ndarray) -> np.ndarray:
        """Islands (n_islands,) bool of ``which`` whose boundary crosses itself in ``x``
        (a step that went past what :meth:`first_contact` follows, or an island whose
        contact is not watched); those not watched are watched from the next step on."""
        crossed = self.crossing(x, which)
        self.pending |= crossed & ~self.watched
        return crossed

    def watch_pending(self, active: np.ndarray) -> np.ndarray:
        """The islands (n_islands,) bool of ``active`` whose step was refused while their
        contact was not watched, watched from now on (none without contact)."""
        newly = self.pending & active
        self.pending[:] = False
        if self.contact is None or not newly.any():
            return np.zeros(self.n_islands, dtype=bool)
        self.watched = self.watched | newly
        self._list = None
        return newly

    def normal_curvature(self, x: np.ndarray, which: np.ndarray):
        """The barrier's curvature along the normals of the pairs of the islands ``which``
        (n_islands,) bool whose contact is followed (:meth:`.Contact.normal_curvature`), a
        sparse (2n, 2n) matrix, or None."""
        if self.contact is None:
            return None
        near = self.near(x, None, None, which)
        return self.contact.normal_curvature(x, near) if len(near.vertex) else None

    def barrier(self, x: np.ndarray, near: Near) -> tuple[np.ndarray, np.ndarray]:
        """Per island the contact barrier of the pairs ``near`` in ``x`` (0 without
        contact), and its gradient (n, 2)."""
        if self.contact is None:
            return np.zeros(self.n_islands), np.zeros_like(x)
        return self.contact.energy(x, near, self.n_islands)
