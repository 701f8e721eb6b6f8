"""The add-on's pipeline: scene → surfels → solve → results in the file.

Contract (docs/architecture.md):

* ``prepare(depsgraph, objects, settings) -> Job``: main thread; reads bpy, samples surfels,
  evaluates materials and reads the lamps (numpy only afterwards).
* ``run(job, progress) -> Result``: no bpy, safe on a worker thread: direct light from the
  lamps with its shadow rays (``light``, phase "lamp shadows"), then the solve.
* ``write(context, job, result) -> Object``: main thread; creates/replaces ``Illumap Surfels``,
  transfers to meshes, exports files.
* ``compute(context, objects, settings, progress=None) -> Result``: the synchronous path.

Shadow rays are the slow part of direct light (a second at 40k surfels, minutes at millions),
so they run on the worker where Esc can stop them, not in ``prepare``.

Nothing in the file changes unless ``run`` succeeded: ``prepare`` only reads, ``run`` never
touches bpy, and ``write`` is called only with a successful result. Problems a user can fix
raise ``IllumapError`` (``IllumapCancelled`` when cancelled).
"""

from __future__ import annotations

import math
import os
import time
from collections import Counter
from dataclasses import dataclass, replace
from typing import Callable

import numpy as np

from illumap import lights
from illumap.identities import object_rng
from illumap.settings import (DEFAULT_BUDGET, QUALITY_PRESETS, Settings, SettingsError,
                              from_preset)
from illumap.settings import spec as setting_spec

from . import checks, emitters, lamps, materials, point_splats, pointcloud, sampling
from .errors import ExitCode, IllumapCancelled, IllumapError, core_cancelled
from .job import Job, Result, Source
from .kinds import HELPER_TYPES, MESH_TYPES, RESULT_TYPES, is_instancer
from .receive import hemisphere_hits, mesh_occluders, receive, target_shadow_samples

Progress = Callable[[float, str], "bool | None"]

# Rough peak memory per surfel for sampling, solver vectors and the FMM tree (bytes). Used to
# refuse budgets that cannot fit before anything is allocated.
BYTES_PER_SURFEL = 2048


def settings_from_preset(name: str, **overrides) -> Settings:
    """Settings for a preset name (draft, medium or high, any case) with keyword overrides
    (``illumap.settings.from_preset``); a bad name is a usage error."""
    try:
        return from_preset(name, **overrides)
    except SettingsError as exc:
        raise IllumapError(str(exc), ExitCode.USAGE) from None


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


def memory_limit(settings: Settings) -> int:
    """The byte limit runs are checked against (settings, else half the physical memory)."""
    if settings.memory_limit:
        return int(settings.memory_limit)
    try:
        return os.sysconf("SC_PHYS_PAGES") * os.sysconf("SC_PAGE_SIZE") // 2
    except (ValueError, OSError, AttributeError):
        return 8 << 30


def _mesh_share(budget: int, mesh_area: float, point_area: float, meshes: int) -> int:
    """The meshes' part of the default budget beside point clouds: their share of the whole
    surface (m²), so that a lamp-sized emitter beside a scan is not given the whole budget."""
    if point_area <= 0:
        return budget
    return max(meshes, int(round(budget * mesh_area / (mesh_area + point_area))))


def check_memory(count: int, settings: Settings) -> None:
    """Refuse a surfel count whose estimated memory exceeds the limit, with the estimate."""
    need = int(count) * BYTES_PER_SURFEL
    limit = memory_limit(settings)
    if need > limit:
        raise IllumapError(
            f"{count:,} surfels would need about {need / 2**30:.1f} GiB "
            f"(~{BYTES_PER_SURFEL} bytes each), more than the {limit / 2**30:.1f} GiB allowed; "
            "lower the density or the surfel budget")


def _split_objects(depsgraph, objects) -> tuple[list, list, list[str]]:
    meshes, points, warnings = [], [], []
    from .output import SURFEL_OBJECT
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


#: Disc radius of the surfels as occluders, in units of each surfel's own radius sqrt(A/π):
#: for lamp shadows (``make_segment_query``) and for exact visibility between surfels
#: (``TransportOperator``'s ``coverage``), so both see the same walls. Holes in a stratified
#: surfel set reach 1.7 of that radius inside a surface and 2.2 at its outline. Too small leaks
#: light, too large darkens: discs overhang outlines and block pairs that see each other.
#: Measured for 1.3 (the core's default) / 1.5 / 1.7 / 2.0:
#: * lamp shadows, a 1 m plate over a floor (100 and 400 surfels/m², four lamp types, 16 rays
#:   per surfel): the worst umbra surfel keeps 31–50% / 19% / 6% (one ray in 16) / 0%.
#: * interreflection through a one-sided thin wall between two rooms (High preset, 400/m²;
#:   tests/blender/test_thin_wall.py): the dark room gets 1.4–1.5% / 0.10–0.17% / 0.04–0.06% /
#:   0.03–0.04% of the lit room's level (0.08–0.09% / 0.02% / 0.01% / 0.01% at 1600/m²; a
#:   two-sided wall leaks ten times less).
#: * over-occlusion, a closed box holding a block, where every row of F·V sums to 1: mean
#:   |row sum − 1| 0.041 / 0.049 / 0.058 / 0.074 at 400/m² (0.020 / 0.024 / 0.029 / 0.037 at
#:   1600/m²; 0.024 and 0.012 without the block or visibility, the operator's own error).
#: * against a Cycles bake of a box with a lamp-shadowing block (tests/blender/
#:   test_bake_compare.py, this value for both uses): relative RMS 0.065 / 0.074 / 0.084 / 0.103,
#:   mean ratio 0.988 / 0.975 / 0.962 / 0.942.
#: 1.7 keeps speckles out of lamp shadows and light out of closed rooms; the price is a few
#: per cent less light in enclosed scenes, shrinking with density.
SURFEL_COVERAGE = 1.7
def occluder_shape(settings: Settings) -> str:
    """The occluder shape this run uses for lamp shadows and exact visibility alike: the
    settings' own, except with a target error, whose models are calibrated on discs.
    Raises IllumapError (exit code 2) for an unknown shape."""
    shapes = setting_spec("occluder_shape").values
    shape = str(settings.occluder_shape).lower()
    if shape not in shapes:
        raise IllumapError(f"Unknown occluder shape '{settings.occluder_shape}' (choose "
                           f"{', '.join(shapes)})", ExitCode.USAGE)
    return "disc" if settings.target_error is not None else shape


