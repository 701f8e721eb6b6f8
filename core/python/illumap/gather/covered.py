"""Receivers that another surface lies flat against (a box's bottom on a floor): no light
reaches them, as in Cycles (no bpy)."""

from __future__ import annotations

import numpy as np

from ..stages.scene import Scene


#: A surface pressed against a receiver hides it when one of its triangles faces the receiver
#: (normals more opposite than this cosine) and contains the receiver's point.
COVER_COS = -0.9
_COVER_NEIGHBOURS = 16
_COVER_OTHERS = 32            # other meshes' triangles near a receiver that could cover it
_EDGE_SLACK = 1e-9            # barycentric, of a triangle's own size
_COVER_CHUNK = 8192           # receivers per batch of triangle tests (≤ 40 MB)


def covered_receivers(scene: Scene, points: np.ndarray, normals: np.ndarray, tolerance: float,
                      owners: np.ndarray | None = None) -> np.ndarray:
    """bool (M,): receivers that another surface lies flat against, facing them (a box's
    bottom on a floor). Rays lifted off such a receiver would start beyond the covering
    surface and see past it, so no light reaches them, as in Cycles. Candidates are the
    triangles of the meshes' front-face surfels nearest to each receiver, and, where the
    nearest triangle of another mesh lies flat against it, that mesh's nearest triangles by
    centroid (``owners`` (M,): each receiver's mesh, its index among the MESH sources, or
    -1): a box's own surfels crowd its bottom's neighbourhood, and a sparse floor's
    triangles hold fewer than one surfel each. One covers it when it faces the receiver,
    lies within ``tolerance`` (m) of its plane and contains its point."""
    from ..neighbours import knn
    sources = [src for src in scene.sources if src.kind == "MESH"]
    if not sources or len(points) == 0 or scene.triangles is None or scene.mesh_triangle_start is None:
        return np.zeros(len(points), dtype=bool)
    points = np.ascontiguousarray(points, dtype=np.float64)
    rows = np.concatenate([np.arange(src.start, src.stop) for src in sources])
    source = np.concatenate([np.full(src.stop - src.start, i) for i, src in enumerate(sources)])
    triangle = scene.mesh_triangle_start[source] + scene.triangle[rows]
    k = min(_COVER_NEIGHBOURS, len(rows))
    idx, dist = knn(scene.positions[rows], points, k)
    # A triangle that covers a point holds it within ``tolerance`` of its plane, and its
    # surfel lies in it too: no farther from the point than the triangle's longest edge
    # and the tolerance. Only points near such a surfel are tested (a scan's points far
    # from every mesh, most of them, are not).
    corners = scene.triangles[triangle]
    longest = np.sqrt(np.max([((corners[:, a] - corners[:, b]) ** 2).sum(axis=1)
                              for a, b in ((0, 1), (1, 2), (2, 0))], axis=0))
    near = np.flatnonzero((dist <= longest[idx] * (1 + 1e-6) + tolerance).any(axis=1))
    covered = np.zeros(len(points), dtype=bool)
    covered[near] = _covered(scene.triangles, triangle[idx[near]], points[near], normals[near],
                             tolerance)
    if owners is None:
        return covered
    # Where the nearest triangle of another mesh lies flat against the point: that mesh's
    # nearest triangles by centroid, with or without surfels.
    ends = np.append(scene.mesh_triangle_start, _mesh_triangle_end(scene))
    mesh_of = np.repeat(np.arange(len(sources)), np.diff(ends))
    centroids = scene.triangles[:ends[-1]].mean(axis=1)
    for i in np.unique(owners[owners >= 0]):
        others = np.flatnonzero(mesh_of != i)
        mine = np.flatnonzero((owners == i) & ~covered)
        if len(mine) == 0 or len(others) == 0:
            continue
        tree = np.ascontiguousarray(centroids[others])
        nearest, _ = knn(tree, points[mine], 1)
        first = scene.triangles[others[nearest[:, 0]]]
        face = np.cross(first[:, 1] - first[:, 0], first[:, 2] - first[:, 0])
        face /= np.maximum(np.linalg.norm(face, axis=1, keepdims=True), 1e-300)
        flat = (np.abs(np.einsum("mc,mc->m", points[mine] - first[:, 0], face)) < tolerance) & \
            (np.einsum("mc,mc->m", face, normals[mine]) < COVER_COS)
        mine = mine[flat]
        if len(mine) == 0:
            continue
        got, _ = knn(tree, points[mine], min(_COVER_OTHERS, len(others)))
        covered[mine] = _covered(scene.triangles, others[got], points[mine],
                                 normals[mine], tolerance)
    return covered


def _mesh_triangle_end(scene: Scene) -> int:
    """Where the meshes' triangles end in ``scene.triangles`` (the clouds' splats follow)."""
    if scene.splat_point is None:
        return len(scene.triangles)
    splats = np.flatnonzero(scene.splat_point >= 0)
    return int(splats[0]) if len(splats) else len(scene.triangles)


def _covered(triangles: np.ndarray, candidates: np.ndarray, points: np.ndarray,
             normals: np.ndarray, tolerance: float) -> np.ndarray:
    """``_covered_by`` over ``candidates`` (M, k) rows of ``triangles``, in chunks."""
    return np.concatenate([_covered_by(triangles[candidates[lo:lo + _COVER_CHUNK]],
                                       points[lo:lo + _COVER_CHUNK],
                                       normals[lo:lo + _COVER_CHUNK], tolerance)
                           for lo in range(0, len(points), _COVER_CHUNK)]) \
        if len(points) else np.zeros(0, dtype=bool)


def _covered_by(tri: np.ndarray, points: np.ndarray, normals: np.ndarray,
                tolerance: float) -> np.ndarray:
    """Whether any of each receiver's candidate triangles (M, k, 3, 3) covers it."""
    e1, e2 = tri[:, :, 1] - tri[:, :, 0], tri[:, :, 2] - tri[:, :, 0]
    normal = np.cross(e1, e2)
    normal /= np.maximum(np.linalg.norm(normal, axis=2, keepdims=True), 1e-300)
    facing = np.einsum("mkc,mc->mk", normal, normals) < COVER_COS
    rel = points[:, None, :] - tri[:, :, 0]
    close = np.abs(np.einsum("mkc,mkc->mk", rel, normal)) < tolerance
    # Barycentric coordinates of the point's projection (Ericson, Real-Time Collision Detection).
    d00, d01, d11 = (np.einsum("mkc,mkc->mk", a, b) for a, b in ((e1, e1), (e1, e2), (e2, e2)))
    d20, d21 = np.einsum("mkc,mkc->mk", rel, e1), np.einsum("mkc,mkc->mk", rel, e2)
    den = d00 * d11 - d01 * d01
    den = np.where(np.abs(den) > 0, den, np.inf)
    v = (d11 * d20 - d01 * d21) / den
    w = (d00 * d21 - d01 * d20) / den
    # A point on a shared edge is inside one of the two triangles, whatever the rounding.
    inside = (v >= -_EDGE_SLACK) & (w >= -_EDGE_SLACK) & (v + w <= 1 + _EDGE_SLACK)
    return (facing & close & inside).any(axis=1)
