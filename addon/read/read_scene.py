"""Reading the scene into a job (main thread): the objects split into meshes, point clouds and
helpers, their surfels sampled (meshes) or taken as they are (point clouds, thinned to the
budget), their materials, the lamps, the world, and the receivers at the objects' own corners
and points. ``pipeline.prepare`` calls it; the adaptive second pass resamples from what it
kept (``_Scene``)."""

from __future__ import annotations

import time
from collections import Counter
from dataclasses import dataclass
from functools import partial
from typing import Callable

import numpy as np

from illumap import lights
from illumap.grid_cells import first_in_each_cell
from illumap.identities import object_rng
from illumap.settings import DEFAULT_BUDGET, Settings
from illumap.stages.scene import PointCloud, Source

from . import emitters, lamps, materials, pointcloud, sampling
from ..preview import point_splats
from .budget import (
    _mesh_share, adaptive_error_ratio_applies, capped_target_warning, check_memory, target_density
)
from ..errors import ExitCode, IllumapCancelled, IllumapError, core_cancelled
from ..job import Job, Progress
from ..kinds import HELPER_TYPES, MESH_TYPES, RESULT_TYPES, is_instancer


@dataclass
class _Scene:
    """What ``prepare`` read, kept for the adaptive second pass (main thread only: the meshes
    hold material references)."""

    tri_meshes: list
    counts: np.ndarray            # pass-2 surfels per mesh object
    points: list                  # point-cloud parts, reused as they are
    point_sources: list           # (name, area, two-sided) per point cloud
    lamps: list
    world: "lights.Lamp | None"
    light_masks: list = None      # per mesh: the triangles whose emission a lamp carries


def _split_objects(depsgraph, objects) -> tuple[list, list, list[str]]:
    meshes, points, warnings = [], [], []
    from ..write.output import SURFEL_OBJECT
    # By name, not in selection order: the surfels' rows, and the budget's share where areas
    # tie, are then the same however the objects were selected.
    for obj in sorted((o for o in objects if o is not None), key=lambda o: o.name):
        if obj.name == SURFEL_OBJECT or obj.type == "LIGHT":
            continue
        if obj.type == "POINTCLOUD":
            points.append(obj)
        elif obj.type in MESH_TYPES:
            ev = obj.evaluated_get(depsgraph)
            if obj.type == "MESH" and len(ev.data.polygons) == 0 and len(ev.data.vertices) > 0:
                points.append(obj)  # vertex-only mesh: a point cloud
            else:
                meshes.append(obj)
        elif obj.type not in HELPER_TYPES:  # empties may instance collections (read_instances)
            warnings.append(f"Object '{obj.name}' ({obj.type.replace('_', ' ').lower()}) is not "
                            "a mesh, point cloud or collection instance: left out of the light")
    return meshes, points, warnings


def _read_geometry(depsgraph, objects, settings: Settings, warnings: list[str]):
    """The objects' geometry as read: (mesh objects, point-cloud objects, the triangle meshes
    (their instances too), the point clouds). Raises IllumapError when nothing is usable."""
    meshes, points, split_warnings = _split_objects(depsgraph, objects)
    warnings.extend(split_warnings)
    # Instances (collection instances, Geometry Nodes instances…) of the given objects: one
    # Python loop over the scene's instances, not over any geometry.
    instances = sampling.read_instances(depsgraph, {o.name for o in objects if o is not None})
    instancers = {tm.instancer for tm in instances}
    for obj in objects:
        if obj is not None and is_instancer(obj) and obj.name not in instancers:
            warnings.append(f"Object '{obj.name}' instances collection "
                            f"'{obj.instance_collection.name}', which holds no mesh: left out "
                            "of the light")
    if settings.transfer:
        counts = Counter(tm.instancer for tm in instances)
        for name, count in sorted(counts.items()):
            warnings.append(f"Object '{name}': its {count} instance(s) take part in the light "
                            "but get no illumination attribute (instances share their mesh); "
                            "the surfel object holds their light")
    if not meshes and not points and not instances:
        raise IllumapError("Nothing to compute: select mesh or point-cloud objects "
                           f"({len(objects)} object(s) given, none usable)")
    tri_meshes = [tm for tm in (sampling.read_mesh(obj, depsgraph, allow_empty=obj.name in instancers)
                                for obj in meshes) if tm is not None] + instances
    for tm in tri_meshes:
        if tm.skipped_triangles:
            warnings.append(f"Object '{tm.name}': {tm.skipped_triangles} zero-area triangle(s) skipped")
    if not tri_meshes and not points:
        raise IllumapError("Nothing to compute: the selected instancers hold no mesh geometry")
    # Normals a cloud lacks are estimated by the build (``pointcloud.with_normals``).
    read = [pointcloud.read_points(obj, depsgraph, warnings) for obj in points]
    return meshes, points, tri_meshes, read


