"""Normals for point clouds without them (scans): PCA, then a consistent orientation.

API::

    normals = estimate_normals(points, k=12)               # (P, 3) unit, oriented
    normals, parts = orient_normals(points, normals, k=12)  # flips given unoriented normals

A PCA normal (smallest eigenvector of the covariance of the k nearest neighbours) has no sign.
Orienting each one on its own, say away from the centroid, flips every surface that faces the
centroid: the inside of a torus, the far side of a bunny's thin ear, a concave fold. Such a
surfel faces into the object, receives no light, and its value depends on how finely the
object is sampled (so a solution on it does not converge as the density grows).

``orient_normals`` makes neighbours agree instead (Hoppe et al., "Surface reconstruction from
unorganized points", 1992): the minimum spanning forest of the k-NN graph weighted by
1 − |nᵢ·nⱼ| carries the sign from point to point along the smoothest paths, so it crosses
between two close sheets only where nothing smoother connects them. One sign per connected
part is left, and a vote decides it: the heuristic direction of every point (away from the
part's centroid where the normal is clearly radial, |cos| ≥ 0.3; else +Z, for flat patches
such as floors), weighted by agreement. Surfaces that face their centroid (a scanned room from
inside) need their normals given. Native (``illumap._core.orient_normals``, O(P k log(P k))).
"""

from __future__ import annotations

from typing import Callable

import numpy as np

from .surfels import InputError

__all__ = ["estimate_normals", "pca_normals", "plane_normals", "orient_normals",
           "orientation_hints", "plane_through", "settled_normals", "receiver_normals",
           "DEFAULT_K"]

#: Neighbours for the PCA and the orientation graph.
DEFAULT_K = 12
#: |cos| between a normal and the centroid direction below which the hint is +Z instead.
RADIAL_COS = 0.3


def _checked_points(points: np.ndarray, name: str = "points") -> np.ndarray:
    pts = np.ascontiguousarray(points, dtype=np.float64)
    if pts.ndim != 2 or pts.shape[1] != 3:
        raise InputError(f"{name}: expected shape (P, 3), got {pts.shape}")
    bad = np.flatnonzero(~np.all(np.isfinite(pts), axis=1))
    if len(bad):
        raise InputError(f"{name}: {len(bad)} rows contain NaN or infinite values "
                         f"(first at index {bad[0]})")
    return pts


def orientation_hints(points: np.ndarray, normals: np.ndarray,
                      part: np.ndarray | None = None) -> np.ndarray:
    """Preferred directions (P, 3) for the sign vote: the unit direction away from the
    centroid of the point's connected ``part`` (default: of all points) where
    |cos(normal, direction)| ≥ 0.3, else +Z."""
    if part is None:
        part = np.zeros(len(points), np.int64)
    count = np.bincount(part).astype(np.float64)
    centre = np.stack([np.bincount(part, points[:, c]) for c in range(3)], axis=1)
    centre /= np.maximum(count, 1.0)[:, None]
    out = points - centre[part]
    out /= np.maximum(np.linalg.norm(out, axis=1, keepdims=True), 1e-300)
    cos = np.einsum("ij,ij->i", normals, out)
    out[np.abs(cos) < RADIAL_COS] = (0.0, 0.0, 1.0)
    return out


def _oriented(pts: np.ndarray, normals: np.ndarray, neighbours: np.ndarray,
              hints: np.ndarray | None, threads: int, progress) -> tuple[np.ndarray, int]:
    from . import _core
    oriented, part = _core.orient_normals(pts, np.ascontiguousarray(normals),
                                          np.ascontiguousarray(neighbours, dtype=np.int64),
                                          threads=threads, progress=progress)
    oriented, part = np.asarray(oriented), np.asarray(part)
    if hints is None:
        hints = orientation_hints(pts, oriented, part)
    hints = _checked_points(hints, "hints")
    if hints.shape != pts.shape:
        raise InputError(f"hints: expected shape {pts.shape}, got {hints.shape}")
    vote = np.bincount(part, np.einsum("ij,ij->i", oriented, hints))
    oriented[vote[part] < 0] *= -1.0
    return oriented, len(vote)


def orient_normals(points: np.ndarray, normals: np.ndarray, k: int = DEFAULT_K, *,
                   hints: np.ndarray | None = None, threads: int = 0,
                   progress: Callable[[float, str], bool | None] | None = None
                   ) -> tuple[np.ndarray, int]:
    """Consistently oriented copy of unit ``normals`` (P, 3) at ``points`` (P, 3, m).

    ``hints`` (P, 3): directions the normals should rather face (default
    :func:`orientation_hints`, per connected part); each connected part of the k-NN graph
    takes the sign that agrees with them best. Returns (normals, number of connected parts).
    """
    from . import _core
    pts = _checked_points(points)
    nrm = _checked_points(normals, "normals")
    if nrm.shape != pts.shape:
        raise InputError(f"normals: expected shape {pts.shape}, got {nrm.shape}")
    if len(pts) < 2:
        return nrm.copy(), len(pts)
    k = int(min(max(int(k), 1), len(pts) - 1))
    idx, _ = _core.knn(pts, pts, k + 1, threads=threads)
    return _oriented(pts, nrm, idx, hints, threads, progress)


