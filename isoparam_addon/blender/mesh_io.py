"""Mesh data in and out of Blender as numpy arrays, never a Python loop over elements.

Everything goes through ``foreach_get``/``foreach_set`` on generic attributes with their
exact dtypes (float32, int32, bool): ~100x faster than the legacy per-element
collections, and a float64 buffer would cost 4-200x more (see BLENDER_NOTES). Attribute
names that moved between Blender 4.2 and 5.0 are looked up with fallbacks.
"""

from __future__ import annotations

import numpy as np

from ..operation.selection import Selection, inner_sides
from ..solver.mesh.halfedges import pair_keys

__all__ = [
    "Selection",
    "read_selection",
    "triangles",
    "write_uvs",
    "uv_layer_name",
    "polygon_of_corner",
    "write_face_colours",
    "pins",
    "set_pins",
    "uv_selection",
    "set_uv_selection",
]


def _attribute(mesh, names, width: int, dtype, length: int):
    """The first existing attribute of ``names`` as an array (length, width), or None."""
    for name in names:
        attr = mesh.attributes.get(name)
        if attr is None:
            continue
        kind = {
            "BOOLEAN": "value",
            "INT": "value",
            "FLOAT": "value",
            "INT32_2D": "value",
            "FLOAT2": "vector",
            "FLOAT_VECTOR": "vector",
        }.get(attr.data_type, "value")
        out = np.empty(length * width, dtype=dtype)
        attr.data.foreach_get(kind, out)
        return out.reshape(length, width) if width > 1 else out
    return None


def uv_layer_name(mesh) -> str:
    """The active UV map, created (as "UVMap") if the mesh has none."""
    if mesh.uv_layers.active is None:
        layer = mesh.uv_layers.new(name="UVMap") if len(mesh.uv_layers) == 0 else mesh.uv_layers[0]
        mesh.uv_layers.active = layer
    return mesh.uv_layers.active.name


def read_selection(obj, *, world_space: bool, uv_selection_locks: bool, every_face: bool = False) -> Selection:
    """Read the selected, visible faces of ``obj`` as a solver input (object mode).

    Nothing is written. With ``uv_selection_locks`` (the UV editor with sync select off),
    corners whose UV is not selected are locked, as Blender's own unwrap does. With
    ``every_face``, selection and visibility are ignored.
    """
    me = obj.data
    nv, ne, nl, nf = len(me.vertices), len(me.edges), len(me.loops), len(me.polygons)
    uv_name = me.uv_layers.active.name if me.uv_layers.active is not None else ""
    pos = _positions(obj, world_space)
    corner_vert = _attribute(me, [".corner_vert"], 1, np.int32, nl)
    edge_verts = _attribute(me, [".edge_verts"], 2, np.int32, ne)
    chosen = np.ones(nf, dtype=bool) if every_face else _selected_faces(me)
    seam = _attribute(me, ["uv_seam", ".uv_seam"], 1, bool, ne)
    if seam is None:  # the attribute is created with the first seam: none yet
        seam = np.zeros(ne, dtype=bool)
    material = _attribute(me, ["material_index"], 1, np.int32, nf)
    uv, locked, pins = _corner_uvs(me, uv_name, uv_selection_locks)
    tri_loops, tri_poly, inner = _chosen_triangles(me, chosen)
    tri_verts = corner_vert[tri_loops]
    used = np.zeros(nv, dtype=bool)
    used[tri_verts.ravel()] = True
    vert_ids = np.flatnonzero(used)
    local = np.cumsum(used) - 1
    seam_edges = edge_verts[_on_faces(me, seam, tri_loops)]
    return Selection(
        name=obj.name,
        V=pos[vert_ids],
        F=local[tri_verts],
        tri_loops=tri_loops,
        tri_poly=tri_poly,
        vert_ids=vert_ids,
        seams=local[seam_edges].astype(np.int64),
        diagonals=local[np.stack([tri_verts[inner], tri_verts[:, [1, 2, 0]][inner]], axis=1)].astype(np.int64),
        uv=uv,
        locked=locked,
        pinned=np.zeros(nl, dtype=bool) if pins is None else pins,
        face_material=(np.zeros(len(tri_poly), np.int64) if material is None else material[tri_poly].astype(np.int64)),
        uv_name=uv_name,
    )


def _positions(obj, world_space: bool) -> np.ndarray:
    """The vertex positions (n, 3) float64 the unwrap flattens: of the active shape key if
    there is one (edit mode shows, and Blender's unwrap flattens, that one), in object
    space, or with ``world_space`` under the object's linear transform."""
    me = obj.data
    nv = len(me.vertices)
    key = obj.active_shape_key
    if key is not None:
        pos = np.empty(3 * nv, dtype=np.float32)
        key.data.foreach_get("co", pos)
        pos = pos.reshape(nv, 3).astype(np.float64)
    else:
        pos = _attribute(me, ["position"], 3, np.float32, nv).astype(np.float64)
    if world_space:
        # the linear part only: an unwrap does not depend on where the object is, and
        # adding its location costs the digits of a small object far from the origin
        # (fuzzing: scale 1e-20 at (-2.5, 3.7, 0.1) collapsed every vertex onto one point)
        M = np.array(obj.matrix_world, dtype=np.float64)
        pos = pos @ M[:3, :3].T
    return pos


