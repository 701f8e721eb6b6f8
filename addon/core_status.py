"""Whether the native core imports, and why not: the state the package sets at registration
and the panel and preferences read. No bpy."""

import sys

_core_error_message = None


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
