"""The light at the receivers (DESIGN.md §6): what a user sees, evaluated at the point that
shows it, after the solve (no bpy). The meshes' corners and the point clouds' points get the
lamps' direct light with shadow rays from the receiver, plus the final gather of the surfels'
solved light (``illumap.receivers``) against the scene's triangles. Before the gather, the
surfels whose disc reaches through another surface are evaluated as receivers too
(``straddling``), and the gather's table takes the lamps' light cast at its own points where
it changes sharply (``lattice``), and a receiver facing a surface across a gap finer than that
table takes the light at its rays' hits there afresh (``gaps``). Receivers that another
surface lies flat against get no light (``covered``). A point cloud's points share their
gathers through an irradiance cache (``illumap.irradiance_cache``, ``Settings.gather_cache``),
and each of its receivers starts clear of its neighbours' splats (``scans.SplatClearance``).

``receive`` returns a new value (``ReceiverLight``); with a target error whose share the
gather's noise exceeds, it gathers once more with more rays (``rays.more_rays``)."""

from __future__ import annotations

import time
from dataclasses import dataclass, field

import numpy as np

from ..stages.scene import Progress, Scene
from .corners import clear_of_rounding, merged_corners
from .covered import covered_receivers
from .evaluation import Evaluation, prepare
from .rays import gather_noise_warning, more_rays, receiver_rays
from .scans import SplatClearance, point_receivers, probe_sides, rows_of


@dataclass(frozen=True)
class ReceiverLight:
    """The light where the user sees it: outgoing radiance (3 channels) at each mesh's
    corners and each point cloud's points, and the surfels' own with those whose disc reaches
    through another surface evaluated as receivers are."""

    radiosity: np.ndarray                            # (N, 3) the surfels' outgoing radiance
    corners: dict = field(default_factory=dict)      # object name → (L, 3)
    points: dict = field(default_factory=dict)       # point cloud name → (P, 3)
    stats: dict | None = None                        # ``stats['receivers']``; None: no gather
    timings: dict = field(default_factory=dict)      # 'receivers' and 'receivers: …', s
    warnings: tuple = ()


def receive(scene: Scene, direct: np.ndarray | None, direct_lamps: np.ndarray | None,
            radiosity: np.ndarray, progress: Progress | None = None, *,
            surfel_estimate: float | None = None,
            enclosed: np.ndarray | None = None) -> ReceiverLight:
    """Evaluate the light at every receiver (DESIGN.md §6) of ``scene`` (with its occluders
    built, ``stages.scene.with_occluders``): the meshes' corners (``scene.receivers``), and
    with Transfer the point clouds' points (their outward side where the orientation is
    unknown, a crease's points the mean of the faces that meet there). ``radiosity``: the
    solved outgoing radiance (N, 3); ``direct``, ``direct_lamps``: the surfels' reflected
    direct light and its lamps' part. Raises the core's Cancelled when ``progress`` returns
    False.

    With a target error, a gather whose estimated noise exceeds its share of the target is
    cast again, once, with the rays ``more_rays`` asks for (``stats['first_gather']`` says
    what the first one found). ``surfel_estimate``: the surfel solve's estimated error, for
    the receivers' estimate. ``enclosed`` (N,) bool: the surfels whose solved rows came from
    their first hits (``stages.solve.Solved.enclosed``), or None."""
    s = scene.settings
    point_sets = point_receivers(scene) if s.transfer else []
    if (not scene.receivers and not point_sets) or scene.occluders is None:
        return ReceiverLight(radiosity=radiosity)
    gather_rays, shadow_samples = receiver_rays(s)
    light = _receive_once(scene, direct, direct_lamps, radiosity, point_sets, gather_rays,
                          shadow_samples, progress, enclosed)
    more = more_rays(s, light.stats["gather_noise"], gather_rays)
    first = None
    if more is not None:
        first = dict(rays=int(gather_rays), cast=int(light.stats["rays"]),
                     gather_noise=light.stats["gather_noise"],
                     seconds=light.timings["receivers"])
        gather_rays = more
        light = _receive_once(scene, direct, direct_lamps, radiosity, point_sets, gather_rays,
                              shadow_samples, progress, enclosed)
    stats, timings = dict(light.stats), dict(light.timings)
    missed = gather_noise_warning(s, stats["gather_noise"], gather_rays)
    if surfel_estimate is not None:
        # The surfels' own error (relative to every surfel that is not a light, lamp-lit or
        # not: the solve's ``scored``) reaches a receiver through the light it gathers
        # from them only (not the sky's part of the gather). Conservative: on the bench
        # scenes 1.09-5.7x the error measured against Cycles at every target; the gather
        # averages the surfels' errors.
        stats["surfel_estimate"] = float(surfel_estimate)
        stats["estimate"] = float(np.hypot(stats["gather_noise"],
                                           stats["surfel_share"] * surfel_estimate))
    if first is not None:
        stats["first_gather"] = first
        stats["rays"] += first["cast"]
        timings["receivers"] += first["seconds"]
    return ReceiverLight(radiosity=light.radiosity, corners=light.corners, points=light.points,
                         stats=stats, timings=timings, warnings=(missed,) if missed else ())