def estimate_normals(points: np.ndarray, k: int = DEFAULT_K, *, threads: int = 0,
                     progress: Callable[[float, str], bool | None] | None = None,
                     neighbours: np.ndarray | None = None) -> np.ndarray:
    """Unit normals (P, 3) of a point cloud (P, 3, m): the plane that most of the ``k``
    nearest neighbours lie on (``plane_normals``; PCA on a smooth surface), oriented by
    :func:`orient_normals`. ``neighbours``: the search :func:`nearest` made for the same
    points and ``k``, when the caller has it (it is not made again)."""
    pts = _checked_points(points)
    if len(pts) < 3:
        raise InputError(f"points: PCA normals need at least 3 points, got {len(pts)}")
    idx = _neighbours(pts, k, threads) if neighbours is None else neighbours
    return _oriented(pts, plane_normals(pts, idx, threads=threads, progress=progress), idx,
                     None, threads, progress)[0]


def _neighbours(pts: np.ndarray, k: int, threads: int) -> np.ndarray:
    from . import _core
    kk = int(min(max(int(k), 2), len(pts) - 1))
    idx, _ = _core.knn(pts, pts, kk + 1, threads=threads)
    return np.asarray(idx)


def nearest(points: np.ndarray, k: int = DEFAULT_K, *, threads: int = 0) -> np.ndarray:
    """Each point's ``k`` nearest points and itself (P, k + 1) int64, as
    :func:`estimate_normals` and :func:`pca_normals` search them (k clamped to [2, P - 1]),
    so that a caller needing both searches once."""
    return _neighbours(_checked_points(points), k, threads)


def pca_normals(points: np.ndarray, k: int = DEFAULT_K, *, threads: int = 0,
                neighbours: np.ndarray | None = None) -> np.ndarray:
    """Unit normals (P, 3), unoriented: the smallest eigenvector of the covariance of each
    point's ``k`` nearest neighbours (itself included). Where two surfaces meet it tilts
    between them: the mean of the surfaces, which is what a vertex on a crease shows.
    ``neighbours``: as for :func:`estimate_normals`. Native
    (``illumap._core.covariance_normals``)."""
    from . import _core
    pts = _checked_points(points)
    if len(pts) < 3:
        raise InputError(f"points: PCA normals need at least 3 points, got {len(pts)}")
    idx = _neighbours(pts, k, threads) if neighbours is None else neighbours
    return np.asarray(_core.covariance_normals(pts, idx, threads=threads))


#: A neighbour lies on a candidate plane within this fraction of the median neighbour distance.
PLANE_INLIER = 0.2
#: Fewer of the neighbours than this share on the best plane: no plane stands out (a curved,
#: unevenly sampled patch), and all of them count (PCA).
PLANE_SHARE = 0.5
#: ... or when they spread along a line: their second variance below this share of the first.
PLANE_SPREAD = 0.05


def plane_normals(points: np.ndarray, neighbours: np.ndarray, *, threads: int = 0,
                  progress: Callable[[float, str], bool | None] | None = None) -> np.ndarray:
    """Unit normals (P, 3), unoriented, of the planes through each point that most of its
    ``neighbours`` (P, 1 + k indices, the point first) lie on. Where two surfaces meet (a
    floor along a wall), a PCA over all neighbours tilts between them, and a splat on such a
    tilted plane stands up out of the floor; here each pair of neighbours proposes the plane
    through it and the point, the plane with the most neighbours within ``PLANE_INLIER`` of
    the median neighbour distance wins (the smaller total distance breaks ties), and a PCA
    over its neighbours gives the normal. On a single smooth surface every neighbour agrees
    and this is PCA. Native (``illumap._core.plane_normals``; O(P k³))."""
    from . import _core
    return np.asarray(_core.plane_normals(
        _checked_points(points), np.ascontiguousarray(neighbours, dtype=np.int64),
        inlier=PLANE_INLIER, share=PLANE_SHARE, spread=PLANE_SPREAD, threads=threads,
        progress=progress))


#: Points (with the point) on a line: their second spread below this share of the first.
ON_A_LINE = 0.05