def _mesh_counts(settings: Settings, tri_meshes: list, read: list, point_area: float,
                 density: float | None, stats: dict) -> np.ndarray:
    """Surfels per mesh: by the target's density (capped by a budget), else by the settings'
    density or budget (the meshes' share of it beside the point clouds)."""
    if not tri_meshes:
        return np.zeros(0, dtype=np.int64)
    mesh_areas = np.array([tm.total_area for tm in tri_meshes])
    n_points = sum(len(p.areas) for p in read)
    if density is not None and settings.budget and stats["density"]["surfels"] >= settings.budget:
        # The budget caps the target's count: spend it exactly, as without a target.
        return sampling.allocate(mesh_areas, budget=max(settings.budget - n_points,
                                                        len(tri_meshes)))
    if density is not None:
        return sampling.allocate(mesh_areas, density=density)
    budget = settings.budget
    if budget is None and settings.density is None:
        budget = DEFAULT_BUDGET
    if budget is not None:
        budget = _mesh_share(budget, float(mesh_areas.sum()), point_area, len(tri_meshes))
    return sampling.allocate(mesh_areas, density=settings.density, budget=budget)


def _prepare(depsgraph, objects, settings: Settings) -> UnbuiltJob:
    """Read the scene on the main thread (surfels, materials, lamps, receivers), to be built
    into the job by ``UnbuiltJob.build`` (the direct light is ``run``'s first phase,
    ``light``).

    With a target error and ``settings.adaptive``, this is pass 1 (a fraction of the surfels,
    uniform); ``next_pass`` builds pass 2 from its result.
    """
    t0 = time.perf_counter()
    warnings: list[str] = []
    meshes, points, tri_meshes, read = _read_geometry(depsgraph, objects, settings, warnings)
    point_sources = [(p.name, float(p.areas.sum()), p.two_sided) for p in read]
    stats: dict = {}
    mesh_area = float(sum(tm.total_area for tm in tri_meshes))
    point_area = sum(src[1] for src in point_sources)
    target = target_density(settings, mesh_area, sum(len(p.areas) for p in read), point_area,
                            stats)
    density, chosen = target if target is not None else (None, None)
    if target is not None:
        capped = capped_target_warning(stats["density"])
        if capped:
            warnings.append(capped)
    counts = _mesh_counts(settings, tri_meshes, read, point_area, density, stats)
    check_memory(int(counts.sum()), settings)  # before sampling allocates anything big
    # Every point is a receiver; the solve needs only as many surfels as the light does.
    wanted = _point_counts(settings, density, [len(p.areas) for p in read], point_sources,
                           mesh_area)
    # Each object's random stream is its own (``object_rng``): the build thins a
    # cloud with this order.
    orders = [object_rng(settings.seed, p.name, 1).permutation(len(p.areas))
              if n < len(p.areas) else None for p, n in zip(read, wanted)]
    lamp_list = lamps.read_lamps(depsgraph, warnings) if settings.lamps else []
    world = lamps.world_light(depsgraph.scene, warnings) if settings.world_ambient else None
    refine = None
    first = counts
    two_passes = settings.adaptive
    if chosen is not None and adaptive_error_ratio_applies(settings):
        two_passes = bool(chosen.get("adaptive", True))   # the models' choice: the faster
    if settings.target_error is not None and two_passes and tri_meshes:
        fraction = float(settings.adaptive_first_pass)
        if not 0.0 < fraction <= 1.0:
            raise IllumapError(f"Adaptive first pass must be a fraction in (0, 1], got {fraction}", ExitCode.USAGE)
        refine = _Scene(tri_meshes, counts, [], point_sources, lamp_list, world)   # points: build
        first = np.maximum(np.rint(counts * fraction).astype(np.int64), 1)
    # The emissive triangles a lamp carries: their surfels' emission leaves the solve.
    mesh_emitters, light_masks = emitters.mesh_lights(tri_meshes, warnings)
    if refine is not None:
        refine.light_masks = light_masks
    samples = [sampling.sample_mesh(tm, int(n), object_rng(settings.seed, tm.name))
               for tm, n in zip(tri_meshes, first)]
    mesh_parts = _surfel_parts(samples, light_masks, warnings)
    receivers = []
    if settings.transfer:
        scratch: list[str] = []   # material warnings were given for the surfels already
        receivers = [r for r in (sampling.read_receivers(obj, warnings, depsgraph, scratch)
                                 for obj in meshes if obj.type == "MESH") if r is not None]
    # The preview that follows the run draws each scan from these (the worker computes its
    # splats, ``point_splats.prepare_frames``).
    splat_inputs = []
    if settings.preview_splats and settings.transfer:
        from ..preview.mesh_preview import splat_inputs as read_splat_inputs
        splat_inputs = [read_splat_inputs(obj) for obj in points if obj.type in RESULT_TYPES]
    read_scene = _ReadScene(
        settings=settings, t0=t0, warnings=warnings, stats=stats, read=read, wanted=wanted,
        orders=orders, point_sources=point_sources, refine=refine, chosen=chosen,
        mesh_parts=mesh_parts, lamp_list=lamp_list, world=world, mesh_emitters=mesh_emitters,
        mesh_surfaces=[_MeshSurface(tm.corners, tm.two_sided) for tm in tri_meshes],
        receivers=receivers, splat_inputs=splat_inputs)
    return UnbuiltJob(partial(_build, read_scene))