def _selected_faces(me) -> np.ndarray:
    """The faces (f,) bool that are selected and not hidden."""
    nf = len(me.polygons)
    select = _attribute(me, [".select_poly"], 1, bool, nf)
    hide = _attribute(me, [".hide_poly"], 1, bool, nf)
    return (np.zeros(nf, bool) if select is None else select) & (True if hide is None else ~hide)


def _corner_uvs(me, uv_name: str, uv_selection_locks: bool):
    """The UVs (corners, 2) float32 of the UV map ``uv_name`` (zero without one), the
    corners (corners,) bool whose UV must not move (pinned, or with ``uv_selection_locks``
    not UV-selected), and the pins (corners,) bool, None if the map has no pin attribute."""
    nl = len(me.loops)
    uv = np.zeros((nl, 2), dtype=np.float32)
    locked = np.zeros(nl, dtype=bool)
    if not uv_name:
        return uv, locked, None
    flat = np.empty(2 * nl, dtype=np.float32)
    me.uv_layers[uv_name].uv.foreach_get("vector", flat)
    uv = flat.reshape(nl, 2)
    pins = _attribute(me, [f".pn.{uv_name}"], 1, bool, nl)
    if pins is not None:
        locked |= pins
    if uv_selection_locks:
        picked = _attribute(me, [".uv_select_vert", f".vs.{uv_name}"], 1, bool, nl)
        if picked is not None:
            locked |= ~picked
    return uv, locked, pins


def _chosen_triangles(me, chosen: np.ndarray):
    """Blender's triangles of the ``chosen`` (f,) bool faces: their corners (t, 3) int64,
    their faces (t,) int64, and which of their sides (t, 3) bool are diagonals, inside
    their face (side k runs from corner k to corner k + 1)."""
    tri_loops, tri_poly, loop_total = triangles(me)
    keep = chosen[tri_poly]
    tri_loops, tri_poly = tri_loops[keep], tri_poly[keep]
    # a triangle side is a diagonal when its corners are not neighbours around the face
    if (loop_total == 3).all():  # triangles only: no diagonals
        inner = np.zeros(tri_loops.shape, dtype=bool)
    else:
        inner = inner_sides(tri_loops, tri_poly, loop_total)
    return tri_loops, tri_poly, inner


def _on_faces(me, seam: np.ndarray, tri_loops: np.ndarray) -> np.ndarray:
    """The ``seam`` (e,) bool edges that are sides of the triangles ``tri_loops`` (t, 3),
    as Blender's unwrap takes them: a loose seam edge, or one of another face, along a
    quad's diagonal would cut the quad in two."""
    if not seam.any():
        return seam
    on_face = np.zeros(len(seam), dtype=bool)
    on_face[_attribute(me, [".corner_edge"], 1, np.int32, len(me.loops))[tri_loops.ravel()]] = True
    return seam & on_face


def mark_seams(mesh, edges: np.ndarray) -> int:
    """Mark the edges of ``mesh`` between the vertex pairs ``edges`` (k, 2 mesh vertex ids)
    as seams (object mode); pairs that are no edge are skipped. Returns how many edges
    were not seams before."""
    ne = len(mesh.edges)
    if not len(edges) or not ne:
        return 0
    edge_verts = np.empty(2 * ne, dtype=np.int32)
    mesh.edges.foreach_get("vertices", edge_verts)
    ends = np.sort(edge_verts.reshape(ne, 2).astype(np.int64), axis=1)
    n = int(max(ends.max(), np.max(edges))) + 1
    key = pair_keys(ends[:, 0], ends[:, 1], n, ordered=True)
    order = np.argsort(key)
    pairs = np.asarray(edges, dtype=np.int64)
    want = pair_keys(pairs[:, 0], pairs[:, 1], n)
    at = np.minimum(np.searchsorted(key[order], want), ne - 1)
    hit = order[at[key[order][at] == want]]
    seam = np.zeros(ne, dtype=bool)
    mesh.edges.foreach_get("use_seam", seam)
    new = int((~seam[hit]).sum())
    seam[hit] = True
    mesh.edges.foreach_set("use_seam", seam)
    return new


