"""bpy helpers shared by the tests, the demo and the benchmarks: meshes in and out of
Blender, edit mode, the methods under comparison, checker-textured Cycles renders.

Importing this module imports bpy (Blender as a Python module), with Blender's user
resources in a temporary folder.
"""

from __future__ import annotations

import numpy as np

from . import blender_user_folder

blender_user_folder()
import bpy  # noqa: E402 - after the user folder is set

METHODS = {
    "isoparam": lambda: bpy.ops.uv.isometric_unwrap(),
    "isoparam, no charts": lambda: bpy.ops.uv.isometric_unwrap(charts=False),
    "isoparam, Refinement 0": lambda: bpy.ops.uv.isometric_unwrap(refine=0),
    "isoparam, Extra Cuts 0": lambda: bpy.ops.uv.isometric_unwrap(extra_cuts=0),
    "isoparam, Refinement 0, Extra Cuts 0": lambda: bpy.ops.uv.isometric_unwrap(refine=0, extra_cuts=0),
    "ANGLE_BASED": lambda: bpy.ops.uv.unwrap(method="ANGLE_BASED", margin=0.001),
    "CONFORMAL": lambda: bpy.ops.uv.unwrap(method="CONFORMAL", margin=0.001),
    # Blender's one-click charts (angle limit 66 degrees, its default)
    "SMART_UV": lambda: bpy.ops.uv.smart_project(angle_limit=1.15192, island_margin=0.001),
    "MINIMUM_STRETCH": lambda: bpy.ops.uv.unwrap(method="MINIMUM_STRETCH", iterations=10, margin=0.001),
}


def available(method: str) -> bool:
    """Whether this Blender has ``method`` (MINIMUM_STRETCH came with 4.3)."""
    if method != "MINIMUM_STRETCH":
        return method in METHODS
    prop = bpy.ops.uv.unwrap.get_rna_type().properties["method"]
    return "MINIMUM_STRETCH" in [item.identifier for item in prop.enum_items]


def add_mesh(name, V, F, seams=None, location=(0, 0, 0)):
    """A mesh object linked to the scene, from vertices (n, 3) and faces: an (m, k) array
    (bulk, fast) or a list of polygons of any sizes; ``seams`` (s, 2) vertex pairs."""
    me = bpy.data.meshes.new(name)
    if isinstance(F, np.ndarray):
        me.vertices.add(len(V))
        me.vertices.foreach_set("co", np.asarray(V, dtype=np.float32).ravel())
        k = F.shape[1]
        me.loops.add(k * len(F))
        me.loops.foreach_set("vertex_index", np.asarray(F, dtype=np.int32).ravel())
        me.polygons.add(len(F))
        me.polygons.foreach_set("loop_start", np.arange(0, k * len(F), k, dtype=np.int32))
        me.update(calc_edges=True)
    else:
        me.from_pydata(np.asarray(V, dtype=float).tolist(), [], F)
        me.update()
    if seams is not None and len(seams):
        ev = np.empty(2 * len(me.edges), np.int32)
        me.edges.foreach_get("vertices", ev)
        ev = np.sort(ev.reshape(-1, 2), axis=1)
        n = len(V)
        key = ev[:, 0].astype(np.int64) * n + ev[:, 1]
        s = np.sort(np.asarray(seams), axis=1)
        me.edges.foreach_set("use_seam", np.isin(key, s[:, 0].astype(np.int64) * n + s[:, 1]))
    ob = bpy.data.objects.new(name, me)
    ob.location = location
    bpy.context.scene.collection.objects.link(ob)
    return ob


def read_uvs(ob):
    """(triangles as vertex indices (t, 3), their corner UVs (t, 3, 2)) of the active UV map."""
    me = ob.data
    me.calc_loop_triangles()
    tri = np.empty(3 * len(me.loop_triangles), np.int32)
    me.loop_triangles.foreach_get("loops", tri)
    tri = tri.reshape(-1, 3)
    uv = np.empty(2 * len(me.loops), np.float32)
    me.uv_layers.active.uv.foreach_get("vector", uv)
    cv = np.empty(len(me.loops), np.int32)
    me.attributes[".corner_vert"].data.foreach_get("value", cv)
    return cv[tri], uv.reshape(-1, 2)[tri].astype(np.float64)


def smart_uv_seams(V, F, angle_limit: float = 1.15) -> np.ndarray:
    """The seams (k, 2 vertex pairs) of Smart UV Project's islands on a mesh (V, F): the
    angle-based charts an artist gets from Blender in one click."""
    bpy.ops.wm.read_homefile(use_empty=True)
    ob = add_mesh("smart", V, np.asarray(F))
    edit(ob)
    bpy.ops.uv.smart_project(angle_limit=angle_limit, island_margin=0.0)
    mark_island_seams()
    bpy.ops.object.mode_set(mode="OBJECT")
    return _seam_edges(ob.data)


