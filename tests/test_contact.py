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
    contact = Contact(edges, island, np.full(6, gap), 1, after, after, X, starting)
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
