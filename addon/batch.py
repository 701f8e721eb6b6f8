"""Headless batch jobs: ``blender -b scene.blend --python scripts/illumap_batch.py -- <options>``.

Options (after ``--``)::

    --objects A,B          objects by name (comma separated)
    --collection NAME      every mesh / point cloud in a collection (and its children)
                           (neither: the selected objects, or if none is selected, every visible
                           mesh and point cloud of the scene)
    --quality Q            draft | medium | high (default medium)
    --density D            surfels per m² (overrides the preset)
    --budget N             total surfels (overrides density)
    --method M             fmm | direct
    --tol T                relative residual
    --target-error E       relative RMS error wanted (e.g. 0.05): chooses the surfel density
                           (--budget caps the count), FMM order, opening angle and tolerance
    --no-adaptive          with --target-error: one uniform pass (default: pass 1 with half
                           the surfels, then pass 2 denser where its illumination varies)
    --transfer DOMAIN      domain of 'illumination' on the meshes: point | corner (default
                           corner; the light is evaluated at the meshes' own corners)
    --no-transfer          leave the meshes alone: results on the surfel object only
    --gather-rays N        final-gather rays per mesh corner (default: the preset's)
    --no-lamps             ignore Blender lamps
    --no-lamp-shadows      lamp light unshadowed (default: rays against the surfels)
    --shadow-samples N     rays per surfel for lamps with a size (default 16)
    --no-world             leave out the world's light (default: included, shadowed)
    --frames A-B[,C...]    frames to compute, one result per frame (default: the current frame)
    --output out.blend     save the result (#### → frame number; added before the extension
                           when several frames are computed and the name has no #)
    --render out.png       Cycles render of the point-instanced preview (same # rules)
    --render-preview meshes  render the meshes with their illumination instead of the discs
    --resolution PX        render size of the longer side (default 256)
    --samples S            Cycles samples (default 16)
    --export-npz PATH      surfel data per frame;  --export-exr PATH  illumination as EXR
    --export-lightmaps P   UV-space lightmap EXR per mesh, P contains {object} (e.g.
                           maps/{object}_####.exr);  --lightmap-size PX (default 256)
                           (lightmaps do not take part in the skip-if-exists check)
    --overwrite            recompute frames whose outputs already exist (default: skip them,
                           so farm machines can split a frame range safely)
    --seed N               sampling seed

Exit codes: 0 success, 2 bad arguments, 3 bad scene or input, 4 solver failure, 130 cancelled.
Each computed frame prints the surfel count, time per phase, iterations and final residual.
"""

from __future__ import annotations

import argparse
import os
import re
import sys
import time

import bpy

from . import pipeline
from .errors import IllumapCancelled, IllumapError

EXIT_OK, EXIT_ARGS, EXIT_INPUT, EXIT_SOLVER, EXIT_CANCELLED = 0, 2, 3, 4, 130


class UsageError(Exception):
    """Bad command-line arguments (exit code 2)."""


class _Parser(argparse.ArgumentParser):
    def error(self, message):  # raise instead of sys.exit, so main() returns the exit code
        raise UsageError(message)


def build_parser() -> argparse.ArgumentParser:
    """The argument parser of the batch command (documented in the module docstring)."""
    p = _Parser(prog="illumap_batch.py", description="Compute Illumap illumination maps headless.",
                epilog="Exit codes: 0 ok, 2 bad arguments, 3 bad scene/input, 4 solver failure, "
                       "130 cancelled.")
    p.add_argument("--objects", help="comma-separated object names")
    p.add_argument("--collection", help="collection name")
    p.add_argument("--quality", default="medium", choices=["draft", "medium", "high"], type=str.lower)
    p.add_argument("--density", type=float, help="surfels per m²")
    p.add_argument("--budget", type=int, help="total surfel count")
    p.add_argument("--method", choices=["fmm", "direct"], type=str.lower)
    p.add_argument("--tol", type=float)
    p.add_argument("--target-error", type=float,
                   help="relative RMS error wanted (e.g. 0.03): Illumap picks the surfel "
                        "density, order, θ and tolerance, and reports an error estimate")
    p.add_argument("--transfer", choices=["point", "corner"], type=str.lower)
    p.add_argument("--no-transfer", action="store_true")
    p.add_argument("--gather-rays", type=int)
    p.add_argument("--no-adaptive", action="store_true")
    p.add_argument("--no-lamps", action="store_true")
    p.add_argument("--no-lamp-shadows", action="store_true")
    p.add_argument("--shadow-samples", type=int, default=16)
    p.add_argument("--occluder-shape", choices=list(pipeline.OCCLUDER_SHAPES), type=str.lower,
                   help="the surfels as occluders for exact visibility and lamp shadows "
                        "(default disc; ignored with --target-error, calibrated on discs)")
    p.add_argument("--world", action=argparse.BooleanOptionalAction, default=True,
                   help="light from the world's Background (default on; --no-world: off)")
    p.add_argument("--frames", help="e.g. 1-3 or 1,5,7-9")
    p.add_argument("--output", help="output .blend (#### = frame)")
    p.add_argument("--render", help="output PNG of the preview (#### = frame)")
    p.add_argument("--render-preview", choices=["points", "meshes"], default="points",
                   type=str.lower, help="what --render shows: the surfels' discs, or the "
                                        "meshes with the light evaluated at their corners")
    p.add_argument("--resolution", type=int, default=256)
    p.add_argument("--samples", type=int, default=16)
    p.add_argument("--export-npz")
    p.add_argument("--export-exr")
    p.add_argument("--export-lightmaps", help="UV-space EXR per mesh; pattern with {object}")
    p.add_argument("--lightmap-size", type=int, default=256)
    p.add_argument("--overwrite", action="store_true")
    p.add_argument("--seed", type=int, default=0)
    return p


