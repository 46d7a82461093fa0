"""A corpus of public real meshes, the readers that load them, and their topology.

The shared meshes (``../shared/meshes``) are few and well known; the default unwrap
must also hold on what users bring: scans open and closed, CAD parts with sharp edges
and inconsistent winding, quad and low-poly game models, meshes of many parts, of
genus two and more. :data:`MANIFEST` names such meshes in public repositories, each by
repository, commit and path, with its licence; :func:`fill_cache` copies them into a
folder (from a local mirror of the repository, else from GitHub) and
``scripts/corpus.py`` unwraps every mesh of a folder. Nothing here is vendored.

Readers, for OBJ, OFF, PLY (ascii, binary little- and big-endian) and STL (ascii and
binary), all return ``(V (n, 3) float64, F (m, 3) int64)``: polygons are split into
triangle fans from their first corner, STL's separate triangles are welded where
their coordinates are exactly equal. Every file is parsed a whole section at a time
(text split into numbers once, binary read with ``np.frombuffer``), never a face at a
time.
"""

from __future__ import annotations

import re
import subprocess
import sys
import urllib.error
import urllib.request
from dataclasses import dataclass
from pathlib import Path
from typing import Literal, NamedTuple

import numpy as np

__all__ = [
    "MANIFEST",
    "MESH_SUFFIXES",
    "Source",
    "Topology",
    "fill_cache",
    "load_mesh",
    "read_obj",
    "read_off",
    "read_ply",
    "read_stl",
    "topology",
]

MESH_SUFFIXES = (".obj", ".off", ".ply", ".stl")


# ---------------------------------------------------------------------------- parsing


def _numbers(text: str) -> tuple[np.ndarray, np.ndarray]:
    """Every whitespace-separated number of ``text`` as float64 (integers below 2^53 are
    exact), and how many each line holds ((lines,) int64, one entry per ``\\n``-separated
    line, blank lines included). The counts come from the bytes: a token starts where a
    non-blank byte follows a blank one."""
    data = text.encode("ascii", errors="replace")
    b = np.frombuffer(data, dtype=np.uint8)
    newline = b == 10
    blank = newline | (b == 32) | (b == 9) | (b == 13) | (b == 11) | (b == 12)  # bytes.split()'s whitespace
    start = ~blank
    start[1:] &= blank[:-1]
    line = np.cumsum(newline)  # the line of every byte
    counts = np.bincount(line[start], minlength=int(newline.sum()) + 1)
    return np.array(data.split(), dtype=np.float64), counts


def _fans(first: np.ndarray, k: np.ndarray) -> np.ndarray:
    """The positions of the corners of the triangle fans of polygons whose ``k`` corners
    sit at ``first + 0 .. first + k - 1`` of a flat array: ((sum(k - 2), 3) int64, in
    the polygons' order; polygons of fewer than three corners give none)."""
    k = np.maximum(np.asarray(k, dtype=np.int64), 2)
    n_tri = k - 2
    poly = np.repeat(np.arange(len(k)), n_tri)
    j = np.arange(len(poly)) - np.repeat(np.cumsum(n_tri) - n_tri, n_tri)  # triangle j of its polygon
    base = np.asarray(first, dtype=np.int64)[poly]
    return np.stack([base, base + j + 1, base + j + 2], axis=1)


def _polygons(values: np.ndarray, starts: np.ndarray) -> np.ndarray:
    """Triangle fans of polygons written as ``k i_0 .. i_{k-1}`` at ``starts`` of the flat
    ``values`` (OFF and ascii PLY faces): (t, 3) int64."""
    k = values[starts].astype(np.int64)
    return values[_fans(starts + 1, k)].astype(np.int64)


def _checked(V: np.ndarray, F: np.ndarray, path: Path) -> tuple[np.ndarray, np.ndarray]:
    """``(V, F)`` as float64 (n, 3) and int64 (m, 3), after checking that every index
    names a vertex."""
    V = np.ascontiguousarray(V, dtype=np.float64).reshape(-1, 3)
    F = np.ascontiguousarray(F, dtype=np.int64).reshape(-1, 3)
    if len(F) == 0:
        raise ValueError(f"{path.name}: no faces")
    bad = np.flatnonzero((F < 0) | (F >= len(V)))
    if len(bad):
        raise ValueError(f"{path.name}: {len(bad)} face indices out of range, the first {F.ravel()[bad[0]]}")
    return V, F