def make_segment_query(positions, normals, areas, progress=None, shape="disc"):
    """The segment query lamp shadows are cast with, ``visible(origins, targets, skip,
    progress=None)``: the core's ``illumap.Occluders`` built once on the surfels (``shape``s
    of the area of discs of SURFEL_COVERAGE), or None when the installed core has none.
    ``progress`` hears the build."""
    import illumap
    occluders = getattr(illumap, "Occluders", None)
    if occluders is None:
        return None
    n = len(areas)
    surfels = illumap.Surfels(positions, normals, areas, np.zeros((n, 3)), np.zeros((n, 3)))
    build = None if progress is None else (lambda f, _phase="": progress(0.0, lights.PHASE))
    occ = occluders(surfels, coverage=SURFEL_COVERAGE, shape=shape, progress=build)

    def visible(origins, targets, skip, progress=None):
        return occ.visible(origins, targets, skip=skip, progress=progress)
    return visible


def adaptive_error_ratio_applies(settings: Settings) -> bool:
    """Whether this run's adaptive passes are those the core's ADAPTIVE_ERROR_RATIO was
    measured with (first pass share and density bound): then the error model may count on it."""
    from illumap import accuracy
    return (settings.adaptive
            and math.isclose(settings.adaptive_first_pass, accuracy.ADAPTIVE_FIRST_SHARE)
            and math.isclose(settings.adaptive_max_ratio, accuracy.ADAPTIVE_MAX_RATIO))


#: With the light evaluated at the meshes (``receive``), the surfels only carry the indirect
#: light, a fraction of what a receiver sees, and the final gather averages their error over
#: its rays: the surfels are solved to this multiple of the target error, at most
#: MAX_SURFEL_TARGET. bench/reference, every scene against its Cycles bake (one run,
#: 2026-12-06): at 5 each target was met with room to spare (10%: 1.4-4.6%, 3%: 0.8-2.0%,
#: 1%: 0.39-0.75%) in about half the time it took at 3 (3%: 0.35-0.62 s instead of 0.73-1.25 s).
RECEIVER_TARGET_RATIO = 5.0
MAX_SURFEL_TARGET = 0.3


def surfel_target(settings: Settings) -> float | None:
    """The target error the surfel solve is held to: the settings' own, or a multiple of it
    when the light is evaluated at the meshes (RECEIVER_TARGET_RATIO)."""
    t = settings.target_error
    if t is None or not settings.transfer:
        return t
    return min(MAX_SURFEL_TARGET, RECEIVER_TARGET_RATIO * t)


def surfel_shadow_samples(settings: Settings) -> int:
    """Shadow rays per surfel and sized lamp (the world's too, up to ``lights.WORLD_SAMPLES``):
    the settings' own, or with a target error at least what a receiver casts for the surfels'
    target (``surfel_target``), at most ``lights.WORLD_SAMPLES``. Each surfel's direct light is
    a sample whose noise every receiver that gathers it takes in: in a room lit through a
    window (the bench's ``window``, Target 1%) the sky seen through it with 16 rays per surfel
    moved the walls by about 1% from one sampling to the next; 32 rays took the scene from
    1.38% to 1.24% against Cycles (64: 1.21%, for twice the rays), the other bench scenes as
    before."""
    own = int(settings.shadow_samples)
    target = surfel_target(settings)
    if target is None:
        return own
    return max(own, min(target_shadow_samples(target), lights.WORLD_SAMPLES))


def target_density(settings: Settings, mesh_area: float, point_count: int, point_area: float,
                   stats: dict) -> tuple[float, dict] | None:
    """Surfels per m² for meshes that the error model says meet ``settings.target_error``,
    and the settings it chose for that count (``illumap.accuracy.choose_mesh_settings``: the
    "mesh" kind, calibrated on stratified triangle samples as ``sampling`` draws them, with the
    adaptive error ratio when two passes run; scans alone: ``choose_settings``, kind
    "point_cloud"). The budget, when set, caps the count. Fills ``stats['density']`` with the
    choice. None without a target error."""
    if settings.target_error is None:
        return None
    from illumap import accuracy
    total = mesh_area + point_area
    kind = "mesh" if mesh_area > 0 else "point_cloud"
    cap = settings.budget if settings.budget else None
    if kind == "point_cloud":
        cap = point_count
    # meshes are sampled at any count, a scan has its points
    summary = dict(n=accuracy.NO_SURFEL_LIMIT if kind == "mesh" else max(point_count, 1),
                   total_area=total, kind=kind)
    try:
        if kind == "mesh":
            chosen = accuracy.choose_mesh_settings(summary, surfel_target(settings), kind=kind,
                                                   adaptive=adaptive_error_ratio_applies(settings),
                                                   max_surfels=cap)
        else:
            chosen = accuracy.choose_settings(summary, surfel_target(settings), kind=kind,
                                              max_surfels=cap)
    except (ValueError, KeyError) as exc:  # InputError is a ValueError
        raise IllumapError(f"Cannot choose a surfel density for target error "
                           f"{settings.target_error:g}: {exc}", ExitCode.INPUT) from None
    density = chosen["n"] / total
    predicted = chosen.get("predicted") or {}
    disc = predicted.get("discretization")
    if disc is None:
        disc = predicted.get("total", float("nan"))
    stats["density"] = dict(target_error=float(settings.target_error), kind=kind,
                            density=float(density), surfels=int(chosen["n"]),
                            predicted_discretization=float(disc),
                            discretization_scale=float(chosen["discretization_scale"]),
                            surfel_target=float(surfel_target(settings)),
                            predicted=float(predicted.get("total", float("nan"))),
                            reached=bool(chosen.get("reached", True)), cap=cap,
                            notes=list(chosen.get("notes", [])))
    return density, chosen