def parse_frames(text: str | None, current: int) -> list[int]:
    """'1-3,7' → [1, 2, 3, 7]; None → [current]."""
    if not text:
        return [current]
    frames = []
    for part in text.split(","):
        m = re.fullmatch(r"\s*(-?\d+)\s*(?:-\s*(-?\d+)\s*)?", part)
        if not m:
            raise UsageError(f"bad frame range {text!r} (use e.g. 1-3 or 1,5,7-9)")
        a = int(m.group(1))
        b = int(m.group(2)) if m.group(2) is not None else a
        if b < a:
            raise UsageError(f"bad frame range {part!r}: end before start")
        frames.extend(range(a, b + 1))
    return sorted(set(frames))


def frame_path(path: str | None, frame: int, several: bool) -> str | None:
    """Substitute the frame for the last run of '#' (zero padded to its length).

    Without '#' and with several frames, '_####' goes before the extension.
    """
    if not path:
        return None
    path = bpy.path.abspath(path) if path.startswith("//") else path
    if "#" not in path and several:
        root, ext = os.path.splitext(path)
        path = f"{root}_####{ext}"
    runs = list(re.finditer(r"#+", path))
    if not runs:
        return os.path.abspath(path)
    m = runs[-1]
    return os.path.abspath(path[:m.start()] + str(frame).zfill(len(m.group())) + path[m.end():])


def _usable(obj) -> bool:
    if obj.name == "Illumap Surfels":
        return False
    if obj.type == "EMPTY":
        return obj.instance_type == "COLLECTION" and obj.instance_collection is not None
    return obj.type in ("MESH", "POINTCLOUD", "CURVE", "SURFACE", "META", "FONT")


def select_objects(scene, view_layer, names: str | None, collection: str | None) -> list:
    """The objects to compute, from --objects / --collection / the selection / the scene."""
    if names is not None:
        wanted = [n.strip() for n in names.split(",") if n.strip()]
        missing = [n for n in wanted if n not in bpy.data.objects]
        if missing:
            raise IllumapError(f"No object named {', '.join(repr(n) for n in missing)} in the file")
        objs = [bpy.data.objects[n] for n in wanted]
        if not objs:
            raise IllumapError("--objects names no object")
        return objs
    if collection is not None:
        coll = bpy.data.collections.get(collection)
        if coll is None:
            raise IllumapError(f"No collection named {collection!r} in the file")
        objs = [o for o in coll.all_objects if _usable(o)]
        if not objs:
            raise IllumapError(f"Collection {collection!r} has no mesh or point-cloud objects")
        return objs
    selected = [o for o in view_layer.objects if o.select_get() and _usable(o)]
    if selected:
        return selected
    return [o for o in scene.objects if _usable(o) and o.visible_get(view_layer=view_layer)]


