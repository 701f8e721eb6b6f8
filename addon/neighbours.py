"""k nearest neighbours: the core's native ``illumap._core.knn`` when present, else numpy.

The numpy fallback is a chunked brute force (O(N·M), for small inputs and for running the
add-on's tests before the native module is built).
"""

from __future__ import annotations

import numpy as np


def knn(points: np.ndarray, queries: np.ndarray, k: int) -> tuple[np.ndarray, np.ndarray]:
    """Indices (M, k) int64 and distances (M, k) float64 (m) of each query's k nearest points.

    Sorted by distance. A query that coincides with a point finds it (distance 0).
    """
    points = np.ascontiguousarray(points, dtype=np.float64)
    queries = np.ascontiguousarray(queries, dtype=np.float64)
    k = int(min(k, len(points)))
    try:
        from illumap import _core  # noqa: PLC0415 - optional native fast path
        idx, dist = _core.knn(points, queries, k)
        return np.asarray(idx, dtype=np.int64), np.asarray(dist, dtype=np.float64)
    except (ImportError, AttributeError):
        pass
    idx = np.empty((len(queries), k), dtype=np.int64)
    dist = np.empty((len(queries), k), dtype=np.float64)
    pp = np.einsum("ij,ij->i", points, points)
    chunk = max(1, 4_000_000 // max(len(points), 1))
    for s in range(0, len(queries), chunk):
        q = queries[s:s + chunk]
        d2 = np.einsum("ij,ij->i", q, q)[:, None] + pp[None, :] - 2.0 * q @ points.T
        part = np.argpartition(d2, k - 1, axis=1)[:, :k] if k < len(points) else \
            np.broadcast_to(np.arange(len(points)), (len(q), len(points))).copy()
        pd = np.take_along_axis(d2, part, axis=1)
        order = np.argsort(pd, axis=1, kind="stable")
        idx[s:s + chunk] = np.take_along_axis(part, order, axis=1)
        dist[s:s + chunk] = np.sqrt(np.maximum(np.take_along_axis(pd, order, axis=1), 0.0))
    return idx, dist
