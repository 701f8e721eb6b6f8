"""Headless batch jobs: ``blender -b scene.blend --python scripts/illumap_batch.py -- <options>``.

Options (after ``--``)::

    --objects A,B          objects by name (comma separated)
    --collection NAME      every mesh / point cloud in a collection (and its children)
                           (neither: the selected objects, or if none is selected, every visible
                           mesh and point cloud of the scene)
    --quality Q            draft | medium | high (default medium)
    --density, --budget, --target-error, --order, --tol, --gather-rays, --no-lamps, --world,
    --transfer, ...        one option per run setting, generated from its declaration in
                           ``illumap.settings`` (the same knobs as the panel's); each
                           overrides the preset; ``--help`` gives every range and default
    --frames A-B[,C...]    frames to compute, one result per frame (default: the current frame)
    --output out.blend     save the result (#### → frame number; added before the extension
                           when several frames are computed and the name has no #)
    --render out.png       Cycles render of the preview from the scene camera (same # rules)
    --render-preview WHAT  what --render shows: objects (default: the lit meshes and scans
                           themselves, as the Object Preview shows them after Compute; with
                           --no-transfer, surfels), or surfels (the solve's discs, a
                           diagnostic); "meshes" and "points" are the older names of the two
    --resolution PX        --render's longer side (default: the scene's resolution and %)
    --samples S            --render's Cycles samples (default: the scene's)
    --device cpu|gpu       --render's Cycles device (default: the scene's); the format follows
                           --render's extension, else the scene's
    --export-npz PATH      surfel data per frame;  --export-exr PATH  illumination as EXR
                           (Blender's own image writer)
    --export-lightmaps P   UV-space lightmap EXR per mesh from its per-corner light, grown
                           across UV seams; P contains {object} (e.g. maps/{object}_####.exr);
                           --lightmap-size PX
    --skip-existing        skip frames whose outputs all exist (default: overwrite, as
                           Blender does; lightmaps are not checked)
    --overwrite-input      allow an output path that is the input .blend itself (refused
                           otherwise)
    --quiet / --verbose    warnings and errors only / finer progress and the thread count

At most ``MAX_FRAMES`` (10,000) frames per job, inside Blender's frame range; split longer
ranges over several jobs.

Every output path is checked before the solve (its folder must be, or can be created as, a
writable folder; no path may be the input file or another output), and every file is written
atomically: first to a hidden temporary file in the same folder, then renamed into place, so a
farm never sees a half-written file and a failed job leaves no partial output.

Exit codes (``errors.ExitCode``, the one table of them):

    0    success: every requested frame computed and every output written
    1    unexpected error (a bug; the traceback is printed)
    2    bad arguments (unknown option, bad value, frame range too long)
    3    bad scene or input (nothing to compute, bad geometry, no light in the scene, memory)
    4    solver failure
    5    an output cannot be written (unwritable folder, path under a file, the input file,
         a render without a camera); checked before the solve where possible
    130  cancelled

A job needs at least one output (else exit 2, before the scene is read). Each phase prints a
line as it starts (long phases their percentage); each computed frame prints the surfel count,
time per phase, iterations and final residual. The core's threads follow Blender's -t or the
scene's Fixed thread count (``threads.py``).
"""

from __future__ import annotations

import contextlib
import os
import sys
import tempfile
import time
import traceback

import bpy

from .write import exports, output
from . import pipeline
from .preview import solid_preview
from .batch_options import (
    MAX_FRAMES, MAX_RESOLUTION, NUMBER_OPTIONS, OUTPUT_OPTIONS, UsageError, build_parser,
    frame_path, make_settings, parse_frames, preview_kind
)
from .errors import ExitCode, IllumapCancelled, IllumapError, NoLightError, OutputError

__all__ = ["main", "run_frames", "build_parser", "make_settings", "parse_frames", "UsageError",
           "MAX_FRAMES", "MAX_RESOLUTION", "NUMBER_OPTIONS", "ExitCode"]

def _usable(obj) -> bool:
    if obj.name == output.SURFEL_OBJECT:
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


def add_preview(context, surfel_object, lit=(), kind: str = "objects") -> list[str]:
    """The preview the UI shows after Compute (``mesh_preview.show_result``): the lit objects
    through the Object Preview and the surfel object hidden, or with ``kind="surfels"`` the
    surfels' discs. Returns the names of the objects shown; a preview that cannot be built
    is said and skipped."""
    from .preview import mesh_preview
    try:
        return mesh_preview.show_result(context, [o for o in lit if o is not None],
                                        surfel_object, objects=kind == "objects",
                                        surfels=kind == "surfels")
    except (ValueError, RuntimeError) as exc:
        print(f"  preview not built: {exc}")
        return []