def make_settings(args) -> pipeline.Settings:
    """Settings from the preset and the overriding options."""
    overrides = dict(density=args.density, budget=args.budget, method=args.method, tol=args.tol,
                     seed=args.seed, target_error=args.target_error,
                     occluder_shape=args.occluder_shape)
    settings = pipeline.settings_from_preset(args.quality, **overrides)
    if args.density is not None and args.density <= 0:
        raise UsageError("--density must be positive")
    if args.budget is not None and args.budget <= 0:
        raise UsageError("--budget must be positive")
    if args.lightmap_size <= 0 or args.resolution <= 0 or args.samples <= 0:
        raise UsageError("--lightmap-size, --resolution and --samples must be positive")
    if args.shadow_samples <= 0:
        raise UsageError("--shadow-samples must be positive")
    if args.gather_rays is not None and args.gather_rays <= 0:
        raise UsageError("--gather-rays must be positive")
    if args.transfer and args.no_transfer:
        raise UsageError("--transfer and --no-transfer exclude each other")
    if args.target_error is not None and not 0.0 < args.target_error < 1.0:
        raise UsageError("--target-error must lie in (0, 1), e.g. 0.05")
    if args.target_error is not None and args.density is not None:
        raise UsageError("--density and --target-error exclude each other: the target error "
                         "chooses the density (use --budget to cap the surfel count)")
    settings.lamps = not args.no_lamps
    settings.lamp_shadows = not args.no_lamp_shadows
    settings.shadow_samples = args.shadow_samples
    settings.adaptive = not args.no_adaptive
    settings.world_ambient = args.world
    if args.transfer:
        settings.transfer, settings.transfer_domain = True, args.transfer.upper()
    if args.no_transfer:
        settings.transfer = False
    if args.gather_rays is not None:
        settings.gather_rays = args.gather_rays
    return settings


def add_preview(context, surfel_object) -> bool:
    """Build the point-instanced preview on the surfel object, if the add-on has one."""
    try:
        from .preview import build_preview
    except ImportError:
        return False
    try:
        build_preview(context, surfel_object)
    except (ValueError, RuntimeError) as exc:
        print(f"  preview not built: {exc}")
        return False
    return True


def render_preview(context, surfel_object, sources, path: str, resolution: int, samples: int,
                   what: str = "points") -> str:
    """Render the preview with Cycles to ``path`` (PNG): the point-instanced discs, or with
    ``what="meshes"`` the source meshes through the mesh preview (mesh_preview.py), which
    stays on in the saved file. Returns a message."""
    from . import mesh_preview
    scene = context.scene
    if what == "meshes":
        if not mesh_preview.build_mesh_preview(sources):
            return "render skipped: no mesh has an 'illumination' attribute"
        surfel_object.hide_render = True
    elif not add_preview(context, surfel_object):
        return "render skipped: the preview is not available"
    if scene.camera is None:
        return "render skipped: the scene has no camera"
    r = scene.render
    saved = (r.engine, r.resolution_x, r.resolution_y, r.resolution_percentage, r.filepath,
             r.image_settings.file_format, scene.cycles.samples, scene.cycles.device)
    hidden = [o for o in sources if not o.hide_render] if what == "points" else []
    aspect = r.resolution_y / max(r.resolution_x, 1)
    try:
        for o in hidden:  # the discs stand in for the source geometry
            o.hide_render = True
        r.engine = "CYCLES"
        scene.cycles.device = "CPU"
        scene.cycles.samples = samples
        if aspect <= 1:
            r.resolution_x, r.resolution_y = resolution, max(1, round(resolution * aspect))
        else:
            r.resolution_x, r.resolution_y = max(1, round(resolution / aspect)), resolution
        r.resolution_percentage = 100
        r.image_settings.file_format = "PNG"
        tmp = path + ".partial.png"
        r.filepath = tmp
        bpy.ops.render.render(write_still=True)
        os.replace(tmp, path)  # a farm never sees a half-written frame
    finally:
        for o in hidden:
            o.hide_render = False
        (r.engine, r.resolution_x, r.resolution_y, r.resolution_percentage, r.filepath,
         r.image_settings.file_format, scene.cycles.samples, scene.cycles.device) = saved
    return f"rendered {path}"


