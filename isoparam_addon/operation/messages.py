"""The operator's words: errors in mesh terms with a hint at what to do, and the solver's
warnings sorted into what the report says (warnings, notes) and what goes to the debug
log."""

from __future__ import annotations

import numpy as np

from ..solver import ErrorKind, InvalidMeshError
from ..solver.errors import counted, offenders
from ..solver.layout.uv_space import FAR_UV
from ..solver.report import FOUR_STEP_KINDS, WarningKind, solver_names
from .selection import Selection

__all__ = [
    "NOT_PACKED_FAR",
    "NOT_MANIFOLD_ERRORS",
    "OVERLAP_ERRORS",
    "OVERLAP_WARNINGS",
    "describe",
    "mesh_names",
    "overlap_words",
    "sorted_words",
]


_HINTS = {
    ErrorKind.NON_FINITE: "Some vertices have invalid (NaN or infinite) coordinates",
    ErrorKind.NON_FINITE_PIN: "Clear the pins (UV > Unpin) of that face, or give them valid UVs",
    ErrorKind.NON_MANIFOLD_EDGE: "Select > Select All by Trait > Non Manifold shows them",
    ErrorKind.NON_MANIFOLD_VERTEX: "Select > Select All by Trait > Non Manifold shows them; "
    "Mesh > Split > Faces by Edges, or a seam through them, separates the fans",
    ErrorKind.DUPLICATE_FACE: "Mesh > Clean Up > Merge by Distance, then Delete Loose, removes them",
    ErrorKind.REPEATED_VERTEX: "Mesh > Clean Up > Degenerate Dissolve removes them",
}


def mesh_names(sel: Selection):
    """Names for the solver's elements as Blender numbers them: a triangle of the selection
    is the mesh face it comes from, a row of its vertices a mesh vertex."""

    def names(element: str, first: tuple[int, ...]) -> str:
        if element == "face" and first[0] < len(sel.tri_poly):
            return f"face {int(sel.tri_poly[first[0]])}"
        if element == "vertex" and first[0] < len(sel.vert_ids):
            return f"vertex {int(sel.vert_ids[first[0]])}"
        if element == "edge":
            a, b = (int(sel.vert_ids[v]) for v in first)
            return f"edge between vertices {a} and {b}"
        return solver_names(element, first)

    return names


def describe(err: InvalidMeshError, sel: Selection) -> str:
    """The solver's error in mesh terms (its indices are rows of the selection), and a hint
    at what to do, prefixed with the mesh's name."""
    text, hint = overlap_words(err, sel)
    return f"'{sel.name}': {text}" + (f". {hint}" if hint else "")


def overlap_words(err: InvalidMeshError, sel: Selection) -> tuple[str, str]:
    """The error's sentence in mesh terms and a hint; for triangles of Blender's
    triangulation that overlap (not faces of the mesh), the two faces they come from."""
    text = err.worded(mesh_names(sel))
    if err.element == "face" and err.what and err.count and (err.indices < len(sel.tri_poly)).all():
        # triangles -> the mesh faces they come from, counted once each (a quad is two)
        poly = sel.tri_poly[err.indices]
        _, at = np.unique(poly, return_index=True)
        text = str(offenders(err.kind, err.what, "face", poly[np.sort(at)]))
    hint = _HINTS.get(err.kind, "")
    if err.kind == ErrorKind.DUPLICATE_FACE and err.count:
        pair = _overlapping_faces(sel, int(err.indices[0]))
        if pair is not None:  # two faces, not a face given twice: Merge by Distance does not help
            a, b = pair
            text = (
                f"{counted(err.count, 'triangle', 'triangles')} of Blender's triangulation "
                f"{'comes' if err.count == 1 else 'come'} twice (first: faces {a} and {b} "
                "share three vertices, so one lies across the other)"
            )
            hint = "Delete or dissolve one of the two faces, or move a vertex off the other's diagonal"
    if err.kind == ErrorKind.NON_MANIFOLD_EDGE and err.edges is not None and len(err.edges):
        overlap = _faces_across(sel, err.edges[0])
        if overlap is not None:  # not an edge of the mesh: Select Non Manifold would show nothing
            a, b, both = overlap
            x, y = (int(sel.vert_ids[v]) for v in err.edges[0])
            if both:
                text = (
                    f"faces {a} and {b} overlap: Blender splits both along their diagonal between vertices {x} and {y}"
                )
            else:
                text = (
                    f"faces {a} and {b} overlap: Blender splits face {a} along its diagonal between "
                    f"vertices {x} and {y}, which is a side of face {b}"
                )
            quads = [f for f in ((a, b) if both else (a,)) if np.count_nonzero(sel.tri_poly == f) == 2]
            hint = "Delete or dissolve one of the two faces"
            if quads:  # a convex quad is split along its other diagonal when this one clashes
                which = f"face {quads[0]}" if len(quads) == 1 else "one of them"
                hint = (
                    f"Make {which} convex (it is then split along its other diagonal), "
                    "or delete or dissolve one of the two faces"
                )
    return text, hint