@dataclass
class _ReadScene:
    """What ``_prepare`` read on the main thread, for ``_build`` on the worker."""

    settings: Settings
    t0: float
    warnings: list
    stats: dict
    read: list
    wanted: list
    orders: list
    point_sources: list
    refine: _Scene | None
    chosen: dict | None
    mesh_parts: object
    lamp_list: list
    world: object
    mesh_emitters: list
    mesh_surfaces: list
    receivers: list
    splat_inputs: list


def _build(scene: _ReadScene, progress: Progress | None = None) -> Job:
    """The job from what was read: numpy and the core only, off the main thread for an
    interactive run (point normals, thinning, occluding triangles, the preview's splats)."""
    def going_on(_fraction=0.0, _phase="") -> bool:
        return progress is None or progress(0.0, BUILD_PHASE) is not False

    def stop_if_cancelled():
        if not going_on():
            raise IllumapCancelled("Cancelled")

    stop_if_cancelled()
    full = [pointcloud.with_normals(p) for p in scene.read]
    clouds = [_point_part(p) for p in full]
    thinned = [_thin_points(part, n, order)
               for part, n, order in zip(clouds, scene.wanted, scene.orders)]
    point_parts = [part for part, _ in thinned]
    for (name, _, _), whole, part in zip(scene.point_sources, clouds, point_parts):
        if len(part[0]) < len(whole[0]):
            scene.stats.setdefault("point_surfels", {})[name] = dict(points=len(whole[0]),
                                                                     surfels=len(part[0]))
    if scene.refine is not None:
        scene.refine.points = point_parts
    parts = _with_points(scene.mesh_parts, point_parts, scene.point_sources)
    stop_if_cancelled()
    triangles, two_sided, splat_point, outlines = _surface_triangles(
        scene.mesh_surfaces, clouds, scene.point_sources, [p.neighbours for p in full])
    for samples in (*scene.read, *full):    # the shared search's tables: 72 B a point
        samples.neighbours = None
    stop_if_cancelled()
    occluders = None
    # Built here when the back faces' probe needs it or the scene has splats: those are cast
    # against as one outline each, which only their outlines (dropped after this) tell.
    if triangles is not None and (outlines is not None
                                  or any(m.two_sided for m in scene.mesh_surfaces)):
        from illumap.receivers import MeshOccluders
        try:
            occluders = MeshOccluders(triangles, progress=going_on, splats=outlines)
        except Exception as exc:  # noqa: BLE001 - the core's Cancelled
            if core_cancelled(exc):
                raise IllumapCancelled("Cancelled") from None
            raise
    outlines = None
    job = _assembled(parts, scene.settings, scene.lamp_list, scene.world, scene.warnings,
                     scene.stats, scene.t0, occluders)
    job.refine = scene.refine
    job.accuracy = scene.chosen
    job.emitters = scene.mesh_emitters
    job.triangles = triangles
    job.two_sided = two_sided
    job.splat_point = splat_point
    job.mesh_triangle_start = np.cumsum([0] + [len(m.corners)
                                               for m in scene.mesh_surfaces])[:-1]
    job.occluders = occluders
    job.clouds = [PointCloud(p.name, p.positions,
                             p.receiver_normals if p.receiver_normals is not None else p.normals,
                             p.albedo, p.emission, owner)
                  for p, (_, owner) in zip(full, thinned)]
    job.receivers = scene.receivers
    for inputs in scene.splat_inputs:
        stop_if_cancelled()
        try:
            point_splats.prepare_frames(*inputs, progress=going_on)
        except Exception as exc:  # noqa: BLE001 - the core's Cancelled
            if core_cancelled(exc):
                raise IllumapCancelled("Cancelled") from None
            raise
    return job