# ------------------------------------------------------------------------------ readers


def read_obj(path: Path) -> tuple[np.ndarray, np.ndarray]:
    """A Wavefront OBJ file (``v`` and ``f`` lines; texture and normal indices ignored),
    through :func:`isoparam_eval.meshes.load_obj` (its UV seams dropped)."""
    from .meshes import load_obj

    V, F, _ = load_obj(path)
    return _checked(V, F, path)


def _chain(jump: np.ndarray, count: int) -> np.ndarray:
    """The first ``count`` offsets of the chain ``0, jump[0], jump[jump[0]], ...``, for
    records whose sizes are known only as they are read (``jump`` maps an offset to
    the next record's, its last entry to itself). Pointer jumping: the chain doubles
    each pass, so log2(count) vectorised passes instead of a loop over the records."""
    out = np.zeros(1, dtype=np.int64)
    while len(out) < count:  # one pass per doubling
        out = np.concatenate([out, jump[out]])
        jump = jump[jump]
    return out[:count]


def read_off(path: Path) -> tuple[np.ndarray, np.ndarray]:
    """An Object File Format file: an optional ``OFF`` keyword (``COFF``, ``NOFF``... too),
    the counts ``n m e``, n vertex lines (x y z and any extra columns), then m faces
    ``k i_0 .. i_{k-1}``: a face a line (any colour after the corners ignored), or as
    one stream of numbers wrapped across lines. ``#`` starts a comment."""
    text = re.sub(r"#[^\n]*", "", path.read_text(encoding="ascii", errors="replace"))
    text = re.sub(r"^\s*[A-Z]*OFF\b", "", text)  # the keyword (its counts may follow on its line)
    values, counts = _numbers(text)
    rows = counts[counts > 0]  # the lines that hold numbers
    starts = np.cumsum(rows) - rows
    if len(rows) == 0:
        raise ValueError(f"{path.name}: empty OFF file")
    n, m = (int(x) for x in values[:2])
    if len(rows) < 1 + n + min(m, 1):
        raise ValueError(f"{path.name}: {n} vertices and {m} faces announced, {len(rows) - 1} lines found")
    V = values[starts[1 : 1 + n, None] + np.arange(3)]
    first = starts[1 + n : 1 + n + m]
    if len(first) < m or np.any(rows[1 + n : 1 + n + m] < 1 + values[first]):  # faces wrapped across lines
        tail = values[starts[1 + n] :]
        jump = np.minimum(np.arange(len(tail) + 1) + 1 + np.append(tail, 0).astype(np.int64), len(tail))
        first = starts[1 + n] + _chain(jump, m)
    return _checked(V, _polygons(values, first), path)


_PLY_TYPES = {
    "char": "i1",
    "int8": "i1",
    "uchar": "u1",
    "uint8": "u1",
    "short": "i2",
    "int16": "i2",
    "ushort": "u2",
    "uint16": "u2",
    "int": "i4",
    "int32": "i4",
    "uint": "u4",
    "uint32": "u4",
    "float": "f4",
    "float32": "f4",
    "double": "f8",
    "float64": "f8",
}


class _Property(NamedTuple):
    """A PLY property: its name and type, and for a list the type of its count."""

    name: str
    dtype: str
    count_dtype: str | None  # None: a scalar


class _Element(NamedTuple):
    """A PLY element: its name, its number of records, their properties in order."""

    name: str
    size: int
    properties: list[_Property]


def _ply_header(head: str, path: Path) -> tuple[str, list[_Element]]:
    """The format (``ascii``, ``binary_little_endian``, ``binary_big_endian``) and the
    elements declared by a PLY header (a few dozen lines)."""
    fmt = ""
    elements: list[_Element] = []
    for line in head.splitlines():  # the header's lines, not the mesh's
        word = line.split()
        if not word:
            continue
        if word[0] == "format":
            fmt = word[1]
        elif word[0] == "element":
            elements.append(_Element(word[1], int(word[2]), []))
        elif word[0] == "property" and elements:
            if word[1] == "list":
                prop = _Property(word[4], _PLY_TYPES[word[3]], _PLY_TYPES[word[2]])
            else:
                prop = _Property(word[2], _PLY_TYPES[word[1]], None)
            elements[-1].properties.append(prop)
    if fmt not in ("ascii", "binary_little_endian", "binary_big_endian"):
        raise ValueError(f"{path.name}: PLY format {fmt!r} not supported")
    return fmt, elements