def _receive_once(scene: Scene, direct, direct_lamps, radiosity: np.ndarray, point_sets: list,
                  gather_rays: int, shadow_samples: int, progress: Progress | None,
                  enclosed: np.ndarray | None = None) -> ReceiverLight:
    """One gather of every receiver with ``gather_rays`` rays and ``shadow_samples`` shadow
    samples per receiver and sized lamp (``receive``)."""
    t0 = time.perf_counter()
    ev = prepare(scene, scene.occluders, direct, direct_lamps, radiosity, gather_rays,
                 shadow_samples, progress, enclosed)
    batch, batch_ids, scan_parts, rays = _batch(ev, point_sets)
    main = _evaluate(ev, batch, batch_ids)
    rays += main.cast
    scan_values, specks, creases, more = _scan_values(ev, point_sets, scan_parts,
                                                      main.values[len(scene.receivers):])
    rays += more
    corners = {rec.name: values for rec, values in zip(scene.receivers, main.values)}
    points = {front.name: values for (front, _), values in zip(point_sets, scan_values)}
    timings = {"receivers": time.perf_counter() - t0}
    ev.lap("rest")
    timings.update({f"receivers: {k}": v for k, v in ev.phases.items()})
    gathered, sums = main.gathered, main.sums
    stats = dict(points=int(main.count),
                 corners=int(sum(len(r.points) for r in scene.receivers)),
                 scan_points=int(sum(len(f.points) for f, _ in point_sets)),
                 rays=int(rays), gather_rays=int(gather_rays),
                 shadow_samples=int(shadow_samples), covered=main.covered,
                 specks=int(specks), crease_points=int(creases),
                 straddling=ev.straddling,
                 lattice_points=0 if ev.exact is None else len(ev.exact.values),
                 lattice_shadowed=ev.lattice_lit,
                 contact_points=ev.contact_points,
                 gap_receivers=ev.gap_receivers,
                 cache_records=(int(gathered.records.sum())
                                if hasattr(gathered, "records") else None),
                 gather_noise=sums.noise, indirect_share=sums.indirect_share,
                 surfel_share=sums.surfel_share)
    return ReceiverLight(radiosity=ev.radiosity, corners=corners, points=points, stats=stats,
                         timings=timings)