#: The progress phase while an ``UnbuiltJob`` is built.
BUILD_PHASE = "building the scene"


@dataclass
class _MeshSurface:
    """A mesh's triangles (T, 3, 3), m, and whether it is an open surface."""

    corners: np.ndarray
    two_sided: bool


@dataclass
class UnbuiltJob:
    """A scene as ``prepare(…, build=False)`` read it on the main thread: ``build(progress)``
    makes the Job from it with numpy and the core alone (the point clouds' normals, thinning
    and splats, the scene's ray-casting structure, the open surfaces' back faces), so an
    interactive run does that on its worker (``operators.ComputeTask``; ``run`` takes only
    a built Job)."""

    build: Callable[..., "Job"]


#: How far a back-face surfel's preview disc sits off its surface, in surfel radii.
BACK_DISC_LIFT = 0.05


#: Rays that look for anything in view of a back face (``_back_faces_in_view``).
BACK_FACE_PROBE_RAYS = 16


def _point_counts(settings: Settings, density: float | None, point_counts: list[int],
                  sources: list, mesh_area: float) -> list[int]:
    """Surfels per point cloud (``point_counts``: its points): its area (m²) × the density
    when one is set or chosen, else its share of the surface in the budget; never more than
    its points."""
    total = mesh_area + sum(src[1] for src in sources)
    out = []
    for points, (_, area, _) in zip(point_counts, sources):
        dens = density if density is not None else settings.density
        if dens is not None:
            want = dens * area
        else:
            budget = settings.budget if settings.budget is not None else DEFAULT_BUDGET
            want = budget * area / total if total > 0 else points
        out.append(int(min(points, max(1, round(want)))))
    return out


def _thin_points(part: tuple, count: int, order: np.ndarray | None) -> tuple[tuple, np.ndarray]:
    """About ``count`` of a cloud's points as surfels, one per cell of a grid sized to the
    cloud's area (the first point in the random ``order``, a permutation of the points, None
    when no thinning is wanted), each carrying the area, albedo and emission (area-weighted)
    of the points nearest to it. Returns (the surfels' part, the surfel (row) of every
    point)."""
    positions, normals, areas = part[0], part[1], part[2]
    n = len(positions)
    if count >= n:
        return part, np.arange(n, dtype=np.int64)
    from illumap.neighbours import knn
    cell = np.sqrt(areas.sum() / count)
    for _ in range(3):   # a surface crosses more cells than its area / cell²: correct the size
        cells = np.floor((positions[order] - positions.min(axis=0)) / cell).astype(np.int64)
        keep = np.sort(order[first_in_each_cell(cells)])
        if abs(len(keep) - count) <= 0.1 * count:
            break
        cell *= np.sqrt(len(keep) / count)
    idx, _ = knn(positions[keep], positions, 1)
    owner = idx[:, 0]
    area = np.bincount(owner, weights=areas, minlength=len(keep))
    weighted = [np.stack([np.bincount(owner, weights=areas * v[:, c], minlength=len(keep))
                          for c in range(3)], axis=1) / np.maximum(area, 1e-300)[:, None]
                for v in (part[3], part[4])]
    thinned = (positions[keep], normals[keep], area, weighted[0], weighted[1]) + \
        tuple(p[keep] for p in part[5:])
    return thinned, owner


