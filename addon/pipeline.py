"""The add-on's pipeline: scene → surfels → solve → results in the file.

Contract (docs/architecture.md):

* ``prepare(depsgraph, objects, settings) -> Job``: main thread; reads bpy, samples surfels,
  evaluates materials and direct light (numpy only afterwards).
* ``run(job, progress) -> Result``: no bpy, safe on a worker thread.
* ``write(context, job, result) -> Object``: main thread; creates/replaces ``Illumap Surfels``,
  transfers to meshes, exports files.
* ``compute(context, objects, settings, progress=None) -> Result``: the synchronous path.

Nothing in the file changes unless ``run`` succeeded: ``prepare`` only reads, ``run`` never
touches bpy, and ``write`` is called only with a successful result. Problems a user can fix
raise ``IllumapError`` (``IllumapCancelled`` when cancelled).
"""

from __future__ import annotations

import os
import time
from dataclasses import dataclass, field, fields, replace
from typing import Callable

import numpy as np

from . import lamps, materials, pointcloud, sampling
from .errors import IllumapCancelled, IllumapError

Progress = Callable[[float, str], "bool | None"]

# Rough peak memory per surfel for sampling, solver vectors and the FMM tree (bytes). Used to
# refuse budgets that cannot fit before anything is allocated.
BYTES_PER_SURFEL = 2048
_MESH_TYPES = {"MESH", "CURVE", "SURFACE", "META", "FONT"}


@dataclass
class Settings:
    """Quality knobs and options of one run (units in the comments)."""

    density: float = 400.0            # surfels per m² (used when budget is None)
    budget: int | None = None         # total surfels over all mesh objects; overrides density
    method: str = "fmm"               # 'fmm' | 'direct' (exact O(N²) reference)
    order: int = 4                    # FMM expansion order
    theta: float = 0.5                # FMM opening angle
    leaf_size: int = 32               # FMM octree leaf size (surfels)
    near_field: str = "disc"          # 'disc' | 'point'
    visibility: str = "none"          # visibility mode passed to the core
    solver: str = "auto"              # 'auto' | 'cg' | 'gmres' | 'jacobi'
    tol: float = 1e-4                 # relative residual
    max_iterations: int = 200
    target_error: float | None = None  # relative RMS wanted; chooses order/θ/visibility/tol
    lamps: bool = True                # add direct light from Blender lamps
    world_ambient: bool = False       # add the world colour as uniform ambient light
    transfer: bool = False            # write 'illumination' onto the source meshes too
    transfer_domain: str = "CORNER"   # 'POINT' | 'CORNER'
    seed: int = 0                     # sampling seed (results are reproducible)
    memory_limit: int | None = None   # bytes; None → half the physical memory
    export_npz: str = ""              # path for surfel data (.npz), '' = none
    export_exr: str = ""              # path for an EXR dump of illumination, '' = none
    export_lightmaps: str = ""        # path pattern with {object}: UV-space EXR per mesh
    lightmap_size: int = 256          # lightmap width = height, pixels


PRESETS: dict[str, dict] = {
    "DRAFT": dict(density=100.0, order=3, theta=0.6, visibility="none", tol=1e-3),
    "MEDIUM": dict(density=400.0, order=4, theta=0.5, visibility="none", tol=1e-4),
    "HIGH": dict(density=1600.0, order=6, theta=0.4, visibility="exact", tol=1e-5),
}


def settings_from_preset(name: str, **overrides) -> Settings:
    """Settings for a preset name (DRAFT/MEDIUM/HIGH, any case) with keyword overrides."""
    key = name.upper()
    if key not in PRESETS:
        raise IllumapError(f"Unknown quality preset '{name}' (choose draft, medium or high)", 2)
    values = dict(PRESETS[key])
    values.update({k: v for k, v in overrides.items() if v is not None})
    known = {f.name for f in fields(Settings)}
    return Settings(**{k: v for k, v in values.items() if k in known})


