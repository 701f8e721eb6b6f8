"""The light at the receivers (DESIGN.md §6): what a user sees, evaluated at the point that
shows it. ``receive`` runs on the worker after the solve (no bpy): the meshes' corners and the
point clouds' points get the lamps' direct light with shadow rays from the receiver, plus the
final gather of the surfels' solved light (``illumap.receivers``) against the scene's
triangles (``mesh_occluders``). Before the gather, the surfels whose disc reaches through
another surface are evaluated as receivers too (``_regather_straddling``), and the gather's
table takes the lamps' light cast at its own points where it changes sharply
(``_exact_direct``), and a receiver facing a surface across a gap finer than that table
takes the light at its rays' hits there afresh (``_across_gaps``). Receivers that another
surface lies flat against get no light (``covered_receivers``). A point cloud's points share
their gathers through an irradiance cache (``illumap.irradiance_cache``,
``Settings.gather_cache``).
"""

from __future__ import annotations

import time
from dataclasses import replace
from typing import Callable

import numpy as np

from illumap import lights
from illumap.identities import combined_ids, object_ids
from illumap.settings import Settings

from . import sampling
from .errors import ExitCode, IllumapCancelled, IllumapError, core_cancelled
from .job import Job, Result

Progress = Callable[[float, str], "bool | None"]


#: With a target error, the gather's noise (relative RMS over the receivers, estimated from
#: the halves of each receiver's ray lattice: ``stats['receivers']['gather_noise']``) is held
#: to this share of the target; its rays, a power of two in [MIN_TARGET_RAYS,
#: MAX_TARGET_RAYS], follow from noise = NOISE_AT_512_RAYS × (512 / rays)^NOISE_EXPONENT. On
#: the bench scenes the estimate was 1.4-2.0% at 64 rays, 0.28-0.37% at 512 and 0.08-0.10% at
#: 2048 (the lattice converges as rays^-0.8, not ^-0.5), and 1.45-2.3x the noise measured
#: with a second seed (bench/reference/gather_noise.py).
GATHER_NOISE_SHARE = 0.5
NOISE_AT_512_RAYS = 0.004
NOISE_EXPONENT = 0.75
MIN_TARGET_RAYS = 64
MAX_TARGET_RAYS = 2048
#: The shadow samples per receiver for a target: ∝ 1/target², a power of two in
#: [MIN_TARGET_SHADOW_SAMPLES, MAX_TARGET_SHADOW_SAMPLES] (no estimate of their noise yet; the
#: counts the bench's targets were met with: bench/results/reference_targets.json).
SHADOW_SAMPLES_AT_2_PERCENT = 128
MIN_TARGET_SHADOW_SAMPLES = 16
MAX_TARGET_SHADOW_SAMPLES = 512


def _power_of_two(wanted: float, low: int, high: int) -> int:
    """The least power of two ≥ ``wanted`` within [low, high] (both powers of two)."""
    count = low
    while count < wanted * (1.0 - 1e-9) and count < high:
        count *= 2
    return count


def receiver_rays(settings: Settings) -> tuple[int, int]:
    """(gather rays, shadow samples) per receiver: the settings', or with a target error the
    fewest gather rays whose predicted noise stays within GATHER_NOISE_SHARE of it, and shadow
    samples ∝ 1/target² (target 10%: 64 / 16, 3%: 128 / 64, 2%: 256 / 128, 1%: 512 / 512)."""
    t = settings.target_error
    if t is None:
        return int(settings.gather_rays), int(settings.receiver_shadow_samples)
    wanted = 512.0 * (NOISE_AT_512_RAYS / (GATHER_NOISE_SHARE * t)) ** (1.0 / NOISE_EXPONENT)
    rays = _power_of_two(wanted, MIN_TARGET_RAYS, MAX_TARGET_RAYS)
    return rays, target_shadow_samples(t)


def target_shadow_samples(target: float) -> int:
    """Shadow rays per point and sized lamp for a relative error ``target`` (0.01 = 1%):
    ∝ 1/target², a power of two in [MIN_TARGET_SHADOW_SAMPLES, MAX_TARGET_SHADOW_SAMPLES]."""
    return _power_of_two(SHADOW_SAMPLES_AT_2_PERCENT * (0.02 / target) ** 2,
                         MIN_TARGET_SHADOW_SAMPLES, MAX_TARGET_SHADOW_SAMPLES)


def more_rays(settings: Settings, gather_noise: float, rays: int) -> int | None:
    """With a target error, the gather rays per receiver that the noise estimated at ``rays``
    asks for, where it exceeds GATHER_NOISE_SHARE of the target (the light at the receivers
    comes from a few bright patches, where the noise model's bench scenes had it spread): the
    noise model's slope from the noise found, a power of two up to MAX_TARGET_RAYS. None
    where the noise is within its share, without a target, or at MAX_TARGET_RAYS already."""
    t = settings.target_error
    if t is None or rays >= MAX_TARGET_RAYS:
        return None
    share = GATHER_NOISE_SHARE * t
    if not gather_noise > share:
        return None
    wanted = rays * (gather_noise / share) ** (1.0 / NOISE_EXPONENT)
    return _power_of_two(wanted, 2 * rays, MAX_TARGET_RAYS)


def gather_noise_warning(settings: Settings, gather_noise: float, rays: int) -> str | None:
    """What to tell a user whose target error the final gather's own noise (relative RMS at
    the receivers, estimated from its rays) already exceeds: the most rays a target casts
    (MAX_TARGET_RAYS) leave about 0.1% on the bench scenes. None otherwise."""
    t = settings.target_error
    if t is None or not gather_noise > t:
        return None
    most = ", the most a target casts" if rays >= MAX_TARGET_RAYS else ""
    return (f"Target error {t:.2%} not met at the objects: the final gather's noise alone is "
            f"estimated at {gather_noise:.2%} ({rays} rays per receiver{most}); loosen the "
            f"target, or turn it off and raise Gather Rays")


def mesh_occluders(job: Job, progress: Progress | None = None):
    """The sampled triangles as a ray-casting scene (``illumap.receivers.MeshOccluders``),
    built once per job; None without mesh triangles. No bpy."""
    if job.occluders is None and job.triangles is not None and len(job.triangles):
        from illumap.receivers import MeshOccluders
        build = None if progress is None else (lambda f, _phase="": progress(0.0, lights.PHASE))
        job.occluders = MeshOccluders(job.triangles, progress=build)
    return job.occluders


#: A corner lies this many times the ray engine's rounding (``MeshOccluders.rounding``) inside
#: its triangle, at least RECEIVER_INSET and at most RECEIVER_INSET_MAX of the way to its
#: centroid.
ROUNDING_CLEARANCE = 4.0
RECEIVER_INSET_MAX = 0.05


def _clear_of_rounding(occ, rec):
    """``rec`` with each corner moved far enough inside its triangle that its rays meet a
    wall standing on its edge: at a room's corner the adjacent wall is as near as the corner
    is inside its face, and rays skip the first ``occ.rounding`` of their way (more, the
    farther the scene reaches from its centre: 20 m out a corner 3e-5 inside saw past the
    wall and read 20% dark)."""
    if rec.inward is None or len(rec.points) == 0:
        return rec
    reach = np.linalg.norm(rec.inward, axis=1)
    share = np.clip(ROUNDING_CLEARANCE * occ.rounding(rec.points) / np.maximum(reach, 1e-300),
                    sampling.RECEIVER_INSET, RECEIVER_INSET_MAX)
    points = rec.points + (share - sampling.RECEIVER_INSET)[:, None] * rec.inward
    return replace(rec, points=points)


