"""Receivers that another surface lies flat against (a box's bottom on a floor): no light
reaches them, as in Cycles (no bpy)."""

from __future__ import annotations

import numpy as np

from ..stages.scene import Scene


#: A surface pressed against a receiver hides it when one of its triangles faces the receiver
#: (normals more opposite than this cosine) and contains the receiver's point.
COVER_COS = -0.9
#: Where the receiver lies near one of the triangle's corners, every corner of it must lie
#: within the tolerance and this slope (1.1°) of the receiver's plane.
FLAT_SLOPE = 0.02
#: A receiver this share of a triangle's longest edge from one of its corners touches it
#: there: a point contact unless the triangle lies flat (FLAT_SLOPE).
POINT_CONTACT = 0.1
_COVER_NEIGHBOURS = 16
_COVER_OTHERS = 32            # other meshes' triangles near a receiver that could cover it
_COVER_FIRST = 8              # ... of which these nearest decide whether one may
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
    # A point contact exempts only another mesh's triangle: where a mesh meets itself (an
    # ear folded into a head) the receiver lies on the line where it passes through.
    other = None if owners is None else source[idx[near]] != np.asarray(owners)[near, None]
    covered[near] = _covered(scene.triangles, triangle[idx[near]], points[near], normals[near],
                             tolerance, other)
    if owners is None:
        return covered
    # Where one of the nearest triangles of other meshes lies flat against the point, their
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
        # Any of the nearest few, not only the nearest: where two boxes' bottoms overlap on a
        # floor, the other box's bottom is as near as the floor and faces the same way.
        nearest, _ = knn(tree, points[mine], min(_COVER_FIRST, len(others)))
        first = scene.triangles[others[nearest]]
        face = np.cross(first[:, :, 1] - first[:, :, 0], first[:, :, 2] - first[:, :, 0])
        face /= np.maximum(np.linalg.norm(face, axis=2, keepdims=True), 1e-300)
        flat = ((np.abs(np.einsum("mkc,mkc->mk", points[mine, None] - first[:, :, 0], face))
                 < tolerance)
                & (np.einsum("mkc,mc->mk", face, normals[mine]) < COVER_COS)).any(axis=1)
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
             normals: np.ndarray, tolerance: float, contacts=None) -> np.ndarray:
    """``_covered_by`` over ``candidates`` (M, k) rows of ``triangles``, in chunks."""
    return np.concatenate([_covered_by(triangles[candidates[lo:lo + _COVER_CHUNK]],
                                       points[lo:lo + _COVER_CHUNK],
                                       normals[lo:lo + _COVER_CHUNK], tolerance,
                                       None if contacts is None
                                       else contacts[lo:lo + _COVER_CHUNK])
                           for lo in range(0, len(points), _COVER_CHUNK)]) \
        if len(points) else np.zeros(0, dtype=bool)


def _covered_by(tri: np.ndarray, points: np.ndarray, normals: np.ndarray,
                tolerance: float, contacts=None) -> np.ndarray:
    """Whether any of each receiver's candidate triangles (M, k, 3, 3) covers it.
    ``contacts`` (M, k) bool: the candidates that may touch it at a point without covering
    it (None: all)."""
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
    # A point contact is no cover: a sphere's pole touches a floor at one vertex, its fan's
    # triangles (tilted 5.6°) hold the floor's vertex there and the floor's hold the pole's
    # corners, yet both open into the wedge between them, which Cycles bakes at 0.86 in the
    # white furnace, not 0. A triangle covers a receiver near one of its corners only when
    # it lies flat against it: every corner within ``tolerance`` and a tilt of FLAT_SLOPE of
    # the receiver's plane. (Elsewhere the shading normal of a smooth mesh, tilted from its
    # face, says too little to ask that.)
    m, j = np.nonzero(facing & close & inside)
    to = tri[m, j] - points[m, None, :]
    far = np.linalg.norm(to, axis=2)
    e3 = e2[m, j] - e1[m, j]
    edge = np.sqrt(np.maximum(np.maximum(d00[m, j], d11[m, j]), np.einsum("kc,kc->k", e3, e3)))
    at_corner = far.min(axis=1) < POINT_CONTACT * edge
    if contacts is not None:
        at_corner &= np.asarray(contacts, dtype=bool)[m, j]
    height = np.abs(np.einsum("kvc,kc->kv", to, normals[m]))
    flat = (height <= tolerance + FLAT_SLOPE * far).all(axis=1)
    covered = np.zeros(len(points), dtype=bool)
    covered[m[flat | ~at_corner]] = True
    return covered
