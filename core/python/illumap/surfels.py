"""Surfels: the validated input of every Illumap computation.

A surfel is a small oriented disc: a position, a unit normal, an area, an RGB albedo
(diffuse reflectance ρ) and an RGB emission E (outgoing radiance it emits by itself).
`Surfels` checks everything once, so that the native module never sees a NaN, a zero
normal or an energy-creating albedo. Every error is an :class:`InputError` whose message
names the array, the first offending index and the reason.
"""

from __future__ import annotations

import os

import numpy as np

__all__ = ["InputError", "Surfels", "NORMAL_TOLERANCE", "BYTES_PER_SURFEL_ESTIMATE",
           "MAX_COORDINATE", "AREA_RANGE"]

#: Normals whose length differs from 1 by less than this are normalized silently;
#: anything further off is taken for a bug upstream (wrong array, unnormalized data) and raises.
NORMAL_TOLERANCE = 1e-3

#: The largest |coordinate| taken (m). The kernels raise distances to powers up to the FMM
#: order: a scene at 1e38 (order 10) or 1e100 (any order) overflows float64 deep in the solve
#: ("solver iterate became non-finite"); an infinite coordinate stored by Blender reads 3.4e38.
from .limits import limit as _limit  # noqa: E402  (the one table of limits)
MAX_COORDINATE = _limit("coordinate").high
#: The surfel areas taken (m²): radii from 1e-12 m to 1e12 m. Scenes scaled by 1e-40 (order 10)
#: or 1e-80 (any order) underflow in the same way.
AREA_RANGE = (1e-24, 1e24)

#: Rough peak memory per surfel of a solve: the input arrays (15 float64), the native octree
#: and interaction lists, and the solver's work vectors (GMRES(30) keeps 31 N×3 vectors).
#: Used only to refuse absurd sizes before allocating anything.
BYTES_PER_SURFEL_ESTIMATE = 1200


class InputError(ValueError):
    """Invalid input: the message says which array, which index and why."""


def _physical_memory_bytes() -> int | None:
    try:
        return int(os.sysconf("SC_PAGE_SIZE")) * int(os.sysconf("SC_PHYS_PAGES"))
    except (AttributeError, ValueError, OSError):  # pragma: no cover - non-POSIX
        return None


def _as_float_array(name: str, value) -> np.ndarray:
    """Copy `value` into a new C-contiguous float64 array, or raise InputError."""
    if value is None:
        raise InputError(f"{name}: missing (got None)")
    try:
        probe = np.asarray(value)
    except Exception as exc:  # ragged lists and the like
        raise InputError(f"{name}: cannot be read as a numeric array ({exc})") from None
    if probe.dtype.kind not in "fiub":
        raise InputError(
            f"{name}: expected real numbers, got dtype {probe.dtype} "
            "(complex, object and string arrays are refused)"
        )
    return np.array(probe, dtype=np.float64, order="C", copy=True)


def _check_shape(name: str, array: np.ndarray, shape: tuple, shape_text: str) -> None:
    if array.shape != shape:
        raise InputError(f"{name}: expected shape {shape_text} = {shape}, got {array.shape}")


def _first_bad(mask: np.ndarray):
    """Index (tuple) of the first True in `mask`, in C order."""
    flat = int(np.flatnonzero(mask.ravel())[0])
    return np.unravel_index(flat, mask.shape)


def _fmt_index(index) -> str:
    return "[" + ", ".join(str(int(i)) for i in index) + "]"


def _check_finite(name: str, array: np.ndarray) -> None:
    bad = ~np.isfinite(array)
    if bad.any():
        index = _first_bad(bad)
        raise InputError(
            f"{name}{_fmt_index(index)} = {array[index]!r} is not finite "
            f"({int(bad.sum())} non-finite value(s) in {name})"
        )


