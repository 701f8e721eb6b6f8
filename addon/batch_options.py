"""The batch command's options: the parser (every run setting's option generated from
``illumap.settings``), the frames, the output names, and the run's Settings from the options.
Usage errors are raised here, before anything is read or computed (``UsageError``).
"""

from __future__ import annotations

import argparse
import os
import re

import bpy
from illumap.limits import limit
from illumap.settings import spec as setting_spec
from illumap.settings import specs as setting_specs

from . import pipeline
from .errors import exit_code_help

#: The most frames one job computes (``--frames``): a farm splits longer ranges over jobs, and
#: a typo such as 1-100000000 is refused before anything is allocated or written.
MAX_FRAMES = limit("frames").high
#: The largest --resolution: Blender's render size limit (RenderSettings.resolution_x).
MAX_RESOLUTION = limit("resolution").high
#: The settings the batch takes as options (``illumap.settings``: each option is generated from
#: the setting's one declaration).
SETTING_OPTIONS = {s.option: s for s in setting_specs() if s.option}
#: Numeric options and the limits (``illumap.limits``) that bound them: the settings' and the
#: render's own.
NUMBER_OPTIONS = {**{option: s.name for option, s in SETTING_OPTIONS.items()
                     if s.limit is not None and not s.choices and s.kind is not bool},
                  "--resolution": "resolution", "--samples": "samples"}
#: Where each group of settings shows in --help.
SETTING_GROUPS = {"sampling": "quality", "solver": "quality", "light": "light",
                  "output": "where the light is written"}


def _range(option: str) -> str:
    """``option``'s range and unit for its help: ``1..65536 px``."""
    lim = limit(NUMBER_OPTIONS[option])
    return f"{lim.interval()}{' ' + lim.unit if lim.unit else ''}"
#: The output options that name files, as argparse destinations.
OUTPUT_OPTIONS = ("output", "render", "export_npz", "export_exr", "export_lightmaps")


class UsageError(Exception):
    """Bad command-line arguments (``ExitCode.USAGE``)."""


class _Parser(argparse.ArgumentParser):
    def error(self, message):  # raise instead of sys.exit, so main() returns the exit code
        raise UsageError(message)


def _help_range(option: str) -> str:
    """``option``'s range for ``--help``, as a user reads it: bounds past anything sensible
    (2³¹ rays, 2⁶² surfels, infinity) are said in words rather than printed."""
    lim = limit(NUMBER_OPTIONS[option])
    unit = f" {lim.unit}" if lim.unit else ""
    if isinstance(lim.high, int) and lim.high >= 2 ** 31 - 1:
        return f"{lim.low} or more{unit}"
    if lim.high is None or lim.high == float("inf"):
        return f"more than {lim.low:g}{unit}"
    return f"{lim.interval()}{unit}"


def budget_help() -> str:
    """The surfel budget's range for ``--help``: what this machine's memory allows."""
    most = pipeline.memory_limit(pipeline.Settings()) // pipeline.BYTES_PER_SURFEL
    return (f"1 to about {most:,} surfels on this machine (its memory at "
            f"{pipeline.BYTES_PER_SURFEL // 1024} KiB per surfel)")


class _HelpFormatter(argparse.RawDescriptionHelpFormatter):
    """Wider option column, so each option's help stays on its lines."""

    def __init__(self, prog):
        super().__init__(prog, max_help_position=30, width=100)


def _setting_help(option: str, spec) -> str:
    """An option's help from its setting's declaration: what it does, its range, its
    default."""
    if spec.kind is bool:
        default = "on" if spec.default else "off"
        head = ("switch off: " + spec.description[0].lower() + spec.description[1:]
                if spec.cli_negative else spec.description)
        return f"{head} (default: {default})"
    if spec.name == "budget":
        accepts = budget_help()
    elif spec.choices:
        accepts = ", ".join(v.lower() for v in spec.values)
    else:
        accepts = _help_range(option)
    if spec.preset:
        default = f"the preset's, {presets_value(spec.name)} for medium"
    elif spec.default is None:
        default = "none"
    else:
        default = str(spec.default).lower() if spec.choices else f"{spec.default:g}" \
            if isinstance(spec.default, float) else str(spec.default)
    return f"{spec.description}; {accepts} (default: {default})"


def presets_value(name: str):
    """The medium preset's value of setting ``name``, as --help shows it."""
    value = pipeline.QUALITY_PRESETS["MEDIUM"][name]
    return f"{value:,}" if isinstance(value, int) else f"{value:g}" \
        if isinstance(value, float) else value