def capped_target_warning(density: dict) -> str | None:
    """What to tell a user whose target error the surfel count cannot reach: the budget (or a
    scan's points) caps it below what the error model needs. None when the target is within
    reach. ``density`` is ``stats['density']`` from ``target_density``."""
    if density.get("reached", True):
        return None
    wanted = density["surfel_target"]
    where = ("above the target" if wanted == density["target_error"] else
             f"where the target leaves them {wanted:.1%} (they carry the indirect light)")
    predicted = f"the surfels are predicted at {density['predicted']:.1%} error {where}"
    head = f"Target error {density['target_error']:.2%} may not be met"
    cap = density.get("cap")
    if cap is None:
        return f"{head}: at the most surfels the error model covers, {predicted}; loosen the target"
    if density["kind"] == "point_cloud":
        limit, remedy = f"the scans' {cap:,} points cap", "a denser scan or a looser target"
    else:
        limit, remedy = f"the surfel budget of {cap:,} caps", "raise the budget or clear it"
    return f"{head}: {limit} the surfels, and {predicted}; {remedy}"


def prepare(depsgraph, objects, settings: Settings, *, build: bool = True) -> "Job | UnbuiltJob":
    """Read the scene on the main thread and build the job (``_prepare``), with any mesh
    preview of the objects switched off while their materials are read. ``build=False``:
    the scene as read (``UnbuiltJob``), to be built on a worker thread (``ComputeTask``)."""
    import bpy

    from . import mesh_preview
    checks.check_settings(settings)   # refused before anything is read
    objects = list(objects)
    with mesh_preview.suspended(objects, bpy.context.view_layer):
        unbuilt = _prepare(depsgraph, objects, settings)
    return unbuilt.build() if build else unbuilt


def _prepare(depsgraph, objects, settings: Settings) -> UnbuiltJob:
    """Read the scene on the main thread (surfels, materials, lamps, receivers), to be built
    into the job by ``UnbuiltJob.build`` (the direct light is ``run``'s first phase,
    ``light``).

    With a target error and ``settings.adaptive``, this is pass 1 (a fraction of the surfels,
    uniform); ``next_pass`` builds pass 2 from its result.
    """
    t0 = time.perf_counter()
    meshes, points, warnings = _split_objects(depsgraph, objects)
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
    point_sources = [(p.name, float(p.areas.sum()), p.two_sided) for p in read]
    stats: dict = {}
    mesh_areas = np.array([tm.total_area for tm in tri_meshes])
    target = target_density(settings, float(mesh_areas.sum()),
                            sum(len(p.areas) for p in read),
                            sum(src[1] for src in point_sources), stats)
    density, chosen = target if target is not None else (None, None)
    if target is not None:
        capped = capped_target_warning(stats["density"])
        if capped:
            warnings.append(capped)
    counts = np.zeros(0, dtype=np.int64)
    point_area = sum(src[1] for src in point_sources)
    if tri_meshes:
        n_points = sum(len(p.areas) for p in read)
        if density is not None and settings.budget and stats["density"]["surfels"] >= settings.budget:
            # The budget caps the target's count: spend it exactly, as without a target.
            counts = sampling.allocate(mesh_areas, budget=max(settings.budget - n_points,
                                                              len(tri_meshes)))
        elif density is not None:
            counts = sampling.allocate(mesh_areas, density=density)
        else:
            budget = settings.budget
            if budget is None and settings.density is None:
                budget = DEFAULT_BUDGET
            if budget is not None:
                budget = _mesh_share(budget, float(mesh_areas.sum()), point_area, len(tri_meshes))
            counts = sampling.allocate(mesh_areas, density=settings.density, budget=budget)
    check_memory(int(counts.sum()), settings)  # before sampling allocates anything big
    # Every point is a receiver; the solve needs only as many surfels as the light does.
    wanted = _point_counts(settings, density, [len(p.areas) for p in read], point_sources,
                           float(mesh_areas.sum()))
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
    mesh_emitters = emitters.mesh_lights(tri_meshes, warnings)
    samples = [sampling.sample_mesh(tm, int(n), object_rng(settings.seed, tm.name))
               for tm, n in zip(tri_meshes, first)]
    mesh_parts = _surfel_parts(samples, warnings)
    receivers = []
    if settings.transfer:
        scratch: list[str] = []   # material warnings were given for the surfels already
        receivers = [r for r in (sampling.read_receivers(obj, warnings, depsgraph, scratch)
                                 for obj in meshes if obj.type == "MESH") if r is not None]
    mesh_surfaces = [_MeshSurface(tm.corners, tm.two_sided) for tm in tri_meshes]
    # The preview that follows the run draws each scan from these (the worker computes its
    # splats, ``point_splats.prepare_frames``).
    splat_inputs = []
    if settings.preview_splats and settings.transfer:
        from .mesh_preview import splat_inputs as read_splat_inputs
        splat_inputs = [read_splat_inputs(obj) for obj in points if obj.type in RESULT_TYPES]

    def build(progress: Progress | None = None) -> Job:
        # numpy and the core only from here: off the main thread for an interactive run
        def going_on(_fraction=0.0, _phase="") -> bool:
            return progress is None or progress(0.0, BUILD_PHASE) is not False

        def stop_if_cancelled():
            if not going_on():
                raise IllumapCancelled("Cancelled")

        stop_if_cancelled()
        full = [pointcloud.with_normals(p) for p in read]
        clouds = [_point_part(p) for p in full]
        thinned = [_thin_points(part, n, order) for part, n, order in zip(clouds, wanted, orders)]
        point_parts = [part for part, _ in thinned]
        for (name, _, _), whole, part in zip(point_sources, clouds, point_parts):
            if len(part[0]) < len(whole[0]):
                stats.setdefault("point_surfels", {})[name] = dict(points=len(whole[0]),
                                                                   surfels=len(part[0]))
        if refine is not None:
            refine.points = point_parts
        parts = _with_points(mesh_parts, point_parts, point_sources)
        stop_if_cancelled()
        triangles, two_sided, splat_point = _surface_triangles(mesh_surfaces, clouds, point_sources)
        stop_if_cancelled()
        occluders = None
        if triangles is not None and any(m.two_sided for m in mesh_surfaces):
            from illumap.receivers import MeshOccluders
            try:
                occluders = MeshOccluders(triangles, progress=going_on)
            except Exception as exc:  # noqa: BLE001 - the core's Cancelled
                if core_cancelled(exc):
                    raise IllumapCancelled("Cancelled") from None
                raise
        job = _assembled(parts, settings, lamp_list, world, warnings, stats, t0, occluders)
        job.refine = refine
        job.accuracy = chosen
        job.emitters = mesh_emitters
        job.triangles = triangles
        job.two_sided = two_sided
        job.splat_point = splat_point
        job.mesh_triangle_start = np.cumsum([0] + [len(m.corners) for m in mesh_surfaces])[:-1]
        job.occluders = occluders
        job.clouds = [PointCloud(p.name, p.positions,
                                 p.receiver_normals if p.receiver_normals is not None else p.normals,
                                 p.albedo, p.emission, owner)
                      for p, (_, owner) in zip(full, thinned)]
        job.receivers = receivers
        for inputs in splat_inputs:
            stop_if_cancelled()
            point_splats.prepare_frames(*inputs)
        return job
    return UnbuiltJob(build)


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