class Surfels:
    """Validated surfel arrays (all float64, C-contiguous, read-only copies).

    Parameters
    ----------
    positions : (N, 3) array_like
    normals : (N, 3) array_like
        Unit normals. Lengths within ``NORMAL_TOLERANCE`` of 1 are renormalized; zero or
        clearly non-unit normals raise.
    areas : (N,) array_like
        Strictly positive areas.
    albedo : (N, 3) array_like
        RGB reflectance in [0, 1). An albedo of 1 or more makes the energy of a closed scene
        diverge and raises.
    emission : (N, 3) array_like
        RGB emitted radiance, >= 0.

    Raises
    ------
    InputError
        With the array's name, the first bad index and the reason.
    """

    __slots__ = ("positions", "normals", "areas", "albedo", "emission")

    def __init__(self, positions, normals, areas, albedo, emission):
        positions = _as_float_array("positions", positions)
        if positions.ndim != 2 or positions.shape[1] != 3:
            raise InputError(f"positions: expected shape (N, 3), got {positions.shape}")
        n = positions.shape[0]
        if n < 1:
            raise InputError("positions: no surfels (N = 0); at least one is needed")
        estimate = n * BYTES_PER_SURFEL_ESTIMATE
        memory = _physical_memory_bytes()
        if memory is not None and estimate > memory:
            raise InputError(
                f"positions: N = {n} surfels would need about {estimate / 2**30:.1f} GiB "
                f"({BYTES_PER_SURFEL_ESTIMATE} bytes per surfel), more than this machine's "
                f"{memory / 2**30:.1f} GiB of memory"
            )

        normals = _as_float_array("normals", normals)
        areas = _as_float_array("areas", areas)
        albedo = _as_float_array("albedo", albedo)
        emission = _as_float_array("emission", emission)
        _check_shape("normals", normals, (n, 3), "(N, 3)")
        _check_shape("areas", areas, (n,), "(N,)")
        _check_shape("albedo", albedo, (n, 3), "(N, 3)")
        _check_shape("emission", emission, (n, 3), "(N, 3)")

        for name, array in (("positions", positions), ("normals", normals), ("areas", areas),
                            ("albedo", albedo), ("emission", emission)):
            _check_finite(name, array)

        length = np.sqrt(np.einsum("ij,ij->i", normals, normals))
        zero = length == 0.0
        if zero.any():
            k = int(np.flatnonzero(zero)[0])
            raise InputError(f"normals[{k}] = {normals[k].tolist()} has zero length")
        off = np.abs(length - 1.0) >= NORMAL_TOLERANCE
        if off.any():
            k = int(np.flatnonzero(off)[0])
            raise InputError(
                f"normals[{k}] = {normals[k].tolist()} has length {length[k]:.6g}; "
                f"normals must have unit length (within {NORMAL_TOLERANCE:g})"
            )
        normals /= length[:, None]

        bad = np.abs(positions) > MAX_COORDINATE
        if bad.any():
            k, c = _first_bad(bad)
            raise InputError(
                f"positions[{k}, {c}] = {positions[k, c]!r} lies beyond ±{MAX_COORDINATE:g}: "
                "at such scales the kernels overflow; express the scene in metres (or "
                "rescale it) and keep it near the origin"
            )

        bad = areas <= 0.0
        if bad.any():
            k = int(np.flatnonzero(bad)[0])
            raise InputError(f"areas[{k}] = {areas[k]!r} must be > 0")
        low, high = AREA_RANGE
        bad = (areas < low) | (areas > high)
        if bad.any():
            k = int(np.flatnonzero(bad)[0])
            raise InputError(
                f"areas[{k}] = {areas[k]!r} lies outside [{low:g}, {high:g}] (radii from "
                f"{np.sqrt(low):g} to {np.sqrt(high):g}): at such scales the kernels overflow "
                "or underflow; express the scene in metres (or rescale it)"
            )

        bad = albedo < 0.0
        if bad.any():
            k, c = _first_bad(bad)
            raise InputError(f"albedo[{k}, {c}] = {albedo[k, c]!r} must be >= 0")
        bad = albedo >= 1.0
        if bad.any():
            k, c = _first_bad(bad)
            raise InputError(
                f"albedo[{k}, {c}] = {albedo[k, c]!r} must be < 1 "
                "(an albedo of 1 or more makes the energy of a closed scene diverge)"
            )

        bad = emission < 0.0
        if bad.any():
            k, c = _first_bad(bad)
            raise InputError(f"emission[{k}, {c}] = {emission[k, c]!r} must be >= 0")

        for array in (positions, normals, areas, albedo, emission):
            array.setflags(write=False)
        object.__setattr__(self, "positions", positions)
        object.__setattr__(self, "normals", normals)
        object.__setattr__(self, "areas", areas)
        object.__setattr__(self, "albedo", albedo)
        object.__setattr__(self, "emission", emission)

    def __setattr__(self, name, value):
        raise AttributeError("Surfels are immutable; build a new Surfels (or use .replace())")

    def __reduce__(self):  # pickle / copy: rebuild (and revalidate) from the arrays
        return (Surfels, (self.positions, self.normals, self.areas, self.albedo, self.emission))

    def __len__(self) -> int:
        return self.positions.shape[0]

    @property
    def n(self) -> int:
        """Number of surfels N."""
        return self.positions.shape[0]

    @property
    def total_area(self) -> float:
        return float(self.areas.sum())

    def replace(self, **arrays) -> "Surfels":
        """A new validated Surfels with some arrays replaced, e.g. ``s.replace(albedo=…)``."""
        unknown = set(arrays) - set(self.__slots__)
        if unknown:
            raise TypeError(f"unknown Surfels array(s): {sorted(unknown)}")
        values = {name: arrays.get(name, getattr(self, name)) for name in self.__slots__}
        return Surfels(**values)

    def same_geometry(self, other: "Surfels") -> bool:
        """True when positions, normals and areas are identical (the transport operator
        depends on nothing else)."""
        if other is self:
            return True
        return (other.n == self.n
                and np.array_equal(other.positions, self.positions)
                and np.array_equal(other.normals, self.normals)
                and np.array_equal(other.areas, self.areas))

    def __repr__(self) -> str:
        return f"Surfels(N={self.n}, total_area={self.total_area:.6g})"