def _merged_corners(occ, rec, lamps_=(), pressed=None) -> tuple[np.ndarray, np.ndarray]:
    """Which corners of ``rec`` share one evaluation: corners of one vertex with one normal
    (a flat grid's four) see the same light unless a wall stands on the vertex between them
    or a shadow edge runs through it, so each joins the first such corner when a ray between
    their points (lifted off the surface) is free and, for each of ``lamps_`` (the world
    aside), a shadow ray from each point to the lamp's centre (a sun's central direction)
    finds both lit or both shadowed. A box standing on a floor's grid lines, lit along them,
    puts its shadow's edge through the floor's vertices: the corners on either side of it,
    all the lead's, had read the vertex fully lit or fully dark, where it is half lit.
    ``pressed`` (a callable: bool per corner of the rows it is given): corners another
    surface lies against. A vertex one of whose corners is pressed has a solid standing on it
    (a box's corner on a floor's vertex), and the ray between its other corners grazes that
    solid's edge, which rounding decides: its corners are evaluated each in its own face.
    Returns (the rows to evaluate, each corner's row among them)."""
    if len(rec.points) == 0:
        return np.zeros(0, dtype=np.int64), np.zeros(0, dtype=np.int64)
    key = np.column_stack([rec.corner_vertex, np.round(rec.normals * 1e5).astype(np.int64)])
    _, group = np.unique(key, axis=0, return_inverse=True)
    group = group.ravel()
    # The lead is the corner of least identity, not the first in Blender's loop order, which
    # changes from session to session: the vertex is then evaluated inside the same face.
    by_group = np.lexsort((rec.ids, group))
    starts = np.flatnonzero(np.r_[True, np.diff(group[by_group]) != 0])
    lead = by_group[starts][group]
    others = np.flatnonzero(lead != np.arange(len(lead)))
    joined = np.arange(len(lead))
    if others.size and pressed is not None:
        shared = np.unique(np.concatenate([lead[others], others]))
        touched = np.zeros(len(lead), dtype=bool)
        touched[shared] = pressed(shared)
        solid = np.zeros(int(group.max()) + 1, dtype=bool)
        solid[group[touched]] = True
        others = others[~solid[group[others]]]
    if others.size:
        lift = occ.offset * rec.normals
        free = occ.visible(rec.points[lead[others]] + lift[lead[others]],
                           rec.points[others] + lift[others]) > 0
        for lamp in lamps_:
            if lamp.kind == "WORLD" or not free.any():
                continue
            pair = others[free]
            ends = np.unique(np.concatenate([lead[pair], pair]))   # a lead once, not per pair
            lit = np.zeros(len(lead), dtype=bool)
            grazing = np.zeros(len(lead), dtype=bool)
            lit[ends], cos = _toward_lamp_centre(occ, lamp, rec.points[ends], rec.normals[ends],
                                                 with_cos=True)
            grazing[ends] = cos < GRAZING_COS
            split = (lit[lead[pair]] != lit[pair]) & ~grazing[lead[pair]] & ~grazing[pair]
            free[np.flatnonzero(free)[split]] = False
        joined[others[free]] = lead[others[free]]
    rows, index = np.unique(joined, return_inverse=True)
    return rows, index.ravel()


#: A lamp whose centre a receiver sees within asin(this) of its own plane (0.6°) sends it
#: under 1% of its light head-on, and its shadow ray grazes the surface: its answer flips with
#: the last bit of the scene's placement (an emitter 1 mm under a ceiling split the corners
#: of two ceiling vertices in one placement and not in another, 0.9% apart). Corners do not
#: split on it.
GRAZING_COS = 0.01


def _toward_lamp_centre(occ, lamp, points: np.ndarray, normals: np.ndarray, *,
                        with_cos: bool = False):
    """bool (M,): whether one shadow ray from each receiver to the middle of ``lamp`` (its
    samples' pattern at its centre: a sun's central direction, an area lamp's centre) is
    free, cast as the receivers' shadow rays are; ``with_cos``: and the cosine (M,) between
    each receiver's normal and the direction to that centre."""
    centre = np.full((len(points), 1, 2), 0.5)
    targets, _ = lights._lamp_samples(lamp, points, normals, 1, centre,
                                     4.0 * max(occ.extent, 1e-3))
    targets = targets.reshape(-1, 3)
    query = occ.segment_query(normals)
    lit = np.asarray(query(points, targets, np.arange(len(points)))) > 0
    if not with_cos:
        return lit
    to = targets - points
    cos = np.einsum("ij,ij->i", to, normals) / np.maximum(np.linalg.norm(to, axis=1), 1e-300)
    return lit, cos


#: A surface pressed against a receiver hides it when one of its triangles faces the receiver
#: (normals more opposite than this cosine) and contains the receiver's point.
COVER_COS = -0.9
_COVER_NEIGHBOURS = 16
_COVER_OTHERS = 32            # other meshes' triangles near a receiver that could cover it
_EDGE_SLACK = 1e-9            # barycentric, of a triangle's own size
_COVER_CHUNK = 8192           # receivers per batch of triangle tests (≤ 40 MB)


