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
"""

from . import accuracy
from ._progress import Cancelled
from .occluders import Occluders
from .operator import (DEFAULT_LEAF_SIZE, DEFAULT_METHOD, DEFAULT_NEAR_FIELD, DEFAULT_ORDER,
                       DEFAULT_THETA, DEFAULT_VISIBILITY, TransportOperator)
from .api import solve
from .solver import DEFAULT_TOL, Solution
from .surfels import InputError, Surfels

__version__ = "0.1.0"

__all__ = [
    "Surfels", "TransportOperator", "Occluders", "solve", "Solution", "InputError", "Cancelled",
    "DEFAULT_METHOD", "DEFAULT_ORDER", "DEFAULT_THETA", "DEFAULT_LEAF_SIZE",
    "DEFAULT_NEAR_FIELD", "DEFAULT_VISIBILITY", "DEFAULT_TOL", "native_available", "accuracy",
]


def native_available() -> bool:
    """True when the native module illumap._core is importable."""
    try:
        from . import _core  # noqa: F401
    except ImportError:
        return False
    return True