def _faces_across(sel: Selection, edge) -> tuple[int, int, bool] | None:
    """For a vertex pair ``edge`` of the selection that is a diagonal inside a mesh face
    (a quad or n-gon split there) and a side or a diagonal of another: those two faces,
    and whether it is a diagonal of both."""
    a, b = sorted(int(v) for v in edge)
    if not len(sel.diagonals) or not (np.sort(sel.diagonals, axis=1) == (a, b)).all(axis=1).any():
        return None
    on = (sel.F == a).any(axis=1) & (sel.F == b).any(axis=1)
    polys, count = np.unique(sel.tri_poly[on], return_counts=True)
    inside = polys[count == 2]  # both triangles of a split face hold its diagonal
    others = polys[count == 1]
    if len(inside) >= 2:
        return int(inside[0]), int(inside[1]), True
    if len(inside) and len(others):
        return int(inside[0]), int(others[0]), False
    return None


def _overlapping_faces(sel: Selection, t: int) -> tuple[int, int] | None:
    """The mesh faces of triangle ``t`` and of the earlier triangle with the same vertices,
    when they are different faces that are not the same vertices twice."""
    key = np.sort(sel.F, axis=1)
    earlier = int(np.flatnonzero((key == key[t]).all(axis=1))[0])
    a, b = int(sel.tri_poly[earlier]), int(sel.tri_poly[t])
    if a == b or np.count_nonzero(sel.tri_poly == a) == np.count_nonzero(sel.tri_poly == b) == 1:
        return None  # one face folded onto itself, or a triangle given twice
    return a, b


_NOTES = frozenset({WarningKind.CHARTS, WarningKind.CUT_APART})  # news, not trouble: reported as INFO


OVERLAP_ERRORS = frozenset({ErrorKind.DUPLICATE_FACE, ErrorKind.NON_MANIFOLD_EDGE})  # what overlapping triangles raise


NOT_MANIFOLD_ERRORS = OVERLAP_ERRORS | {ErrorKind.NON_MANIFOLD_VERTEX}  # what the solver splits when not strict


# why Blender's packer is not run: it makes NaN of such UVs, or crashes
NOT_PACKED_FAR = f"not packed: UVs beyond {FAR_UV:.0e} or not finite (far pins, world scale, or a kept corner)"

# how the solver says it split them
OVERLAP_WARNINGS = frozenset({WarningKind.DUPLICATE_FACES, WarningKind.NON_MANIFOLD_EDGES})


def sorted_words(res, sel: Selection, refined: bool) -> tuple[list[str], list[str], list[str]]:
    """The solver's warnings as the report says them, mesh faces and vertices named as
    Blender numbers them: warnings (what may need the artist), notes (what the unwrap did:
    charts, cuts) and details (what its four steps met: debug log only, or, without
    refinement, also a warning in the artist's words). As they hold for what the operator
    writes: the solver holds a vertex whose corners are pinned to different UVs at their
    mean, but pins never move here (``place_in_uv_space`` puts every pinned corner back
    on its own UV)."""
    names = mesh_names(sel)
    warnings, notes, details = [], [], []
    for w in res.warnings:
        if w.kind in _NOTES:
            notes.append(w.worded(names))
        elif w.kind in FOUR_STEP_KINDS:
            # with refinement, which starts from the four-step layout, the refined layout
            # is what counts (its folds, overlaps or stretch are warned about): the debug
            # log's; without, the layout's own trouble, said in the artist's words
            details.append(w.worded(names))
            if not refined:
                warnings.append(_fast_layout_words(w, names))
        elif w.kind != WarningKind.PIN_CONFLICT:
            warnings.append(w.worded(names))
    if res.stats.pin_conflicts:
        warnings.append(
            f"{counted(res.stats.pin_conflicts, 'pinned vertex has', 'pinned vertices have')} corners pinned "
            "to different UVs: each corner "
            "stays on its pin, so the faces around them stretch between the pins "
            "(unpin all but one UV of each to avoid it)"
        )
    return warnings, notes, details


def _fast_layout_words(w, names) -> str:
    """What the four steps met (a warning of one of the ``FOUR_STEP_KINDS``), said to an artist who
    unwrapped with Refinement 0, and what to do about it."""
    n = w.count
    first = f" (first: {names(w.element, w.first)})" if w.first else ""
    was = "was" if n == 1 else "were"
    if w.kind == WarningKind.DEGENERATE_FANS:
        what = f"around {counted(n, 'vertex', 'vertices')} the faces are too thin to lay out exactly"
    elif w.kind == WarningKind.RESTARTED:
        what = (
            f"{counted(n, 'island', 'islands')} would fold in the fast layout and {was} laid out with "
            f"angles kept instead, areas uneven{first}"
        )
    elif w.kind == WarningKind.DEGENERATE_SCALE:
        what = f"{counted(n, 'island', 'islands')} could not be sized to the model and may be too large or small"
    else:  # not_converged
        what = f"{counted(n, 'island', 'islands')} {was} laid out before the fast solve settled{first}"
    return f"{what}: a Refinement above 0 corrects it"
