"""The add-on's pipeline: scene → surfels → solve → results in the file.

Contract (docs/architecture.md):

* ``prepare(depsgraph, objects, settings) -> Job``: main thread; reads bpy, samples surfels,
  evaluates materials and reads the lamps (numpy only afterwards).
* ``run_passes(job, progress, on_main=None) -> Result``: no bpy, safe on a worker thread: the
  job as ``illumap.Scene`` (``to_scene``) through ``illumap.run``, the one loop over a run's
  passes (direct light with its shadow rays, phase "lamp shadows", then the solve; an
  adaptive run's second pass read by ``next_pass`` on the main thread through ``on_main``;
  then the light at the receivers). ``run(job)`` is the job's own pass alone.
* ``write(context, job, result) -> Object``: main thread; creates/replaces ``Illumap Surfels``,
  transfers to meshes, exports files.
* ``compute(context, objects, settings, progress=None) -> Result``: the synchronous path.

``prepare`` reads the scene through ``read_scene`` and plans the run's cost with ``budget``;
the computation is ``illumap``'s (``illumap.stages``, ``illumap.gather``).

Shadow rays are the slow part of direct light (a second at 40k surfels, minutes at millions),
so they run on the worker where Esc can stop them, not in ``prepare``.

Nothing in the file changes unless ``run`` succeeded: ``prepare`` only reads, ``run`` never
touches bpy, and ``write`` is called only with a successful result. Problems a user can fix
raise ``IllumapError`` (``IllumapCancelled`` when cancelled).
"""

from __future__ import annotations

import time
from contextlib import contextmanager
from dataclasses import replace

import numpy as np

from illumap.identities import object_rng
from illumap.settings import QUALITY_PRESETS, Settings, SettingsError, from_preset
from illumap.stages.errors import NoLight, RunError
from illumap.stages.light import Lit
from illumap.stages.light import light as light_stage
from illumap.stages.scene import Scene, Source  # noqa: F401
from illumap.stages.solve import Solved  # noqa: F401

from . import checks
from .read import sampling
# The budget's and the scene reading's public names are the pipeline's too (tests, the batch).
from .read.budget import (  # noqa: F401
    BYTES_PER_SURFEL, SURFEL_COVERAGE, memory_limit, occluder_shape, surfel_shadow_samples,
    surfel_target
)
from .errors import ExitCode, IllumapCancelled, IllumapError, NoLightError, core_cancelled
from .job import Job, Progress, Result
from .read.read_scene import (  # noqa: F401
    BACK_DISC_LIFT, BUILD_PHASE, UnbuiltJob, _assemble, _prepare
)
from .read.read_scene import _Scene  # noqa: F401


def settings_from_preset(name: str, **overrides) -> Settings:
    """Settings for a preset name (draft, medium or high, any case) with keyword overrides
    (``illumap.settings.from_preset``); a bad name is a usage error."""
    try:
        return from_preset(name, **overrides)
    except SettingsError as exc:
        raise IllumapError(str(exc), ExitCode.USAGE) from None



def prepare(depsgraph, objects, settings: Settings, *, build: bool = True) -> "Job | UnbuiltJob":
    """Read the scene on the main thread and build the job (``_prepare``), with any mesh
    preview of the objects switched off while their materials are read. ``build=False``:
    the scene as read (``UnbuiltJob``), to be built on a worker thread (``ComputeTask``)."""
    import bpy

    from .preview import mesh_preview
    checks.check_settings(settings)   # refused before anything is read
    objects = list(objects)
    with mesh_preview.suspended(objects, bpy.context.view_layer):
        unbuilt = _prepare(depsgraph, objects, settings)
    return unbuilt.build() if build else unbuilt


def to_scene(job: Job) -> Scene:
    """The job as ``illumap.Scene``, the plain value ``illumap.run`` takes (no copies)."""
    return Scene(settings=job.settings, positions=job.positions, normals=job.normals,
                 areas=job.areas, albedo=job.albedo, emission=job.emission,
                 solve_emission=job.solve_emission, sources=tuple(job.sources),
                 lamps=tuple(job.lamps), emitters=tuple(job.emitters), world=job.world,
                 uv=job.uv, triangle=job.triangle, bary=job.bary,
                 material_index=job.material_index, triangles=job.triangles,
                 two_sided=job.two_sided, mesh_triangle_start=job.mesh_triangle_start,
                 splat_point=job.splat_point, clouds=tuple(job.clouds),
                 receivers=tuple(job.receivers), occluders=job.occluders,
                 accuracy=job.accuracy, refine=job.refine, warnings=tuple(job.warnings),
                 timings=dict(job.timings), stats=dict(job.stats))


def _lit(job: Job) -> "Scene | Lit":
    """The job as ``illumap.run`` starts from it: lit already (``light``) or not."""
    scene = to_scene(job)
    if job.direct is None:
        return scene
    return Lit(scene=scene, direct=job.direct, direct_lamps=job.direct_lamps,
               hemisphere=job.hemisphere, timings=dict(job.timings), stats=dict(job.stats),
               warnings=tuple(job.warnings))