class _Reader:
    """Reads PLY values at many record offsets at once: from the flat numbers of an ascii
    body (every value one slot) or from the bytes of a binary body."""

    def __init__(self, body: bytes | np.ndarray, order: Literal["<", ">"] | None):
        self.order = order  # '<' or '>' for binary, None for ascii
        if order is None:
            self.flat = np.asarray(body, dtype=np.float64)
        else:
            # padded, so that reads at the candidate offsets past the end stay in bounds
            self.flat = np.concatenate([np.frombuffer(body, dtype=np.uint8), np.zeros(16, np.uint8)])

    def size(self, dtype: str) -> int:
        return 1 if self.order is None else np.dtype(dtype).itemsize

    def read(self, at: np.ndarray, dtype: str) -> np.ndarray:
        """The values of type ``dtype`` at offsets ``at`` (any shape)."""
        if self.order is None:
            return self.flat[at]
        width = np.dtype(dtype).itemsize
        at = np.minimum(at, len(self.flat) - 16)
        raw = self.flat[at[..., None] + np.arange(width)]
        return raw.view(np.dtype(dtype).newbyteorder(self.order))[..., 0]

    def walk(self, element: _Element, at: np.ndarray) -> tuple[np.ndarray, dict[str, np.ndarray]]:
        """Where the records starting at offsets ``at`` end, and the offset of each
        property in them (of a list: of its count)."""
        at = np.asarray(at, dtype=np.int64)
        where = {}
        for p in element.properties:
            where[p.name] = at
            if p.count_dtype is None:
                at = at + self.size(p.dtype)
            else:
                k = self.read(at, p.count_dtype).astype(np.int64)
                at = at + self.size(p.count_dtype) + np.maximum(k, 0) * self.size(p.dtype)
        return at, where


def _record_starts(reader: _Reader, element: _Element, start: int) -> np.ndarray:
    """The offsets of the ``element.size`` records of a binary element from byte
    ``start``: evenly spaced when every record has the first one's size (all
    triangles, say), else the :func:`_chain` of "next record" offsets from every byte."""
    if element.size == 0:
        return np.zeros(0, dtype=np.int64)
    step = int(reader.walk(element, np.array([start]))[0][0]) - start
    even = start + step * np.arange(element.size, dtype=np.int64)
    if np.all(reader.walk(element, even)[0] == even + step):
        return even
    end = len(reader.flat) - 16
    jump, _ = reader.walk(element, np.arange(start, end + 1))
    return start + _chain(np.minimum(jump, end) - start, element.size)


def read_ply(path: Path) -> tuple[np.ndarray, np.ndarray]:
    """A PLY file (ascii or binary): the ``vertex`` element's x, y, z and the ``face``
    element's ``vertex_indices`` (or ``vertex_index``) lists, of any sizes; other
    elements and properties are read past."""
    data = path.read_bytes()
    cut = data.find(b"end_header")
    if not data.startswith(b"ply") or cut < 0:
        raise ValueError(f"{path.name}: not a PLY file")
    body_at = data.index(b"\n", cut) + 1
    fmt, elements = _ply_header(data[:cut].decode("ascii", errors="replace"), path)
    V = F = None
    if fmt == "ascii":
        values, counts = _numbers(data[body_at:].decode("ascii", errors="replace"))
        rows = counts[counts > 0]
        line_starts = np.cumsum(rows) - rows
        reader = _Reader(values, None)
        line = 0
    else:
        reader = _Reader(data[body_at:], "<" if fmt == "binary_little_endian" else ">")
        at = 0
    for e in elements:  # a few elements: vertex, face, maybe edge or material
        if fmt == "ascii":
            starts = line_starts[line : line + e.size]  # one record a line
            line += e.size
        else:
            starts = _record_starts(reader, e, at)
            at = int(reader.walk(e, starts[-1:])[0][0]) if e.size else at
        _, where = reader.walk(e, starts)
        if e.name == "vertex":
            V = np.stack([reader.read(where[c], _scalar_type(e, c, path)) for c in "xyz"], axis=1)
        elif e.name == "face":
            p = next((p for p in e.properties if p.name in ("vertex_indices", "vertex_index")), None)
            if p is None or p.count_dtype is None:
                raise ValueError(f"{path.name}: the face element has no vertex_indices list")
            k = reader.read(where[p.name], p.count_dtype).astype(np.int64)
            first = where[p.name] + reader.size(p.count_dtype)
            corners = _fans(np.zeros(len(k), dtype=np.int64), k)  # corner j of the polygon: j
            poly = np.repeat(np.arange(len(k)), np.maximum(k, 2) - 2)
            F = reader.read(first[poly, None] + corners * reader.size(p.dtype), p.dtype).astype(np.int64)
    if V is None or F is None:
        raise ValueError(f"{path.name}: no vertex or no face element")
    return _checked(V, F, path)