@dataclass
class Source:
    """Which surfels came from which object, for transfer and reporting."""

    name: str
    kind: str      # 'MESH' | 'POINTS'
    start: int
    stop: int
    area: float    # m²


@dataclass
class Job:
    """Everything ``run`` needs, numpy only (no bpy references)."""

    settings: Settings
    positions: np.ndarray
    normals: np.ndarray
    areas: np.ndarray
    albedo: np.ndarray
    emission: np.ndarray          # self-emission (radiance)
    direct: np.ndarray            # albedo × incident lamp/world radiance
    uv: np.ndarray                # (N, 2) active UV per surfel (NaN: none)
    triangle: np.ndarray          # (N,) int64 triangle of the evaluated mesh (-1: point input)
    bary: np.ndarray              # (N, 3) barycentric coordinates in it (NaN: point input)
    material_index: np.ndarray    # (N,) int64 material slot (-1: point input)
    sources: list[Source]
    warnings: list[str] = field(default_factory=list)
    timings: dict[str, float] = field(default_factory=dict)

    @property
    def count(self) -> int:
        """Number of surfels."""
        return len(self.areas)


@dataclass
class Result:
    """A solved job: outgoing radiance per surfel and statistics."""

    radiosity: np.ndarray         # (N, 3) outgoing radiance
    iterations: int
    residuals: list
    converged: bool
    timings: dict[str, float]
    stats: dict
    count: int
    warnings: list[str] = field(default_factory=list)
    object_name: str = ""

    @property
    def residual(self) -> float:
        """Final relative residual: the solver's recomputed true residual when it reports one
        (``stats['final_residual']``), else the last iteration's (nan if none)."""
        final = self.stats.get("final_residual") if isinstance(self.stats, dict) else None
        if final is not None:
            return float(final)
        return float(self.residuals[-1]) if len(self.residuals) else float("nan")


def memory_limit(settings: Settings) -> int:
    """The byte limit runs are checked against (settings, else half the physical memory)."""
    if settings.memory_limit:
        return int(settings.memory_limit)
    try:
        return os.sysconf("SC_PHYS_PAGES") * os.sysconf("SC_PAGE_SIZE") // 2
    except (ValueError, OSError, AttributeError):
        return 8 << 30


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
    for obj in objects:
        if obj is None or obj.name == SURFEL_OBJECT or obj.type == "LIGHT":
            continue
        if obj.type == "POINTCLOUD":
            points.append(obj)
        elif obj.type in _MESH_TYPES:
            ev = obj.evaluated_get(depsgraph)
            if obj.type == "MESH" and len(ev.data.polygons) == 0 and len(ev.data.vertices) > 0:
                points.append(obj)  # vertex-only mesh: a point cloud
            else:
                meshes.append(obj)
        elif obj.type != "EMPTY":  # empties may instance collections (read_instances)
            warnings.append(f"Object '{obj.name}' ({obj.type}) is not a mesh or point cloud; skipped")
    return meshes, points, warnings


