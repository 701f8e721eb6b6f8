"""The transport operator y = F·V·x, wrapping the native ``illumap._core.Operator``.

For receiver i and source j (docs/architecture.md, "The kernel, exactly")::

    F_ij = A_j · max(0, cos_i) · max(0, cos_j) / (π r²) · w(t),   t = π r² / ((A_i + A_j)/2)

with the bounded "disc" near-field weight w(t) = t/(1+t) for close pairs (ramping to 1 by
t = 32), or w ≡ 1 for ``near_field="point"`` (the bare point kernel, kept to show where it
fails). ``apply(x)`` returns the gathered ``Σ_j F_ij V_ij x_j`` per colour channel, before
albedo. V = 1 for now (``visibility="none"``).

The default expansion parameters live here, in one place: :data:`DEFAULT_ORDER`,
:data:`DEFAULT_THETA`, :data:`DEFAULT_LEAF_SIZE`.
"""

from __future__ import annotations

import numbers

import numpy as np

from .surfels import InputError, Surfels
from ._progress import ProgressGuard

try:  # the native module is built separately (core/src); keep the package importable without it
    from . import _core
except ImportError as _exc:  # pragma: no cover - depends on the build
    _core = None
    _CORE_IMPORT_ERROR = _exc
else:
    _CORE_IMPORT_ERROR = None

__all__ = [
    "TransportOperator", "DEFAULT_METHOD", "DEFAULT_ORDER", "DEFAULT_THETA",
    "DEFAULT_LEAF_SIZE", "DEFAULT_NEAR_FIELD", "DEFAULT_VISIBILITY", "METHODS",
    "NEAR_FIELDS", "VISIBILITIES", "MAX_ORDER",
]

# --- defaults: the one place to change them -------------------------------------------------
DEFAULT_METHOD = "fmm"
DEFAULT_ORDER = 4
DEFAULT_THETA = 0.5
DEFAULT_LEAF_SIZE = 32
DEFAULT_NEAR_FIELD = "disc"
DEFAULT_VISIBILITY = "none"

METHODS = ("fmm", "direct")
NEAR_FIELDS = ("disc", "point")
MAX_ORDER = 16

#: Visibility modes: name -> (implemented, reciprocal). A reciprocal mode has V_ij = V_ji, which
#: keeps diag(A)·F·V symmetric so that CG applies. "seed" (the talk's attenuation lookup) is not
#: reciprocal in general; "exact" (ray casting against the surfel discs) is.
VISIBILITIES = {
    "none": (True, True),
    "seed": (False, False),
    "exact": (False, True),
}

#: The keywords ``solve`` forwards to TransportOperator.
OPERATOR_KEYWORDS = ("method", "order", "theta", "leaf_size", "near_field", "visibility",
                     "threads")


def _require_core():
    if _core is None:
        raise ImportError(
            "illumap._core, the native module, is not available "
            f"({_CORE_IMPORT_ERROR}); build it with `pip install --no-build-isolation ./core`"
        )
    return _core


def _check_choice(name, value, choices):
    if not isinstance(value, str) or value not in choices:
        raise InputError(f"{name}: expected one of {list(choices)}, got {value!r}")
    return value


def _check_int(name, value, low, high=None):
    if isinstance(value, bool) or not isinstance(value, numbers.Integral):
        raise InputError(f"{name}: expected an integer, got {value!r}")
    value = int(value)
    if value < low or (high is not None and value > high):
        upper = "" if high is None else f" and <= {high}"
        raise InputError(f"{name}: expected an integer >= {low}{upper}, got {value}")
    return value


def check_values(values, n: int, name: str = "values") -> np.ndarray:
    """Validate an N×3 array of per-surfel values (finite) and return it as float64 C."""
    try:
        array = np.ascontiguousarray(values, dtype=np.float64)
    except (TypeError, ValueError) as exc:
        raise InputError(f"{name}: cannot be read as a float array ({exc})") from None
    if array.shape != (n, 3):
        raise InputError(f"{name}: expected shape (N, 3) = ({n}, 3), got {array.shape}")
    bad = ~np.isfinite(array)
    if bad.any():
        k, c = np.unravel_index(int(np.flatnonzero(bad.ravel())[0]), bad.shape)
        raise InputError(f"{name}[{k}, {c}] = {array[k, c]!r} is not finite")
    return array


def validate_keywords(*, method=DEFAULT_METHOD, order=DEFAULT_ORDER, theta=DEFAULT_THETA,
                      leaf_size=DEFAULT_LEAF_SIZE, near_field=DEFAULT_NEAR_FIELD,
                      visibility=DEFAULT_VISIBILITY, threads=0) -> dict:
    """Check the operator keywords (raises InputError) and return them normalized."""
    out = {}
    out["method"] = _check_choice("method", method, METHODS)
    out["order"] = _check_int("order", order, 0, MAX_ORDER)
    if isinstance(theta, bool) or not isinstance(theta, numbers.Real) \
            or not np.isfinite(theta) or not 0.0 < float(theta) < 1.0:
        raise InputError(f"theta: expected a number in (0, 1), got {theta!r}")
    out["theta"] = float(theta)
    out["leaf_size"] = _check_int("leaf_size", leaf_size, 1)
    out["near_field"] = _check_choice("near_field", near_field, NEAR_FIELDS)
    out["visibility"] = _check_choice("visibility", visibility, tuple(VISIBILITIES))
    if not VISIBILITIES[out["visibility"]][0]:
        raise InputError(
            f"visibility={out['visibility']!r} is not implemented yet; only "
            "visibility='none' (V = 1, no occlusion) is available in this version"
        )
    out["threads"] = _check_int("threads", threads, 0)
    return out