def _batch(ev: Evaluation, point_sets: list) -> tuple:
    """Every object's receivers in one batch (the gather tabulates the surfels' light once).
    A point cloud of unknown orientation brings the side of each point that a probe found
    facing out, and both sides of the points whose patch the probe left open. Returns (the
    receivers, their identities (None: the rows themselves), each scan's probe, rays cast)."""
    from ..refinement import LUMINANCE_WEIGHTS
    lum = np.asarray(LUMINANCE_WEIGHTS, dtype=np.float64)
    batch = [clear_of_rounding(ev.occ, rec) for rec in ev.scene.receivers]
    batch_ids: list[np.ndarray | None] = [None] * len(batch)
    rays, scan_parts = 0, []
    from ..scan_values import ScanPatches
    offset = 0
    for front, other in point_sets:
        # A scan of unknown orientation: its patches' neighbour search serves the clearance.
        patches = None if other is None else ScanPatches(front.points, front.normals)
        clear = SplatClearance(front.points, front.normals, ev.occ,
                               _splats_of(ev.scene, offset, len(front.points)),
                               None if patches is None else patches.neighbours)
        offset += len(front.points)
        if other is None:
            scan_parts.append((clear,))
            batch.append(clear.lifted(front))
            batch_ids.append(None)
            continue
        patches, side, settled, cast = probe_sides(front, other, ev.incident_at, ev.gather_rays,
                                                   ev.shadow_samples, lum, clear, patches)
        rays += cast
        done, both = np.flatnonzero(settled), np.flatnonzero(~settled)
        outward = np.where(side[:, None], front.normals, -front.normals)
        scan_parts.append((patches, side, settled, done, both, clear))
        batch += [clear.lifted(rows_of(front, done, outward[done])),
                  clear.lifted(rows_of(front, both)), clear.lifted(rows_of(other, both))]
        batch_ids += [done, both, both]
    return batch, batch_ids, scan_parts, rays


def _splats_of(scene: Scene, offset: int, count: int) -> np.ndarray | None:
    """(T,) int: the point of the cloud whose points are ``offset`` … ``offset + count − 1``
    over all clouds that each triangle is a splat of, −1 for the rest; None: no splats."""
    if scene.splat_point is None:
        return None
    local = np.asarray(scene.splat_point, dtype=np.int64) - offset
    return np.where((local >= 0) & (local < count), local, -1)


@dataclass
class _Sums:
    """What the estimate needs, by luminance: the gather's noise (relative RMS over the
    receivers) and the shares of the light gathered, and gathered from the surfels."""

    noise: float
    indirect_share: float
    surfel_share: float


@dataclass
class _Main:
    """The main batch's values (one (rows, 3) array per receiver set) and what it cast."""

    values: list
    gathered: object
    cast: int
    covered: int
    count: int
    sums: _Sums


def _evaluate(ev: Evaluation, batch: list, batch_ids: list) -> _Main:
    """The light at every receiver of ``batch``, corners that see the same light evaluated
    once (``merged_corners``)."""
    scene, occ = ev.scene, ev.occ
    s = scene.settings
    mesh_of = {src.name: i for i, src in enumerate(x for x in scene.sources if x.kind == "MESH")}

    def pressed_in(rec):
        """Which of ``rec``'s corners (rows) another surface lies against."""
        if rec.name not in mesh_of:
            return None
        own = mesh_of[rec.name]
        return lambda rows: covered_receivers(scene, rec.points[rows], rec.normals[rows],
                                              2.0 * occ.offset,
                                              np.full(len(rows), own, np.int64))

    merged = [merged_corners(occ, rec, ev.all_lamps if s.lamp_shadows else (),
                             pressed_in(rec)) for rec in batch]
    points = np.concatenate([rec.points[rows] for rec, (rows, *_) in zip(batch, merged)])
    normals = np.concatenate([rec.normals[rows] for rec, (rows, *_) in zip(batch, merged)])
    # A point's own normal stands for its face: its cosine rays all lie above it.
    faces = np.concatenate([(rec.normals if rec.faces is None else rec.faces)[rows]
                            for rec, (rows, *_) in zip(batch, merged)])
    offsets = np.cumsum([0] + [len(rows) for rows, *_ in merged])
    # Each receiver's rays follow from its identity in its object alone (a corner's from
    # its vertex and face, a point's from its row, both sides of a point alike): not from
    # which other objects are in the batch, nor from the order Blender keeps faces in.
    ids = np.concatenate([rec.ids[rows] if own is None else own[rows]
                          for rec, own, (rows, *_) in zip(batch, batch_ids, merged)]
                         ).astype(np.int64)
    # Each batch row's mesh among the MESH sources (-1: a point cloud's point).
    batch_meshes = np.concatenate([np.full(len(rows), mesh_of.get(rec.name, -1), np.int64)
                                   for rec, (rows, *_) in zip(batch, merged)])
    # A point cloud's points (each part of the batch on its own) share their gathers.
    shared = np.concatenate([np.full(len(rows), part if part >= len(scene.receivers) else -1,
                                     np.int64)
                             for part, (rows, *_) in enumerate(merged)])
    # A vertex's corners in other face planes take its lead's rays in their own faces.
    casters = np.concatenate([lo + c for lo, (_, _, c) in zip(offsets[:-1], merged)]
                             ).astype(np.int64)
    incident, gathered, cast, covered = ev.incident_at(points, normals, ids, batch_meshes,
                                                       shared=shared, gaps=True, timed=True,
                                                       faces=faces, casters=casters)
    values_of = [rec.emission + rec.albedo * incident[lo + index]
                 for rec, lo, (_, index, _) in zip(batch, offsets[:-1], merged)]
    sums = _noise_sums(ev, batch, offsets, merged, values_of, gathered)
    ev.lap("values")
    return _Main(values_of, gathered, int(cast), covered, len(points), sums)


