"""Illumap's Blender add-on: properties, preferences, operators, panel and preview.

The top-level extension package registers this package (``from .addon import register,
unregister``). Registration first tries to import the native core (``import illumap``) and the
pipeline that uses it. When that fails — a wheel for another platform, a missing build — it
registers a reduced UI: the panel says why, and only the operators that need nothing but bpy
are available (CAD Sketcher does the same for its solver); ``core_status`` holds why.
"""

import bpy
from bpy.app.handlers import persistent

from .ui import operators, panel, preferences, properties, tool_operators
from .preview import surfel_preview as preview
from .core_status import check_native, core_error

_registered = []


@persistent
def _on_load_post(*_args):
    preferences.initialize_scenes()


def register():
    check_native()
    classes = list(properties.classes) + list(preferences.classes) + \
        list(tool_operators.classes) + list(panel.classes)
    if core_error() is None:
        classes += list(operators.core_classes)
    for cls in classes:
        bpy.utils.register_class(cls)
        _registered.append(cls)
        if cls is properties.IllumapSettings:
            bpy.types.Scene.illumap = bpy.props.PointerProperty(type=properties.IllumapSettings)
    if _on_load_post not in bpy.app.handlers.load_post:
        bpy.app.handlers.load_post.append(_on_load_post)
    try:
        preferences.initialize_scenes()
    except AttributeError:
        pass  # bpy.data is restricted while Blender starts up; load_post does it then


def unregister():
    if _on_load_post in bpy.app.handlers.load_post:
        bpy.app.handlers.load_post.remove(_on_load_post)
    if hasattr(bpy.types.Scene, "illumap"):
        del bpy.types.Scene.illumap
    while _registered:
        cls = _registered.pop()
        bpy.utils.unregister_class(cls)


__all__ = ["register", "unregister", "core_error", "check_native", "build_preview"]
build_preview = preview.build_preview
