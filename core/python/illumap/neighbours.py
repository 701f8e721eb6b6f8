"""k nearest neighbours of points (the native k-d search), with checked inputs."""

from __future__ import annotations

import numpy as np

from .surfels import InputError

__all__ = ["knn"]


def knn(points: np.ndarray, queries: np.ndarray, k: int, *, threads: int = 0,
        progress=None) -> tuple[np.ndarray, np.ndarray]:
    """Indices (M, k) int64 and distances (M, k) float64 (in the points' unit, m) of each
    query's ``k`` nearest points, nearest first; ``k`` is clamped to the number of points.
    A query that coincides with a point finds it (distance 0).

    ``threads``: worker threads (0: all); ``progress(fraction, phase)`` may cancel
    (:class:`illumap.Cancelled`). Raises InputError for arrays that are not (N, 3) finite
    numbers, no points, or ``k`` < 1.
    """
    from . import _core

    points = _coordinates(points, "points")
    queries = _coordinates(queries, "queries")
    if len(points) == 0:
        raise InputError("knn needs at least one point")
    if int(k) < 1:
        raise InputError(f"knn needs k >= 1, got {k}")
    k = min(int(k), len(points))
    if len(queries) == 0:
        return np.empty((0, k), dtype=np.int64), np.empty((0, k), dtype=np.float64)
    idx, dist = _core.knn(points, queries, k, threads=threads, progress=progress)
    return np.asarray(idx, dtype=np.int64), np.asarray(dist, dtype=np.float64)


def _coordinates(values, name: str) -> np.ndarray:
    array = np.ascontiguousarray(values, dtype=np.float64)
    if array.ndim != 2 or array.shape[1] != 3:
        raise InputError(f"knn: {name} must be an (N, 3) array, got shape {array.shape}")
    if not np.isfinite(array).all():
        bad = int(np.flatnonzero(~np.isfinite(array).all(axis=1))[0])
        raise InputError(f"knn: {name}[{bad}] is not finite ({array[bad].tolist()})")
    return array
