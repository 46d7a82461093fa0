"""isoparam: fast isometric UV unwrapping for Blender (Sun & Hancock's method).

The package root only registers the add-on; it does not import ``bpy`` at module level,
so ``import isoparam_addon.solver`` works in plain CPython. The Blender glue lives in
:mod:`.blender`, the numerics in :mod:`.solver`.
"""


def register():
    from .blender import register as _register

    _register()


def unregister():
    from .blender import unregister as _unregister

    _unregister()