def _report(frame: int, result: pipeline.Result, out) -> None:
    print(f"Illumap frame {frame}: {result.count} surfels, {result.iterations} iterations, "
          f"final residual {result.residual:.3g}, converged {result.converged}", file=out)
    for phase, seconds in result.timings.items():
        print(f"  {phase:<16} {seconds:8.3f} s", file=out)
    density = result.stats.get("density")
    if density:
        print(f"  target error {density['target_error']:.3g}: {density['density']:.0f} surfels/m² "
              f"({density['surfels']} surfels, predicted discretization error "
              f"{density['predicted_discretization']:.3g})", file=out)
    adaptive = result.stats.get("adaptive")
    if adaptive:
        first = adaptive["pass1"]
        print(f"  adaptive: pass 1 {first['surfels']} surfels, {first['iterations']} iterations, "
              f"{first['seconds']:.3f} s; pass 2 {adaptive['pass2_surfels']} surfels, density "
              f"multiplier {adaptive['mean_multiplier']:.2f} on average, "
              f"{adaptive['max_multiplier']:.2f} at most, over {adaptive['regions']} regions",
              file=out)
    shape = result.stats.get("occluder_shape", "disc")
    if result.stats.get("visibility") == "exact":
        against = result.stats.get("visibility_occluders",
                                   f"{result.stats.get('visibility_shape', shape)}s")
        print(f"  visibility       exact, {against}", file=out)
    if result.stats.get("shadow_rays"):
        against = result.stats.get("shadow_occluders", f"{shape}s")
        print(f"  shadow rays      {result.stats['shadow_rays']} ({against})", file=out)
    receivers = result.stats.get("receivers")
    if receivers:
        print(f"  receivers        {receivers['corners']} corners, {receivers['rays']} rays "
              f"({receivers['gather_rays']} gather rays each; gather noise "
              f"{receivers['gather_noise']:.2%}, indirect share {receivers['indirect_share']:.0%}"
              + (f"; estimated error at the meshes {receivers['estimate']:.2%}"
                 if "estimate" in receivers else "") + ")", file=out)
    accuracy = result.stats.get("accuracy")
    if accuracy:
        chosen = accuracy["settings"]
        estimate = accuracy.get("estimate", {}).get("total")
        print(f"  target error {chosen['target_error']:.3g}: method {chosen['method']}, "
              f"order {chosen['order']}, theta {chosen['theta']}, visibility "
              f"{chosen['visibility']}, tol {chosen['tol']:.2g}"
              + (f" or solver error ≤ {chosen['error_tol']:.2g}" if chosen.get("error_tol")
                 else "") + "; estimated error "
              f"{estimate if estimate is None else format(estimate, '.3g')} (needs about "
              f"{chosen['density']:.0f} surfels/m²)", file=out)
    for w in result.warnings:
        print(f"  Warning: {w}", file=out)


def run_frames(args, out=None) -> int:
    """Compute every requested frame; returns the exit code (raises IllumapError on failure)."""
    out = out or sys.stdout  # looked up per call, so redirected output is honoured
    context = bpy.context
    scene = context.scene
    settings = make_settings(args)
    frames = parse_frames(args.frames, scene.frame_current)
    several = len(frames) > 1
    for frame in frames:
        outputs = {k: frame_path(getattr(args, k), frame, several)
                   for k in ("output", "render", "export_npz", "export_exr")}
        wanted = [p for p in outputs.values() if p]
        if wanted and not args.overwrite and all(os.path.exists(p) for p in wanted):
            print(f"Illumap frame {frame}: outputs exist, skipped (use --overwrite)", file=out)
            continue
        for p in wanted:
            os.makedirs(os.path.dirname(p) or ".", exist_ok=True)
        scene.frame_set(frame)
        objects = select_objects(scene, context.view_layer, args.objects, args.collection)
        lightmaps = frame_path(args.export_lightmaps, frame, several) if args.export_lightmaps else ""
        frame_settings = pipeline.replace(settings, export_npz=outputs["export_npz"] or "",
                                          export_exr=outputs["export_exr"] or "",
                                          export_lightmaps=lightmaps,
                                          lightmap_size=args.lightmap_size)
        t0 = time.perf_counter()
        result = pipeline.compute(context, objects, frame_settings)
        result.timings["total"] = time.perf_counter() - t0
        _report(frame, result, out)
        surfels = bpy.data.objects.get(result.object_name or "Illumap Surfels")
        add_preview(context, surfels)  # the saved file opens with the preview in place
        if outputs["output"]:
            bpy.ops.wm.save_as_mainfile(filepath=outputs["output"], copy=True, check_existing=False)
            print(f"  saved {outputs['output']}", file=out)
        if outputs["render"]:
            msg = render_preview(context, surfels, objects, outputs["render"], args.resolution,
                                 args.samples, args.render_preview)
            print(f"  {msg}", file=out)
    return EXIT_OK


def main(argv: list[str] | None = None) -> int:
    """Run the batch command; returns the process exit code (see the module docstring)."""
    if argv is None:
        argv = sys.argv[sys.argv.index("--") + 1:] if "--" in sys.argv else []
    try:
        args = build_parser().parse_args(argv)
        return run_frames(args)
    except UsageError as exc:
        print(f"illumap_batch: error: {exc}", file=sys.stderr)
        return EXIT_ARGS
    except IllumapCancelled as exc:
        print(f"illumap_batch: cancelled: {exc}", file=sys.stderr)
        return EXIT_CANCELLED
    except KeyboardInterrupt:
        print("illumap_batch: cancelled", file=sys.stderr)
        return EXIT_CANCELLED
    except IllumapError as exc:
        print(f"illumap_batch: error: {exc}", file=sys.stderr)
        return exc.exit_code