def prepare(depsgraph, objects, settings: Settings) -> Job:
    """Read the scene on the main thread and build the job (surfels + direct light)."""
    t0 = time.perf_counter()
    objects = list(objects)
    meshes, points, warnings = _split_objects(depsgraph, objects)
    # Instances (collection instances, Geometry Nodes instances…) of the given objects: one
    # Python loop over the scene's instances, not over any geometry.
    instances = sampling.read_instances(depsgraph, {o.name for o in objects if o is not None})
    instancers = {tm.instancer for tm in instances}
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
    counts = np.zeros(0, dtype=np.int64)
    if tri_meshes:
        counts = sampling.allocate([tm.total_area for tm in tri_meshes],
                                   density=settings.density, budget=settings.budget)
    check_memory(int(counts.sum()), settings)  # before sampling allocates anything big
    rng = np.random.default_rng(settings.seed)
    parts, sources, start = [], [], 0
    for tm, n in zip(tri_meshes, counts):
        s = sampling.sample_mesh(tm, int(n), rng)
        albedo, emission = materials.surfel_materials(s, warnings)
        uv = s.uv()
        parts.append((s.positions, s.normals, s.areas, albedo, emission,
                      uv if uv is not None else np.full((len(s.areas), 2), np.nan),
                      s.triangle, s.bary, s.material_index))
        sources.append(Source(tm.name, "MESH", start, start + len(s.areas), tm.total_area))
        start += len(s.areas)
    for obj in points:
        p = pointcloud.read_points(obj, depsgraph, warnings)
        m = len(p.areas)
        parts.append((p.positions, p.normals, p.areas, p.albedo, p.emission,
                      np.full((m, 2), np.nan), np.full(m, -1, np.int64), np.full((m, 3), np.nan),
                      np.full(m, -1, np.int64)))
        sources.append(Source(p.name, "POINTS", start, start + len(p.areas), float(p.areas.sum())))
        start += len(p.areas)
    check_memory(start, settings)
    pos, nrm, area, albedo, emission, uv, tri, bary, mat_idx = (
        np.concatenate([p[i] for p in parts]) for i in range(9))
    t1 = time.perf_counter()
    incident = np.zeros_like(pos)
    if settings.lamps or settings.world_ambient:
        lamp_list = lamps.read_lamps(depsgraph, warnings) if settings.lamps else []
        ambient = lamps.world_ambient(depsgraph.scene) if settings.world_ambient else None
        incident = lamps.incident_radiance(lamp_list, pos, nrm, ambient=ambient)
    if settings.visibility != "none" and settings.lamps:
        warnings.append("Lamp light is not shadowed yet (visibility for lamps comes later)")
    t2 = time.perf_counter()
    return Job(settings=settings, positions=np.ascontiguousarray(pos), normals=np.ascontiguousarray(nrm),
               areas=np.ascontiguousarray(area), albedo=np.ascontiguousarray(albedo),
               emission=np.ascontiguousarray(emission), direct=np.ascontiguousarray(albedo * incident), uv=uv,
               triangle=tri.astype(np.int64), bary=bary, material_index=mat_idx.astype(np.int64),
               sources=sources, warnings=warnings,
               timings={"sampling": t1 - t0, "direct light": t2 - t1})


def run(job: Job, progress: Progress | None = None) -> Result:
    """Solve B = E + ρ F V B for the job. Pure numpy/illumap: never touches bpy.

    Raises IllumapCancelled when ``progress`` returns False, IllumapError on bad input
    (exit code 3) or solver failure (exit code 4).
    """
    try:
        import illumap
    except ImportError as exc:
        raise IllumapError(f"The Illumap core module is not installed ({exc})", 4) from None
    s = job.settings
    try:
        surfels = illumap.Surfels(job.positions, job.normals, job.areas, job.albedo,
                                  job.emission + job.direct)
    except illumap.InputError as exc:
        raise IllumapError(f"Invalid surfels: {exc}", 3) from None
    if s.target_error is not None:
        if not 0.0 < s.target_error < 1.0:
            raise IllumapError(f"Target error must lie in (0, 1), got {s.target_error}", 2)
        kwargs = dict(target_error=s.target_error, progress=progress, near_field=s.near_field)
    else:
        kwargs = dict(method=s.method, solver=s.solver, tol=s.tol,
                      max_iterations=s.max_iterations, progress=progress,
                      near_field=s.near_field)
        if s.method == "fmm":
            kwargs.update(order=s.order, theta=s.theta, leaf_size=s.leaf_size)
        if s.visibility != "none":
            kwargs["visibility"] = s.visibility
    t0 = time.perf_counter()
    try:
        sol = illumap.solve(surfels, **kwargs)
    except illumap.Cancelled:
        raise IllumapCancelled("Cancelled") from None
    except illumap.InputError as exc:
        raise IllumapError(f"Invalid input: {exc}", 3) from None
    except IllumapError:
        raise
    except Exception as exc:  # noqa: BLE001 - anything from the solver is a solver failure
        raise IllumapError(f"Solver failed: {type(exc).__name__}: {exc}", 4) from exc
    timings = dict(job.timings)
    timings.update({f"solve: {k}": float(v) for k, v in dict(getattr(sol, "timings", {}) or {}).items()})
    timings["solve"] = time.perf_counter() - t0
    warnings = list(job.warnings)
    if not sol.converged:
        warnings.append(f"Solver did not converge in {sol.iterations} iterations "
                        f"(residual {float(sol.residuals[-1]) if len(sol.residuals) else float('nan'):.3g})")
    radiosity = np.asarray(sol.radiosity, dtype=np.float64)
    if not np.all(np.isfinite(radiosity)):
        raise IllumapError("Solver returned non-finite values", 4)
    return Result(radiosity=radiosity, iterations=int(sol.iterations), residuals=list(sol.residuals),
                  converged=bool(sol.converged), timings=timings, stats=dict(getattr(sol, "stats", {}) or {}),
                  count=job.count, warnings=warnings)


