"""The add-on's pipeline: scene → surfels → solve → results in the file.

Contract (docs/architecture.md):

* ``prepare(depsgraph, objects, settings) -> Job``: main thread; reads bpy, samples surfels,
  evaluates materials and reads the lamps (numpy only afterwards).
* ``run(job, progress) -> Result``: no bpy, safe on a worker thread: direct light from the
  lamps with its shadow rays (``light``, phase "lamp shadows"), then the solve.
* ``write(context, job, result) -> Object``: main thread; creates/replaces ``Illumap Surfels``,
  transfers to meshes, exports files.
* ``compute(context, objects, settings, progress=None) -> Result``: the synchronous path.

``prepare`` reads the scene through ``read_scene`` and plans the run's cost with ``budget``;
the light at the objects' own corners and points is ``receive``'s.

Shadow rays are the slow part of direct light (a second at 40k surfels, minutes at millions),
so they run on the worker where Esc can stop them, not in ``prepare``.

Nothing in the file changes unless ``run`` succeeded: ``prepare`` only reads, ``run`` never
touches bpy, and ``write`` is called only with a successful result. Problems a user can fix
raise ``IllumapError`` (``IllumapCancelled`` when cancelled).
"""

from __future__ import annotations

import time
from dataclasses import replace

import numpy as np

from illumap import lights
from illumap.identities import object_rng
from illumap.settings import QUALITY_PRESETS, Settings, SettingsError, from_preset

from . import checks, sampling
# The budget's and the scene reading's public names are the pipeline's too (tests, the batch).
from .budget import (BYTES_PER_SURFEL, SURFEL_COVERAGE, memory_limit, occluder_shape,  # noqa: F401
                     surfel_shadow_samples, surfel_target)
from .errors import ExitCode, IllumapCancelled, IllumapError, core_cancelled
from .job import Job, Progress, Result, Source
from .read_scene import BACK_DISC_LIFT, BUILD_PHASE, UnbuiltJob, _assemble, _prepare  # noqa: F401
from .read_scene import _Scene  # noqa: F401
from .receive import hemisphere_hits, mesh_occluders, receive


def settings_from_preset(name: str, **overrides) -> Settings:
    """Settings for a preset name (draft, medium or high, any case) with keyword overrides
    (``illumap.settings.from_preset``); a bad name is a usage error."""
    try:
        return from_preset(name, **overrides)
    except SettingsError as exc:
        raise IllumapError(str(exc), ExitCode.USAGE) from None


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
        # Surfels that light reaches only through a slit take their rows from first hits.
        kwargs["hemisphere_enclosed"] = job.hemisphere.enclosed(
            job.direct_lamps, job.emission, job.solve_emission)
        kwargs["hemisphere_links"] = job.hemisphere.links
    if "occluder_triangles" in kwargs and job.refine is None:
        # The solve builds its own ray scene of these triangles: the receivers' is released
        # meanwhile and built again for them (a scan's splats: about 1 GB per million points).
        job.occluders = None
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
