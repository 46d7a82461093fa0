"""The one exception family raised by the solver.

Every input problem raises :class:`InvalidMeshError` (a ``ValueError``) whose message
names how many elements are affected and the first offender, and whose attributes
carry the same facts for programs (the Blender operator turns them into a report that
tells the artist how to find the elements).
"""

from __future__ import annotations

import numpy as np

__all__ = ["IsoparamError", "InvalidMeshError", "SolverError"]


class IsoparamError(Exception):
    """Base class of every error isoparam raises on purpose."""


class InvalidMeshError(IsoparamError, ValueError):
    """The input mesh cannot be parametrized as given.

    Attributes
    ----------
    kind : str
        One of ``"empty"``, ``"shape"``, ``"non_finite"``, ``"non_finite_pin"``,
        ``"index_range"``, ``"repeated_vertex"``, ``"duplicate_face"``,
        ``"non_manifold_edge"``, ``"non_manifold_vertex"``, ``"seam"``.
    element : str
        ``"vertex"``, ``"face"`` or ``"edge"``: what ``indices`` index.
    indices : (k,) int
        Every offending element (vertex or face index into the caller's arrays;
        for edges, rows of ``edges``).
    edges : (k, 2) int or None
        For edge problems, the vertex pairs of the offending edges.
    """

    def __init__(self, kind: str, message: str, element: str = "", indices=None, edges=None):
        super().__init__(message)
        self.kind = kind
        self.element = element
        self.indices = np.asarray([] if indices is None else indices, dtype=np.int64)
        self.edges = None if edges is None else np.asarray(edges, dtype=np.int64)
        self.what = ""  # the message's predicate, its verb in the plural (from :func:`offenders`)

    @property
    def count(self) -> int:
        return int(self.indices.size)

    def worded(self, names) -> str:
        """The message with the first offender named by ``names(element, first)`` (a vertex
        pair for an edge), for a caller that numbers elements its own way; as raised for
        messages not made by :func:`offenders`."""
        if not self.what or not self.count:
            return str(self)
        first = tuple(int(v) for v in self.edges[0]) if self.edges is not None else (int(self.indices[0]),)
        return _sentence(self.count, self.element, self.what, names(self.element, first))


class SolverError(IsoparamError, RuntimeError):
    """A valid mesh on which the numerical method failed (reported, never NaN)."""


def offenders(kind: str, what: str, element: str, indices, edges=None) -> InvalidMeshError:
    """Build an :class:`InvalidMeshError` whose message quotes the count and first index.

    ``what`` completes the sentence "<count> <element>s <what>", its verb in the plural,
    e.g. ``offenders("non_finite", "have non-finite coordinates", "vertex", idx)``; for
    one offender both agree ("1 vertex has non-finite coordinates").
    """
    indices = np.asarray(indices, dtype=np.int64).ravel()
    count = indices.size
    first = ""
    if count:
        first = f"{element} {indices[0]}"
        if edges is not None:
            a, b = np.asarray(edges)[0]
            first = f"edge ({a}, {b})"
    err = InvalidMeshError(kind, _sentence(count, element, what, first), element, indices, edges)
    err.what = what
    return err


def _sentence(count: int, element: str, what: str, first: str) -> str:
    plural = element if count == 1 else {"vertex": "vertices"}.get(element, element + "s")
    return f"{count} {plural} {(_singular_verb(what) if count == 1 else what)} (first: {first})"


_SINGULAR = {"have": "has", "are": "is", "index": "indexes", "use": "uses", "repeat": "repeats", "join": "joins"}


def _singular_verb(what: str) -> str:
    """The phrase with its first word, a plural verb, in the singular: have -> has,
    are -> is, index -> indexes (every verb an offender message uses is in the table)."""
    verb, _, rest = what.partition(" ")
    return f"{_SINGULAR[verb]} {rest}" if rest else _SINGULAR[verb]


def counted(n: int, one: str, many: str) -> str:
    """``"1 vertex has"`` or ``"3 vertices have"``: the count with the words that agree."""
    return f"{n} {one if n == 1 else many}"