def _add_setting(group, option: str, spec) -> None:
    """The option of one run setting (``illumap.settings.Spec``). Every option defaults to
    None: the preset or the setting's own default then decides."""
    keywords = dict(dest=spec.name, default=None,
                    help=_setting_help(option, spec).replace("%", "%%"))  # argparse formats it
    if spec.kind is bool and spec.cli_negative:
        group.add_argument(option, action="store_false", **keywords)
    elif spec.kind is bool:
        group.add_argument(option, action=argparse.BooleanOptionalAction, **keywords)
    elif spec.choices:
        group.add_argument(option, choices=[v.lower() for v in spec.values], type=str.lower,
                           **keywords)
    else:
        metavar = {"int": "N", "float": "X"}.get(spec.kind.__name__, "VALUE")
        group.add_argument(option, type=spec.kind, metavar=metavar, **keywords)


def build_parser() -> argparse.ArgumentParser:
    """The argument parser of the batch command (documented in the module docstring)."""
    presets = pipeline.QUALITY_PRESETS
    p = _Parser(prog="illumap_batch.py", formatter_class=_HelpFormatter,
                description="Compute Illumap illumination maps headless: blender -b scene.blend "
                            "--python scripts/illumap_batch.py -- [options]. At least one "
                            "output (--output, --render, --export-*) is required. Outputs are "
                            "overwritten, as Blender overwrites its renders (--skip-existing "
                            "keeps them).",
                epilog=exit_code_help() + f" At most {MAX_FRAMES:,} frames per job. Outputs "
                       "are checked before the solve and written atomically.")
    g = p.add_argument_group("what to light")
    g.add_argument("--objects", metavar="A,B", help="comma-separated object names (default: "
                   "the selected objects, or every visible mesh and point cloud)")
    g.add_argument("--collection", metavar="NAME", help="every mesh and point cloud in a "
                   "collection and its children")
    g.add_argument("--frames", metavar="A-B[,C]",
                   help=f"frames to compute, e.g. 1-3 or 1,5,7-9 (default: the scene's current "
                        f"frame; at most {MAX_FRAMES:,})")
    groups = {title: p.add_argument_group(title) for title in dict.fromkeys(
        SETTING_GROUPS.values())}
    groups["quality"].add_argument(
        "--quality", default="medium", choices=["draft", "medium", "high"], type=str.lower,
        help="preset (default: medium): draft "
             f"{presets['DRAFT']['budget']:,} surfels, medium "
             f"{presets['MEDIUM']['budget']:,}, high {presets['HIGH']['budget']:,}")
    for option, spec in SETTING_OPTIONS.items():
        _add_setting(groups[SETTING_GROUPS[spec.group]], option, spec)
    g = p.add_argument_group("outputs (at least one; '#' in a name is the frame number)")
    g.add_argument("--output", metavar="FILE.blend",
                   help="save the lit scene (#### = frame; with several frames and no '#', "
                        "_#### goes before the extension)")
    g.add_argument("--render", metavar="IMAGE",
                   help="render the lit objects from the scene camera with Cycles, with the "
                        "scene's render settings unless the options below override them; the "
                        "format follows the file's extension (.png, .jpg, .exr, ...), else "
                        "the scene's")
    g.add_argument("--resolution", type=int, metavar="PX",
                   help=f"--render's longer side, {_range('--resolution')} (default: the "
                        "scene's resolution and percentage)")
    g.add_argument("--samples", type=int, metavar="S",
                   help=f"--render's Cycles samples, {_help_range('--samples')} (default: "
                        "the scene's)")
    g.add_argument("--device", choices=["cpu", "gpu"], type=str.lower,
                   help="--render's Cycles device (default: the scene's)")
    g.add_argument("--render-preview", choices=["objects", "surfels", "meshes", "points"],
                   default=None, type=str.lower,
                   help="what --render shows: the lit objects (default), or the solve's "
                        "surfels as discs (a diagnostic)")
    g.add_argument("--export-npz", metavar="FILE.npz", help="the surfels' data")
    g.add_argument("--export-exr", metavar="FILE.exr",
                   help="the surfels' illumination as a float EXR (one pixel per surfel)")
    g.add_argument("--export-lightmaps", metavar="PATTERN",
                   help="a UV-space EXR lightmap per mesh, from the light at its corners, "
                        "with {object} in the name (e.g. maps/{object}_####.exr)")
    g.add_argument("--skip-existing", action="store_true",
                   help="skip a frame whose outputs all exist (default: overwrite them, as "
                        "Blender does; lightmaps are not checked)")
    g.add_argument("--overwrite", action="store_true", help=argparse.SUPPRESS)  # the default
    g.add_argument("--overwrite-input", action="store_true",
                   help="allow an output path that is the input .blend itself")
    g = p.add_argument_group("messages")
    g.add_argument("--quiet", action="store_true",
                   help="print only warnings and errors (default: a line per phase)")
    g.add_argument("--verbose", action="store_true",
                   help="also print the progress of long phases in finer steps and the "
                        "worker thread count")
    return p