def covered_receivers(job: Job, points: np.ndarray, normals: np.ndarray, tolerance: float,
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
    from illumap.neighbours import knn
    sources = [src for src in job.sources if src.kind == "MESH"]
    if not sources or len(points) == 0 or job.triangles is None or job.mesh_triangle_start is None:
        return np.zeros(len(points), dtype=bool)
    points = np.ascontiguousarray(points, dtype=np.float64)
    rows = np.concatenate([np.arange(src.start, src.stop) for src in sources])
    source = np.concatenate([np.full(src.stop - src.start, i) for i, src in enumerate(sources)])
    triangle = job.mesh_triangle_start[source] + job.triangle[rows]
    k = min(_COVER_NEIGHBOURS, len(rows))
    idx, dist = knn(job.positions[rows], points, k)
    # A triangle that covers a point holds it within ``tolerance`` of its plane, and its
    # surfel lies in it too: no farther from the point than the triangle's longest edge
    # and the tolerance. Only points near such a surfel are tested (a scan's points far
    # from every mesh, most of them, are not).
    corners = job.triangles[triangle]
    longest = np.sqrt(np.max([((corners[:, a] - corners[:, b]) ** 2).sum(axis=1)
                              for a, b in ((0, 1), (1, 2), (2, 0))], axis=0))
    near = np.flatnonzero((dist <= longest[idx] * (1 + 1e-6) + tolerance).any(axis=1))
    covered = np.zeros(len(points), dtype=bool)
    covered[near] = _covered(job.triangles, triangle[idx[near]], points[near], normals[near],
                             tolerance)
    if owners is None:
        return covered
    # Where the nearest triangle of another mesh lies flat against the point: that mesh's
    # nearest triangles by centroid, with or without surfels.
    ends = np.append(job.mesh_triangle_start, _mesh_triangle_end(job))
    mesh_of = np.repeat(np.arange(len(sources)), np.diff(ends))
    centroids = job.triangles[:ends[-1]].mean(axis=1)
    for i in np.unique(owners[owners >= 0]):
        others = np.flatnonzero(mesh_of != i)
        mine = np.flatnonzero((owners == i) & ~covered)
        if len(mine) == 0 or len(others) == 0:
            continue
        tree = np.ascontiguousarray(centroids[others])
        nearest, _ = knn(tree, points[mine], 1)
        first = job.triangles[others[nearest[:, 0]]]
        face = np.cross(first[:, 1] - first[:, 0], first[:, 2] - first[:, 0])
        face /= np.maximum(np.linalg.norm(face, axis=1, keepdims=True), 1e-300)
        flat = (np.abs(np.einsum("mc,mc->m", points[mine] - first[:, 0], face)) < tolerance) & \
            (np.einsum("mc,mc->m", face, normals[mine]) < COVER_COS)
        mine = mine[flat]
        if len(mine) == 0:
            continue
        got, _ = knn(tree, points[mine], min(_COVER_OTHERS, len(others)))
        covered[mine] = _covered(job.triangles, others[got], points[mine],
                                 normals[mine], tolerance)
    return covered


def _mesh_triangle_end(job: Job) -> int:
    """Where the meshes' triangles end in ``job.triangles`` (the clouds' splats follow)."""
    if job.splat_point is None:
        return len(job.triangles)
    splats = np.flatnonzero(job.splat_point >= 0)
    return int(splats[0]) if len(splats) else len(job.triangles)


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


def _point_receivers(job: Job) -> list[tuple]:
    """Receivers at every point of each point cloud (``(receivers, back)``; ``back`` the same
    points facing the other way for clouds of unknown orientation, else None), in the order
    of their sources."""
    backs = {src.name for src in job.sources if src.kind == "BACK"}
    out = []
    for cloud in job.clouds:
        n = len(cloud.positions)
        make = lambda normals, c=cloud, n=n: sampling.Receivers(  # noqa: E731
            c.name, np.arange(n, dtype=np.int64), c.positions, normals, c.albedo, c.emission, n)
        out.append((make(cloud.normals), make(-cloud.normals) if cloud.name in backs else None))
    return out


def _splat_owners(job: Job, back: np.ndarray) -> tuple[np.ndarray | None, np.ndarray | None]:
    """Per triangle of ``job.triangles``: the row in the front field (surfels not in
    ``back``) and in the back field of the surfel that stands for the point whose splat it
    is, or -1 (mesh triangles)."""
    if job.splat_point is None or (job.splat_point < 0).all():
        return None, None
    front_row = np.cumsum(~back) - 1
    back_row = np.cumsum(back) - 1
    sources = {(src.name, src.kind): src for src in job.sources}
    owner_front = np.full(len(job.splat_point), -1, dtype=np.int64)
    owner_back = np.full(len(job.splat_point), -1, dtype=np.int64)
    offset = 0
    for cloud in job.clouds:
        n = len(cloud.positions)
        mine = (job.splat_point >= offset) & (job.splat_point < offset + n)
        surfel = cloud.surfel[job.splat_point[mine] - offset]
        owner_front[mine] = front_row[sources[(cloud.name, "POINTS")].start + surfel]
        twin = sources.get((cloud.name, "BACK"))
        if twin is not None:
            owner_back[mine] = back_row[twin.start + surfel]
        offset += n
    return owner_front, owner_back


def triangle_ids(job: Job) -> np.ndarray:
    """Each triangle's identity (T,) int64 in ``job.triangles``: its mesh's name and its row
    among that mesh's triangles, or its point and its place in that point's splat; not its
    row in the scene, which the objects before it set."""
    tri = job.triangles
    ids = np.zeros(len(tri), dtype=np.int64)
    owner = (np.full(len(tri), -1, dtype=np.int64) if job.splat_point is None
             else np.asarray(job.splat_point, dtype=np.int64))
    mesh_end = int((owner < 0).sum())
    meshes = [src.name for src in job.sources if src.kind == "MESH"]
    starts = [int(a) for a in (job.mesh_triangle_start if job.mesh_triangle_start is not None
                               else [0])]
    for name, lo, hi in zip(meshes, starts, starts[1:] + [mesh_end]):
        ids[lo:hi] = object_ids(name, np.arange(hi - lo))
    if mesh_end < len(tri):
        points = owner[mesh_end:]
        first = np.flatnonzero(np.r_[True, np.diff(points) != 0])
        rank = np.arange(len(points)) - np.repeat(first, np.diff(np.r_[first, len(points)]))
        ids[mesh_end:] = combined_ids(points, rank)
    return ids


def lattice_ids(job: Job, triangle: np.ndarray) -> np.ndarray:
    """The identities (L,) int64 of lattice points given by the triangle each lies in, in the
    order ``gather_lattices`` gives them (each triangle's together): its triangle's identity
    and its place there. A far object, a move or a scaling leaves them as they are."""
    triangle = np.asarray(triangle, dtype=np.int64)
    if not len(triangle):
        return np.zeros(0, dtype=np.int64)
    first = np.flatnonzero(np.r_[True, np.diff(triangle) != 0])
    place = np.arange(len(triangle)) - np.repeat(first, np.diff(np.r_[first, len(triangle)]))
    return combined_ids(triangle_ids(job)[triangle], place)


def surfel_ids(job: Job) -> np.ndarray:
    """Each surfel's identity (N,) int64, which its rays follow from: its object's name and its
    row within the object (both sides of a point alike), whatever else the scene holds."""
    ids = np.zeros(job.count, dtype=np.int64)
    for src in job.sources:
        ids[src.start:src.stop] = object_ids(src.name, np.arange(src.stop - src.start))
    return ids


def hemisphere_hits(job: Job, progress: Progress | None = None):
    """What each surfel's hemisphere meets (``illumap.conservation.Hemisphere``: the share
    whose first hit is a lit face, and the share open to the world), against the scene's
    triangles and splats; None without triangles. Back faces are lit where the gather has a
    back field (open meshes that kept back surfels) and on every splat. No bpy."""
    occ = mesh_occluders(job, progress)
    if occ is None:
        return None
    from illumap.conservation import hemisphere_hits as hits
    sides = _gather_sides(job)
    lit_backs = (np.ones(len(job.triangles), dtype=bool) if sides is None
                 else np.asarray(sides, dtype=bool).copy())
    if job.splat_point is not None:
        lit_backs |= job.splat_point >= 0
    # The rays belong to the direct light's phase (light() casts them first): its fraction
    # stays where it starts, so the phases keep their order.
    report = None if progress is None else (lambda f, _p="": progress(0.0, lights.PHASE))
    clouds = {cloud.name for cloud in job.clouds}
    points = np.zeros(job.count, dtype=bool)
    # A surfel's rays follow from its object and its row there (both sides of a point alike),
    # so that adding, removing or turning another object changes none of its rays.
    ids = surfel_ids(job)
    for src in job.sources:
        if src.name in clouds:
            points[src.start:src.stop] = True
    return hits(occ, job.positions, job.normals, lit_backs=lit_backs, inset=points, ids=ids,
                seed=job.settings.seed, links=True, progress=report)


#: Shadow rays per lattice point and sized lamp: a hit interpolates three lattice points and
#: a receiver averages hundreds of hits, so the lattice's own noise averages out.
LATTICE_SHADOW_SAMPLES = 4
#: Rays per lattice point that find how much of the sky it sees: the receivers' shadow
#: samples, within [MIN_LATTICE_WORLD_SAMPLES, lights.WORLD_SAMPLES] (the surfels' own count).
#: The sky is most of the light outdoors, so fewer would show.
MIN_LATTICE_WORLD_SAMPLES = 16


def _regather_straddling(job: Job, result: "Result", occ, sent: np.ndarray, back: np.ndarray,
                         owners, back_owners, rays: int, background, sides) -> int:
    """Evaluate the surfels whose disc reaches through another surface
    (``illumap.receivers.straddling_surfels``: a floor's along a wall, a crease's in a scan)
    as receivers are: their direct light plus a gather of the other surfels' light. Their
    solved values scatter by tens of percent where the light is smooth, and a receiver at the
    line where the surfaces meet sees them at close range. Their direct light is the lamps'
    and emitters' (``job.direct_lamps``); the world's comes through the gather's rays that
    leave the scene (``background``); ``sides``: ``_gather_sides``. Updates ``sent`` and
    ``result.radiosity`` in place; returns how many were evaluated."""
    from illumap import receivers as rc
    direct = job.direct_lamps
    if direct is None:
        return 0
    bad = rc.straddling_surfels(job.positions, job.normals, job.areas)
    rows = np.flatnonzero(bad)
    if not rows.size or bad.all():
        return 0

    def good_field(side, owner_rows):
        """The field of this side's surfels that are not re-evaluated, and splat owners
        (rows of the whole side's field) as rows of it."""
        good = side & ~bad
        if not good.any():
            return None, None if owner_rows is None else np.full_like(owner_rows, -1)
        remap = np.full(int(side.sum()), -1, dtype=np.int64)
        remap[good[side]] = np.arange(int(good.sum()))
        own = (None if owner_rows is None
               else np.where(owner_rows >= 0, remap[np.maximum(owner_rows, 0)], -1))
        return rc.SurfelField(job.positions[good], job.normals[good], sent[good]), own

    front_field, own_front = good_field(~back, owners)
    back_field_, own_back = good_field(back, back_owners) if back.any() else (None, None)
    if front_field is None:
        return 0
    # The triangles no good surfel stands for (the re-evaluated surfels' splats, the meshes'
    # own) are tabulated only where that takes fewer lookups than the rays (a dense scan's
    # straddling surfels stand for hundreds of thousands of splat triangles).
    untabled = sum(int((o < 0).sum()) for o in (own_front, own_back) if o is not None) \
        if own_front is not None else 2 * len(job.triangles)
    g = rc.gather(occ, front_field, job.positions[rows], job.normals[rows], rays=rays,
                  seed=job.settings.seed, ids=surfel_ids(job)[rows],
                  background=background, back_field=back_field_, two_sided=sides, owners=own_front,
                  back_owners=own_back, tabulate=3 * untabled <= rows.size * rays)
    sent[rows] = job.solve_emission[rows] + direct[rows] + job.albedo[rows] * g.radiance
    result.radiosity[rows] = sent[rows] + job.emission[rows] - job.solve_emission[rows]
    return int(rows.size)


def _gather_sides(job: Job) -> np.ndarray | None:
    """``job.two_sided`` as the gather takes it: an open mesh none of whose back faces kept a
    surfel (they face only the black world, ``pipeline._back_faces_in_view``: nothing sees
    them) is one-sided there. Its back then sends nothing, as the solve had it, and the gather
    tabulates no back lattice over it, which would look the back field up from surfels metres
    away (a ground plane's underside took most of the receivers' tables on the open bench
    scene at Target 1%)."""
    sided = job.two_sided
    if sided is None or job.mesh_triangle_start is None:
        return sided
    live = {src.name for src in job.sources if src.kind == "BACK"}
    meshes = [src.name for src in job.sources if src.kind == "MESH"]
    starts = [int(a) for a in job.mesh_triangle_start]
    mesh_end = len(sided) if job.splat_point is None else int((job.splat_point < 0).sum())
    out = sided.copy()
    for name, lo, hi in zip(meshes, starts, starts[1:] + [mesh_end]):
        if name not in live:
            out[lo:hi] = False
    return out


def _exact_direct(job: Job, occ, sent: np.ndarray, front: np.ndarray, field_,
                  owners, sides, shadow_samples: int) -> tuple:
    """The gather's ``ExactPart`` for the front field (None without lamp or sky light) and
    the number of lattice points shadow rays were cast from: the reflected direct light of
    the lamps, the emitters and the world at the points where the gather tabulates the
    surfels' light, beside the surfels' light less their own direct part. A hit then sees a
    lamp's shadow edge, or the sky hidden under an object resting on a floor, as sharp as
    that lattice, not blurred over the surfels' spacing: what lights a receiver beside a
    contact or a shadow. Shadow rays are cast only where the surfels' direct light changes
    sharply (``sharpness``, blended in by it); elsewhere their average is as good. The sky
    takes ``shadow_samples`` rays per point (the receivers'; MIN_LATTICE_WORLD_SAMPLES to
    ``lights.WORLD_SAMPLES``), the lamps LATTICE_SHADOW_SAMPLES."""
    from illumap import receivers as rc
    sky = job.world is not None and job.direct is not None
    lit = job.direct if sky else job.direct_lamps
    if lit is None or not np.any(lit[front]):
        return None, 0
    s = job.settings
    all_lamps = list(job.lamps) + list(job.emitters)
    (points, normals, owner), _ = rc.gather_lattices(occ, field_, two_sided=sides, owners=owners,
                                                     triangles=True)
    if not len(points):
        return None, 0
    pos, nrm, direct = job.positions[front], job.normals[front], lit[front]
    weight = rc.sharpness(pos, direct, points)
    values = rc.SurfelField(pos, nrm, direct).at(points, normals, occ)
    sharp = np.flatnonzero(weight > 0)
    if sharp.size:
        p_, n_ = points[sharp], normals[sharp]
        ids = lattice_ids(job, owner)[sharp]   # not their place in the list
        albedo = rc.SurfelField(pos, nrm, job.albedo[front]).at(p_, n_, occ)
        query = occ.segment_query(n_)
        shadows = (lights.Shadows(query, samples=LATTICE_SHADOW_SAMPLES, seed=s.seed,
                                 extent=occ.extent, ids=ids)
                   if all_lamps and s.lamp_shadows else None)
        exact = albedo * lights.incident_radiance(all_lamps, p_, n_, shadows=shadows)
        if sky:
            rays = min(max(int(shadow_samples), MIN_LATTICE_WORLD_SAMPLES), lights.WORLD_SAMPLES)
            sky_shadows = (lights.Shadows(query, samples=rays, seed=s.seed, extent=occ.extent,
                                         ids=ids) if s.lamp_shadows else None)
            exact += albedo * lights.incident_radiance([job.world], p_, n_, shadows=sky_shadows)
        values[sharp] += weight[sharp, None] * (exact - values[sharp])
    return rc.ExactPart(rest=rc.SurfelField(pos, nrm, (sent - lit)[front]),
                        values=values), int(sharp.size)


#: A lattice point is beside a contact where a surfel of a surface facing it lies within this
#: many of that surfel's radii (and it faces that surfel within about 72°, as the surfel faces
#: it): a sphere resting on a floor, a box's foot, a corner.
CONTACT_REACH = 2.0
CONTACT_FACING = 0.3
#: Gather rays per lattice point beside a contact (fewer when the receivers cast fewer): on
#: the sky bench scene 128 and 512 gave the same error.
CONTACT_RAYS = 128


def _beside_contacts(points: np.ndarray, normals: np.ndarray, pos: np.ndarray,
                     nrm: np.ndarray, areas: np.ndarray) -> np.ndarray:
    """Rows of ``points`` (L, 3, facing unit ``normals``) with a surfel (``pos``, ``nrm``,
    ``areas``: m, unit, m²) of another surface facing them within CONTACT_REACH of its
    radii (see there)."""
    from illumap.neighbours import knn
    if not len(points) or not len(pos):
        return np.zeros(0, dtype=np.int64)
    near, dist = knn(pos, points, 8)
    row, col = np.nonzero(dist < CONTACT_REACH * np.sqrt(areas / np.pi)[near])
    q = near[row, col]
    to = pos[q] - points[row]
    d = dist[row, col]
    facing = ((np.einsum("ic,ic->i", normals[row], to) > CONTACT_FACING * d)
              & (np.einsum("ic,ic->i", nrm[q], -to) > CONTACT_FACING * d))
    return np.unique(row[facing])


def _gathered_at_contacts(job: Job, occ, exact, front: np.ndarray, field_, back_field,
                          owners, back_owners, sides, rays: int) -> tuple:
    """Under a sky (the exact part has it), the lattice points of the ``front`` surfels' field
    beside a contact (``_beside_contacts``) take the light between the surfaces gathered
    afresh (``rays`` rays each, the sky's part left to the exact part) in place of the
    surfels' own: where a sphere rests on a floor, both the sky hidden under it and the light
    bounced between them change over less than a surfel's spacing. Returns the exact part and
    how many points gathered. Without a sky the receivers that face such a gap take the light
    at their rays' hits instead (``_across_gaps``): on the lamp-lit bench scenes this gather
    had changed no error by 0.1% and cost a third of the receivers' time."""
    from illumap import receivers as rc
    if exact is None or job.world is None:
        return exact, 0
    (points, normals, owner), _ = rc.gather_lattices(occ, field_, two_sided=sides, owners=owners,
                                                     triangles=True)
    beside = _beside_contacts(points, normals, job.positions[front], job.normals[front],
                              job.areas[front])
    if not beside.size:
        return exact, 0
    p_, n_ = points[beside], normals[beside]
    gathered = rc.gather(occ, field_, p_, n_, rays=rays, seed=job.settings.seed,
                         ids=lattice_ids(job, owner)[beside], back_field=back_field,
                         two_sided=sides,
                         owners=owners, back_owners=back_owners, exact=exact,
                         tabulate=False)
    albedo = rc.SurfelField(job.positions[front], job.normals[front],
                            job.albedo[front]).at(p_, n_, occ)
    values = np.array(exact.values, dtype=np.float64, copy=True)
    values[beside] += albedo * gathered.radiance - exact.rest.at(p_, n_, occ)
    return rc.ExactPart(rest=exact.rest, values=values), int(beside.size)


#: A receiver facing a surface across a gap narrower than the gather's lattice (a sphere's
#: underside just above a floor) sees that surface's lamp light change over less than the
#: lattice resolves. Where GAP_SHARE of GAP_RAYS probe rays meet a surface facing it (cosine
#: between the normals below -GAP_FACING) nearer than the field's reach, what those rays
#: took from the lattice is replaced by the lamps' light cast at their hits (one shadow ray
#: per hit and lamp: the rays average them) and the light gathered there afresh
#: (GAP_BOUNCE_RAYS per hit), in proportion. Without a sky only: under one
#: the lattice points beside contacts gather afresh (``_gathered_at_contacts``), and there
#: this made no error smaller.
GAP_FACING = 0.5
GAP_SHARE = 0.5
GAP_RAYS = 32
GAP_SHADOW_SAMPLES = 1
GAP_BOUNCE_RAYS = 16


def _gap_candidates(points: np.ndarray, normals: np.ndarray, pos: np.ndarray,
                    nrm: np.ndarray, reach: float) -> np.ndarray:
    """Rows of receivers (``points``, unit ``normals``) with a surfel (``pos``, ``nrm``)
    facing them within ``reach`` (m) in front of them: the ones that may face a gap."""
    from illumap.neighbours import knn
    if not len(points) or not len(pos):
        return np.zeros(0, dtype=np.int64)
    near, dist = knn(pos, points, 8)
    ahead = np.einsum("mkc,mc->mk", pos[near] - points[:, None, :], normals)
    facing = ((np.einsum("mkc,mc->mk", nrm[near], normals) < -GAP_FACING)
              & (dist < reach) & (ahead > 0))
    return np.flatnonzero(facing.any(axis=1))


def _across_gaps(job: Job, occ, exact, gatherer, front: np.ndarray, points: np.ndarray,
                 normals: np.ndarray, ids: np.ndarray, rays: int,
                 radiance: np.ndarray) -> tuple[int, int]:
    """Corrects the gather's ``radiance`` (M, 3, in place) at the receivers that face a gap
    (GAP_SHARE, above): the mean over GAP_RAYS probe rays of the light at the hits across it
    (the lamps' cast there, the rest gathered there) less what the gather's tables hold.
    Returns how many receivers and the rays cast. Needs the exact part (its field: the
    ``front`` surfels' light less their lamp light). Receivers are taken GAP_CHUNK at a
    time (each one's rays follow from its id alone, so the chunks change no result): a
    dense scan's candidates' rays and hits would otherwise hold gigabytes at once."""
    all_lamps = list(job.lamps) + list(job.emitters)
    s = job.settings
    if exact is None or job.world is not None or not all_lamps or not s.lamp_shadows:
        return 0, 0
    from illumap import receivers as rc
    pos, nrm = job.positions[front], job.normals[front]
    reach = exact.rest.reach
    albedo_field = None
    fixed_count = cast_rays = 0
    for lo in range(0, len(points), GAP_CHUNK):
        hi = min(lo + GAP_CHUNK, len(points))
        rows = lo + _gap_candidates(points[lo:hi], normals[lo:hi], pos, nrm, reach)
        if not rows.size:
            continue
        if albedo_field is None:
            albedo_field = rc.SurfelField(pos, nrm, job.albedo[front])
        fixed, cast = _gap_rows(job, occ, gatherer, albedo_field, all_lamps, reach, rows,
                                points, normals, ids, rays, radiance)
        fixed_count += fixed
        cast_rays += cast
    return fixed_count, cast_rays


#: Receivers ``_across_gaps`` takes at once (GAP_RAYS rays each).
GAP_CHUNK = 65536


def _gap_rows(job: Job, occ, gatherer, albedo_field, all_lamps, reach: float,
              rows: np.ndarray, points: np.ndarray, normals: np.ndarray, ids: np.ndarray,
              rays: int, radiance: np.ndarray) -> tuple[int, int]:
    """``_across_gaps`` for the candidate receivers ``rows``: (receivers corrected, rays)."""
    from illumap import receivers as rc
    s = job.settings
    k = min(int(rays), GAP_RAYS)
    dirs = rc.cosine_directions(normals[rows], k, ids[rows], s.seed).reshape(-1, 3)
    origins = np.repeat(points[rows] + occ.offset * normals[rows], k, axis=0)
    tri, dist, front_hit = occ.intersect(origins, dirs)
    cast_rays = int(rows.size) * k
    hit = tri >= 0
    c = occ.corners[tri[hit]]
    side = np.cross(c[:, 1] - c[:, 0], c[:, 2] - c[:, 0])
    side *= np.where(front_hit[hit], 1.0, -1.0)[:, None]     # the face the ray met
    hit_normals = np.zeros_like(dirs)
    hit_normals[hit] = side / np.maximum(np.linalg.norm(side, axis=1, keepdims=True), 1e-300)
    across = hit & (dist < reach) & (np.einsum(
        "ic,ic->i", hit_normals, np.repeat(normals[rows], k, axis=0)) < -GAP_FACING)
    gap = across.reshape(-1, k).mean(axis=1) >= GAP_SHARE
    cast = np.flatnonzero(across & front_hit & np.repeat(gap, k))
    if not cast.size:
        return 0, cast_rays
    p_ = origins[cast] + dist[cast, None] * dirs[cast]
    n_ = hit_normals[cast]
    # Each hit's random streams follow from its receiver's id and its ray, not from which
    # other receivers are in the batch.
    hit_ids = ids[rows][cast // k].astype(np.int64) * k + cast % k
    albedo = albedo_field.at(p_, n_)
    shadows = lights.Shadows(occ.segment_query(n_), samples=GAP_SHADOW_SAMPLES, seed=s.seed,
                            extent=occ.extent, ids=hit_ids)
    # The light bounced in the gap gathered afresh from each hit too: the surfels' own
    # (``exact.rest``) is as coarse there as the lattice.
    bounced = gatherer.gather(p_, n_, rays=GAP_BOUNCE_RAYS, ids=hit_ids, seed=s.seed + 1)
    lit = albedo * (bounced.radiance + lights.incident_radiance(all_lamps, p_, n_,
                                                               shadows=shadows))
    tabled = gatherer.hit_values(tri[cast], np.ones(cast.size, dtype=bool), p_)
    correction = np.zeros((rows.size, 3))
    np.add.at(correction, cast // k, lit - tabled)
    fixed = rows[gap]
    radiance[fixed] = np.maximum(radiance[fixed] + correction[gap] / k, 0.0)
    return int(gap.sum()), cast_rays + int(shadows.rays) + int(bounced.rays)


#: A scan of unknown orientation is first lit on both sides with this share of the gather's
#: rays and of the shadow samples (at least SIDE_PROBE_MIN_RAYS): most patches' outside is
#: plain from that
#: (``illumap.receivers.ScanPatches.sides``), and only the other patches take the full gather
#: on both sides.
SIDE_PROBE_SHARE = 1 / 16
SIDE_PROBE_MIN_RAYS = 8
#: The probe lights this share of a patch's points (every point of a patch of at most
#: SIDE_PROBE_WHOLE_PATCH): a patch's sides are judged on its sums (``ScanPatches.sides``).
SIDE_PROBE_POINTS = 1 / 4
SIDE_PROBE_WHOLE_PATCH = 64
#: ... and at most about this many of any patch: the probe's cost then stops growing with
#: the scan's density (a 990k-point Cornell box scan probed 250k points with 16M rays); a
#: patch still decides on the sums over thousands of points. Scans of under 4 × this many
#: points per patch (the bench scans) are probed as before.
SIDE_PROBE_MOST_POINTS = 8192


def _rows_of(rec, rows: np.ndarray, normals: np.ndarray | None = None):
    """The receivers ``rows`` of ``rec`` (with other ``normals``)."""
    return replace(rec, corner_vertex=rec.corner_vertex[rows], points=rec.points[rows],
                   normals=rec.normals[rows] if normals is None else normals,
                   albedo=rec.albedo[rows], emission=rec.emission[rows],
                   inward=None if rec.inward is None else rec.inward[rows],
                   corner_id=rec.ids[rows])


def _probe_sides(front, back, incident_at, gather_rays: int, shadow_samples: int,
                 lum: np.ndarray) -> tuple:
    """Which side of each point of a cloud of unknown orientation faces out, from a probe
    gather of both sides (``front`` and ``back``: the same points, opposite normals).
    Returns (``ScanPatches``, side (P,) bool: True where the front normal faces out,
    settled (P,) bool: whose patch the probe decided, rays cast); a gather too short to
    probe decides nothing."""
    from illumap.scan_values import ScanPatches
    n = len(front.points)
    patches = ScanPatches(front.points, front.normals)
    rays = max(SIDE_PROBE_MIN_RAYS, int(gather_rays * SIDE_PROBE_SHARE))
    if n == 0 or 2 * rays >= gather_rays:
        return patches, np.ones(n, dtype=bool), np.zeros(n, dtype=bool), 0
    ids = patches.sample(SIDE_PROBE_POINTS, SIDE_PROBE_WHOLE_PATCH, SIDE_PROBE_MOST_POINTS)
    m = len(ids)
    incident, gathered, cast, _ = incident_at(
        np.concatenate([front.points[ids], back.points[ids]]),
        np.concatenate([front.normals[ids], back.normals[ids]]),
        np.concatenate([ids, ids]), rays=rays,
        samples=max(SIDE_PROBE_MIN_RAYS, int(shadow_samples * SIDE_PROBE_SHARE)))
    lit_front = front.emission[ids] + front.albedo[ids] * incident[:m]
    lit_back = back.emission[ids] + back.albedo[ids] * incident[m:]
    noise_front = (front.albedo[ids] @ lum) * gathered.stderr[:m]
    noise_back = (back.albedo[ids] @ lum) * gathered.stderr[m:]
    side, settled = patches.sides(lit_front, lit_back, noise_front, noise_back, rows=ids)
    return patches, side, settled, cast


def receive(job: Job, result: "Result", progress: Progress | None = None, *,
            per_receiver: tuple[int, int] | None = None) -> None:
    """Evaluate the light at every receiver (DESIGN.md §6): the meshes' corners
    (``job.receivers``) into ``result.receiver_values``, and with Transfer the point clouds'
    points (their outward side where the orientation is unknown, a crease's points the mean of
    the faces that meet there) into
    ``result.point_receiver_values``. Direct light from lamps and emitters with shadow rays
    from the receiver, plus the final gather of the surfels' solved light
    (``illumap.receivers``); the world's light through the gather's rays that leave the
    scene. No bpy; runs on the worker after the solve. Raises IllumapCancelled when
    cancelled.

    ``per_receiver``: (gather rays, shadow samples) instead of ``receiver_rays``'. With a
    target error, a gather whose estimated noise exceeds its share of the target is cast
    again, once, with the rays ``more_rays`` asks for (``stats['receivers']['first_gather']``
    says what the first one found)."""
    point_sets = _point_receivers(job) if job.settings.transfer else []
    if not job.receivers and not point_sets:
        return
    from illumap import receivers as rc
    t0 = time.perf_counter()
    s = job.settings
    occ = mesh_occluders(job, progress)
    if occ is None:
        return
    # What the surfels send on: their solved radiance (with the emission left to them); the
    # open surfaces' and two-sided points' back faces are a field of their own.
    sent = result.radiosity - job.emission + job.solve_emission
    back = np.zeros(job.count, dtype=bool)
    for src in job.sources:
        if src.kind == "BACK":
            back[src.start:src.stop] = True
    owners, back_owners = _splat_owners(job, back)
    gather_rays, shadow_samples = receiver_rays(s) if per_receiver is None else per_receiver
    background = None if job.world is None else job.world.color
    sides = _gather_sides(job)
    # Seconds of each part (``result.timings['receivers: …']``), for the scaling benchmark.
    phases: dict[str, float] = {}
    mark = [time.perf_counter()]

    def lap(name: str) -> None:
        now = time.perf_counter()
        phases[name] = phases.get(name, 0.0) + now - mark[0]
        mark[0] = now

    straddling = _regather_straddling(job, result, occ, sent, back, owners, back_owners,
                                      gather_rays, background, sides)
    field_ = rc.SurfelField(job.positions[~back], job.normals[~back], sent[~back])
    back_field = (rc.SurfelField(job.positions[back], job.normals[back], sent[back])
                  if back.any() else None)
    lap("straddling")
    exact, lattice_lit = _exact_direct(job, occ, sent, ~back, field_, owners, sides,
                                       shadow_samples)
    exact, contact_points = _gathered_at_contacts(job, occ, exact, ~back, field_, back_field,
                                                  owners, back_owners, sides,
                                                  min(gather_rays, CONTACT_RAYS))
    all_lamps = list(job.lamps) + list(job.emitters)
    from illumap.refinement import LUMINANCE_WEIGHTS
    lum = np.asarray(LUMINANCE_WEIGHTS, dtype=np.float64)
    noise2 = light2 = indirect = from_surfels = total = 0.0
    gap_receivers = 0
    report = None if progress is None else (lambda f, _p="": progress(f, "gather"))

    def gather_at(points, normals, ids, rays):
        return gatherer.gather(points, normals, rays=rays, seed=s.seed, ids=ids, progress=report)

    def incident_at(points, normals, ids, meshes=None, rays=gather_rays, shared=None,
                    samples=shadow_samples, gaps=False, timed=False):
        """Incident radiance (M, 3) at receivers, the gather's result, the rays cast and the
        receivers found covered (inside or under another surface: no light). ``shared`` (M,)
        int: receivers of one group (≥ 0) share the gather through an irradiance cache
        (``illumap.irradiance_cache``); -1 or None: each gathers itself. ``gaps``: correct
        the receivers that face a gap (``_across_gaps``; the main batch's). ``timed``: its
        parts go into ``phases``."""
        nonlocal gap_receivers
        if timed:
            lap("corners and side probe")
        shadows = None
        if all_lamps and s.lamp_shadows:
            shadows = lights.Shadows(occ.segment_query(normals), samples=samples,
                                    seed=s.seed, extent=occ.extent, ids=ids)
        direct = lights.incident_radiance(all_lamps, points, normals, shadows=shadows)
        if timed:
            lap("direct")
        gap_cast = 0
        if shared is not None and s.gather_cache > 0 and (shared >= 0).any():
            from illumap.irradiance_cache import MIN_REACH_SHARE, cached_gather

            def full_gather(rows, rays_=None):
                """The cache's gathers; those in full (not its probes) corrected across gaps
                here, so that the receivers between records take the corrected light."""
                nonlocal gap_receivers, gap_cast
                g = gather_at(points[rows], normals[rows], ids[rows], rays if rays_ is None else rays_)
                if gaps and rays_ is None:
                    fixed, cast_ = _across_gaps(job, occ, exact, gatherer, ~back, points[rows],
                                                normals[rows], ids[rows], rays, g.radiance)
                    gap_receivers += fixed
                    gap_cast += cast_
                return g

            gathered = cached_gather(
                lambda rows, rays=None: full_gather(rows, rays),
                points, normals, groups=shared, accuracy=s.gather_cache, max_reach=occ.extent,
                min_reach=MIN_REACH_SHARE * field_.reach, progress=report)
            if timed:
                lap("gather")
        else:
            gathered = gather_at(points, normals, ids, rays)
            if timed:
                lap("gather")
            if gaps:
                gap_receivers, gap_cast = _across_gaps(job, occ, exact, gatherer, ~back, points,
                                                       normals, ids, rays, gathered.radiance)
        if timed:
            lap("gaps")
        incident = direct + gathered.radiance
        hidden = covered_receivers(job, points, normals, 2.0 * occ.offset, meshes)
        incident[hidden] = 0.0
        if timed:
            lap("covered")
        cast = gathered.rays + gap_cast + (shadows.rays if shadows is not None else 0)
        return incident, gathered, cast, int(hidden.sum())

    try:
        # One prepared gather for every batch below: the field is tabulated once.
        gatherer = rc.Gatherer(occ, field_, background=background, back_field=back_field,
                               two_sided=sides, owners=owners, back_owners=back_owners,
                               exact=exact, progress=report)
        lap("tables")
        # Every object's receivers in one batch (the gather tabulates the surfels' light
        # once), corners that see the same light evaluated once. A point cloud of unknown
        # orientation brings the side of each point that a probe found facing out, and both
        # sides of the points whose patch the probe left open.
        batch = [_clear_of_rounding(occ, rec) for rec in job.receivers]
        batch_ids: list[np.ndarray | None] = [None] * len(batch)   # None: the rows themselves
        rays, scan_parts = 0, []
        for front, other in point_sets:
            if other is None:
                scan_parts.append(None)
                batch.append(front)
                batch_ids.append(None)
                continue
            patches, side, settled, cast = _probe_sides(front, other, incident_at, gather_rays,
                                                        shadow_samples, lum)
            rays += cast
            done, both = np.flatnonzero(settled), np.flatnonzero(~settled)
            outward = np.where(side[:, None], front.normals, -front.normals)
            scan_parts.append((patches, side, settled, done, both))
            batch += [_rows_of(front, done, outward[done]), _rows_of(front, both),
                      _rows_of(other, both)]
            batch_ids += [done, both, both]
        mesh_of = {src.name: i for i, src in
                   enumerate(x for x in job.sources if x.kind == "MESH")}

        def pressed_in(rec):
            """Which of ``rec``'s corners (rows) another surface lies against."""
            if rec.name not in mesh_of:
                return None
            own = mesh_of[rec.name]
            return lambda rows: covered_receivers(job, rec.points[rows], rec.normals[rows],
                                                  2.0 * occ.offset,
                                                  np.full(len(rows), own, np.int64))

        merged = [_merged_corners(occ, rec, all_lamps if s.lamp_shadows else (),
                                  pressed_in(rec)) for rec in batch]
        points = np.concatenate([rec.points[rows] for rec, (rows, _) in zip(batch, merged)])
        normals = np.concatenate([rec.normals[rows] for rec, (rows, _) in zip(batch, merged)])
        offsets = np.cumsum([0] + [len(rows) for rows, _ in merged])
        # Each receiver's rays follow from its identity in its object alone (a corner's from
        # its vertex and face, a point's from its row, both sides of a point alike): not from
        # which other objects are in the batch, nor from the order Blender keeps faces in.
        ids = np.concatenate([rec.ids[rows] if own is None else own[rows]
                              for rec, own, (rows, _) in zip(batch, batch_ids, merged)]
                             ).astype(np.int64)
        # Each batch row's mesh among the MESH sources (-1: a point cloud's point).
        mesh_index = {src.name: i for i, src in
                      enumerate(x for x in job.sources if x.kind == "MESH")}
        batch_meshes = np.concatenate([np.full(len(rows), mesh_index.get(rec.name, -1), np.int64)
                                       for rec, (rows, _) in zip(batch, merged)])
        # A point cloud's points (each part of the batch on its own) share their gathers.
        shared = np.concatenate([np.full(len(rows), part if part >= len(job.receivers) else -1,
                                         np.int64)
                                 for part, (rows, _) in enumerate(merged)])

        incident, gathered, cast, covered = incident_at(points, normals, ids, batch_meshes,
                                                        shared=shared, gaps=True, timed=True)
        rays += cast
        values_of = []
        for rec, lo, (_, index) in zip(batch, offsets[:-1], merged):
            rows = lo + index
            values = rec.emission + rec.albedo * incident[rows]
            values_of.append(values)
            # What the estimate needs: the gather's noise and the share of the light gathered
            # from the surfels, by luminance.
            rho = rec.albedo @ lum
            # The halves' squares pooled, not the rays' variance: the rays are a lattice,
            # whose error is 1.45-2.3x below the halves' and 2.6-11x below what independent
            # rays would leave (bench/reference/gather_noise.py).
            noise2 += float(((rho * gathered.halves[rows]) ** 2).sum())
            light2 += float(((values @ lum) ** 2).sum())
            gathered_lum = gathered.radiance[rows] @ lum
            indirect += float((rho * gathered_lum).sum())
            if background is not None and gathered.open is not None:
                # the sky's part of the gather owes nothing to the surfels
                gathered_lum = np.maximum(gathered_lum - gathered.open[rows] * (background @ lum), 0.0)
            from_surfels += float((rho * gathered_lum).sum())
            total += float((values @ lum).sum())
        lap("values")
        rest = iter(values_of[len(job.receivers):])
        from illumap.scan_values import crease_surfaces, remove_specks
        scan_values, specks, creases = [], 0, 0
        for (front, other), part in zip(point_sets, scan_parts):
            if other is None:
                values, outward = next(rest), front.normals
            else:   # the outside of each smooth patch, then the creases' faces
                patches, side, settled, done, both = part
                chosen, along, against = next(rest), next(rest), next(rest)
                # The open patches decide on their full values, as a whole (the probe's
                # values stand in elsewhere: no open patch reads them).
                front_full = np.zeros((len(side), 3))
                back_full = np.zeros((len(side), 3))
                front_full[both], back_full[both] = along, against
                side = np.where(settled, side, patches.sides(front_full, back_full)[0])
                values = np.empty((len(side), 3))
                values[done] = chosen
                values[both] = np.where(side[both, None], along, against)
                outward = np.where(side[:, None], front.normals, -front.normals)
                faces = crease_surfaces(front.points, outward)
                if len(faces.rows):
                    r = faces.rows
                    extra, _, more, _ = incident_at(faces.points, faces.normals, r)
                    rays += more
                    values = faces.mean(values, front.emission[r] + front.albedo[r] * extra)
                    creases += int(len(np.unique(r)))
            lap("creases")
            # A cloud of unknown orientation: its patches found the same neighbours already.
            shared_nn = None if other is None else part[0].neighbours
            values, replaced = remove_specks(front.points, outward, values,
                                                neighbours=shared_nn)
            lap("specks")
            specks += replaced
            scan_values.append(values)
    except IllumapError:
        raise
    except Exception as exc:  # noqa: BLE001
        if core_cancelled(exc):
            raise IllumapCancelled("Cancelled") from None
        raise IllumapError(f"Evaluating the light at the receivers failed: "
                           f"{type(exc).__name__}: {exc}", ExitCode.SOLVER) from exc
    for rec, values in zip(job.receivers, values_of):
        result.receiver_values[rec.name] = values
    for (front, _), values in zip(point_sets, scan_values):
        result.point_receiver_values[front.name] = values
    result.timings["receivers"] = time.perf_counter() - t0
    lap("rest")
    result.timings.update({f"receivers: {k}": v for k, v in phases.items()})
    gather_noise = float(np.sqrt(noise2 / light2)) if light2 > 0 else 0.0
    share = indirect / total if total > 0 else 0.0
    surfel_share = from_surfels / total if total > 0 else 0.0
    result.stats["receivers"] = dict(points=int(len(points)),
                                     corners=int(sum(len(r.points) for r in job.receivers)),
                                     scan_points=int(sum(len(f.points) for f, _ in point_sets)),
                                     rays=int(rays), gather_rays=int(gather_rays),
                                     shadow_samples=int(shadow_samples), covered=covered,
                                     specks=int(specks), crease_points=int(creases),
                                     straddling=straddling,
                                     lattice_points=0 if exact is None else len(exact.values),
                                     lattice_shadowed=lattice_lit,
                                     contact_points=contact_points,
                                     gap_receivers=gap_receivers,
                                     cache_records=(int(gathered.records.sum())
                                                    if hasattr(gathered, "records") else None),
                                     gather_noise=gather_noise, indirect_share=float(share),
                                     surfel_share=float(surfel_share))
    more = None if per_receiver is not None else more_rays(s, gather_noise, gather_rays)
    if more is not None:
        first = dict(rays=int(gather_rays), cast=int(rays), gather_noise=gather_noise,
                     seconds=result.timings["receivers"])
        receive(job, result, progress, per_receiver=(more, shadow_samples))
        result.stats["receivers"]["first_gather"] = first
        result.stats["receivers"]["rays"] += first["cast"]
        result.timings["receivers"] += first["seconds"]
        return
    missed = gather_noise_warning(s, gather_noise, gather_rays)
    if missed:
        result.warnings.append(missed)
    estimate = (result.stats.get("accuracy") or {}).get("estimate", {}).get("total")
    if estimate is not None:
        # The surfels' own error (relative to every surfel that is not a light, lamp-lit or
        # not: pipeline.run's ``scored``) reaches a receiver through the light it gathers
        # from them only (not the sky's part of the gather). Conservative: on the bench
        # scenes 1.09-5.7x the error measured against Cycles at every target; the gather
        # averages the surfels' errors.
        result.stats["receivers"]["surfel_estimate"] = float(estimate)
        result.stats["receivers"]["estimate"] = float(np.hypot(gather_noise,
                                                               surfel_share * estimate))
