"""An island's boundary kept from crossing itself (solver/refinement/contact.py): the barrier, its
gradient, and the first contact along a step."""

import numpy as np
import pytest

from isoparam_addon.solver.refinement.contact import Contact, Near


def _two_banks(gap=0.1):
    """Three thin parts of one island's boundary (each a loop there and back): along
    (0,0)-(1,0), along (1,1)-(0,1), and from (0.5, 0.3) up to (0.5, 2)."""
    edges = np.array([[0, 1], [1, 0], [2, 3], [3, 2], [4, 5], [5, 4]])
    x = np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0], [0.5, 0.3], [0.5, 2.0]])
    X = np.hstack([x * 10.0, np.zeros((6, 1))])  # far apart on the surface: the barrier acts
    after = np.array([1, 0, 3, 2, 5, 4])
    starting = np.arange(6)
    island = np.zeros(6, np.int64)
    contact = Contact(edges, island, np.full(6, gap), 1, after, after, X, starting, np.full(6, -1))
    return contact, x


def test_the_first_contact_of_a_moving_vertex_with_an_edge():
    contact, x = _two_banks()
    p = np.zeros_like(x)
    p[4] = [0.0, -1.0]  # down onto the first edge: meets it at t = 0.3
    near = Near(np.array([4]), np.array([0]), np.array([0.1]))
    assert contact.first_contact(x, p, near, 1)[0] == pytest.approx(0.3)
    p[4] = [2.0, -1.0]  # sideways past its end: no contact
    assert contact.first_contact(x, p, near, 1)[0] == np.inf
    p[:] = 0.0
    p[[0, 1]] = [0.0, 1.0]  # the edge rises to the vertex
    assert contact.first_contact(x, p, near, 1)[0] == pytest.approx(0.3)


def test_the_barrier_acts_within_the_gap_only_and_its_gradient_is_exact():
    contact, x = _two_banks(gap=0.5)
    near = contact.near(x, np.ones(1, dtype=bool))
    assert (4, 0) in set(zip(near.vertex.tolist(), near.edge.tolist()))
    energy, grad = contact.energy(x, near, 1)
    assert energy[0] > 0 and grad[4, 1] < 0  # pushed up, away from the edge below
    for i, c in [(4, 0), (4, 1), (0, 1), (1, 1)]:  # against central differences
        h = 1e-6
        up, down = x.copy(), x.copy()
        up[i, c] += h
        down[i, c] -= h
        numeric = (contact.energy(up, near, 1)[0][0] - contact.energy(down, near, 1)[0][0]) / (2 * h)
        assert grad[i, c] == pytest.approx(numeric, rel=1e-5, abs=1e-8)
    far = x.copy()
    far[4] = [3.0, 0.5]  # beyond the gap of every edge
    assert contact.energy(far, contact.near(far, np.ones(1, dtype=bool)), 1)[0][0] == 0.0


def test_a_pair_list_renewed_where_vertices_outran_it_is_the_list_built_anew(monkeypatch):
    """Where a few vertices move beyond their allowance, only their pairs are found again
    (:class:`.watch._VerletList`); the pairs within their gap, the barrier they give and
    the first contact along the step are those of a list built anew, to the last bit."""
    from isoparam_addon.solver.refinement import watch as watching
    from isoparam_addon.solver.refinement.watch import ContactWatch

    renewals = []
    renew = watching._VerletList.renewed
    monkeypatch.setattr(watching._VerletList, "renewed", lambda *a: renewals.append(a[3].sum()) or renew(*a))

    n = 80
    angle = np.linspace(0.0, 2.0 * np.pi, n, endpoint=False)
    x = np.stack([np.cos(angle), 0.06 * np.sin(angle)], axis=1)  # a thin ellipse: two banks
    edges = np.stack([np.arange(n), (np.arange(n) + 1) % n], axis=1)
    gap = 0.5 * np.linalg.norm(x[edges[:, 1]] - x[edges[:, 0]], axis=1)
    after, before = edges[:, 1], (np.arange(n) - 1) % n
    X = np.hstack([x * [1.0, 20.0], np.zeros((n, 1))])  # apart on the surface: the barrier acts
    contact = Contact(edges, np.zeros(n, np.int64), gap, 1, after, before, X, np.arange(n), np.full(n, -1))
    one = np.ones(1, dtype=bool)

    def watch():
        w = ContactWatch(contact, 1)
        w.no_contact[:], w.watched[:] = False, True
        return w

    rng = np.random.default_rng(3)
    kept = watch()
    kept.near(x, None, None, one)  # listed here
    moved = x.copy()
    few = rng.choice(np.flatnonzero(x[:, 1] > 0), 6, replace=False)
    moved[few, 1] -= 0.07  # a few top vertices pressed towards the bottom bank
    p = np.zeros_like(x)
    p[few] = rng.normal(size=(6, 2)) * 0.02
    t = np.ones(1)
    renewed = kept.near_step(moved, p, t, one)
    fresh = watch().near_step(moved, p, t, one)
    assert renewals == [6] and len(renewed[0].vertex) > 0

    (act, meet), (act_fresh, meet_fresh) = renewed, fresh
    close = contact.near(moved, one)  # every pair within its gap in the moved layout
    within = set(zip(close.vertex.tolist(), close.edge.tolist()))
    assert within and all(
        within <= set(zip(listed.vertex.tolist(), listed.edge.tolist())) for listed in (act, act_fresh)
    )
    energy, grad = contact.energy(moved, act, 1)
    energy_fresh, grad_fresh = contact.energy(moved, act_fresh, 1)
    assert energy[0] > 0 and energy[0] == energy_fresh[0] and np.array_equal(grad, grad_fresh)
    first = contact.first_contact(moved, p, meet, 1)
    assert np.array_equal(first, contact.first_contact(moved, p, meet_fresh, 1))
