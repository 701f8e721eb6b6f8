"""Checks of the arrays that callers hand to Illumap: read as float64, finite, of the expected
shape, each failure an :class:`~illumap.surfels.InputError` that names the array and the entry.
Big arrays (a scan's 12M splat triangles) are checked a chunk of rows at a time, so the check's
own mask stays small."""

from __future__ import annotations

import numpy as np

from .surfels import InputError


def read_float_array(value, name: str) -> np.ndarray:
    """``value`` as a C-contiguous float64 array, or an InputError naming ``name``."""
    try:
        return np.ascontiguousarray(value, dtype=np.float64)
    except (TypeError, ValueError) as exc:
        raise InputError(f"{name}: cannot be read as a float array ({exc})") from None


def require_finite(array: np.ndarray, name: str) -> np.ndarray:
    """``array`` unchanged, or an InputError naming its first non-finite entry."""
    bad = ~np.isfinite(array)
    if bad.any():
        index = np.unravel_index(int(np.flatnonzero(bad.ravel())[0]), bad.shape)
        where = ", ".join(str(int(i)) for i in index)
        raise InputError(f"{name}[{where}] = {array[index]!r} is not finite")
    return array


def check_values(values, n: int, name: str = "values") -> np.ndarray:
    """Validate an N×3 array of per-surfel values (finite) and return it as float64 C."""
    array = read_float_array(values, name)
    if array.shape != (n, 3):
        raise InputError(f"{name}: expected shape (N, 3) = ({n}, 3), got {array.shape}")
    return require_finite(array, name)


#: Rows checked at once by ``first_nonfinite_row``: a scan's 12M splat triangles checked whole
#: took a 107 MB mask, twice per solve.
FINITE_CHECK_ROWS = 1 << 16


def first_nonfinite_row(array: np.ndarray) -> int:
    """The first row of ``array`` (any shape, rows along axis 0) holding a value that is not
    finite, or -1; checked ``FINITE_CHECK_ROWS`` rows at a time, so the mask stays small."""
    for lo in range(0, len(array), FINITE_CHECK_ROWS):
        part = array[lo:lo + FINITE_CHECK_ROWS]
        if not np.isfinite(part).all():
            rows = np.isfinite(part.reshape(len(part), -1)).all(axis=1)
            return lo + int(np.flatnonzero(~rows)[0])
    return -1