def frame_limits(scene=None) -> tuple[int, int]:
    """The frame numbers Blender can set (``Scene.frame_current``'s hard range: it clamps
    anything outside, which would compute one frame under many numbers)."""
    prop = bpy.types.Scene.bl_rna.properties["frame_current"]
    return int(prop.hard_min), int(prop.hard_max)


def parse_frames(text: str | None, current: int) -> list[int]:
    """'1-3,7' → [1, 2, 3, 7]; None → [current].

    The ranges are checked (Blender's frame range, at most ``MAX_FRAMES`` distinct frames)
    before any list of frames is built, so a typo such as 1-100000000 costs nothing."""
    if not text:
        return [current]
    low, high = frame_limits()
    ranges = []
    for part in text.split(","):
        m = re.fullmatch(r"\s*(-?\d{1,18})\s*(?:-\s*(-?\d{1,18})\s*)?", part)
        if not m:
            raise UsageError(f"bad frame range {part.strip()!r} in --frames "
                             "(use e.g. 1-3 or 1,5,7-9)")
        a = int(m.group(1))
        b = int(m.group(2)) if m.group(2) is not None else a
        if b < a:
            raise UsageError(f"bad frame range {part.strip()!r}: end before start")
        ranges.append((a, b))
    # Distinct frames of the union of the ranges, counted without listing them.
    count, reach = 0, None
    for a, b in sorted(ranges):
        if reach is not None and a <= reach:
            a = reach + 1
        if b >= a:
            count += b - a + 1
        reach = b if reach is None else max(reach, b)
        if count > MAX_FRAMES:
            raise UsageError(f"--frames {text.strip()!r} asks for more than {MAX_FRAMES:,} "
                             f"frames, the most one job computes: split the range over "
                             "several jobs")
    for a, b in ranges:
        if a < low or b > high:
            raise UsageError(f"frame range '{a}-{b}' lies outside Blender's frames "
                             f"{low}..{high}")
    return sorted({f for a, b in ranges for f in range(a, b + 1)})


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


def make_settings(args) -> pipeline.Settings:
    """Settings from the preset and the overriding options."""
    for option, name in NUMBER_OPTIONS.items():   # NaN fails too
        value = getattr(args, option[2:].replace("-", "_"), None) \
            if option not in SETTING_OPTIONS else getattr(args, name)
        if value is not None and not limit(name).contains(value):
            raise UsageError(f"{option} must lie in {_range(option)}, got {value}")
    if args.render_preview in ("meshes", "objects") and args.transfer is False:
        raise UsageError(f"--render-preview {args.render_preview} shows the light transferred "
                         "to the meshes: it cannot be combined with --no-transfer")
    if args.quiet and args.verbose:
        raise UsageError("--quiet and --verbose exclude each other")
    if args.export_lightmaps and args.transfer is False:
        raise UsageError("--export-lightmaps is made from the light at the meshes' corners: "
                         "it cannot be combined with --no-transfer")
    if args.transfer_domain and args.transfer is False:
        raise UsageError("--transfer and --no-transfer exclude each other")
    if args.target_error is not None and args.density is not None:
        raise UsageError("--density and --target-error exclude each other: the target error "
                         "chooses the density (use --budget to cap the surfel count)")
    overrides = {spec.name: getattr(args, spec.name) for spec in SETTING_OPTIONS.values()}
    if args.transfer_domain is not None:
        overrides["transfer_domain"] = setting_spec("transfer_domain").canonical(
            args.transfer_domain)
    settings = pipeline.settings_from_preset(args.quality, **overrides)
    if args.target_error is not None and args.budget is None:
        settings.budget = None          # the target chooses the count; --budget caps it
    settings.preview_splats = bool(args.render) and preview_kind(args) == "objects"
    return settings


def preview_kind(args) -> str:
    """What ``--render`` shows and the saved file opens with: "objects" (the Object Preview
    on the lit objects, the default) or "surfels" (the solve's discs; the default where
    --no-transfer leaves the objects without light)."""
    kind = {"meshes": "objects", "points": "surfels"}.get(args.render_preview,
                                                            args.render_preview)
    if kind is None:
        kind = "surfels" if args.transfer is False else "objects"
    return kind
