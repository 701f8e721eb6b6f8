"""Illumap: diffuse global illumination (radiosity) on point models with a Fast Multipole Method.

Public API (docs/architecture.md)::

    Surfels(positions, normals, areas, albedo, emission)     # validates; raises InputError
    TransportOperator(surfels, method="fmm", order=…, theta=…, leaf_size=…, near_field="disc",
                      visibility="none")                      # .apply(values), .stats, .symmetric
    solve(surfels, *, method=…, solver="auto"|"cg"|"gmres"|"jacobi", tol=…, max_iterations=…,
          progress=None, operator=None, target_error=None, **operator_keywords) -> Solution
                                                              # (illumap.api: target_error
                                                              #  → illumap.accuracy)
    Occluders(surfels, coverage=1.3, shape="disc")           # .visible(origins, targets, skip=)
    InputError(ValueError), Cancelled(Exception)
    run(scene, progress=None, *, next_pass=None) -> Gathered  # illumap.stages: Scene → Lit
                                                              # → Solved → Gathered, one loop
                                                              # over the passes
    Scene, Source, PointCloud, Receivers                      # the scene as plain data
"""

import importlib

__version__ = "0.1.0"

# Names that need the native module load on first use (PEP 562), so that the pure modules
# (illumap.settings, illumap.limits, illumap.identities) import without it: the add-on's reduced
# UI declares its properties from illumap.settings even where the native module cannot load.
_LAZY = {
    "accuracy": (".accuracy", None), "Cancelled": ("._progress", "Cancelled"),
    "Occluders": (".occluders", "Occluders"), "solve": (".api", "solve"),
    "Solution": (".solver", "Solution"), "DEFAULT_TOL": (".solver", "DEFAULT_TOL"),
    "Surfels": (".surfels", "Surfels"), "InputError": (".surfels", "InputError"),
    "TransportOperator": (".operator", "TransportOperator"),
    "run": (".stages.passes", "run"), "Gathered": (".stages.passes", "Gathered"),
    "Scene": (".stages.scene", "Scene"), "Source": (".stages.scene", "Source"),
    "PointCloud": (".stages.scene", "PointCloud"), "Receivers": (".stages.scene", "Receivers"),
    "RunError": (".stages.errors", "RunError"), "NoLight": (".stages.errors", "NoLight"),
    **{name: (".operator", name) for name in (
        "DEFAULT_LEAF_SIZE", "DEFAULT_METHOD", "DEFAULT_NEAR_FIELD", "DEFAULT_ORDER",
        "DEFAULT_THETA", "DEFAULT_VISIBILITY")},
}


def __getattr__(name: str):
    if name not in _LAZY:
        raise AttributeError(f"module 'illumap' has no attribute {name!r}")
    module, attribute = _LAZY[name]
    value = importlib.import_module(module, __name__)
    value = value if attribute is None else getattr(value, attribute)
    globals()[name] = value
    return value


def __dir__():
    return sorted(set(globals()) | set(_LAZY))


__all__ = [
    "Surfels", "TransportOperator", "Occluders", "solve", "Solution", "InputError", "Cancelled",
    "DEFAULT_METHOD", "DEFAULT_ORDER", "DEFAULT_THETA", "DEFAULT_LEAF_SIZE",
    "DEFAULT_NEAR_FIELD", "DEFAULT_VISIBILITY", "DEFAULT_TOL", "native_available", "load_native",
    "accuracy", "run", "Gathered", "Scene", "Source", "PointCloud", "Receivers", "RunError",
    "NoLight",
]


def native_available() -> bool:
    """True when the native module illumap._core is importable."""
    try:
        load_native()
    except ImportError:
        return False
    return True


def load_native() -> None:
    """Import the native module illumap._core; raises the ImportError that says why it cannot
    load (a missing build, another platform's or Python's, a library the loader lacks)."""
    from . import _core  # noqa: F401