def triangles(me) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Blender's triangulation of the mesh (object mode): the corners of every triangle
    (t, 3) int64, the face of every triangle (t,) int64, and the corner count of every
    face (f,) int64.

    ``loop_triangles.foreach_get`` goes through RNA item by item (at 100k faces: corners
    42 ms, faces 25 ms, ``polygons`` loop totals 20 ms, against 0.06 ms for the
    ``loop_triangle_polygons`` array). A face of k corners has k - 2 triangles, which
    gives the counts; an all-triangle mesh needs nothing else, since each face is its
    own triangle with its corners in order. Quads and n-gons read Blender's corners (as
    does a mesh with a face of two corners, which only an unvalidated import makes).
    """
    me.calc_loop_triangles()
    nt, nf = len(me.loop_triangles), len(me.polygons)
    tri_poly = np.empty(nt, dtype=np.int32)
    me.loop_triangle_polygons.foreach_get("value", tri_poly)
    tri_poly = tri_poly.astype(np.int64)
    count = np.bincount(tri_poly, minlength=nf)
    loop_total = count + 2  # (a face of fewer than 3 corners has no triangle and is never read)
    if nt == nf and (count == 1).all():  # every face a triangle: corners 3f, 3f + 1, 3f + 2
        return 3 * tri_poly[:, None] + np.arange(3), tri_poly, loop_total
    tri_loops = np.empty(3 * nt, dtype=np.int32)
    me.loop_triangles.foreach_get("loops", tri_loops)
    return tri_loops.reshape(nt, 3).astype(np.int64), tri_poly, loop_total


def write_uvs(mesh, uv_name: str, uv: np.ndarray) -> None:
    """Write every corner's UV (corners, 2) into the named UV map (object mode only)."""
    mesh.uv_layers[uv_name].uv.foreach_set("vector", np.ascontiguousarray(uv, dtype=np.float32).ravel())
    mesh.update()


def read_uvs(mesh, uv_name: str, loops: np.ndarray) -> np.ndarray:
    """The UVs (..., 2) float64 of the corners ``loops`` (any shape) in the named UV map
    (object mode only)."""
    uv = np.empty(2 * len(mesh.loops), dtype=np.float32)
    mesh.uv_layers[uv_name].uv.foreach_get("vector", uv)
    return uv.reshape(-1, 2)[loops].astype(np.float64)


def pins(mesh, uv_name: str) -> np.ndarray | None:
    """The pins of a UV map (corners,) bool (object mode); None if it has no pin attribute."""
    return _attribute(mesh, [f".pn.{uv_name}"], 1, bool, len(mesh.loops))


def set_pins(mesh, uv_name: str, pins: np.ndarray | None) -> None:
    """Set the pins of a UV map (object mode) to ``pins`` (corners,) bool, or remove its
    pin attribute (None), as :func:`pins` read them."""
    name = f".pn.{uv_name}"
    if pins is None:
        if mesh.attributes.get(name) is not None:
            mesh.attributes.remove(mesh.attributes[name])
    else:
        layer = mesh.uv_layers[uv_name]
        if hasattr(layer, "pin_ensure"):  # 5.0 creates pins lazily
            layer.pin_ensure()
        layer.pin.foreach_set("value", np.ascontiguousarray(pins, dtype=bool))
    mesh.update()


def _uv_selection_names(uv_name: str) -> list[str]:
    return [".uv_select_vert", ".uv_select_edge", ".uv_select_face", f".vs.{uv_name}", f".es.{uv_name}"]  # 5.0; 4.x


def uv_selection(mesh, uv_name: str) -> dict:
    """The UV selection (object mode): each attribute that holds it (5.0 or 4.x names) as a
    bool array, or None where it does not exist."""
    sizes = {"CORNER": len(mesh.loops), "FACE": len(mesh.polygons)}
    out = {}
    for name in _uv_selection_names(uv_name):
        attr = mesh.attributes.get(name)
        out[name] = None if attr is None else _attribute(mesh, [name], 1, bool, sizes[attr.domain])
    return out


def set_uv_selection(mesh, state: dict) -> None:
    """Put back a UV selection read by :func:`uv_selection` (object mode)."""
    for name, values in state.items():
        attr = mesh.attributes.get(name)
        if values is None:
            if attr is not None:
                mesh.attributes.remove(attr)
        elif attr is not None:
            attr.data.foreach_set("value", values)
    mesh.update()


def polygon_of_corner(mesh) -> np.ndarray:
    """(corners,) int64: the face of every corner."""
    nf = len(mesh.polygons)
    total = np.empty(nf, dtype=np.int32)
    mesh.polygons.foreach_get("loop_total", total)
    return np.repeat(np.arange(nf), total)


def write_face_colours(mesh, name: str, face_rgba: np.ndarray, faces: np.ndarray) -> None:
    """Colour the corners of ``faces`` (object mode) in a float corner colour attribute,
    created white if missing, and show it in the viewport (active colour)."""
    attrs = mesh.color_attributes
    attr = attrs.get(name)
    if attr is None or attr.domain != "CORNER" or attr.data_type != "FLOAT_COLOR":
        if attr is not None:
            attrs.remove(attr)
        attr = attrs.new(name, "FLOAT_COLOR", "CORNER")
        attr.data.foreach_set("color", np.ones(4 * len(mesh.loops), dtype=np.float32))
    rgba = np.empty(4 * len(mesh.loops), dtype=np.float32)
    attr.data.foreach_get("color", rgba)
    rgba = rgba.reshape(-1, 4)
    poly = polygon_of_corner(mesh)
    row = np.full(len(mesh.polygons), -1, dtype=np.int64)
    row[faces] = np.arange(len(faces))
    hit = row[poly] >= 0
    rgba[hit] = face_rgba[row[poly[hit]]]
    attr.data.foreach_set("color", rgba.ravel())
    attrs.active_color = attr
    mesh.update()
