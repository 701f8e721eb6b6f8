"""Points binned into a regular grid: the first point of each occupied cell, as a sparse and
even sample of a dense scan (the shared probes' sentinels, the thinning of a scan into surfels).
No bpy."""

from __future__ import annotations

import numpy as np


def first_in_each_cell(key: np.ndarray) -> np.ndarray:
    """The first row (ascending rows) of each distinct row of ``key`` (M, D) int ≥ 0: as
    ``np.unique(key, axis=0, return_index=True)``, with the rows packed into one integer
    where they fit (a tenth of the time at a million rows)."""
    key = np.asarray(key, dtype=np.int64)
    if len(key) == 0:
        return np.zeros(0, dtype=np.int64)
    span = key.max(axis=0) + 1
    if (key.min() >= 0) and float(np.prod(span.astype(np.float64))) < 2.0 ** 62:
        code = key[:, 0].copy()
        for d in range(1, key.shape[1]):
            code = code * span[d] + key[:, d]
        _, first = np.unique(code, return_index=True)
    else:
        _, first = np.unique(key, axis=0, return_index=True)
    return np.sort(first)