#: Image formats by file extension, for ``--render`` (Blender's ``file_format`` names).
RENDER_FORMATS = {".png": "PNG", ".jpg": "JPEG", ".jpeg": "JPEG", ".exr": "OPEN_EXR",
                  ".tif": "TIFF", ".tiff": "TIFF", ".bmp": "BMP", ".tga": "TARGA",
                  ".webp": "WEBP", ".hdr": "HDR", ".jp2": "JPEG2000"}


def render_format(path: str, scene_format: str) -> str:
    """The file format ``--render path`` is written in: the one its extension names, else the
    scene's own (Output Properties > Output > File Format)."""
    return RENDER_FORMATS.get(os.path.splitext(path)[1].lower(), scene_format)


def render_size(render, resolution: int | None) -> tuple[int, int]:
    """(width, height) of ``--render``: the scene's resolution at its percentage, or with
    ``--resolution`` that many pixels on the longer side at the scene's aspect ratio."""
    if resolution is None:
        scale = render.resolution_percentage / 100.0
        return (max(1, int(render.resolution_x * scale)),
                max(1, int(render.resolution_y * scale)))
    aspect = render.resolution_y / max(render.resolution_x, 1)
    if aspect <= 1:
        return resolution, max(1, round(resolution * aspect))
    return max(1, round(resolution / aspect)), resolution


def render_still() -> None:
    """Render the scene's camera view and write it to ``render.filepath`` (Blender's F12)."""
    bpy.ops.render.render(write_still=True)


def _remove_partials(tmp: str) -> None:
    """Remove every file Blender may have made from the temporary render path ``tmp`` (itself,
    or it with an extension added)."""
    folder, base = os.path.split(tmp)
    with contextlib.suppress(OSError):
        for name in os.listdir(folder):
            if name.startswith(base):
                with contextlib.suppress(OSError):
                    os.remove(os.path.join(folder, name))


def render_preview(context, surfel_object, sources, path: str, resolution: int | None = None,
                   samples: int | None = None, what: str = "objects",
                   device: str | None = None) -> str:
    """Render the scene camera's view with Cycles to ``path``, with the preview that
    ``add_preview`` put in place: the lit objects themselves (``what="objects"``), or the
    surfels' discs standing in for the source geometry (``"surfels"``).

    The scene's own render settings apply (resolution and percentage, Cycles samples and
    device, colour management, file format and its options) unless ``resolution``,
    ``samples`` or ``device`` override them; the format follows ``path``'s extension where it
    names one. The image goes to a hidden temporary file renamed onto ``path``; a failed
    render leaves no file behind. Returns a message; raises OutputError when nothing could be
    rendered or written. The scene's settings are put back afterwards."""
    from .preview import mesh_preview
    scene = context.scene
    if what == "objects":
        if not any(mesh_preview.has_mesh_preview(o) for o in sources if o is not None):
            raise OutputError(f"--render {path!r} not rendered: no object has an "
                              "'illumination' attribute (the Object Preview needs the "
                              "transfer)")
    elif surfel_object is None or surfel_object.hide_render or \
            preview_module().find_preview_modifier(surfel_object) is None:
        raise OutputError(f"--render {path!r} not rendered: the surfel preview is not "
                          "available")
    if scene.camera is None:
        raise OutputError(f"--render {path!r} not rendered: the scene has no camera")
    r = scene.render
    cycles = scene.cycles
    image = r.image_settings
    saved = (r.engine, r.resolution_x, r.resolution_y, r.resolution_percentage, r.filepath,
             image.file_format, image.color_mode, image.color_depth, r.use_file_extension,
             cycles.samples, cycles.device)
    hidden = [o for o in sources if not o.hide_render] if what == "surfels" else []
    width, height = render_size(r, resolution)
    tmp = None
    try:
        for o in hidden:  # the discs stand in for the source geometry
            o.hide_render = True
        r.engine = "CYCLES"    # the preview's emission shading is Cycles'
        if device is not None:
            cycles.device = device.upper()
        if samples is not None:
            cycles.samples = samples
        r.resolution_x, r.resolution_y, r.resolution_percentage = width, height, 100
        fmt = render_format(path, r.image_settings.file_format)
        if r.image_settings.file_format != fmt:
            r.image_settings.file_format = fmt
        r.use_file_extension = False      # the file is written where it was asked for
        with atomic_path(path) as tmp:  # a farm never sees a half-written frame
            try:
                r.filepath = tmp
                render_still()
                if not os.path.isfile(tmp) or not os.path.getsize(tmp):
                    raise OutputError(f"--render {path!r}: Cycles wrote no image")
            except BaseException:
                _remove_partials(tmp)
                raise
    except (OSError, RuntimeError) as exc:
        raise OutputError(f"--render {path!r} could not be written: {str(exc).strip()}") from None
    finally:
        for o in hidden:
            o.hide_render = False
        (r.engine, r.resolution_x, r.resolution_y, r.resolution_percentage, r.filepath,
         image.file_format) = saved[:6]
        for name, value in zip(("color_mode", "color_depth"), saved[6:8]):
            with contextlib.suppress(TypeError, ValueError):   # not offered by the format
                setattr(image, name, value)
        r.use_file_extension, cycles.samples, cycles.device = saved[8:]
    return f"rendered {path} ({width}×{height}, {fmt})"