def suzanne(levels: int = 2):
    """Suzanne subdivided, triangulated, with seams from Smart UV Project's islands:
    a scan-like curved mesh with several islands. Returns (V, F, seams)."""
    bpy.ops.wm.read_homefile(use_empty=True)
    bpy.ops.mesh.primitive_monkey_add()
    ob = bpy.context.active_object
    mod = ob.modifiers.new("subsurf", "SUBSURF")
    mod.levels = levels
    bpy.ops.object.modifier_apply(modifier=mod.name)
    bpy.ops.object.mode_set(mode="EDIT")
    bpy.ops.mesh.select_all(action="SELECT")
    bpy.ops.mesh.quads_convert_to_tris()
    bpy.ops.uv.smart_project(angle_limit=1.15, island_margin=0.0)
    mark_island_seams()
    bpy.ops.object.mode_set(mode="OBJECT")
    me = ob.data
    V = np.empty(3 * len(me.vertices), np.float32)
    me.vertices.foreach_get("co", V)
    cv = np.empty(len(me.loops), np.int32)
    me.loops.foreach_get("vertex_index", cv)
    ev = np.empty(2 * len(me.edges), np.int32)
    me.edges.foreach_get("vertices", ev)
    seam = np.zeros(len(me.edges), bool)
    me.edges.foreach_get("use_seam", seam)
    return V.reshape(-1, 3).astype(np.float64), cv.reshape(-1, 3).astype(np.int64), ev.reshape(-1, 2)[seam]


def checker_material(scale: float = 24.0):
    mat = bpy.data.materials.new("checker")
    if bpy.app.version < (5, 0, 0):  # always on from 5.0
        mat.use_nodes = True
    nodes, links = mat.node_tree.nodes, mat.node_tree.links
    bsdf = next(n for n in nodes if n.type == "BSDF_PRINCIPLED")
    coords = nodes.new("ShaderNodeTexCoord")
    checker = nodes.new("ShaderNodeTexChecker")
    checker.inputs["Scale"].default_value = scale
    checker.inputs["Color1"].default_value = (0.92, 0.92, 0.92, 1.0)
    checker.inputs["Color2"].default_value = (0.08, 0.25, 0.65, 1.0)
    links.new(coords.outputs["UV"], checker.inputs["Vector"])
    links.new(checker.outputs["Color"], bsdf.inputs["Base Color"])
    return mat


def mark_island_seams() -> None:
    """Blender's *Seams from Islands* on the meshes in edit mode (before 5.0, headless, it
    sees no UV selection unless sync select is on: it is, for the call)."""
    settings = bpy.context.scene.tool_settings
    sync, settings.use_uv_select_sync = settings.use_uv_select_sync, True
    bpy.ops.uv.seams_from_islands()
    settings.use_uv_select_sync = sync


def _seam_edges(me) -> np.ndarray:
    """The seam edges of mesh ``me`` (k, 2 vertex pairs; object mode)."""
    seam = np.zeros(len(me.edges), dtype=bool)
    me.edges.foreach_get("use_seam", seam)
    ev = np.empty(2 * len(me.edges), dtype=np.int32)
    me.edges.foreach_get("vertices", ev)
    return ev.reshape(-1, 2)[seam].astype(np.int64)


def seams_of_islands(ob) -> np.ndarray:
    """The edges (k, 2 vertex pairs) between the UV islands of ``ob``'s active UV map
    (object mode before and after)."""
    edit(ob)
    mark_island_seams()
    object_mode()
    return _seam_edges(ob.data)


def add_seam_lines(ob, pairs, radius: float):
    """Red tubes of ``radius`` along the edges ``pairs`` (k, 2 vertex pairs) of ``ob``: the
    seams drawn on the model for a render."""
    curve = bpy.data.curves.new("seams", "CURVE")
    curve.dimensions = "3D"
    curve.bevel_depth = radius
    V = np.array([ob.matrix_world @ v.co for v in ob.data.vertices])
    for a, b in np.asarray(pairs).tolist():  # a figure's few hundred seam edges
        spline = curve.splines.new("POLY")
        spline.points.add(1)
        spline.points[0].co = (*V[a], 1.0)
        spline.points[1].co = (*V[b], 1.0)
    mat = bpy.data.materials.new("seam")
    if bpy.app.version < (5, 0, 0):  # always on from 5.0
        mat.use_nodes = True
    nodes = mat.node_tree.nodes
    bsdf = next(n for n in nodes if n.type == "BSDF_PRINCIPLED")
    bsdf.inputs["Base Color"].default_value = (0.9, 0.05, 0.05, 1.0)
    curve.materials.append(mat)
    lines = bpy.data.objects.new("seams", curve)
    bpy.context.scene.collection.objects.link(lines)
    return lines


