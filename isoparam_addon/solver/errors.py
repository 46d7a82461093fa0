"""The one exception family raised by the solver.

Every input problem raises :class:`InvalidMeshError` (a ``ValueError``) whose message
names how many elements are affected and the first offender, and whose attributes
carry the same facts for programs, its :class:`ErrorKind` first (the Blender operator
turns them into a report that tells the artist how to find the elements).
"""

from __future__ import annotations

from enum import StrEnum

import numpy as np

__all__ = ["ErrorKind", "IsoparamError", "InvalidMeshError", "SolverError"]


class ErrorKind(StrEnum):
    """What is wrong with the input of an :class:`InvalidMeshError`; what its ``element``
    and ``indices`` name, if anything. A string enum: it compares equal to its value."""

    EMPTY = "empty"  # no vertices or no faces (no indices)
    SHAPE = "shape"  # vertices, faces or pins of the wrong shape or dtype, ragged or not numbers (no indices)
    NON_FINITE = "non_finite"  # vertices with NaN or infinite coordinates (vertices)
    NON_FINITE_PIN = "non_finite_pin"  # faces with a pinned corner whose UV is NaN or infinite (faces)
    INDEX_RANGE = "index_range"  # faces indexing a vertex that does not exist (faces)
    REPEATED_VERTEX = "repeated_vertex"  # faces using one vertex twice (faces)
    SEAM = "seam"  # seams or inner edges not a (k, 2) int array, or naming a missing vertex (seams, inner edges)
    # what is not a manifold: raised only with ``split_nonmanifold=False`` (else split, and warned)
    DUPLICATE_FACE = "duplicate_face"  # faces repeating an earlier face's vertices (faces)
    NON_MANIFOLD_EDGE = "non_manifold_edge"  # edges shared by more than two faces (edges)
    NON_MANIFOLD_VERTEX = "non_manifold_vertex"  # bow-ties: vertices whose faces form several fans (vertices)


class IsoparamError(Exception):
    """Base class of every error isoparam raises on purpose."""


class InvalidMeshError(IsoparamError, ValueError):
    """The input mesh cannot be parametrized as given.

    Attributes
    ----------
    kind : ErrorKind
        What is wrong (the table in :class:`ErrorKind`).
    element : str
        ``"vertex"``, ``"face"`` or ``"edge"`` (or ``"seam"``, ``"inner_edge"``): what
        ``indices`` index.
    indices : (k,) int
        Every offending element (vertex or face index into the caller's arrays;
        for edges, rows of ``edges``).
    edges : (k, 2) int or None
        For edge problems, the vertex pairs of the offending edges.
    """

    def __init__(self, kind: ErrorKind, message: str, element: str = "", indices=None, edges=None):
        super().__init__(message)
        self.kind = ErrorKind(kind)  # a member, also when given its value
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


def offenders(kind: ErrorKind, what: str, element: str, indices, edges=None) -> InvalidMeshError:
    """Build an :class:`InvalidMeshError` whose message quotes the count and first index.

    ``what`` completes the sentence "<count> <element>s <what>", its verb in the plural,
    e.g. ``offenders(ErrorKind.NON_FINITE, "have non-finite coordinates", "vertex", idx)``; for
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