@dataclass
class PointCloud:
    """A point cloud as read, every point a receiver (numpy only): positions and the normals
    it is lit about (P, 3; ``PointSamples.receiver_normals``), albedo and emission (P, 3), and
    the surfel (row in its own source) that stands for each point in the solve."""

    name: str
    positions: np.ndarray
    normals: np.ndarray
    albedo: np.ndarray
    emission: np.ndarray
    surfel: np.ndarray


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
        keys = np.floor((positions[order] - positions.min(axis=0)) / cell).astype(np.int64)
        _, first = np.unique(keys, axis=0, return_index=True)
        keep = np.sort(order[first])
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


def _surface_triangles(tri_meshes: list, point_parts: list, point_sources: list) -> tuple:
    """The scene's surface as triangles (T, 3, 3), m: the meshes' own, then each point
    cloud's splats (``illumap.splats``); which of them are two-sided (T,) bool (open meshes;
    point clouds of unknown orientation); and the point each splat triangle belongs to (T,)
    int64, counted over all clouds in order (-1: a mesh's). Nones for an empty scene."""
    parts = [tm.corners for tm in tri_meshes]
    sided = [np.full(len(tm.corners), tm.two_sided) for tm in tri_meshes]
    owner = [np.full(len(tm.corners), -1, dtype=np.int64) for tm in tri_meshes]
    first = 0
    if point_parts:
        from illumap.splats import splat_triangles
        for part, (_, _, both) in zip(point_parts, point_sources):
            tri = splat_triangles(part[0], part[1], part[2])
            parts.append(tri)
            sided.append(np.full(len(tri), both))
            n = len(part[0])
            owner.append(first + np.repeat(np.arange(n, dtype=np.int64), len(tri) // max(n, 1)))
            first += n
    if not parts:
        return None, None, None
    return np.concatenate(parts), np.concatenate(sided), np.concatenate(owner)


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


def _assemble(settings: Settings, samples: list, point_parts: list, point_sources: list,
              lamp_list: list, world, warnings: list[str], stats: dict, t0: float,
              occluders=None) -> Job:
    """Materials and the Job from sampled meshes and point clouds (direct light: ``light``);
    ``occluders`` (the scene's triangles) find the open surfaces' back faces in view."""
    parts = _with_points(_surfel_parts(samples, warnings), point_parts, point_sources)
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


def _surfel_parts(samples: list, warnings: list[str]) -> _SurfelParts:
    """The meshes' surfels with their materials (main thread: the materials are bpy's)."""
    fronts, sources, start = [], [], 0
    for s in samples:
        albedo, emission = materials.surfel_materials(s, warnings)
        fronts.append((s.positions, s.normals, s.areas, albedo, emission, _uv_rows(s),
                       s.triangle, s.bary, s.material_index))
        sources.append(Source(s.mesh.name, "MESH", start, start + len(s.areas), s.mesh.total_area))
        start += len(s.areas)
    in_lamp = [s.mesh.light_mask[s.triangle] if s.mesh.light_mask is not None
               else np.zeros(len(s.areas), dtype=bool) for s in samples]
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


def triangles_occlude(job: Job) -> bool:
    """Whether triangles are this job's occluders (lamp shadows, exact visibility,
    receivers): the meshes' own and the point clouds' splats (``_surface_triangles``)."""
    return job.triangles is not None


def shadow_query(job: Job, normals: np.ndarray, progress: Progress | None = None):
    """The segment query lamp shadows are cast with from points with ``normals`` (surfels or
    receivers), ``visible(origins, targets, rows, progress=None)``: against the meshes' own
    triangles when every source is a mesh (``MeshOccluders.segment_query``), else against the
    surfels as occluders (``make_segment_query``). None when the core has neither."""
    if triangles_occlude(job):
        return mesh_occluders(job, progress).segment_query(normals)
    return make_segment_query(job.positions, job.normals, job.areas, progress,
                              shape=occluder_shape(job.settings))


def _shadows(job: Job, normals: np.ndarray, samples: int, progress: Progress | None):
    """``lights.Shadows`` for points with ``normals`` (``shadow_query``), or None with a
    warning when the core has no ray query."""
    query = shadow_query(job, normals, progress)
    if query is None:
        job.warnings.append("Lamp shadows need the core's occluder query, which this "
                            "build lacks: lamp light is unshadowed")
        return None
    extent = float(np.ptp(job.positions, axis=0).max()) if len(job.positions) else 1.0
    return lights.Shadows(query, samples=samples, seed=job.settings.seed, extent=extent,
                         progress=progress)


#: Scale each surfel's transport row to its measured hemisphere share
#: (``illumap.conservation``) and take the world's light at the surfels from the same rays.
#: White furnace against Cycles (bench/reference/furnace.py --conserve on/off): Suzanne
#: 0.83 -> 0.23 RMS (max 2.93 -> 1.01, the solve converges), bunny scan 2.18 -> 0.037 (max
#: 8.1 -> 1.10), room scan 0.195 -> 0.0005; bench monkey 4.56% -> 2.5%. False restores the
#: kernel's own rows (to compare; light is then created where parts overlap).
CONSERVE_LIGHT = True


def light(job: Job, progress: Progress | None = None) -> Job:
    """Direct light of ``job.lamps``, the emissive meshes' lamps (``job.emitters``) and the
    world (``job.world``) into ``job.direct``, shadows cast against the scene; no bpy, runs on the worker
    (``run`` calls it first). Adds the "direct light" and "shadow rays" timings and
    ``stats["shadow_rays"]``. Does nothing when ``job.direct`` is already set. Raises
    IllumapCancelled when ``progress`` returns False."""
    if job.direct is not None:
        return job
    t0 = time.perf_counter()
    s = job.settings
    pos, nrm = job.positions, job.normals
    shadows = None
    try:
        # The world's light comes through the rays that bound each surfel's transport row:
        # its sky and its surfaces then share one hemisphere, and a white furnace reads 1.
        if CONSERVE_LIGHT and triangles_occlude(job) and job.hemisphere is None:
            job.hemisphere = hemisphere_hits(job, progress)
            job.timings["hemisphere"] = time.perf_counter() - t0
        world_by_rays = job.world is not None and job.hemisphere is not None
        all_lamps = (list(job.lamps) + list(job.emitters)
                     + ([job.world] if job.world and not world_by_rays else []))
        if progress is not None and progress(0.0, lights.PHASE if all_lamps and s.lamp_shadows
                                             else "direct light") is False:
            raise IllumapCancelled("Cancelled")
        if all_lamps and s.lamp_shadows:
            shadows = _shadows(job, nrm, surfel_shadow_samples(s), progress)
        incident, from_world = lights.incident_radiance(all_lamps, pos, nrm, shadows=shadows,
                                                       world_apart=True)
        if world_by_rays:
            from_world = job.hemisphere.open[:, None] * np.asarray(job.world.color)[None, :]
    except IllumapError:
        raise
    except Exception as exc:  # noqa: BLE001 - a failing ray query is reported, not raised raw
        if core_cancelled(exc):
            raise IllumapCancelled("Cancelled") from None
        raise IllumapError(f"Lamp shadows failed: {type(exc).__name__}: {exc}", ExitCode.SOLVER) from exc
    if shadows is not None:
        job.timings["shadow rays"] = shadows.seconds
        job.stats["shadow_rays"] = int(shadows.rays)
        job.stats["shadow_occluders"] = ("triangles" if triangles_occlude(job)
                                         else f"{occluder_shape(s)}s")
    job.direct_lamps = np.ascontiguousarray(job.albedo * incident)
    job.direct = np.ascontiguousarray(job.direct_lamps + job.albedo * from_world)
    job.timings["direct light"] = time.perf_counter() - t0
    return job


def next_pass(job: Job, result: "Result") -> Job | None:
    """Pass 2 of an adaptive run (main thread): resample every mesh with a density multiplier
    per region from how much pass 1's illumination varies there, same final surfel count as a
    uniform run. None when ``job`` has no further pass."""
    scene = job.refine
    if scene is None:
        return None
    from illumap import refinement
    from illumap.neighbours import knn
    t0 = time.perf_counter()
    s = job.settings
    # Front faces only: an open surface's back surfels sit on its front ones.
    front = min([src.start for src in job.sources if src.kind == "BACK"] + [job.count])
    meshes = [(tm.corners, job.triangle[src.start:src.stop], job.bary[src.start:src.stop],
               tm.total_area)
              for tm, src in zip(scene.tri_meshes, (src for src in job.sources
                                                    if src.kind == "MESH"))]
    refined = refinement.refine(job.positions[:front], result.radiosity[:front], meshes,
                                max_ratio=s.adaptive_max_ratio, knn=knn)
    regions, weights, offset = refined.regions, refined.multipliers, refined.count
    # The uniform run's mesh budget, shared by weighted area: same total, moved to variation.
    per_mesh = refined.per_mesh()
    weighted = [float((w * reg.area).sum()) for w, reg in zip(per_mesh, regions)]
    counts = sampling.allocate(np.array(weighted), budget=int(scene.counts.sum()))
    samples = [sampling.sample_mesh(tm, int(n), object_rng(s.seed, tm.name, 2),
                                    regions=reg, weights=w)
               for tm, n, reg, w in zip(scene.tri_meshes, counts, regions, per_mesh)]
    stats = dict(job.stats)
    stats.pop("shadow_rays", None)
    refine_seconds = time.perf_counter() - t0
    new = _assemble(s, samples, scene.points, scene.point_sources, scene.lamps, scene.world,
                    list(job.warnings), stats, t0, job.occluders)
    new.accuracy = job.accuracy
    new.emitters, new.triangles = job.emitters, job.triangles
    new.two_sided, new.splat_point, new.clouds = job.two_sided, job.splat_point, job.clouds
    new.mesh_triangle_start = job.mesh_triangle_start
    new.receivers, new.occluders = job.receivers, job.occluders
    new.timings = {"pass 1: " + k_: v for k_, v in result.timings.items()} | \
        {"adaptive refinement": refine_seconds} | new.timings
    new.stats["adaptive"] = dict(
        pass1=dict(surfels=int(job.count), iterations=int(result.iterations),
                   seconds=float(sum(result.timings.get(k_, 0.0)
                                     for k_ in ("sampling", "direct light", "solve")))),
        pass2_surfels=int(new.count), regions=int(offset),
        max_multiplier=float(weights.max()), mean_multiplier=float(weights.mean()),
        refined_regions=int((weights > 1.0 + 1e-9).sum()))
    return new


def run(job: Job, progress: Progress | None = None) -> Result:
    """Direct light (``light``), then solve B = E + ρ F V B for the job. Pure numpy/illumap:
    never touches bpy.

    Raises IllumapCancelled when ``progress`` returns False, IllumapError on bad input
    (exit code 3) or solver failure (exit code 4).
    """
    try:
        import illumap
    except ImportError as exc:
        raise IllumapError(f"The Illumap core module is not installed ({exc})", ExitCode.SOLVER) from None
    if isinstance(job, UnbuiltJob):
        raise TypeError("run needs a built Job: call the UnbuiltJob's build() first")
    s = job.settings
    checks.check_settings(s)    # a Job built without prepare is refused the same way
    shape = occluder_shape(s)   # an unknown shape is refused before any work
    light(job, progress)
    checks.check_light(job)   # no light reaches any surface: no solve for a black map
    try:
        surfels = illumap.Surfels(job.positions, job.normals, job.areas, job.albedo,
                                  job.solve_emission + job.direct)
    except illumap.InputError as exc:
        raise IllumapError(f"Invalid surfels: {exc}", ExitCode.INPUT) from None
    if s.target_error is not None:
        from illumap import accuracy
        solve = accuracy.solve
        # Surfels always see each other past occluders: the error model's occlusion probe
        # measures how much skipping visibility would cost, which does not prove a scene needs
        # none (an open scene's sphere read 2% bright at Target 3%). The occluders are the
        # shadows' own.
        # The estimate scores every surfel that is not a light: the lamps' direct light that
        # the solve takes as emission is light a receiver sees like any other.
        kwargs = dict(target_error=surfel_target(s), progress=progress, near_field=s.near_field,
                      coverage=SURFEL_COVERAGE, probe=False,
                      scored=~(job.emission.max(axis=1) > 0))
        if triangles_occlude(job):
            kwargs["occluder_triangles"] = job.triangles   # as without a target (below)
        chosen = job.accuracy or {}
        if job.refine is not None and chosen:
            # An adaptive pass 1 only finds where the light varies: the final count's settings
            # (chosen for these surfels, the model would buy pass 1 the whole target), and no
            # error estimate.
            kwargs.update(settings=chosen, estimate=False)
        else:
            kwargs.update(kind=chosen.get("kind"),
                          discretization_scale=chosen.get("discretization_scale", 1.0))
    else:
        solve = illumap.solve
        kwargs = dict(method=s.method, solver=s.solver, tol=s.tol,
                      max_iterations=s.max_iterations, progress=progress,
                      near_field=s.near_field)
        if s.method == "fmm":
            kwargs.update(order=s.order, theta=s.theta, leaf_size=s.leaf_size)
        if s.visibility != "none":
            kwargs["visibility"] = s.visibility
        if s.visibility == "exact":
            if triangles_occlude(job):
                # Meshes only: surfels see each other past the true triangles (what lamp
                # shadows and receivers see too), not past discs that overhang outlines.
                kwargs["occluder_triangles"] = job.triangles
            else:  # the lamp shadows' occluders
                kwargs.update(coverage=SURFEL_COVERAGE, visibility_shape=shape)
    if job.hemisphere is not None:
        kwargs["hemisphere_hits"] = job.hemisphere.hits
    t0 = time.perf_counter()
    try:
        sol = solve(surfels, **kwargs)
    except illumap.Cancelled:
        raise IllumapCancelled("Cancelled") from None
    except illumap.InputError as exc:
        raise IllumapError(f"Invalid input: {exc}", ExitCode.INPUT) from None
    except IllumapError:
        raise
    except Exception as exc:  # noqa: BLE001 - anything from the solver is a solver failure
        raise IllumapError(f"Solver failed: {type(exc).__name__}: {exc}", ExitCode.SOLVER) from exc
    timings = dict(job.timings)
    timings.update({f"solve: {k}": float(v) for k, v in dict(getattr(sol, "timings", {}) or {}).items()})
    timings["solve"] = time.perf_counter() - t0
    warnings = list(job.warnings)
    if not sol.converged:
        reason = (getattr(sol, "stats", None) or {}).get("warning")
        warnings.append(f"Solver did not converge in {sol.iterations} iterations "
                        f"(residual {float(sol.residuals[-1]) if len(sol.residuals) else float('nan'):.3g})"
                        + (f": {reason}" if reason else "")
                        + "; the result is written but is not the converged light")
    # The emission that lamps carried is still what those surfels send to the eye.
    radiosity = np.asarray(sol.radiosity, dtype=np.float64) + (job.emission - job.solve_emission)
    if not np.all(np.isfinite(radiosity)):
        raise IllumapError("Solver returned non-finite values", ExitCode.SOLVER)
    # Light is never negative: what the approximations leave below 0 (a few surfels of
    # interpenetrating solids) is 0, here and at the receivers (``_final_values``).
    negative = int((radiosity < 0).any(axis=1).sum())
    np.maximum(radiosity, 0.0, out=radiosity)
    stats = dict(getattr(sol, "stats", {}) or {})
    stats.update(job.stats)
    stats["occluder_shape"] = shape
    if s.visibility == "exact":
        stats["visibility_occluders"] = ("triangles" if "occluder_triangles" in kwargs
                                         else f"{stats.get('visibility_shape', shape)}s")
    result = Result(radiosity=radiosity, iterations=int(sol.iterations),
                    residuals=list(sol.residuals), converged=bool(sol.converged),
                    timings=timings, stats=stats, count=job.count, warnings=warnings)
    stats["negative_surfels"] = negative
    if job.refine is None:   # the last pass: evaluate the light where the user sees it
        receive(job, result, progress)
        _final_values(result)
        dark = _lit_only_inside(job, result)
        if dark:
            result.warnings.append(dark)
    return result


def _final_values(result: Result) -> None:
    """The receivers' values as written: never negative (counted in ``stats``); a non-finite
    value is a failure, and nothing is written."""
    negative = 0
    for kind in (result.receiver_values, result.point_receiver_values):
        for name, values in kind.items():
            if not np.all(np.isfinite(values)):
                bad = int((~np.isfinite(values)).any(axis=1).sum())
                raise IllumapError(f"Evaluating the light at '{name}' gave {bad} non-finite "
                                   "value(s): nothing was written", ExitCode.SOLVER)
            negative += int((values < 0).any(axis=1).sum())
            np.maximum(values, 0.0, out=values)
    result.stats["negative_receivers"] = negative


def _lit_only_inside(job: Job, result: Result) -> str | None:
    """A warning for closed meshes that no light reaches although a lamp or an emitter lies
    within their bounds: their normals face out while the light is inside them, and Illumap,
    as a renderer does for a closed surface, takes the inside of a closed mesh for its back,
    which is never lit. Cycles would light the back faces; flipping the normals does here."""
    two_sided = {src.name for src in job.sources if src.kind == "BACK"}
    lit_by = [(lamp.name, lamp.position[None] if lamp.triangles is None
               else lamp.triangles.mean(axis=1)) for lamp in list(job.lamps) + list(job.emitters)
              if lamp.kind != "WORLD" and lamp.kind != "SUN"]
    names = []
    for src in job.sources:
        if src.kind != "MESH" or src.name in two_sided or src.stop <= src.start:
            continue
        rows = slice(src.start, src.stop)
        if result.radiosity[rows].max() > 0 or job.emission[rows].max() > 0:
            continue
        lo, hi = job.positions[rows].min(axis=0), job.positions[rows].max(axis=0)
        inside = [name for name, at in lit_by if name != src.name
                  and np.any(np.all((at > lo) & (at < hi), axis=1))]
        if inside:
            names.append((src.name, inside[0]))
    if not names:
        return None
    obj, light_name = names[0]
    more = f" (and {len(names) - 1} more)" if len(names) > 1 else ""
    return (f"Object '{obj}'{more} is closed and receives no light, while '{light_name}' lies "
            "inside it: its normals face outward, and the inside of a closed mesh is its back, "
            "which Illumap does not light (Cycles would). Flip its normals (Edit Mode, Mesh > "
            "Normals > Flip) to light it from inside")


def write(context, job: Job, result: Result):
    """Write the result into the file (main thread): surfel object, transfers, exports, as one
    transaction (``output.Transaction``). Every target is checked first (it still exists, is
    not in Edit Mode, its counts match, ``output.transfer_problem``); the exports go to
    temporary files and the datablocks are staged beside the old ones; then everything is
    swapped in. Any failure raises IllumapError (OutputError for an export) and leaves the
    file's data and the export paths as they were."""
    from . import exports, output

    t0 = time.perf_counter()
    s = job.settings
    # An open surface's back-face surfels sit on its front ones: their discs move a hair
    # along their own normals, behind the front disc seen from the front and in front of it
    # seen from the back, so the preview shows each side without z-fighting.
    shown = job.positions
    backs = [src for src in job.sources if src.kind == "BACK"]
    if backs:
        shown = job.positions.copy()
        for src in backs:
            sl = slice(src.start, src.stop)
            shown[sl] += (BACK_DISC_LIFT * np.sqrt(job.areas[sl] / np.pi))[:, None] * job.normals[sl]
    warnings: list[str] = []
    points, meshes = [], []          # (target, values) to write
    if s.transfer:                   # 1. every target checked; nothing changes yet
        objects = context.blend_data.objects
        users = output.object_users(context.blend_data)
        depsgraph = context.evaluated_depsgraph_get()
        problems = []

        def target_of(name, kinds):
            target = objects.get(name)
            if target is None or target.type not in kinds:
                problems.append(f"Object '{name}' was removed or renamed while Illumap computed")
                return None
            problem = output.transfer_problem(target, users)
            if problem is not None:
                problems.append(problem)
                return None
            return target
        for name, values in point_values(job, result).items():
            target = target_of(name, ("POINTCLOUD", "MESH"))
            if target is None:
                continue
            if output.point_count(target) != len(values):
                warnings.append(f"Point cloud '{name}': its modifiers change the number of "
                                "points; the illumination stays on the surfel object")
                continue
            points.append((target, values))
        for rec in job.receivers:
            values = result.receiver_values.get(rec.name)
            if values is None:
                continue
            target = target_of(rec.name, ("MESH",))
            if target is None:
                continue
            mesh = target.data
            if len(mesh.loops) != len(rec.corner_vertex) or len(mesh.vertices) != rec.vertex_count:
                problems.append(f"Object '{rec.name}': its mesh changed while Illumap computed "
                                f"({len(mesh.loops)} corners, {len(rec.corner_vertex)} when "
                                "read)")
                continue
            repeat = output.repeat_problem(target, depsgraph)
            if repeat is not None:
                warnings.append(repeat)
                continue
            meshes.append((target, rec, values))
        if problems:
            more = f" (and {len(problems) - 3} more)" if len(problems) > 3 else ""
            raise IllumapError("Illumap could not write the result: " + "; ".join(problems[:3])
                               + more + ". Nothing was written; run again.")
    with output.Transaction(context) as tx:
        # 2. exports, into temporary files beside their targets
        if s.export_npz:
            arrays = dict(positions=job.positions, normals=job.normals, areas=job.areas,
                          albedo=job.albedo, emission=job.emission, direct=job.direct,
                          illumination=result.radiosity, uv=job.uv, triangle=job.triangle,
                          bary=job.bary, material_index=job.material_index,
                          object_index=np.repeat(np.arange(len(job.sources)),
                                                 [src.stop - src.start for src in job.sources]),
                          object_names=np.array([src.name for src in job.sources]))
            tx.stage_file(output.npz_path(s.export_npz),
                          lambda tmp: exports.export_npz(tmp, **arrays))
        if s.export_exr:
            tx.stage_file(s.export_exr, lambda tmp: exports.export_exr(tmp, result.radiosity))
        if s.export_lightmaps:
            pattern = exports.lightmap_pattern(s.export_lightmaps)
            for src in job.sources:
                sl = slice(src.start, src.stop)
                if src.kind != "MESH" or not np.isfinite(job.uv[sl]).all():
                    warnings.append(f"Object '{src.name}' has no UV map: no lightmap written")
                else:
                    tx.stage_file(pattern.replace("{object}", bpy_safe_name(src.name)),
                                  lambda tmp, sl=sl: exports.export_lightmap(
                                      tmp, job.uv[sl], result.radiosity[sl], s.lightmap_size))
        # 3. the datablocks, staged beside the old ones
        tx.stage_surfels(shown, job.normals, job.areas, result.radiosity, job.albedo,
                         job.emission)
        for target, values in points:
            tx.stage_colors(target.data, "POINT", values)
        for target, rec, values in meshes:
            output.stage_mesh_values(tx, target, rec, values, s.transfer_domain)
        # 4. swapped in together
        obj = tx.commit()
    result.warnings.extend(warnings + tx.warnings)
    result.timings["write"] = time.perf_counter() - t0
    result.object_name = obj.name
    return obj


def _luminance_weights() -> np.ndarray:
    """Rec. 709 luminance of linear RGB, as the core weighs light (one definition)."""
    from illumap.refinement import LUMINANCE_WEIGHTS
    return np.asarray(LUMINANCE_WEIGHTS, dtype=np.float64)


def point_values(job: Job, result: Result) -> dict[str, np.ndarray]:
    """Outgoing radiance (n, 3) per point of each point-cloud source, in its own order: as
    evaluated at the point (``receive``), else the point's surfel, for two-sided points the
    brighter of its two sides."""
    out = {}
    backs = {src.name: src for src in job.sources if src.kind == "BACK"}
    lum = _luminance_weights()
    for src in job.sources:
        if src.kind != "POINTS":
            continue
        if src.name in result.point_receiver_values:
            out[src.name] = result.point_receiver_values[src.name]
            continue
        values = result.radiosity[src.start:src.stop]
        back = backs.get(src.name)
        if back is not None:
            other = result.radiosity[back.start:back.stop]
            values = np.where((other @ lum > values @ lum)[:, None], other, values)
        out[src.name] = values
    return out


def bpy_safe_name(name: str) -> str:
    """An object name made safe for a file name."""
    return "".join(c if c.isalnum() or c in "-_." else "_" for c in name)


def compute(context, objects, settings: Settings, progress: Progress | None = None) -> Result:
    """prepare → run → write on the calling (main) thread; returns the Result.

    Transfer targets and export paths are checked before anything is read or solved
    (``output.check_targets``); Illumap's own objects are never inputs."""
    from . import output
    objects = [o for o in objects if o is None or not output.is_illumap_object(o)]
    output.check_targets(objects, settings)
    job = prepare(context.evaluated_depsgraph_get(), objects, settings)
    result = run(job, progress)
    second = next_pass(job, result)
    if second is not None:
        job, result = second, run(second, progress)
    write(context, job, result)
    return result


__all__ = ["Settings", "QUALITY_PRESETS", "settings_from_preset", "Job", "Result", "Source", "prepare",
           "light", "run", "write", "compute", "next_pass", "IllumapError", "IllumapCancelled", "replace"]
