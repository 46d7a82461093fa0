"""Blender glue: the only code that touches both bpy and numpy.

Imports bpy lazily (in :func:`register`), so that importing the package (the extension's
``__init__`` does) costs nothing until Blender registers it.
"""

from __future__ import annotations

_classes: tuple = ()


def _menu_draw(self, context):
    self.layout.separator()
    self.layout.operator("uv.isometric_unwrap", text="Isometric Unwrap")
    self.layout.operator("uv.isometric_show_stretch", text="Show UV Stretch")


def _menus():
    """Menus to extend: UV > Unwrap in both editors, as Blender's layout differs by version.

    4.2 has two independent menus. From 4.3 on the 3D view's UV menu shows (4.3) or
    inlines (4.4+) the UV editor's Unwrap menu, so extending that one reaches both.
    """
    import bpy

    menus = [bpy.types.IMAGE_MT_uvs_unwrap]
    if bpy.app.version < (4, 3, 0):
        menus.append(bpy.types.VIEW3D_MT_uv_map)
    return menus


def register():
    import bpy

    from . import record
    from .operators import UV_OT_isometric_show_stretch, UV_OT_isometric_unwrap

    global _classes
    _classes = (UV_OT_isometric_unwrap, UV_OT_isometric_show_stretch)
    for cls in _classes:
        bpy.utils.register_class(cls)
    record.register()
    for menu in _menus():
        menu.append(_menu_draw)


def unregister():
    import bpy

    from . import record

    for menu in _menus():
        menu.remove(_menu_draw)
    record.unregister()
    for cls in reversed(_classes):
        bpy.utils.unregister_class(cls)