class TransportOperator:
    """The gathered transport ``y_i = Σ_j F_ij V_ij x_j`` over validated surfels.

    Parameters
    ----------
    surfels : Surfels
    method : "fmm" | "direct"
        "direct" is the exact O(N²) reference; "fmm" reproduces it up to expansion error.
    order : int
        Expansion order p of the FMM (0 … MAX_ORDER); ignored by "direct".
    theta : float
        Opening criterion of the dual-tree traversal, in (0, 1).
    leaf_size : int
        Maximum surfels per octree leaf.
    near_field : "disc" | "point"
        Bounded point-to-disc rule (default) or the bare point kernel.
    visibility : "none"
        Only "none" (V = 1) is implemented. "seed" and "exact" are reserved for the
        visibility issue and raise InputError for now.
    threads : int
        Worker threads, 0 = all hardware threads.
    progress : callable(fraction, phase) -> bool | None, optional
        Called while the tree and lists are built; returning False or raising cancels
        with :class:`illumap.Cancelled`.
    """

    def __init__(self, surfels: Surfels, method: str = DEFAULT_METHOD, *,
                 order: int = DEFAULT_ORDER, theta: float = DEFAULT_THETA,
                 leaf_size: int = DEFAULT_LEAF_SIZE, near_field: str = DEFAULT_NEAR_FIELD,
                 visibility: str = DEFAULT_VISIBILITY, threads: int = 0, progress=None):
        if not isinstance(surfels, Surfels):
            raise InputError(
                f"surfels: expected an illumap.Surfels, got {type(surfels).__name__} "
                "(build one with illumap.Surfels(positions, normals, areas, albedo, emission))"
            )
        checked = validate_keywords(method=method, order=order, theta=theta,
                                    leaf_size=leaf_size, near_field=near_field,
                                    visibility=visibility, threads=threads)
        self.method = checked["method"]
        self.order = checked["order"]
        self.theta = checked["theta"]
        self.leaf_size = checked["leaf_size"]
        self.near_field = checked["near_field"]
        self.visibility = checked["visibility"]
        self.threads = checked["threads"]
        self._reciprocal_visibility = VISIBILITIES[self.visibility][1]
        if progress is not None and not callable(progress):
            raise InputError(f"progress: expected a callable or None, got {progress!r}")
        self.surfels = surfels
        core = _require_core()
        guard = ProgressGuard(progress)
        with guard:
            self._op = core.Operator(
                surfels.positions, surfels.normals, surfels.areas,
                method=self.method, order=self.order, theta=self.theta,
                leaf_size=self.leaf_size, near_field=self.near_field, threads=self.threads,
                progress=guard.native_callback(),
            )

    @property
    def n(self) -> int:
        return self.surfels.n

    @property
    def shape(self):
        return (self.n, self.n)

    def apply(self, values, progress=None) -> np.ndarray:
        """Return ``Σ_j F_ij V_ij values_j`` (N×3) for finite N×3 ``values``."""
        values = check_values(values, self.n)
        if progress is not None and not callable(progress):
            raise InputError(f"progress: expected a callable or None, got {progress!r}")
        guard = ProgressGuard(progress)
        with guard:
            return self._op.apply(values, progress=guard.native_callback())

    __call__ = apply

    def apply_rows(self, values, rows) -> np.ndarray:
        """Exact direct sums for the selected receivers ``rows`` (int array): len(rows)×3."""
        values = check_values(values, self.n)
        rows = np.ascontiguousarray(rows, dtype=np.int64).ravel()
        if rows.size and (rows.min() < 0 or rows.max() >= self.n):
            k = int(np.flatnonzero((rows < 0) | (rows >= self.n))[0])
            raise InputError(f"rows[{k}] = {rows[k]} is out of range [0, {self.n})")
        return self._op.apply_rows(values, rows)

    @property
    def symmetric(self) -> bool:
        """True when diag(A)·F·V is symmetric (reciprocal kernel and visibility): CG applies."""
        return bool(self._op.symmetric) and self._reciprocal_visibility

    @property
    def stats(self) -> dict:
        stats = dict(self._op.stats)
        stats.update(method=self.method, order=self.order, theta=self.theta,
                     leaf_size=self.leaf_size, near_field=self.near_field,
                     visibility=self.visibility, n=self.n)
        return stats

    def keywords(self) -> dict:
        """The keywords this operator was built with."""
        return dict(method=self.method, order=self.order, theta=self.theta,
                    leaf_size=self.leaf_size, near_field=self.near_field,
                    visibility=self.visibility, threads=self.threads)

    def __repr__(self) -> str:
        return (f"TransportOperator(N={self.n}, method={self.method!r}, order={self.order}, "
                f"theta={self.theta}, leaf_size={self.leaf_size}, "
                f"near_field={self.near_field!r}, visibility={self.visibility!r})")
