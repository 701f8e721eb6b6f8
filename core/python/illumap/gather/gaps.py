"""Receivers facing a surface across a gap finer than the gather's lattice (a sphere's
underside just above a floor) take the light at their rays' hits afresh (no bpy)."""

from __future__ import annotations

import numpy as np

from .. import lights
from ..stages.scene import Scene


#: A receiver facing a surface across a gap narrower than the gather's lattice (a sphere's
#: underside just above a floor) sees that surface's lamp light change over less than the
#: lattice resolves. Where GAP_SHARE of GAP_RAYS probe rays meet a surface facing it (cosine
#: between the normals below -GAP_FACING) nearer than the field's reach, what those rays
#: took from the lattice is replaced by the lamps' light cast at their hits (one shadow ray
#: per hit and lamp: the rays average them) and the light gathered there afresh
#: (GAP_BOUNCE_RAYS per hit), in proportion. Without a sky only: under one
#: the lattice points beside contacts gather afresh (``gathered_at_contacts``), and there
#: this made no error smaller.
GAP_FACING = 0.5
GAP_SHARE = 0.5
GAP_RAYS = 32
GAP_SHADOW_SAMPLES = 1
GAP_BOUNCE_RAYS = 16


def gap_candidates(points: np.ndarray, normals: np.ndarray, pos: np.ndarray,
                    nrm: np.ndarray, reach: float) -> np.ndarray:
    """Rows of receivers (``points``, unit ``normals``) with a surfel (``pos``, ``nrm``)
    facing them within ``reach`` (m) in front of them: the ones that may face a gap."""
    from ..neighbours import knn
    if not len(points) or not len(pos):
        return np.zeros(0, dtype=np.int64)
    near, dist = knn(pos, points, 8)
    ahead = np.einsum("mkc,mc->mk", pos[near] - points[:, None, :], normals)
    facing = ((np.einsum("mkc,mc->mk", nrm[near], normals) < -GAP_FACING)
              & (dist < reach) & (ahead > 0))
    return np.flatnonzero(facing.any(axis=1))


def across_gaps(scene: Scene, occ, exact, gatherer, front: np.ndarray, points: np.ndarray,
                 normals: np.ndarray, ids: np.ndarray, rays: int,
                 radiance: np.ndarray) -> tuple[int, int]:
    """Corrects the gather's ``radiance`` (M, 3, in place) at the receivers that face a gap
    (GAP_SHARE, above): the mean over GAP_RAYS probe rays of the light at the hits across it
    (the lamps' cast there, the rest gathered there) less what the gather's tables hold.
    Returns how many receivers and the rays cast. Needs the exact part (its field: the
    ``front`` surfels' light less their lamp light). Receivers are taken GAP_CHUNK at a
    time (each one's rays follow from its id alone, so the chunks change no result): a
    dense scan's candidates' rays and hits would otherwise hold gigabytes at once."""
    all_lamps = list(scene.lamps) + list(scene.emitters)
    s = scene.settings
    if exact is None or scene.world is not None or not all_lamps or not s.lamp_shadows:
        return 0, 0
    from .. import receivers as rc
    pos, nrm = scene.positions[front], scene.normals[front]
    reach = exact.rest.reach
    albedo_field = None
    fixed_count = cast_rays = 0
    for lo in range(0, len(points), GAP_CHUNK):
        hi = min(lo + GAP_CHUNK, len(points))
        rows = lo + gap_candidates(points[lo:hi], normals[lo:hi], pos, nrm, reach)
        if not rows.size:
            continue
        if albedo_field is None:
            albedo_field = rc.SurfelField(pos, nrm, scene.albedo[front])
        fixed, cast = _gap_rows(scene, occ, gatherer, albedo_field, all_lamps, reach, rows,
                                points, normals, ids, rays, radiance)
        fixed_count += fixed
        cast_rays += cast
    return fixed_count, cast_rays


#: Receivers ``across_gaps`` takes at once (GAP_RAYS rays each).
GAP_CHUNK = 65536


def _gap_rows(scene: Scene, occ, gatherer, albedo_field, all_lamps, reach: float,
              rows: np.ndarray, points: np.ndarray, normals: np.ndarray, ids: np.ndarray,
              rays: int, radiance: np.ndarray) -> tuple[int, int]:
    """``across_gaps`` for the candidate receivers ``rows``: (receivers corrected, rays)."""
    from .. import receivers as rc
    s = scene.settings
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