def _noise_sums(ev: Evaluation, batch: list, offsets, merged: list, values_of: list,
                gathered) -> _Sums:
    """The gather's noise and the shares of gathered light over the receivers (``_Sums``)."""
    from ..refinement import LUMINANCE_WEIGHTS
    lum = np.asarray(LUMINANCE_WEIGHTS, dtype=np.float64)
    background = None if ev.scene.world is None else ev.scene.world.color
    noise2 = light2 = indirect = from_surfels = total = 0.0
    for rec, lo, (_, index, _), values in zip(batch, offsets[:-1], merged, values_of):
        rows = lo + index
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
    return _Sums(noise=float(np.sqrt(noise2 / light2)) if light2 > 0 else 0.0,
                 indirect_share=float(indirect / total if total > 0 else 0.0),
                 surfel_share=float(from_surfels / total if total > 0 else 0.0))


def _scan_values(ev: Evaluation, point_sets: list, scan_parts: list, rest_values: list) -> tuple:
    """Each point cloud's values (P, 3) from the batch's (``rest_values``, in batch order): a
    scan of unknown orientation takes the outside of each smooth patch, then the mean over
    the faces that meet at its creases; specks replaced by their neighbours'. Returns (the
    values per cloud, specks replaced, crease points, rays cast)."""
    from ..scan_values import crease_surfaces, remove_specks
    rest = iter(rest_values)
    scan_values, specks, creases, rays = [], 0, 0, 0
    for (front, other), part in zip(point_sets, scan_parts):
        if other is None:
            values, outward = next(rest), front.normals
        else:   # the outside of each smooth patch, then the creases' faces
            patches, side, settled, done, both, clear = part
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
            faces = crease_surfaces(front.points, outward, albedo=front.albedo,
                                    progress=ev.report)
            if len(faces.rows):
                r = faces.rows
                # The faces' receivers lie along the creases, as dense as the points:
                # they share their gathers as the points do (the cache's normal term
                # keeps each face's records to that face).
                at = clear.lift(r, faces.points, faces.normals)
                extra, _, more, _ = ev.incident_at(at, faces.normals, r,
                                                   shared=np.zeros(len(r), dtype=np.int64))
                rays += more
                values = faces.mean(values, front.emission[r] + front.albedo[r] * extra)
                creases += int(len(np.unique(r)))
        ev.lap("creases")
        # A cloud of unknown orientation: its patches found the same neighbours already.
        shared_nn = None if other is None else part[0].neighbours
        values, replaced = remove_specks(front.points, outward, values, neighbours=shared_nn)
        ev.lap("specks")
        specks += replaced
        scan_values.append(values)
    return scan_values, specks, creases, rays