def _scalar_type(e: _Element, name: str, path: Path) -> str:
    """The type of scalar property ``name`` of element ``e``."""
    for p in e.properties:
        if p.name == name and p.count_dtype is None:
            return p.dtype
    raise ValueError(f"{path.name}: element {e.name} has no property {name}")


def read_stl(path: Path) -> tuple[np.ndarray, np.ndarray]:
    """An STL file, binary (its size is 84 + 50 x its triangle count) or ascii (every
    ``vertex x y z``), its corners welded where they are exactly equal (-0 = +0)."""
    data = path.read_bytes()
    n = int(np.frombuffer(data[80:84], dtype="<u4")[0]) if len(data) >= 84 else -1
    if len(data) == 84 + 50 * n:
        record = np.dtype([("normal", "<f4", 3), ("corners", "<f4", (3, 3)), ("attribute", "<u2")])
        P = np.frombuffer(data, dtype=record, count=n, offset=84)["corners"].reshape(-1, 3).astype(np.float64)
    else:
        found = re.findall(rb"vertex\s+(\S+)\s+(\S+)\s+(\S+)", data)
        P = np.array(found, dtype=np.float64).reshape(-1, 3)
    V, F = np.unique(P + 0.0, axis=0, return_inverse=True)  # + 0.0 turns -0 into +0
    return _checked(V, F.reshape(-1, 3), path)


_READERS = {".obj": read_obj, ".off": read_off, ".ply": read_ply, ".stl": read_stl}


def load_mesh(path: str | Path) -> tuple[np.ndarray, np.ndarray]:
    """The mesh in ``path`` (OBJ, OFF, PLY or STL, by its suffix, any case) as
    ``(V (n, 3) float64, F (m, 3) int64)``, polygons fan-triangulated."""
    path = Path(path)
    reader = _READERS.get(path.suffix.lower())
    if reader is None:
        raise ValueError(f"{path.name}: not one of {', '.join(MESH_SUFFIXES)}")
    return reader(path)


# ----------------------------------------------------------------------------- topology


@dataclass(frozen=True)
class Topology:
    """Facts of a triangle mesh that say what it asks of an unwrap.

    ``vertices`` counts the vertices faces use; ``euler`` is V - E + F over them (2 for
    a sphere, 2 - 2g for a closed surface of genus g, one less per hole);
    ``boundary_loops`` counts the independent cycles of the edges with one face (two
    holes that touch at a vertex count twice); ``non_manifold_edges`` have three faces
    or more; ``components`` are the parts connected through shared vertices;
    ``inconsistent_edges`` are interior edges whose two faces run them the same way
    (winding flips).
    """

    vertices: int
    faces: int
    euler: int
    boundary_loops: int
    non_manifold_edges: int
    components: int
    inconsistent_edges: int


def topology(F: np.ndarray) -> Topology:
    """The :class:`Topology` of triangles ``F (m, 3)``."""
    import scipy.sparse as sp
    from scipy.sparse import csgraph

    from isoparam_addon.solver.mesh.halfedges import HalfEdges

    F = np.asarray(F, dtype=np.int64)
    used, Fc = np.unique(F, return_inverse=True)
    Fc = Fc.reshape(-1, 3)
    n = len(used)
    he = HalfEdges(Fc, n)

    def parts(a: np.ndarray, b: np.ndarray) -> np.ndarray:
        """Component labels of the vertices joined by edges (a, b)."""
        graph = sp.coo_matrix((np.ones(len(a)), (a, b)), shape=(n, n))
        return csgraph.connected_components(graph, directed=False)[1]

    boundary = he.edge_vertices[he.edge_count == 1]
    on_boundary = np.unique(boundary)
    # independent cycles of the boundary's graph: one per loop, and one more per pinch
    # where two loops touch at a vertex
    loops = len(boundary) - len(on_boundary) + len(np.unique(parts(*boundary.T)[on_boundary])) if len(boundary) else 0
    ab = Fc.ravel(), np.roll(Fc, -1, axis=1).ravel()
    h = np.flatnonzero(he.twin >= 0)
    same_way = ab[0][h] == ab[0][he.twin[h]]  # twins that start at the same vertex
    return Topology(
        vertices=n,
        faces=len(Fc),
        euler=n - he.n_edges + len(Fc),
        boundary_loops=loops,
        non_manifold_edges=len(he.overfull),
        components=len(np.unique(parts(*ab))),
        inconsistent_edges=int(same_way.sum()) // 2,
    )