def preview_module():
    from .preview import surfel_preview as preview
    return preview


def _report(frame: int, result: pipeline.Result, out, warn_to=None) -> None:
    """The frame's summary on ``out``; its warnings on ``warn_to`` too when that differs
    (--quiet keeps the warnings)."""
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
              f"{receivers['gather_noise']:.2%}, indirect share {receivers['indirect_share']:.0%}, "
              f"from the surfels {receivers.get('surfel_share', 0.0):.0%}"
              + (f"; estimated error at the meshes {receivers['estimate']:.2%}"
                 if "estimate" in receivers else "") + ")", file=out)
        first = receivers.get("first_gather")
        if first:
            print(f"  gathered again   the first gather's noise at {first['rays']} rays, "
                  f"{first['gather_noise']:.2%}, exceeded its share of the target", file=out)
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
        print(f"  Warning: {w}", file=out if warn_to is None or warn_to is out else warn_to,
              flush=True)


def _flag(option: str) -> str:
    return "--" + option.replace("_", "-")


def _same_file(a: str, b: str) -> bool:
    return bool(a) and bool(b) and os.path.realpath(a) == os.path.realpath(b)


def _writable_folder(option: str, path: str, checked: dict) -> None:
    """Raise OutputError unless files can be created next to ``path`` (``output.
    folder_problem``). ``checked`` caches the problem of each folder seen."""
    folder = os.path.dirname(os.path.abspath(path)) or os.sep
    if folder not in checked:
        checked[folder] = output.folder_problem(path)[1]
    if checked[folder]:
        raise OutputError(f"{_flag(option)} {path!r} cannot be written: {checked[folder]}")


def check_outputs(args, frames: list[int], several: bool, input_path: str) -> None:
    """Refuse, before anything is computed, output paths that cannot be written: a folder
    that is not writable or lies under a file, a path that is a folder, the input .blend
    (unless ``--overwrite-input``), two options naming one file, and ``--render`` in a scene
    without a camera. Raises OutputError (``ExitCode.OUTPUT``)."""
    if args.render and bpy.context.scene.camera is None:
        raise OutputError(f"--render {args.render!r} cannot be rendered: the scene has no "
                          "camera (add one, or leave out --render)")
    checked: dict = {}
    for frame in frames:
        seen: dict[str, str] = {}
        for option in OUTPUT_OPTIONS:
            path = frame_path(getattr(args, option), frame, several)
            if not path:
                continue
            if option == "export_npz":
                path = output.npz_path(path)
            if os.path.isdir(path):
                raise OutputError(f"{_flag(option)} {path!r} is a folder: give a file name")
            if _same_file(path, input_path) and not args.overwrite_input:
                raise OutputError(f"{_flag(option)} {path!r} is the input file itself: "
                                  "choose another path, or pass --overwrite-input to replace "
                                  "the input")
            real = os.path.realpath(path)
            if real in seen and option != "export_lightmaps":
                raise OutputError(f"{_flag(seen[real])} and {_flag(option)} both name "
                                  f"{path!r}: give each output its own file")
            seen[real] = option
            if option in ("export_exr", "export_lightmaps") and exports.exr_problem():
                raise OutputError(f"{_flag(option)} {path!r} cannot be written: "
                                  f"{exports.exr_problem()}")
            _writable_folder(option, path, checked)
        if not several:
            break