def render(
    ob,
    path,
    elevation: float = 0.6,
    samples: int = 16,
    size=(480, 360),
    azimuth: float = 0.0,
    checker: float = 24.0,
    distance: float = 1.0,
) -> None:
    """A checker-textured (``checker`` squares across the UV square) Cycles render (CPU) of
    ``ob``, framed from above at an angle (turned by ``azimuth`` radians about the vertical,
    from ``distance`` times the usual distance)."""
    scene = bpy.context.scene
    scene.render.engine = "CYCLES"
    scene.cycles.device = "CPU"
    scene.cycles.samples = samples
    scene.cycles.use_denoising = False
    scene.render.resolution_x, scene.render.resolution_y = size
    ob.data.materials.clear()
    ob.data.materials.append(checker_material(checker))
    lo = np.array([min(v[i] for v in ob.bound_box) for i in range(3)])
    hi = np.array([max(v[i] for v in ob.bound_box) for i in range(3)])
    centre, radius = (lo + hi) / 2, float(np.linalg.norm(hi - lo)) / 2
    cam = bpy.data.objects.new("cam", bpy.data.cameras.new("cam"))
    scene.collection.objects.link(cam)
    c, s_ = np.cos(azimuth), np.sin(azimuth)
    offset = np.array([1.3 * c + 1.6 * s_, 1.3 * s_ - 1.6 * c, 2.2 * elevation + 0.4])
    cam.location = centre + distance * radius * offset
    target = bpy.data.objects.new("target", None)
    scene.collection.objects.link(target)
    target.location = centre
    track = cam.constraints.new("TRACK_TO")
    track.target = target
    scene.camera = cam
    sun = bpy.data.objects.new("sun", bpy.data.lights.new("sun", "SUN"))
    sun.data.energy = 3.0
    sun.rotation_euler = (0.6, 0.2, 0.8)
    scene.collection.objects.link(sun)
    if scene.world is None:
        scene.world = bpy.data.worlds.new("world")
    scene.world.color = (0.35, 0.35, 0.38)
    scene.render.filepath = str(path)
    bpy.ops.render.render(write_still=True)


def edit(*objects, select_all=True):
    """Enter edit mode on these objects (the first one active), everything selected."""
    if bpy.context.object is not None and bpy.context.object.mode != "OBJECT":
        bpy.ops.object.mode_set(mode="OBJECT")
    for ob in bpy.context.scene.objects:
        ob.select_set(False)
    for ob in objects:
        ob.select_set(True)
    bpy.context.view_layer.objects.active = objects[0]
    bpy.ops.object.mode_set(mode="EDIT")
    if select_all:
        bpy.ops.mesh.select_all(action="SELECT")


def object_mode():
    if bpy.context.object is not None and bpy.context.object.mode != "OBJECT":
        bpy.ops.object.mode_set(mode="OBJECT")


def set_uvs_and_pins(ob, uv, pins):
    """Write the active map's corner UVs (corners, 2) and pins (corners,) bool, object mode."""
    layer = ob.data.uv_layers.active
    layer.uv.foreach_set("vector", np.asarray(uv, dtype=np.float32).ravel())
    if hasattr(layer, "pin_ensure"):  # 5.0 creates pins lazily; 4.2 always has them
        layer.pin_ensure()
    layer.pin.foreach_set("value", np.asarray(pins, dtype=bool))


def corner_uvs(ob):
    """(corners, 2) float32 UVs of the active map."""
    me = ob.data
    out = np.empty(2 * len(me.loops), dtype=np.float32)
    me.uv_layers.active.uv.foreach_get("vector", out)
    return out.reshape(-1, 2)


def corner_verts(ob):
    me = ob.data
    out = np.empty(len(me.loops), dtype=np.int32)
    me.attributes[".corner_vert"].data.foreach_get("value", out)
    return out


def triangles(ob):
    """Loop triangles as (t, 3) corner indices."""
    me = ob.data
    me.calc_loop_triangles()
    t = np.empty(3 * len(me.loop_triangles), dtype=np.int32)
    me.loop_triangles.foreach_get("loops", t)
    return t.reshape(-1, 3)


def positions(ob):
    me = ob.data
    out = np.empty(3 * len(me.vertices), dtype=np.float32)
    me.attributes["position"].data.foreach_get("vector", out)
    return out.reshape(-1, 3).astype(np.float64)


def snapshot(ob):
    """Every attribute of the mesh as raw bytes, plus its UV maps' names."""
    me = ob.data
    out = {"uv_maps": tuple(u.name for u in me.uv_layers)}
    sizes = {"POINT": len(me.vertices), "EDGE": len(me.edges), "FACE": len(me.polygons), "CORNER": len(me.loops)}
    widths = {"FLOAT_VECTOR": 3, "FLOAT2": 2, "INT32_2D": 2, "FLOAT_COLOR": 4, "BYTE_COLOR": 4, "QUATERNION": 4}
    for attr in me.attributes:
        n = sizes.get(attr.domain, 0) * widths.get(attr.data_type, 1)
        kind = (
            "vector"
            if attr.data_type in ("FLOAT_VECTOR", "FLOAT2")
            else ("color" if "COLOR" in attr.data_type else "value")
        )
        dtype = bool if attr.data_type == "BOOLEAN" else (np.int32 if "INT" in attr.data_type else np.float32)
        buf = np.empty(n, dtype=dtype)
        attr.data.foreach_get(kind, buf)
        out[attr.name] = buf.tobytes()
    return out