# ----------------------------------------------------------------------------- manifest


@dataclass(frozen=True)
class Source:
    """Where one corpus mesh comes from: a file at a commit of a public GitHub
    repository, under ``licence``; ``kind`` says what it exercises."""

    name: str
    repo: str
    commit: str
    path: str
    licence: str
    kind: str

    @property
    def filename(self) -> str:
        """Its file name in a cache folder: the name and the source's suffix, lower case."""
        return self.name + Path(self.path).suffix.lower()

    @property
    def url(self) -> str:
        return f"https://raw.githubusercontent.com/{self.repo}/{self.commit}/{self.path}"


_LIBIGL = ("libigl/libigl-tutorial-data", "c1f9ede366d02e3531ecbaec5e3769312f31cccd")
_TRIMESH = ("mikedh/trimesh", "a513c0e2cfa6dfbd3121a6dfd8ceb002b9ef55d8")
_COMMON = ("alecjacobson/common-3d-test-models", "8a4f8642acaf43f9cd7b67858a1502e1055ef202")
_GPY = ("sgsellan/gpytoolbox", "8dbc5f98efe108f7d8c8923fa9a3bb308cb2d4e9")
_ASSIMP = ("assimp/assimp", "21bea12f1278090c09a94c39ca090d9fb458ccd9")
_CHESS = ("scenevr/chess", "c58e6a2d74a4f07db523e811b15a05f873ec8d96")
_NO_LICENCE = "unclear (no licence in the repository; origin: {})"
_TRIMESH_MIT = "MIT (trimesh's licence; the model's origin is not stated)"

