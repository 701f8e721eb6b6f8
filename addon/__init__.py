"""Illumap's Blender add-on: properties, preferences, operators, panel and preview.

The top-level extension package registers this package (``from .addon import register,
unregister``). Registration first tries to import the native core (``import illumap``) and the
pipeline that uses it. When that fails — a wheel for another platform, a missing build — it
registers a reduced UI: the panel says why, and only the operators that need nothing but bpy
are available (CAD Sketcher does the same for its solver).
"""

import sys

import bpy
from bpy.app.handlers import persistent

from . import operators, panel, preferences, preview, properties

_core_error_message = None
_registered = []


def _import_core():
    """Import the native core and the pipeline; raise whatever the import raises."""
    import illumap  # the core package, installed from the bundled wheel
    native_available = getattr(illumap, "native_available", None)
    if native_available is not None and not native_available():
        from illumap import _core  # noqa: F401  (raises the ImportError that says why)
    from . import pipeline  # noqa: F401


def _explain(error):
    version = ".".join(map(str, sys.version_info[:3]))
    if isinstance(error, ModuleNotFoundError) and error.name == "illumap":
        first = "The native module 'illumap' is not installed."
    elif isinstance(error, ImportError):
        first = f"The native module could not be loaded: {error}"
    else:
        first = f"The native module failed to initialise: {type(error).__name__}: {error}"
    return (f"{first}\nBlender's Python is {version} on {sys.platform}; the Illumap wheel "
            f"must match it.")


def check_core():
    """Try the import again and return the problem as text (None when the core works)."""
    global _core_error_message
    try:
        _import_core()
    except Exception as error:  # any failure means the reduced UI
        _core_error_message = _explain(error)
    else:
        _core_error_message = None
    return _core_error_message


def core_error():
    """Why the native module is unavailable, or None when it works."""
    return _core_error_message


@persistent
def _on_load_post(*_args):
    preferences.initialize_scenes()


def register():
    check_core()
    classes = list(properties.classes) + list(preferences.classes) + \
        list(operators.basic_classes) + list(panel.classes)
    if _core_error_message is None:
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


__all__ = ["register", "unregister", "core_error", "check_core", "build_preview"]
build_preview = preview.build_preview