def write(context, job: Job, result: Result):
    """Write the result into the file (main thread): surfel object, transfers, exports."""
    from . import output

    t0 = time.perf_counter()
    obj = output.write_surfels(context, job.positions, job.normals, job.areas, result.radiosity,
                               job.albedo, job.emission)
    if job.settings.transfer:
        for src in job.sources:
            target = context.blend_data.objects.get(src.name)
            if src.kind == "MESH" and target is not None and target.type == "MESH":
                sl = slice(src.start, src.stop)
                output.transfer_to_mesh(target, job.positions[sl], job.normals[sl],
                                        result.radiosity[sl], job.settings.transfer_domain)
    if job.settings.export_npz:
        output.export_npz(job.settings.export_npz, positions=job.positions, normals=job.normals,
                          areas=job.areas, albedo=job.albedo, emission=job.emission,
                          direct=job.direct, illumination=result.radiosity, uv=job.uv,
                          triangle=job.triangle, bary=job.bary, material_index=job.material_index,
                          object_index=np.repeat(np.arange(len(job.sources)),
                                                 [s.stop - s.start for s in job.sources]),
                          object_names=np.array([s.name for s in job.sources]))
    if job.settings.export_exr:
        output.export_exr(job.settings.export_exr, result.radiosity)
    if job.settings.export_lightmaps:
        pattern = job.settings.export_lightmaps
        if "{object}" not in pattern:
            root, ext = os.path.splitext(pattern)
            pattern = f"{root}_{{object}}{ext or '.exr'}"
        for src in job.sources:
            sl = slice(src.start, src.stop)
            if src.kind != "MESH" or not np.isfinite(job.uv[sl]).all():
                result.warnings.append(f"Object '{src.name}' has no UV map: no lightmap written")
            else:
                output.export_lightmap(pattern.replace("{object}", bpy_safe_name(src.name)),
                                       job.uv[sl], result.radiosity[sl], job.settings.lightmap_size)
    result.timings["write"] = time.perf_counter() - t0
    result.object_name = obj.name
    return obj


def bpy_safe_name(name: str) -> str:
    """An object name made safe for a file name."""
    return "".join(c if c.isalnum() or c in "-_." else "_" for c in name)


def compute(context, objects, settings: Settings, progress: Progress | None = None) -> Result:
    """prepare → run → write on the calling (main) thread; returns the Result."""
    job = prepare(context.evaluated_depsgraph_get(), objects, settings)
    result = run(job, progress)
    write(context, job, result)
    return result


__all__ = ["Settings", "PRESETS", "settings_from_preset", "Job", "Result", "Source", "prepare",
           "run", "write", "compute", "IllumapError", "IllumapCancelled", "replace"]
