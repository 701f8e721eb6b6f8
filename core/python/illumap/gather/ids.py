"""Identities the gather's rays follow from (no bpy): each surfel's, triangle's and lattice
point's, from its object's name and its place there, not from its row in the scene; and
which triangles the gather takes as two-sided, and which surfel each splat stands for."""

from __future__ import annotations

import numpy as np

from ..identities import combined_ids, object_ids
from ..stages.scene import Scene


def back_field_rows(scene: Scene, back: np.ndarray) -> np.ndarray:
    """The surfels (rows, (B,) int64) whose light the gather's back field holds, in its order:
    the back faces' (``back``: open surfaces, scans of unknown side), then the points of each
    cloud of known orientation (normals given). A ray that slips between such a cloud's
    splats meets one from behind where Cycles, baking the surface, meets it from the front:
    it takes the point's own light, as the solve's hemisphere shares count it lit
    (``stages.light``). Black there, the bunny scan given its normals read 1% dark over its
    body and 7% at its base in the white furnace, and worse than without its normals."""
    twins = {src.name for src in scene.sources if src.kind == "BACK"}
    one_sided = [np.arange(src.start, src.stop) for src in scene.sources
                 if src.kind == "POINTS" and src.name not in twins]
    return np.concatenate([np.flatnonzero(back)] + one_sided).astype(np.int64)


def back_field_normals(scene: Scene, back: np.ndarray, rows: np.ndarray) -> np.ndarray:
    """The normals (B, 3) of the back field's surfels (``back_field_rows``): a back face's
    own, a one-sided point's turned round (its back)."""
    return np.where(back[rows, None], scene.normals[rows], -scene.normals[rows])


def splat_owners(scene: Scene, back: np.ndarray,
                 back_rows: np.ndarray | None = None) -> tuple[np.ndarray | None, np.ndarray | None]:
    """Per triangle of ``scene.triangles``: the row (int32) in the front field (surfels not in
    ``back``) and in the back field (surfels ``back_rows``, default those in ``back``) of the
    surfel that stands for the point whose splat it is, or -1 (mesh triangles)."""
    if scene.splat_point is None or (scene.splat_point < 0).all():
        return None, None
    # int32: a scan's splats are a dozen triangles per point (the core reads them as they are).
    front_row = (np.cumsum(~back) - 1).astype(np.int32)
    back_row = np.full(len(back), -1, dtype=np.int32)
    rows = np.flatnonzero(back) if back_rows is None else np.asarray(back_rows, dtype=np.int64)
    back_row[rows] = np.arange(len(rows))
    sources = {(src.name, src.kind): src for src in scene.sources}
    owner_front = np.full(len(scene.splat_point), -1, dtype=np.int32)
    owner_back = np.full(len(scene.splat_point), -1, dtype=np.int32)
    offset = 0
    for cloud in scene.clouds:
        n = len(cloud.positions)
        mine = (scene.splat_point >= offset) & (scene.splat_point < offset + n)
        surfel = cloud.surfel[scene.splat_point[mine] - offset]
        points = sources[(cloud.name, "POINTS")]
        owner_front[mine] = front_row[points.start + surfel]
        twin = sources.get((cloud.name, "BACK"), points)
        owner_back[mine] = back_row[twin.start + surfel]
        offset += n
    return owner_front, owner_back


def triangle_ids(scene: Scene, rows: np.ndarray | None = None) -> np.ndarray:
    """Each triangle's identity (T,) int64 in ``scene.triangles`` (``rows``: only those
    triangles' (R,), in that order): its mesh's name and its row among that mesh's triangles,
    or its point and its place in that point's splat; not its row in the scene, which the
    objects before it set. Only the triangles asked for are worked on (a scan has a dozen
    splat triangles per point; the lattices lie on a few mesh triangles)."""
    count = len(scene.triangles)
    rows = (np.arange(count, dtype=np.int64) if rows is None
            else np.asarray(rows, dtype=np.int64).reshape(-1))
    ids = np.zeros(len(rows), dtype=np.int64)
    point = scene.splat_point
    mesh_end = count if point is None else int((point < 0).sum())
    meshes = [src.name for src in scene.sources if src.kind == "MESH"]
    starts = [int(a) for a in (scene.mesh_triangle_start if scene.mesh_triangle_start is not None
                               else [0])]
    for name, lo, hi in zip(meshes, starts, starts[1:] + [mesh_end]):
        mine = (rows >= lo) & (rows < hi)
        if mine.any():
            ids[mine] = object_ids(name, rows[mine] - lo)
    splat = rows >= mesh_end
    if splat.any():
        # The splats follow the meshes, each point's together, points in order: a triangle's
        # place in its splat is its distance from the first row of its point.
        points = np.asarray(point[rows[splat]], dtype=np.int64)
        first = mesh_end + np.searchsorted(point[mesh_end:], points, side="left")
        ids[splat] = combined_ids(points, rows[splat] - first)
    return ids


def lattice_ids(scene: Scene, triangle: np.ndarray) -> np.ndarray:
    """The identities (L,) int64 of lattice points given by the triangle each lies in, in the
    order ``gather_lattices`` gives them (each triangle's together): its triangle's identity
    and its place there. A far object, a move or a scaling leaves them as they are."""
    triangle = np.asarray(triangle, dtype=np.int64)
    if not len(triangle):
        return np.zeros(0, dtype=np.int64)
    first = np.flatnonzero(np.r_[True, np.diff(triangle) != 0])
    place = np.arange(len(triangle)) - np.repeat(first, np.diff(np.r_[first, len(triangle)]))
    return combined_ids(triangle_ids(scene, triangle), place)


def surfel_ids(scene: Scene) -> np.ndarray:
    """Each surfel's identity (N,) int64, which its rays follow from: its object's name and its
    row within the object (both sides of a point alike), whatever else the scene holds."""
    ids = np.zeros(scene.count, dtype=np.int64)
    for src in scene.sources:
        ids[src.start:src.stop] = object_ids(src.name, np.arange(src.stop - src.start))
    return ids


def gather_sides(scene: Scene) -> np.ndarray | None:
    """``scene.two_sided`` as the gather takes it: an open mesh none of whose back faces kept a
    surfel (they face only the black world, ``the reader's back-face probe``: nothing sees
    them) is one-sided there. Its back then sends nothing, as the solve had it, and the gather
    tabulates no back lattice over it, which would look the back field up from surfels metres
    away (a ground plane's underside took most of the receivers' tables on the open bench
    scene at Target 1%)."""
    sided = scene.two_sided
    if sided is None or scene.mesh_triangle_start is None:
        return sided
    live = {src.name for src in scene.sources if src.kind == "BACK"}
    meshes = [src.name for src in scene.sources if src.kind == "MESH"]
    starts = [int(a) for a in scene.mesh_triangle_start]
    mesh_end = len(sided) if scene.splat_point is None else int((scene.splat_point < 0).sum())
    out = sided.copy()
    for name, lo, hi in zip(meshes, starts, starts[1:] + [mesh_end]):
        if name not in live:
            out[lo:hi] = False
    return out


def with_splat_backs(scene: Scene, sides: np.ndarray | None) -> np.ndarray | None:
    """``sides`` (``gather_sides``) with every splat two-sided: a one-sided cloud's back
    shows its point's light (``back_field_rows``)."""
    if sides is None or scene.splat_point is None:
        return sides
    return np.asarray(sides, dtype=bool) | (scene.splat_point >= 0)