def _keep_light(job: Job, lit: Lit) -> Job:
    """Keep the direct light of ``lit`` on ``job`` (the export writes it; a second run of the
    same job starts from it)."""
    job.direct, job.direct_lamps, job.hemisphere = lit.direct, lit.direct_lamps, lit.hemisphere
    job.occluders = lit.scene.occluders
    job.timings.update(lit.timings)
    job.stats.update(lit.stats)
    job.warnings[:] = list(lit.warnings)
    return job


@contextmanager
def _user_errors():
    """The core's errors as the add-on's: what a user reads, with the batch's exit code."""
    try:
        yield
    except IllumapError:
        raise
    except NoLight as exc:
        raise NoLightError(str(exc)) from None
    except RunError as exc:
        code = ExitCode.SOLVER if exc.kind == "solver" else ExitCode.INPUT
        raise IllumapError(str(exc), code) from exc.__cause__
    except SettingsError as exc:
        raise IllumapError(str(exc), ExitCode.USAGE) from None
    except Exception as exc:  # noqa: BLE001 - only the core's Cancelled is translated
        if core_cancelled(exc):
            raise IllumapCancelled("Cancelled") from None
        raise


def light(job: Job, progress: Progress | None = None) -> Job:
    """Direct light of the job's lamps, emitters and world into ``job.direct``
    (``illumap.stages.light``); nothing when ``job.direct`` is set already. No bpy. Raises
    IllumapCancelled when ``progress`` returns False."""
    if job.direct is not None:
        return job
    with _user_errors():
        return _keep_light(job, light_stage(to_scene(job), progress))


def run(job: Job, progress: Progress | None = None) -> Result:
    """This job's pass of ``illumap.run`` (light → solve → the light at the receivers, the
    last only when the job has no further pass): for drivers that make the next pass
    themselves (``next_pass``). Pure numpy/illumap: never touches bpy.

    Raises IllumapCancelled when ``progress`` returns False, IllumapError on bad input
    (exit code 3) or solver failure (exit code 4)."""
    return run_passes(job, progress, passes=False)


def run_passes(job: Job, progress: Progress | None = None, *, on_main=None,
               passes: bool = True) -> Result:
    """Every pass of the job's run through the one loop, ``illumap.run``: an adaptive run's
    second pass is read by ``next_pass`` through ``on_main(call)``, which runs ``call`` on
    Blender's main thread and returns its value (default: here; the operator's worker hands
    it to its modal timer). The result's ``job`` is the last pass's. No bpy here."""
    try:
        import illumap
    except ImportError as exc:
        raise IllumapError(f"The Illumap core module is not installed ({exc})", ExitCode.SOLVER) from None
    if isinstance(job, UnbuiltJob):
        raise TypeError("run needs a built Job: call the UnbuiltJob's build() first")
    checks.check_settings(job.settings)    # a Job built without prepare is refused the same way
    jobs = [job]

    def following(solved):
        def call():
            return next_pass(solved.lit.scene, solved)
        new = call() if on_main is None else on_main(call)
        if new is not None:
            jobs.append(new)
        return None if new is None else to_scene(new)
    with _user_errors():
        gathered = illumap.run(_lit(job), progress, next_pass=following if passes else None)
    last = _keep_light(jobs[-1], gathered.solved.lit)
    solved = gathered.solved
    return Result(radiosity=gathered.radiosity, iterations=solved.iterations,
                  residuals=list(solved.residuals), converged=solved.converged,
                  timings=dict(gathered.timings), stats=dict(gathered.stats), count=last.count,
                  warnings=list(gathered.warnings), receiver_values=dict(gathered.corners),
                  point_receiver_values=dict(gathered.points), job=last)


def next_pass(job: "Job | Scene", result: "Result | Solved") -> Job | None:
    """Pass 2 of an adaptive run (main thread): resample every mesh with a density multiplier
    per region from how much pass 1's illumination varies there, same final surfel count as a
    uniform run. None when ``job`` has no further pass. ``job``: the pass-1 job or its
    ``illumap.Scene``; ``result``: its Result or ``illumap``'s Solved value."""
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
    new = _assemble(s, samples, scene.light_masks, scene.points, scene.point_sources,
                    scene.lamps, scene.world, list(job.warnings), stats, t0, job.occluders)
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




def write(context, job: Job, result: Result):
    """Write the result into the file (main thread): surfel object, transfers, exports, as one
    transaction (``output.Transaction``). Every target is checked first (it still exists, is
    not in Edit Mode, its counts match, ``output.transfer_problem``); the exports go to
    temporary files and the datablocks are staged beside the old ones; then everything is
    swapped in. Any failure raises IllumapError (OutputError for an export) and leaves the
    file's data and the export paths as they were."""
    from .write import exports, output

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
    """prepare → every pass (``run_passes``: the one loop, ``illumap.run``) → write on the
    calling (main) thread; returns the Result.

    Transfer targets and export paths are checked before anything is read or solved
    (``output.check_targets``); Illumap's own objects are never inputs."""
    from .write import output
    objects = [o for o in objects if o is None or not output.is_illumap_object(o)]
    output.check_targets(objects, settings)
    job = prepare(context.evaluated_depsgraph_get(), objects, settings)
    result = run_passes(job, progress)
    write(context, result.job, result)
    return result


__all__ = ["Settings", "QUALITY_PRESETS", "settings_from_preset", "Job", "Result", "Source", "prepare",
           "light", "run", "run_passes", "to_scene", "write", "compute", "next_pass", "IllumapError", "IllumapCancelled", "replace"]