#: The corpus: meshes of public repositories that are neither the shared meshes
#: (``../shared/meshes``: spot, bunny, fandisk, rocker arm, homer, beetle, teapot,
#: nefertiti) nor the held-back evaluation set. ``kind`` says what each exercises.
MANIFEST: tuple[Source, ...] = (
    Source(
        "camelhead",
        *_LIBIGL,
        "camelhead.off",
        _NO_LICENCE.format("Sorkine & Cohen-Or 2004"),
        "open scan, one boundary loop, 11k vertices; OFF",
    ),
    Source(
        "lion",
        *_LIBIGL,
        "lion.off",
        _NO_LICENCE.format("unknown"),
        "open scan, one boundary loop, 8k vertices; OFF",
    ),
    Source("face", *_LIBIGL, "face.obj", _NO_LICENCE.format("unknown"), "open face scan, 26k vertices"),
    Source("bumpy", *_LIBIGL, "bumpy.off", _NO_LICENCE.format("unknown"), "closed genus 0, bumps all over"),
    Source("fertility", *_LIBIGL, "fertility.off", _NO_LICENCE.format("AIM@SHAPE"), "closed scan, genus 4"),
    Source(
        "decimated-knight",
        *_LIBIGL,
        "decimated-knight.off",
        _NO_LICENCE.format("Cosmic Blobs (Baran)"),
        "closed low-poly figure, 502 vertices",
    ),
    Source("3holes", *_LIBIGL, "3holes.off", _NO_LICENCE.format("unknown"), "closed, genus 3"),
    Source("halftunnel", *_LIBIGL, "halftunnel.off", _NO_LICENCE.format("unknown"), "open, three boundary loops"),
    Source(
        "horse-quad", *_LIBIGL, "horse_quad.obj", _NO_LICENCE.format("unknown"), "closed quad mesh (every face a quad)"
    ),
    Source(
        "inspired-quads",
        *_LIBIGL,
        "inspired_mesh_quads_Smooth.off",
        _NO_LICENCE.format("unknown"),
        "open quad-dominant remesh; OFF faces wrapped across lines",
    ),
    Source(
        "intersection-quads",
        *_LIBIGL,
        "intersection_quads.off",
        _NO_LICENCE.format("unknown"),
        "quad mesh, four boundary loops",
    ),
    Source(
        "truck",
        *_LIBIGL,
        "truck.obj",
        _NO_LICENCE.format("SHREC 2009"),
        "50 parts, non-manifold edges, inconsistent winding, 192 boundary loops",
    ),
    Source(
        "cheburashka",
        *_LIBIGL,
        "cheburashka.off",
        _NO_LICENCE.format("Cosmic Blobs (Baran)"),
        "closed organic figure, thin ears",
    ),
    Source("snail", *_LIBIGL, "snail.obj", _NO_LICENCE.format("unknown"), "open shell, one boundary loop"),
    Source(
        "max-planck-decimated",
        *_LIBIGL,
        "decimated-max.obj",
        _NO_LICENCE.format("MPI Saarbruecken"),
        "closed decimated bust",
    ),
    Source(
        "bumpy-cube",
        *_LIBIGL,
        "bumpy-cube.obj",
        _NO_LICENCE.format("unknown"),
        "closed bumpy cube, 20k vertices",
    ),
    Source("lilium", *_LIBIGL, "lilium.obj", _NO_LICENCE.format("unknown"), "open, one boundary loop"),
    Source(
        "featuretype", *_TRIMESH, "models/featuretype.STL", _TRIMESH_MIT, "CAD part, sharp edges, 16 holes; binary STL"
    ),
    Source(
        "tray-bottom", *_TRIMESH, "models/1002_tray_bottom.STL", _TRIMESH_MIT, "closed CAD part of genus 23; ascii STL"
    ),
    Source(
        "adis16480", *_TRIMESH, "models/ADIS16480.STL", _TRIMESH_MIT, "closed CAD sensor housing of genus 24; ascii STL"
    ),
    Source(
        "angle-block",
        *_TRIMESH,
        "models/angle_block.STL",
        _TRIMESH_MIT,
        "CAD block whose STL has cracks (37 boundary loops, pinched); binary STL headed 'solid'",
    ),
    Source(
        "cycloidal",
        *_TRIMESH,
        "models/cycloidal.ply",
        _TRIMESH_MIT,
        "gear assembly: 100 parts, non-manifold edges, 21k vertices; binary PLY with colours",
    ),
    Source(
        "fixed-top",
        *_TRIMESH,
        "models/fixed_top.ply",
        _TRIMESH_MIT,
        "closed CAD part of genus 7; binary PLY, face colours after the list",
    ),
    Source("quadknot", *_TRIMESH, "models/quadknot.obj", _TRIMESH_MIT, "knotted tube (genus 1), quads"),
    Source(
        "rabbit",
        *_TRIMESH,
        "models/rabbit.obj",
        _TRIMESH_MIT,
        "low-poly model: 9 closed parts, tris, quads and 16-gons",
    ),
    Source("plate-holes", *_TRIMESH, "models/plate_holes.STL", _TRIMESH_MIT, "closed CAD plate of genus 5; binary STL"),
    Source(
        "torus-stl", *_TRIMESH, "models/torus.STL", _TRIMESH_MIT, "closed torus (genus 1); binary STL headed 'solid'"
    ),
    Source(
        "idler-riser",
        *_TRIMESH,
        "models/idler_riser.STL",
        _TRIMESH_MIT,
        "CAD part: two parts, four boundary loops; binary STL",
    ),
    Source(
        "multibody",
        *_TRIMESH,
        "models/multibody.stl",
        _TRIMESH_MIT,
        "two solids in one ascii STL, inconsistent winding, 20 vertices",
    ),
    Source(
        "chair",
        *_TRIMESH,
        "models/chair_model.obj",
        _TRIMESH_MIT,
        "double-sided game model: every triangle twice, opposite ways",
    ),
    Source(
        "fuze",
        *_TRIMESH,
        "models/fuze_ascii.ply",
        _TRIMESH_MIT,
        "closed bottle, 502 vertices; ascii PLY with texcoord lists",
    ),
    Source(
        "alligator",
        *_COMMON,
        "data/alligator.obj",
        _NO_LICENCE.format("Alec Jacobson"),
        "planar (z = 0) 2D outline mesh, one boundary loop: already flat",
    ),
    Source(
        "ogre",
        *_COMMON,
        "data/ogre.obj",
        _NO_LICENCE.format("unknown"),
        "a creature of 44 parts (62k vertices, 15 boundary loops): the largest multi-part mesh here",
    ),
    Source(
        "woody",
        *_COMMON,
        "data/woody.obj",
        _NO_LICENCE.format("Scott Schaefer"),
        "planar (z = 0) 2D figure, one boundary loop, 694 vertices: already flat",
    ),
    Source(
        "airplane",
        *_GPY,
        "test/unit_tests_data/airplane.obj",
        "CC BY 3.0 (YahooJAPAN via Thingiverse)",
        "open model with 27 holes",
    ),
    Source(
        "teddy",
        *_GPY,
        "test/unit_tests_data/teddy.obj",
        "CC BY-SA 3.0 (techkey via Thingiverse)",
        "closed toy, genus 0",
    ),
    Source(
        "mountain",
        *_GPY,
        "test/unit_tests_data/mountain.obj",
        "CC BY 4.0 (lastloginname via Thingiverse)",
        "open height field, 26k vertices",
    ),
    Source(
        "fox",
        *_GPY,
        "test/unit_tests_data/fox_ascii.stl",
        "unclear (gpytoolbox is MIT; its credits omit it)",
        "closed low-poly fox, 313 vertices; ascii STL",
    ),
    Source(
        "spider",
        *_ASSIMP,
        "test/models/OBJ/spider.obj",
        "BSD-3-Clause (assimp's test/models)",
        "low-poly game model: 19 parts, holes, inconsistent winding",
    ),
    Source(
        "max-export",
        *_ASSIMP,
        "test/models/STL/3DSMaxExport.STL",
        "BSD-3-Clause (assimp's test/models)",
        "24 parts, non-manifold edges; binary STL from 3ds Max",
    ),
    Source(
        "wuson",
        *_ASSIMP,
        "test/models/OBJ/WusonOBJ.obj",
        "BSD-3-Clause (assimp's test/models)",
        "game character of 51 parts, 56 boundary loops",
    ),
    Source(
        "sphere-with-hole",
        *_ASSIMP,
        "test/models/STL/sphereWithHole.stl",
        "BSD-3-Clause (assimp's test/models)",
        "tiny sphere, its hole pinched into three loops, 146 vertices; ascii STL with tabs",
    ),
    Source(
        "chess-knight",
        *_CHESS,
        "models/knight.obj",
        "MIT (the repository's readme)",
        "low-poly chess knight of quads, base split off, 210 vertices",
    ),
)