def _surface_triangles(tri_meshes: list, point_parts: list, point_sources: list,
                       point_neighbours: list | None = None) -> tuple:
    """The scene's surface as triangles (T, 3, 3), m: the meshes' own, then each point
    cloud's splats (``illumap.splats``); which of them are two-sided (T,) bool (open meshes;
    point clouds of unknown orientation); and the point each splat triangle belongs to (T,)
    int32, counted over all clouds in order (-1: a mesh's); and the splats' outlines
    (``illumap.splats.SplatOutlines`` of all clouds' points in order, None without points),
    for the ray scene. Nones for an empty scene.
    ``point_neighbours``: per cloud, its points' own search (``pointcloud.own_neighbours``)
    or None, so the splats' planes need not search again."""
    if not tri_meshes and not point_parts:
        return None, None, None, None
    from illumap.splats import DEFAULT_SIDES, SplatOutlines, splat_triangles
    # One array filled in place: concatenating the parts held a scan's splats twice (0.86 GB
    # per 1M points each).
    counts = [len(tm.corners) for tm in tri_meshes] + \
        [len(part[0]) * DEFAULT_SIDES for part in point_parts]
    total = int(sum(counts))
    corners = np.empty((total, 3, 3))
    sided = np.empty(total, dtype=bool)
    owner = np.full(total, -1, dtype=np.int32)   # int32: a dozen splat triangles per point
    start = 0
    for tm in tri_meshes:
        stop = start + len(tm.corners)
        corners[start:stop] = tm.corners
        sided[start:stop] = tm.two_sided
        start = stop
    first = 0
    nearest = point_neighbours or [None] * len(point_parts)
    outlines = []
    for part, (_, _, both), table in zip(point_parts, point_sources, nearest):
        n = len(part[0])
        stop = start + n * DEFAULT_SIDES
        if n:
            outlines.append(splat_triangles(part[0], part[1], part[2], out=corners[start:stop],
                                            nearest=table, outlines=True)[1])
        sided[start:stop] = both
        owner[start:stop].reshape(n, DEFAULT_SIDES)[:] = first + np.arange(n)[:, None]
        start, first = stop, first + n
    from illumap.splats import OUTLINE_RAYS
    return corners, sided, owner, SplatOutlines.joined(outlines) if OUTLINE_RAYS else None


def _back_faces_in_view(occluders, positions: np.ndarray, normals: np.ndarray) -> np.ndarray:
    """Which points (facing ``normals``) see any triangle in ``BACK_FACE_PROBE_RAYS`` rays: the
    back of a room's wall that faces only the black world can neither send nor receive light.
    All of them when there are no occluders to ask."""
    if occluders is None or len(positions) == 0:
        return np.ones(len(positions), dtype=bool)
    from illumap.receivers import cosine_directions
    k = BACK_FACE_PROBE_RAYS
    dirs = cosine_directions(normals, k, np.arange(len(positions))).reshape(-1, 3)
    origins = np.repeat(positions + occluders.offset * normals, k, axis=0)
    tri, _, _ = occluders.intersect(origins, dirs)
    return (tri.reshape(-1, k) >= 0).any(axis=1)


def _assemble(settings: Settings, samples: list, light_masks: list, point_parts: list,
              point_sources: list, lamp_list: list, world, warnings: list[str], stats: dict,
              t0: float, occluders=None) -> Job:
    """Materials and the Job from sampled meshes (``light_masks``: per mesh, the triangles
    whose emission a lamp carries) and point clouds (direct light: ``light``);
    ``occluders`` (the scene's triangles) find the open surfaces' back faces in view."""
    parts = _with_points(_surfel_parts(samples, light_masks, warnings), point_parts,
                         point_sources)
    return _assembled(parts, settings, lamp_list, world, warnings, stats, t0, occluders)


@dataclass
class _SurfelParts:
    """The surfels as read (numpy only), before the open surfaces' back faces are chosen:
    each part is (positions, normals, areas, albedo, emission, uv, triangle, bary,
    material index)."""

    fronts: list                  # meshes' and point clouds' parts, in order
    sources: list                 # Source of each front part
    in_lamp: list                 # (n,) bool per front part: emission a lamp carries
    backs: list                   # (sample index, name, area, part) per open mesh: every row
    point_backs: list             # (name, area, part) per point cloud of unknown orientation