@contextlib.contextmanager
def atomic_path(final: str):
    """Yield a temporary path in ``final``'s folder (hidden, same extension) to write to;
    on success it is renamed onto ``final`` in one step (``os.replace``), on failure removed.
    Creates the folder."""
    folder = os.path.dirname(os.path.abspath(final))
    os.makedirs(folder, exist_ok=True)
    root, ext = os.path.splitext(os.path.basename(final))
    fd, tmp = tempfile.mkstemp(prefix=f".{root}.", suffix=".partial" + ext, dir=folder)
    os.close(fd)
    os.remove(tmp)   # a fresh name: Blender would keep an existing file as a .blend1 backup
    try:
        yield tmp
        if not os.path.isfile(tmp):
            raise OutputError(f"{final!r} was not written")
        os.replace(tmp, final)
    except BaseException:
        with contextlib.suppress(OSError):
            os.remove(tmp)
        raise


@contextlib.contextmanager
def atomic_pattern(pattern: str):
    """Lightmaps: yield a pattern with ``{object}`` inside a hidden temporary folder next to
    the final files; on success every file written there is renamed into place, on failure
    the folder is removed. A pattern with ``{object}`` in its folder part is written in
    place (no common folder to stage in)."""
    pattern = exports.lightmap_pattern(pattern)
    folder, base = os.path.split(os.path.abspath(pattern))
    if "{object}" in folder:
        yield pattern
        return
    os.makedirs(folder, exist_ok=True)
    stage = tempfile.mkdtemp(prefix=".illumap-partial-", dir=folder)
    try:
        yield os.path.join(stage, base)
        for name in os.listdir(stage):
            os.replace(os.path.join(stage, name), os.path.join(folder, name))
    finally:
        import shutil
        shutil.rmtree(stage, ignore_errors=True)


def save_copy(path: str) -> None:
    """Save a copy of the open file to ``path`` (the open file keeps its own path)."""
    bpy.ops.wm.save_as_mainfile(filepath=path, copy=True, check_existing=False)


class ProgressPrinter:
    """The batch's progress callback (``pipeline.Progress``): a line when a phase starts, and
    for a long phase its percentage every ``step`` (10%, 5% with --verbose) once it has run
    for ``after`` seconds. Flushed at once, so a farm's log shows where a job is."""

    def __init__(self, frame: int, out, verbose: bool = False, after: float = 2.0) -> None:
        self.frame, self.out = frame, out
        self.step = 5 if verbose else 10        # per cent
        self.after = 0.0 if verbose else after
        self.phase = None
        self.started = 0.0
        self.shown = 0

    def __call__(self, fraction: float, phase: str):
        now = time.perf_counter()
        phase = str(phase or "working")
        if phase != self.phase:
            self.phase, self.started, self.shown = phase, now, 0
            print(f"Illumap frame {self.frame}: {phase}", file=self.out, flush=True)
            return True
        try:
            percent = int(100 * min(max(float(fraction), 0.0), 1.0))
        except (TypeError, ValueError):
            return True
        if now - self.started >= self.after and percent >= self.shown + self.step:
            self.shown = percent - percent % self.step
            print(f"Illumap frame {self.frame}: {phase} {percent:3d}%", file=self.out,
                  flush=True)
        return True


class _Quiet:
    """A sink for the messages --quiet leaves out."""

    def write(self, text):
        return len(text)

    def flush(self):
        pass