# -------------------------------------------------------------------------------- cache


def _mirror_git_dir(mirror: Path, repo: str) -> Path | None:
    """The git directory of ``repo`` in a mirror folder (``owner+name/repo``, bare or
    with a work tree's ``.git``), if there is one."""
    root = mirror / repo.replace("/", "+") / "repo"
    for d in (root / ".git", root):
        if (d / "HEAD").is_file():
            return d
    return None


def fill_cache(cache_dir: str | Path, mirror: str | Path = "/work/.mirror") -> list[Path]:
    """Copy every :data:`MANIFEST` entry into ``cache_dir`` (made if missing) as
    ``Source.filename``: from the repository's git directory under ``mirror`` when it
    has the commit, else from raw.githubusercontent.com. Files already there are kept;
    a file that cannot be had is skipped with a message (after one failed download, no
    other is tried: offline). Returns the files present."""
    cache_dir, mirror = Path(cache_dir), Path(mirror)
    cache_dir.mkdir(parents=True, exist_ok=True)
    present, offline = [], None
    for s in MANIFEST:  # a few dozen files
        dest = cache_dir / s.filename
        if not dest.exists():
            data = None
            git_dir = _mirror_git_dir(mirror, s.repo)
            if git_dir is not None:
                command = ["git", f"--git-dir={git_dir}", "show", f"{s.commit}:{s.path}"]
                shown = subprocess.run(command, capture_output=True, check=False)
                data = shown.stdout if shown.returncode == 0 else None
            if data is None and offline is None:
                try:
                    with urllib.request.urlopen(s.url, timeout=30) as response:
                        data = response.read()
                except (urllib.error.URLError, OSError) as e:
                    offline = e  # one failed download is enough: the next ones are not tried
            if data is None:
                print(f"skipped {s.name}: not in {mirror}, and {s.url} unreachable ({offline})", file=sys.stderr)
                continue
            tmp = dest.with_suffix(dest.suffix + ".part")
            tmp.write_bytes(data)
            tmp.replace(dest)
        present.append(dest)
    return present