def _surfel_parts(samples: list, light_masks: list, warnings: list[str]) -> _SurfelParts:
    """The meshes' surfels with their materials (main thread: the materials are bpy's);
    ``light_masks`` (``emitters.mesh_lights``): per mesh, the triangles whose emission a
    lamp carries."""
    fronts, sources, start = [], [], 0
    for s in samples:
        albedo, emission = materials.surfel_materials(s, warnings)
        fronts.append((s.positions, s.normals, s.areas, albedo, emission, _uv_rows(s),
                       s.triangle, s.bary, s.material_index))
        sources.append(Source(s.mesh.name, "MESH", start, start + len(s.areas), s.mesh.total_area))
        start += len(s.areas)
    in_lamp = [mask[s.triangle] for s, mask in zip(samples, light_masks)]
    scratch: list[str] = []   # the front faces' evaluation already warned about the materials
    backs = []
    for index, s in enumerate(samples):
        if s.mesh.two_sided and len(s.areas):
            albedo, emission = materials.surfel_materials(s, scratch, side="back")
            backs.append((index, s.mesh.name, s.mesh.total_area,
                          (s.positions, -s.normals, s.areas, albedo, emission, _uv_rows(s),
                           s.triangle, s.bary, s.material_index)))
    return _SurfelParts(fronts, sources, in_lamp, backs, [])


def _with_points(meshes: _SurfelParts, point_parts: list, point_sources: list) -> _SurfelParts:
    """The meshes' parts followed by the point clouds' (no bpy); a cloud of unknown
    orientation brings its back faces too."""
    fronts, sources, in_lamp = list(meshes.fronts), list(meshes.sources), list(meshes.in_lamp)
    start = sources[-1].stop if sources else 0
    for part, (name, area, _) in zip(point_parts, point_sources):
        fronts.append(part)
        sources.append(Source(name, "POINTS", start, start + len(part[2]), area))
        start += len(part[2])
        in_lamp.append(np.zeros(len(part[2]), dtype=bool))
    point_backs = [(name, area, (part[0], -part[1]) + tuple(part[2:]))
                   for part, (name, area, two_sided) in zip(point_parts, point_sources)
                   if two_sided]
    return _SurfelParts(fronts, sources, in_lamp, meshes.backs, point_backs)


def _point_part(p) -> tuple:
    """A point cloud (``pointcloud.PointSamples`` with normals) as a surfel part."""
    m = len(p.areas)
    return (p.positions, p.normals, p.areas, p.albedo, p.emission, np.full((m, 2), np.nan),
            np.full(m, -1, np.int64), np.full((m, 3), np.nan), np.full(m, -1, np.int64))


def _uv_rows(samples) -> np.ndarray:
    uv = samples.uv()
    return uv if uv is not None else np.full((len(samples.areas), 2), np.nan)


def _assembled(parts: _SurfelParts, settings: Settings, lamp_list: list, world,
               warnings: list[str], stats: dict, t0: float, occluders=None) -> Job:
    """The Job from the surfels' parts (no bpy): the back faces of open surfaces, as surfels
    of their own (normals reversed), where they can exchange light with anything
    (``occluders``, the scene's triangles, say where; under a world, everywhere); then the
    points of unknown orientation (normals estimated), two-sided: a surfel each way."""
    chosen, sources, in_lamp = list(parts.fronts), list(parts.sources), list(parts.in_lamp)
    start = sources[-1].stop if sources else 0
    for index, name, area, part in parts.backs:
        keep = _back_faces_in_view(occluders, part[0], part[1]) if world is None \
            else np.ones(len(part[2]), dtype=bool)
        if not keep.any():
            continue
        chosen.append(tuple(column[keep] for column in part))
        sources.append(Source(name, "BACK", start, start + int(keep.sum()), area))
        start += int(keep.sum())
        in_lamp.append(parts.in_lamp[index][keep])
    for name, area, part in parts.point_backs:
        chosen.append(part)
        sources.append(Source(name, "BACK", start, start + len(part[0]), area))
        start += len(part[0])
        in_lamp.append(np.zeros(len(part[0]), dtype=bool))
    check_memory(start, settings)
    pos, nrm, area, albedo, emission, uv, tri, bary, mat_idx = (
        np.concatenate([p[i] for p in chosen]) for i in range(9))
    # Emission that a lamp of emitters.py carries leaves the solve (the surfels still reflect).
    in_lamp = np.concatenate(in_lamp)
    timings = {"sampling": time.perf_counter() - t0}
    return Job(settings=settings, positions=np.ascontiguousarray(pos), normals=np.ascontiguousarray(nrm),
               areas=np.ascontiguousarray(area), albedo=np.ascontiguousarray(albedo),
               emission=np.ascontiguousarray(emission),
               direct=None, uv=uv,
               solve_emission=np.ascontiguousarray(np.where(in_lamp[:, None], 0.0, emission)),
               triangle=tri.astype(np.int64), bary=bary, material_index=mat_idx.astype(np.int64),
               sources=sources, warnings=warnings, timings=timings, stats=stats,
               lamps=list(lamp_list), world=world)
