"""The settings of one Illumap run, declared once.

Each field of :class:`Settings` carries everything every front end needs: its default, the
label and description an artist reads, its choices, its group and its command-line spelling.
Its range is the limit of the same name in :mod:`illumap.limits`. From this one declaration
come the add-on's scene properties (``addon/ui/properties.py``), the batch command's options
(``addon/batch.py``), the validation (:func:`check`) and the settings table of
``docs/limits.md`` (:func:`markdown`).

Pure Python: imports neither numpy, nor the native core, nor bpy, so the add-on's reduced UI
(the native module failed to load) still declares its properties from here.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field, fields
from typing import Any

from .limits import LIMITS, limit

__all__ = ["Choice", "Settings", "SettingsError", "QUALITY_PRESETS", "DEFAULT_BUDGET",
           "DEFAULT_PRESET", "GROUPS", "spec", "specs", "check", "from_preset", "markdown",
           "page"]

#: Surfels over all meshes when neither a density nor a budget is given: a count, not a
#: density, so a scene modelled in centimetres gets as many as one modelled in metres.
DEFAULT_BUDGET = 10_000

#: Preset name → settings values. Every preset casts shadows: speed never comes from leaving
#: out what the scene needs.
QUALITY_PRESETS: dict[str, dict] = {
    "DRAFT": dict(budget=2_500, order=3, theta=0.6, visibility="exact", tol=1e-3,
                  gather_rays=128, receiver_shadow_samples=32),
    "MEDIUM": dict(budget=DEFAULT_BUDGET, order=4, theta=0.5, visibility="exact", tol=1e-4,
                   gather_rays=512, receiver_shadow_samples=128),
    # The light at the meshes is limited by the gather and the surfel count, not by the
    # expansions: order 4 at 30k surfels reached 0.94% on the Cornell box in 4.5 s where
    # order 6, theta 0.4 at 40k took 11 s for 0.93% (bench/reference, 8192-sample reference).
    "HIGH": dict(budget=30_000, order=4, theta=0.5, visibility="exact", tol=1e-4,
                 gather_rays=2048, receiver_shadow_samples=512),
}
DEFAULT_PRESET = "MEDIUM"

#: The groups, in the order the panel and ``--help`` show them.
GROUPS = {"sampling": "Surfels", "solver": "Solver", "light": "Light",
          "output": "Output", "internal": "Internal"}


class SettingsError(ValueError):
    """A setting outside what a run accepts; the message names the setting."""


@dataclass(frozen=True)
class Choice:
    """One value of a setting with choices: ``value`` as a run spells it (the core's lower-case
    names; Blender's attribute domains in capitals). Every front end matches it in any case."""

    value: str
    label: str
    description: str
    offered: bool = True    # shown in the add-on's menus (False: Python API and batch only)


@dataclass(frozen=True)
class Spec:
    """What one setting is, for the front ends (the metadata of a :class:`Settings` field)."""

    name: str
    default: Any
    kind: type                  # bool, int, float or str
    label: str
    description: str
    group: str
    optional: bool = False      # None means "not set" (the run chooses)
    choices: tuple[Choice, ...] = ()
    ui: bool = True             # a scene property of the add-on
    ui_default: Any = None      # the property's default where the field's is None
    cli: str | None = ""        # the batch option ('' : --name-with-dashes, None: none)
    cli_negative: bool = False  # a bool whose option switches it off (--no-lamps)

    @property
    def limit(self):
        """The limit of the same name (``illumap.limits``), or None."""
        return _LIMITS.get(self.name)

    @property
    def option(self) -> str | None:
        """The batch option, e.g. ``--gather-rays``; None when the batch has none."""
        if self.cli is None:
            return None
        return self.cli or "--" + ("no-" if self.cli_negative else "") + \
            self.name.replace("_", "-")

    @property
    def values(self) -> tuple[str, ...]:
        """The accepted values of a setting with choices."""
        return tuple(c.value for c in self.choices)

    def canonical(self, value: str) -> str:
        """``value`` (any case) as the run spells it; ValueError when it is not a choice."""
        for c in self.choices:
            if isinstance(value, str) and value.lower() == c.value.lower():
                return c.value
        raise ValueError(f"{self.name}: expected one of "
                         f"{', '.join(v.lower() for v in self.values)}, got {value!r}")

    @property
    def preset(self) -> bool:
        """Whether the quality presets set it."""
        return self.name in QUALITY_PRESETS[DEFAULT_PRESET]

    @property
    def property_default(self):
        """The add-on property's default: the default preset's value, else ``ui_default``,
        else the field's own default."""
        if self.preset:
            return QUALITY_PRESETS[DEFAULT_PRESET][self.name]
        return self.default if self.ui_default is None else self.ui_default


_LIMITS = {lim.name: lim for lim in LIMITS}


def _setting(default, kind: type, label: str, description: str, group: str, **extra):
    return field(default=default, metadata={"spec": dict(default=default, kind=kind, label=label,
                                                         description=description, group=group,
                                                         **extra)})


@dataclass
class Settings:
    """The quality knobs and options of one run (units in each description)."""

    # --- surfels ------------------------------------------------------------------------------
    density: float | None = _setting(
        None, float, "Surfels per m²", "More surfels: finer bounced light and contact shadows; "
        "the solve's time grows about in proportion", "sampling", optional=True,
        ui_default=100.0)
    budget: int | None = _setting(
        None, int, "Surfel Count", "Surfels over all objects, whatever the scene's scale: more "
        "give finer bounced light and contact shadows; the solve's time grows about in "
        "proportion. Overrides the density; neither set: the default preset's count",
        "sampling", optional=True)
    seed: int = _setting(
        0, int, "Random Seed", "Another seed places the surfels differently (another noise "
        "pattern, the same light on average); no cost. The same seed gives the same picture "
        "every time", "sampling")
    target_error: float | None = _setting(
        None, float, "Error", "Relative RMS error wanted in the light at the meshes (0.05 = 5%): "
        "chooses the surfels, their solver settings and the rays per vertex", "sampling",
        optional=True, ui_default=0.05)
    adaptive: bool = _setting(
        True, bool, "Refine Where Light Changes", "With a target error: solve once with half "
        "the surfels, then resample denser where that illumination varies (shadow edges, near "
        "lights, corners) and solve again with the same total count", "sampling",
        cli_negative=True)
    adaptive_first_pass: float = _setting(
        0.5, float, "First Pass Share", "With a target error: the first pass's surfels as a "
        "share of the final count", "internal", ui=False, cli=None)
    adaptive_max_ratio: float = _setting(
        4.0, float, "Largest Refinement", "With a target error: the largest density multiplier "
        "of the second pass", "internal", ui=False, cli=None)
    # --- solver -------------------------------------------------------------------------------
    method: str = _setting(
        "fmm", str, "Light Exchange", "How the light every surfel sends to every other is "
        "added up", "solver", choices=(
            Choice("fmm", "Fast (multipole)", "Groups far surfaces together (Fast Multipole "
                   "Method): time grows in proportion to the surfels"),
            Choice("direct", "Exact (every pair)", "Every pair of surfels exactly: a reference "
                   "for small scenes; time grows with the square of the surfels")))
    order: int = _setting(
        4, int, "Far Light Accuracy (order)", "Fast mode: how finely light from distant "
        "surfaces is summed up (the multipole order). Higher is more accurate and slower "
        "(each step adds about a third to the solve)", "solver")
    theta: float = _setting(
        0.5, float, "Far Light Distance (angle)", "Fast mode: how far a group of surfaces must "
        "be before its light is summed up as a group (the opening angle). Smaller is more "
        "accurate and slower", "solver")
    leaf_size: int = _setting(
        32, int, "Surfels per Group", "Fast mode: surfels handled together (the octree's leaf "
        "size). Changes the speed, not the picture", "solver")
    near_field: str = _setting(
        "disc", str, "Near Light", "How light between neighbouring surfels is integrated",
        "internal", ui=False, cli=None, choices=(
            Choice("disc", "Disc", "Each surfel as the disc it stands for"),
            Choice("point", "Point", "The bare point kernel (a comparison)")))
    visibility: str = _setting(
        "exact", str, "Shadows Between Surfaces", "How the bounced light between surfaces is "
        "shadowed", "solver", choices=(
            Choice("seed", "Estimated (nearby surfels)", "Shadows between surfaces estimated "
                   "from the surfels near each path: faster, but light can leak through thin "
                   "walls and under objects"),
            Choice("exact", "Exact (rays)", "Shadows between surfaces by rays against the "
                   "objects' own triangles (and point clouds' points): no leaks; costs rays, "
                   "most in large open scenes"),
            Choice("none", "None", "No shadows between surfaces (a comparison)", offered=False)))
    # Each shape has the disc's area: octagons are nearly the disc (solves with exact
    # visibility on the bunny scan took 0.55-0.74x the discs' time), squares about as fast
    # with corners at 1.25x the disc radius. illumap.occluders spells the same shapes.
    occluder_shape: str = _setting(
        "disc", str, "Point Cloud Blockers", "Point clouds: the shape each point blocks light "
        "with, for shadows (meshes block with their own faces; with a target error: discs)",
        "solver", choices=(
            Choice("disc", "Disc", "Each point blocks light as a round disc (what the target "
                   "error is calibrated on)"),
            Choice("octagon", "Octagon", "Octagons of the same area: nearly the same shadows, "
                   "faster rays"),
            Choice("quad", "Square", "Squares of the same area: the fastest rays; corners reach "
                   "a little further, so edges shadow a little more")))
    solver: str = _setting(
        "auto", str, "Solver Method", "The method that settles the bounced light: the same "
        "picture, a different time", "solver", choices=(
            Choice("auto", "Automatic", "Picks the fastest of the two below for the scene "
                   "(same picture)"),
            Choice("cg", "Conjugate Gradients", "For scenes where light is exchanged "
                   "symmetrically"),
            Choice("gmres", "GMRES", "Works for every scene; a little more memory"),
            Choice("jacobi", "Jacobi", "Plain iteration (a comparison)", offered=False)))
    tol: float = _setting(
        1e-4, float, "Solver Precision", "When the bounced light counts as settled (the "
        "solver's relative residual). Smaller is more exact; each 10× smaller costs a few more "
        "solver steps", "solver")
    max_iterations: int = _setting(
        200, int, "Most Solver Steps", "The solve stops here even if not settled (a warning "
        "says so)", "solver")
    memory_limit: int | None = _setting(
        None, int, "Memory Limit", "Bytes a run may plan to use (None: half the physical "
        "memory)", "internal", optional=True, ui=False, cli=None)
    # --- light --------------------------------------------------------------------------------
    lamps: bool = _setting(
        True, bool, "Lamps", "Light from Blender's lamps (point, spot, sun, area). Off: "
        "emissive objects and the world only", "light", cli_negative=True)
    lamp_shadows: bool = _setting(
        True, bool, "Lamp Shadows", "Lamps cast shadows: rays from every surfel toward each "
        "lamp, against the objects' own faces (and point clouds' points). Off: faster, lamps "
        "light through objects", "light", cli_negative=True)
    shadow_samples: int = _setting(
        16, int, "Soft Shadow Rays (bounce)", "Rays per surfel toward each lamp with a size "
        "(radius, area, sun angle), for the light that bounces: more give smoother soft "
        "shadows in the bounced light; cost grows in proportion", "light")
    world_ambient: bool = _setting(
        True, bool, "World Light", "Light from the world's Background (a colour, or an "
        "environment image's mean), shadowed by the scene as Cycles does; a black world adds "
        "nothing", "light", cli="--world")
    gather_rays: int = _setting(
        512, int, "Bounced Light Rays", "Rays per corner (or point) that collect the light "
        "bounced by the scene: more give smoother, less blotchy bounced light; time grows in "
        "proportion", "light")
    gather_cache: float = _setting(
        0.15, float, "Point Cloud Light Sharing", "Point clouds: nearby points share the "
        "bounced light they collect (an irradiance cache of this accuracy). Smaller: sharper "
        "bounced light, slower; 0: every point collects its own (slowest)", "light")
    receiver_shadow_samples: int = _setting(
        128, int, "Soft Shadow Rays (objects)", "Rays per corner (or point) toward each lamp "
        "or glowing object with a size: more give smoother soft shadows on your objects; time "
        "grows in proportion", "light")
    # --- output -------------------------------------------------------------------------------
    transfer: bool = _setting(
        True, bool, "Write to Objects", "Evaluate the light at the objects' own corners "
        "(points of point clouds) and write it there as the colour attribute 'illumination'. "
        "Off: the light stays on the surfel object only", "output", cli_negative=True)
    transfer_domain: str = _setting(
        "CORNER", str, "Store Per", "Where the attribute holds its values", "output",
        cli="--transfer", choices=(
            Choice("POINT", "Vertex", "One value per vertex: smooth across edges"),
            Choice("CORNER", "Face Corner", "One value per face corner: hard edges and creases "
                   "keep their light apart")))
    preview_splats: bool = _setting(
        False, bool, "Preview Splats", "Also compute the scans' preview splats on the worker",
        "internal", ui=False, cli=None)
    # The batch command declares its file outputs itself: they take frame numbers ('#').
    export_npz: str = _setting("", str, "Surfel Data", "Path for the surfels' data (.npz); "
                               "'': none", "output", ui=False, cli=None)
    export_exr: str = _setting("", str, "Surfel EXR", "Path for the surfels' illumination as "
                               "a float EXR; '': none", "output", ui=False, cli=None)
    export_lightmaps: str = _setting(
        "", str, "Lightmaps", "Path pattern with {object}: a UV-space EXR lightmap per mesh; "
        "'': none", "output", ui=False, cli=None)
    lightmap_size: int = _setting(256, int, "Lightmap Size", "Lightmap width and height "
                                  "(pixels)", "output", ui=False)


def specs() -> tuple[Spec, ...]:
    """Every setting's :class:`Spec`, in declaration order."""
    return _SPECS


def spec(name: str) -> Spec:
    """The :class:`Spec` of setting ``name``; KeyError for an unknown name."""
    return _BY_NAME[name]


_SPECS = tuple(Spec(name=f.name, **f.metadata["spec"]) for f in fields(Settings))
_BY_NAME = {s.name: s for s in _SPECS}


def check(settings: Settings) -> None:
    """Refuse settings that a run would reject deep inside, or with a raw type error (integers
    of 2^31 or more, NaN tolerances, an FMM order above the native limit). Raises
    :class:`SettingsError` naming the setting and what it accepts."""
    for s in _SPECS:
        value = getattr(settings, s.name)
        if value is None and s.optional:
            continue
        if s.choices:
            try:
                s.canonical(value)
            except ValueError as exc:
                raise SettingsError(f"Invalid setting {exc}") from None
        elif s.limit is not None and not s.limit.contains(value):
            raise SettingsError(f"Invalid setting {s.limit.message(value)}")


def from_preset(name: str, **overrides) -> Settings:
    """The settings of quality preset ``name`` (draft, medium or high, any case), with the
    keyword overrides that are not None. A density given without a budget replaces the
    preset's count. Raises :class:`SettingsError` for an unknown preset or setting."""
    key = name.upper()
    if key not in QUALITY_PRESETS:
        raise SettingsError(f"Unknown quality preset '{name}' (choose draft, medium or high)")
    unknown = sorted(set(overrides) - set(_BY_NAME))
    if unknown:
        raise SettingsError(f"Unknown setting {', '.join(unknown)}")
    values = dict(QUALITY_PRESETS[key])
    if overrides.get("density") is not None and overrides.get("budget") is None:
        values.pop("budget", None)
    values.update({k: v for k, v in overrides.items() if v is not None})
    return Settings(**values)


def replace(settings: Settings, **changes) -> Settings:
    """A copy of ``settings`` with ``changes``."""
    return dataclasses.replace(settings, **changes)


def page() -> str:
    """docs/limits.md: every limit (``illumap.limits.markdown``), then every setting
    (:func:`markdown`)."""
    from .limits import markdown as limits_markdown
    return (limits_markdown() + "\n## Settings\n\nEvery setting of a run, generated from its "
            "one declaration (`core/python/illumap/settings.py`), which also makes the add-on's "
            "fields, the batch command's options and the check every run passes. *accepts* is "
            "the range of the limit of the same name above.\n\n" + markdown())


def markdown() -> str:
    """The settings table of ``docs/limits.md``: each setting's label, batch option, default
    and range, by group."""
    lines = []
    for group, title in GROUPS.items():
        rows = [s for s in _SPECS if s.group == group]
        if not rows:
            continue
        lines += ["", f"### {title}", "", "| setting | in the panel | batch option | default "
                  "| accepts |", "|---|---|---|---|---|"]
        for s in rows:
            if s.choices:
                accepts = ", ".join(f"`{c.value}`" for c in s.choices)
            elif s.limit is not None:
                accepts = s.limit.interval() + (f" {s.limit.unit}" if s.limit.unit else "")
            else:
                accepts = s.kind.__name__
            default = "—" if s.default is None else f"`{s.default!r}`".replace("'", "")
            lines.append(f"| `{s.name}` | {s.label if s.ui else '—'} | "
                         f"{f'`{s.option}`' if s.option else '—'} | {default} | {accepts} |")
    return "\n".join(lines[1:]) + "\n"


def _check_the_table() -> None:
    """The declaration's own consistency, at import: presets name settings; every limit a
    setting names exists (a typo would silently drop a check)."""
    for preset in QUALITY_PRESETS.values():
        unknown = set(preset) - set(_BY_NAME)
        assert not unknown, f"presets name unknown settings {unknown}"
    for s in _SPECS:
        if s.kind in (int, float) and not s.choices:
            limit(s.name)   # KeyError for a number without a range


_check_the_table()