def run_frames(args, out=None) -> int:
    """Compute every requested frame; returns ``ExitCode.OK`` (raises IllumapError,
    OutputError or UsageError on failure)."""
    out = out or sys.stdout  # looked up per call, so redirected output is honoured
    say = _Quiet() if args.quiet else out          # progress and reports
    context = bpy.context
    scene = context.scene
    settings = make_settings(args)                 # usage errors, before anything is read
    frames = parse_frames(args.frames, scene.frame_current)
    if not any(getattr(args, o) for o in OUTPUT_OPTIONS):
        raise UsageError("no output: give at least one of --output, --render, --export-npz, "
                         "--export-exr, --export-lightmaps (a job without one would compute "
                         "and write nothing)")
    several = len(frames) > 1
    input_path = bpy.data.filepath
    check_outputs(args, frames, several, input_path)   # before any solve
    from . import threads
    count, source = threads.apply(scene)
    if args.verbose:
        print(f"Illumap: {count} worker thread{'s' * (count != 1)} ({source})", file=say,
              flush=True)
    for frame in frames:
        outputs = {k: frame_path(getattr(args, k), frame, several)
                   for k in ("output", "render", "export_npz", "export_exr")}
        if outputs["export_npz"]:
            outputs["export_npz"] = output.npz_path(outputs["export_npz"])
        wanted = [p for p in outputs.values()
                  if p and not (args.overwrite_input and _same_file(p, input_path))]
        if wanted and args.skip_existing and all(os.path.exists(p) for p in wanted):
            print(f"Illumap frame {frame}: outputs exist, skipped (--skip-existing)", file=say,
                  flush=True)
            continue
        scene.frame_set(frame)
        objects = select_objects(scene, context.view_layer, args.objects, args.collection)
        lightmaps = frame_path(args.export_lightmaps, frame, several) if args.export_lightmaps else ""
        t0 = time.perf_counter()
        progress = None if args.quiet else ProgressPrinter(frame, say, args.verbose)
        try:
            # The exports go to temporary files beside their targets, renamed into place
            # when the frame succeeded (atomic_path, atomic_pattern).
            with contextlib.ExitStack() as stack:
                npz = stack.enter_context(atomic_path(outputs["export_npz"])) \
                    if outputs["export_npz"] else ""
                exr = stack.enter_context(atomic_path(outputs["export_exr"])) \
                    if outputs["export_exr"] else ""
                maps = stack.enter_context(atomic_pattern(lightmaps)) if lightmaps else ""
                frame_settings = pipeline.replace(settings, export_npz=npz, export_exr=exr)
                result = pipeline.compute(context, objects, frame_settings, progress)
                if maps:
                    if progress is not None:
                        progress(0.0, "lightmaps")
                    written, notes = exports.export_lightmaps(result, maps,
                                                                    settings.lightmap_size)
                    result.warnings.extend(notes)
        except OSError as exc:   # the inputs are in memory: an export failed
            raise OutputError(f"Writing the exports of frame {frame} failed: {exc}") from None
        result.timings["total"] = time.perf_counter() - t0
        _report(frame, result, say, out)
        surfels = bpy.data.objects.get(result.object_name or output.SURFEL_OBJECT)
        lit = [bpy.data.objects.get(n) for n in
               list(result.receiver_values) + list(result.point_receiver_values)]
        # The saved file opens with the preview in place, as the UI shows it after Compute.
        add_preview(context, surfels, lit, preview_kind(args))
        # While the file's Solid Preview is on, the meshes this frame lit show it too.
        solid_preview.after_run(context, list(result.receiver_values.keys()))
        if outputs["render"]:   # before the save: a frame whose render failed saves nothing
            if progress is not None:
                progress(0.0, "render")
            msg = render_preview(context, surfels, [o for o in lit if o is not None]
                                 if preview_kind(args) == "objects" else objects,
                                 outputs["render"], args.resolution, args.samples,
                                 preview_kind(args), args.device)
            print(f"  {msg}", file=say, flush=True)
        if outputs["output"]:
            try:
                with atomic_path(outputs["output"]) as tmp:
                    save_copy(tmp)
            except (OSError, RuntimeError) as exc:
                raise OutputError(f"--output {outputs['output']!r} could not be saved: "
                                  f"{str(exc).strip()}") from None
            print(f"  saved {outputs['output']}", file=say, flush=True)
    return ExitCode.OK


def main(argv: list[str] | None = None) -> int:
    """Run the batch command; returns the process exit code (see the module docstring)."""
    if argv is None:
        argv = sys.argv[sys.argv.index("--") + 1:] if "--" in sys.argv else []
    try:
        args = build_parser().parse_args(argv)
        return int(run_frames(args))
    except UsageError as exc:
        print(f"illumap_batch: error: {exc}", file=sys.stderr)
        return int(ExitCode.USAGE)
    except IllumapCancelled as exc:
        print(f"illumap_batch: cancelled: {exc}", file=sys.stderr)
        return int(ExitCode.CANCELLED)
    except KeyboardInterrupt:
        print("illumap_batch: cancelled", file=sys.stderr)
        return int(ExitCode.CANCELLED)
    except NoLightError as exc:
        print(f"illumap_batch: nothing computed: {exc}", file=sys.stderr)
        return int(exc.exit_code)
    except IllumapError as exc:
        print(f"illumap_batch: error: {exc}", file=sys.stderr)
        return int(exc.exit_code)
    except Exception:  # noqa: BLE001 - a bug: say so, and never exit 0
        traceback.print_exc()
        print("illumap_batch: internal error (see the traceback above)", file=sys.stderr)
        return int(ExitCode.INTERNAL)