def plane_through(offsets: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The plane through a point and its chosen neighbours: ``offsets`` (..., k, 3) are the
    neighbours minus the point, zero rows for those left out. Returns its unit normal
    (..., 3), sign arbitrary, and whether the points lie on a line through the point instead
    (..., bool), where no plane is defined."""
    spread, axes = np.linalg.eigh(np.einsum("...kc,...kd->...cd", offsets, offsets))
    return axes[..., 0], spread[..., 1] < ON_A_LINE ** 2 * spread[..., 2]


#: ``settled_normals`` fits each point's plane through this many nearest points ...
SETTLE_NEIGHBOURS = 8
#: ... of those whose normal is within acos(this) of its own (either orientation) ...
SETTLE_COS = 0.9
#: ... when at least this many are (itself included); else it keeps its normal.
SETTLE_MIN_POINTS = 4


def settled_normals(positions, normals, neighbours: np.ndarray | None = None) -> np.ndarray:
    """Each point's normal refitted as the plane through it and those of its
    ``SETTLE_NEIGHBOURS`` nearest points on the same surface (normals within acos
    ``SETTLE_COS``), oriented as given. A fit over all neighbours tilts beside an edge, where
    the other surface's points are among them (a block's side 6° downwards next to the floor
    it stands on): its splat, in that plane, then stands off the true surface by a tenth of
    the spacing at its far end and shadows the points along the edge. Returns (N, 3).
    ``neighbours``: the points' own search (P, SETTLE_NEIGHBOURS + 1 or more columns, the
    point first, as :func:`nearest` makes it; its first SETTLE_NEIGHBOURS + 1 are read: knn
    keeps ties to the lower index, so they are what that narrower search finds) when the
    caller has it; else it is made here. Native (``illumap._core.settled_normals``)."""
    from . import _core
    p = np.ascontiguousarray(positions, dtype=np.float64)
    n = np.ascontiguousarray(normals, dtype=np.float64)
    if len(p) < SETTLE_MIN_POINTS:
        return n
    columns = min(SETTLE_NEIGHBOURS + 1, len(p))
    shape = np.shape(neighbours) if neighbours is not None else ()
    if len(shape) == 2 and shape[0] == len(p) and shape[1] >= columns:
        idx = np.ascontiguousarray(neighbours[:, :columns], dtype=np.int64)
    else:
        idx, _ = _core.knn(p, p, columns)
    return np.asarray(_core.settled_normals(p, n, idx, same_cos=SETTLE_COS,
                                            min_points=SETTLE_MIN_POINTS, on_a_line=ON_A_LINE))


#: A neighbour whose fitted plane turns from the point's by more than acos(this) lies on
#: another surface (the preview splats' ``splats.PREVIEW_EDGE_COS``).
RECEIVER_TURN_COS = 0.9
#: ... and a point whose PCA normal tilts from its plane by more than this (degrees) lies on
#: the crease itself.
RECEIVER_CREASE_TILT = 30.0


def receiver_normals(points: np.ndarray, normals: np.ndarray,
                     neighbours: np.ndarray) -> np.ndarray:
    """The unit normals (P, 3) a scan without normals is lit about, oriented as ``normals``
    (P, 3, :func:`estimate_normals`' planes) at ``points`` (P, 3, m), from the same search
    ``neighbours`` (P, 1 + k, the point first, :func:`nearest`).

    The PCA over all neighbours (:func:`pca_normals`): on a curved surface the smooth normal,
    as a mesh's vertex normal is. But beside a crease, where some neighbour's plane turns
    from the point's by more than acos ``RECEIVER_TURN_COS`` and the PCA tilts by less than
    ``RECEIVER_CREASE_TILT`` from the point's plane, that tilt is the other surface's points
    pulling it, and the point's own plane is taken: lit about the tilt, a point a row below
    a lit box's top edge took the top's light, and the preview drew a bright band down the
    box's dark front face. A point tilted further lies on the crease itself; the gather
    lights it by the faces that meet there (``scan_values.crease_surfaces``, which finds
    them from this tilt). Units: none (directions)."""
    pts = _checked_points(points)
    own = _checked_points(normals, "normals")
    idx = np.ascontiguousarray(neighbours, dtype=np.int64)
    if own.shape != pts.shape or idx.ndim != 2 or len(idx) != len(pts):
        raise InputError(f"receiver_normals: normals {own.shape} and neighbours {idx.shape} "
                         f"must have one row per point ({len(pts)})")
    spread = pca_normals(pts, neighbours=idx)
    cos = np.einsum("ij,ij->i", spread, own)
    spread *= np.where(cos < 0, -1.0, 1.0)[:, None]
    turned = np.zeros(len(pts), dtype=bool)
    for lo in range(0, len(pts), _RECEIVER_CHUNK):      # bounded memory at millions of points
        rows = slice(lo, lo + _RECEIVER_CHUNK)
        turned[rows] = (np.abs(np.einsum("ic,ikc->ik", own[rows], own[idx[rows, 1:]]))
                        < RECEIVER_TURN_COS).any(axis=1)
    beside = turned & (np.abs(cos) >= np.cos(np.radians(RECEIVER_CREASE_TILT)))
    return np.where(beside[:, None], own, spread)


_RECEIVER_CHUNK = 1 << 18
