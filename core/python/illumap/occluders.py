"""Segment occlusion against the surfels: shadows of lamps with the occluders of
``visibility="exact"``.

:class:`Occluders` builds the Embree scene of the surfels once (the same discs or quads, of the
same size, as ``TransportOperator(..., visibility="exact")``) and answers, for any number of
segments, whether an occluder meets them::

    occ = Occluders(surfels)                        # coverage=1.3, shape="disc"
    v = occ.visible(surfels.positions, lamp_pos,    # (M, 3) each, metres
                    skip=np.arange(surfels.n))      # float32 (M,), 1 = lit, 0 = shadowed

Lamps: point and spot lamps pass their position as the target; area lamps one sample point
per segment; a sun a far target ``origin + distance · direction_to_sun`` (see
:meth:`Occluders.visible` for how far is safe).
"""

from __future__ import annotations

import numpy as np

from ._progress import ProgressGuard
from .limits import limit
from .array_checks import read_float_array, require_finite
from .operator import OCCLUDER_SHAPES
from .surfels import InputError, Surfels

try:
    from . import _core
except ImportError as _exc:  # pragma: no cover - depends on the build
    _core = None
    _CORE_IMPORT_ERROR = _exc
else:
    _CORE_IMPORT_ERROR = None

__all__ = ["Occluders", "OCCLUDER_SHAPES", "DEFAULT_ENDPOINT_OFFSET"]

#: Share of the skipped surfel's disc radius trimmed off the start of a segment; the same
#: default as the operator's ``endpoint_offset``.
DEFAULT_ENDPOINT_OFFSET = 0.05


def _points(name: str, value, m: int | None = None) -> np.ndarray:
    array = read_float_array(value, name)
    if array.ndim != 2 or array.shape[1] != 3:
        raise InputError(f"{name}: expected shape (M, 3), got {array.shape}")
    if m is not None and array.shape[0] != m:
        raise InputError(f"{name}: expected {m} rows (as origins), got {array.shape[0]}")
    return require_finite(array, name)


class Occluders:
    """The surfels as occluders, for visibility of arbitrary segments (lamp shadows).

    Parameters
    ----------
    surfels : Surfels
        Positions in metres (any unit works: everything scales with the surfels' own spacing).
    coverage : float
        Occluder radius = coverage·sqrt(A/π) (a quad: side coverage·sqrt(A)). Use the value
        given to the operator (default 1.3, as ``TransportOperator``).
    shape : "disc" | "quad" | "octagon"
        Oriented discs (default, as the operator), or equal-area squares or regular octagons
        (faster rays; the octagon is within 0.974-1.054 × the disc's radius).
    threads : int
        Worker threads for the build and the queries, 0 = all hardware threads.
    progress : callable(fraction, phase) -> bool | None, optional
        Called while the scene is built; returning False or raising cancels with
        :class:`illumap.Cancelled`.

    Raises
    ------
    InputError
        On a bad argument.
    """

    def __init__(self, surfels: Surfels, *, coverage: float = 1.3, shape: str = "disc",
                 threads: int = 0, progress=None):
        if not isinstance(surfels, Surfels):
            raise InputError(f"surfels: expected an illumap.Surfels, got {type(surfels).__name__}")
        limit("coverage").check(coverage, InputError)
        if not isinstance(shape, str) or shape not in OCCLUDER_SHAPES:
            raise InputError(f"shape: expected one of {list(OCCLUDER_SHAPES)}, got {shape!r}")
        limit("threads").check(threads, InputError)
        if progress is not None and not callable(progress):
            raise InputError(f"progress: expected a callable or None, got {progress!r}")
        if _core is None:
            raise ImportError(f"illumap._core, the native module, is not available "
                              f"({_CORE_IMPORT_ERROR})")
        self.surfels = surfels
        self.coverage = float(coverage)
        self.shape = shape
        self.threads = int(threads)
        guard = ProgressGuard(progress)
        with guard:
            self._scene = _core.Occluders(surfels.positions, surfels.normals, surfels.areas,
                                          coverage=self.coverage, shape=shape,
                                          threads=self.threads,
                                          progress=guard.native_callback())

    @property
    def n(self) -> int:
        """Number of occluders (surfels)."""
        return self.surfels.n

    def visible(self, origins, targets, *, skip=None, progress=None,
                endpoint_offset: float = DEFAULT_ENDPOINT_OFFSET) -> np.ndarray:
        """Visibility of the segments ``origins[k] -> targets[k]``.

        Parameters
        ----------
        origins, targets : (M, 3) array_like of float
            Segment ends in world metres (the surfels' units), finite.
        skip : (M,) array_like of int, optional
            A surfel at the origin (or -1 for none) whose own disc must not occlude: the
            part of the segment within ``endpoint_offset × r`` of its tangent plane is
            ignored (r: its disc radius; along the segment ``endpoint_offset × r / cos``, at
            most 2 r), as the operator trims its pairs; that also hides coincident duplicates
            and neighbours' discs that pass just above it on a curved surface (no shadow acne
            at grazing lamp angles). Without it, a segment that starts on a surfel is blocked
            by it.
            Nothing is trimmed at the target (a lamp is not a surfel).
        progress : callable(fraction, phase) -> bool | None, optional
            Returning False or raising cancels with :class:`illumap.Cancelled`.
        endpoint_offset : float
            The trim at a skipped origin, a height above its tangent plane in units of its
            disc radius (default 0.05).

        Returns
        -------
        numpy.ndarray, float32, shape (M,)
            1.0 where no occluder (disc or quad of any surfel) meets the segment, 0.0 where
            one does. A segment of zero length, or one entirely trimmed, is visible.

        Notes
        -----
        Segments are clipped in double precision to the occluders' bounding box (padded by
        two disc radii) before they reach Embree's single-precision rays, which are relative
        to the box centre. So precision depends on the scene's size, not on the world origin
        or the target's distance: for a sun, pass ``target = origin + D · direction`` with any
        finite D larger than the scene's diagonal (e.g. 10× the diagonal, or 1e6 m); only the
        part inside the box is tested.
        """
        origins = _points("origins", origins)
        m = origins.shape[0]
        targets = _points("targets", targets, m)
        if skip is not None:
            try:
                skip_array = np.asarray(skip)
            except Exception as exc:  # noqa: BLE001 - ragged input and the like
                raise InputError(f"skip: cannot be read as an integer array ({exc})") from None
            if skip_array.dtype.kind not in "iu":
                raise InputError(f"skip: expected integers, got dtype {skip_array.dtype}")
            skip_array = np.ascontiguousarray(skip_array, dtype=np.int64)
            if skip_array.shape != (m,):
                raise InputError(f"skip: expected shape (M,) = ({m},), got {skip_array.shape}")
            bad = (skip_array < -1) | (skip_array >= self.n)
            if bad.any():
                k = int(np.flatnonzero(bad)[0])
                raise InputError(f"skip[{k}] = {skip_array[k]} is not -1 or a surfel index "
                                 f"in [0, {self.n})")
            skip = skip_array
        limit("endpoint_offset").check(endpoint_offset, InputError)
        if progress is not None and not callable(progress):
            raise InputError(f"progress: expected a callable or None, got {progress!r}")
        guard = ProgressGuard(progress)
        with guard:
            return self._scene.visible(origins, targets, skip=skip,
                                       endpoint_offset=float(endpoint_offset),
                                       progress=guard.native_callback())

    def __repr__(self) -> str:
        return (f"Occluders(N={self.n}, coverage={self.coverage}, shape={self.shape!r})")
