"""Scene settings (``scene.illumap``) and the last run's statistics.

Quality presets map to the solver knobs through one table, ``presets.QUALITY_PRESETS``.
Choosing a preset copies its values into the advanced settings, so the user sees what the
preset means; editing an advanced setting switches the preset to "Custom". The operator always reads the advanced
settings (``settings_values``), so what is shown is what runs.
"""

import dataclasses
import math

import bpy
from bpy.props import (BoolProperty, CollectionProperty, EnumProperty, FloatProperty,
                       IntProperty, PointerProperty, StringProperty)

from .presets import QUALITY_PRESETS
from .preview import DEFAULT_DISC_SCALE

#: The quality presets (``presets.QUALITY_PRESETS``) as property values: enum values in capitals.
PRESET_PROPERTY_VALUES = {name: {key: (value.upper() if key in ("visibility", "solver",
                                                                 "near_field", "method")
                                       else value)
                                 for key, value in values.items()}
                          for name, values in QUALITY_PRESETS.items()}
# Every field's min/max/soft_min/soft_max comes from the one table of limits
# (illumap.limits), which the core and the settings check use too. Without the core the
# reduced UI cannot compute, and its fields have no bounds to show.
try:
    from illumap.limits import limit as _limit
except Exception:  # pragma: no cover - the reduced UI
    _limit = None


def field_bounds(name: str) -> dict:
    """The property keywords of the limit ``name`` (``illumap.limits.Limit.ui``)."""
    return _limit(name).ui() if _limit is not None else {}


DEFAULT_PRESET = "MEDIUM"
#: The fields' defaults: the default preset's values, and the two fields no preset sets.
_DEFAULTS = dict(density=100.0, gather_cache=0.15, **PRESET_PROPERTY_VALUES[DEFAULT_PRESET])

PRESET_ITEMS = [
    ("DRAFT", "Draft", "Few surfels, low FMM order, loose tolerance: quick look"),
    ("MEDIUM", "Medium", "Balanced density, FMM order and tolerance"),
    ("HIGH", "High", "Dense surfels, high FMM order, tight tolerance"),
    ("CUSTOM", "Custom", "Use the advanced settings as set"),
]
# Comparison-only modes (no occlusion, Jacobi iteration, the bare point kernel) are not
# offered here: they stay in the Python API (``pipeline.Settings``).
VISIBILITY_ITEMS = [
    ("SEED", "Estimated (nearby surfels)",
     "Shadows between surfaces estimated from the surfels near each path: faster, but light "
     "can leak through thin walls and under objects"),
    ("EXACT", "Exact (rays)",
     "Shadows between surfaces by rays against the objects' own triangles (and point clouds' "
     "points): no leaks; costs rays, most in large open scenes"),
]
OCCLUDER_SHAPE_ITEMS = [
    ("DISC", "Disc", "Each point blocks light as a round disc (what Target Error is "
                     "calibrated on)"),
    ("OCTAGON", "Octagon", "Octagons of the same area: nearly the same shadows, faster rays"),
    ("QUAD", "Square", "Squares of the same area: the fastest rays; corners reach a little "
                       "further, so edges shadow a little more"),
]
SOLVER_ITEMS = [
    ("AUTO", "Automatic", "Picks the fastest of the two below for the scene (same picture)"),
    ("CG", "Conjugate Gradients", "For scenes where light is exchanged symmetrically"),
    ("GMRES", "GMRES", "Works for every scene; a little more memory"),
]
METHOD_ITEMS = [
    ("FMM", "Fast (multipole)", "Groups far surfaces together (Fast Multipole Method): time "
                                "grows in proportion to the surfels"),
    ("DIRECT", "Exact (every pair)", "Every pair of surfels exactly: a reference for small "
                                     "scenes; time grows with the square of the surfels"),
]
SAMPLING_ITEMS = [
    ("DENSITY", "Per Square Metre", "A number of surfels per square metre of surface"),
    ("BUDGET", "Total Count", "A total number of surfels, spread by area"),
]
DOMAIN_ITEMS = [
    ("POINT", "Vertex", "One value per vertex: smooth across edges"),
    ("CORNER", "Face Corner", "One value per face corner: hard edges and creases keep their "
                              "light apart"),
]
PREVIEW_MODE_ITEMS = [
    ("ILLUMINATION", "Illumination", "Discs emit the computed outgoing radiance"),
    ("ALBEDO_IRRADIANCE", "Albedo x Irradiance", "Discs emit the reflected light only"),
]

# Guard: while a preset is being applied, field updates must not switch the preset to Custom.
_applying_preset = False


def apply_preset(props, preset):
    """Copy the table values of ``preset`` into ``props`` (no-op for "CUSTOM")."""
    global _applying_preset
    values = PRESET_PROPERTY_VALUES.get(preset)
    if values is None:
        return
    _applying_preset = True
    try:
        for key, value in values.items():
            if value is not None and hasattr(props, key):
                setattr(props, key, value)
        props.sampling = "BUDGET"
    finally:
        _applying_preset = False


def _preset_update(self, _context):
    self.initialized = True
    apply_preset(self, self.preset)


def _same(a, b):
    # Float properties are stored in single precision: 1e-3 reads back as 0.0010000000475.
    if isinstance(b, float):
        return math.isclose(a, b, rel_tol=1e-6)
    return a == b


def _touch(self, _context):
    self.initialized = True


def _field_update(self, _context):
    if _applying_preset:
        return
    self.initialized = True
    if self.preset != "CUSTOM":
        values = PRESET_PROPERTY_VALUES.get(self.preset, {})
        if any(not _same(getattr(self, k), v) for k, v in values.items()
               if v is not None and hasattr(self, k)) \
                or self.sampling != "BUDGET":
            self.preset = "CUSTOM"


class IllumapPhaseTime(bpy.types.PropertyGroup):
    # ``name`` (inherited) is the phase.
    seconds: FloatProperty(name="Seconds", default=0.0, precision=3)


class IllumapStats(bpy.types.PropertyGroup):
    """What the last run of Compute Illumination Map reported (read-only in the UI)."""

    valid: BoolProperty(name="Has Result", default=False)
    surfels: IntProperty(name="Surfels", default=0)
    iterations: IntProperty(name="Iterations", default=0)
    residual: FloatProperty(name="Final Residual", default=0.0, precision=6)
    converged: BoolProperty(name="Converged", default=False)
    total_seconds: FloatProperty(name="Total Time", default=0.0, precision=3)
    phases: CollectionProperty(type=IllumapPhaseTime)
    summary: StringProperty(name="Summary", default="")
    density: FloatProperty(name="Density", default=0.0, precision=1,
                           description="Surfels per m² chosen for the target error (0: none)")
    predicted_error: FloatProperty(name="Predicted Discretization Error", default=0.0,
                                   precision=4)
    first_pass_surfels: IntProperty(name="Pass 1 Surfels", default=0,
                                    description="Surfels of the adaptive first pass (0: one pass)")
    first_pass_iterations: IntProperty(name="Pass 1 Iterations", default=0)
    shadow_rays: IntProperty(name="Shadow Rays", default=0)
    occluder_shape: StringProperty(name="Occluder Shape", default="",
                                   description="The surfels' shape as occluders ('': none)")
    chosen_settings: StringProperty(
        name="Chosen Settings", default="",
        description="Solver settings the error model chose for the target error ('': none)")
    estimated_error: FloatProperty(
        name="Estimated Error", default=0.0, precision=4,
        description="A-posteriori estimate of the surfels' relative RMS error (0: none)")
    estimated_error_at_objects: FloatProperty(
        name="Estimated Error at the Objects", default=0.0, precision=4,
        description="What the surfels' estimated error and the gather's noise make of the "
                    "relative RMS error of the light written to the objects (0: none)")

    def clear(self):
        self.valid = False
        self.surfels = 0
        self.iterations = 0
        self.residual = 0.0
        self.converged = False
        self.total_seconds = 0.0
        self.phases.clear()
        self.summary = ""
        self.density = 0.0
        self.predicted_error = 0.0
        self.first_pass_surfels = 0
        self.first_pass_iterations = 0
        self.shadow_rays = 0
        self.occluder_shape = ""
        self.chosen_settings = ""
        self.estimated_error = 0.0
        self.estimated_error_at_objects = 0.0


class IllumapSettings(bpy.types.PropertyGroup):
    initialized: BoolProperty(
        name="Initialized", default=False, options={"HIDDEN"},
        description="Set once the settings were taken from the add-on preferences or edited")
    preset: EnumProperty(name="Quality", items=PRESET_ITEMS, default=DEFAULT_PRESET,
                         update=_preset_update)

    # Sampling
    sampling: EnumProperty(name="Surfels Set By", items=SAMPLING_ITEMS,
                           description="How the number of surfels (the small discs the light "
                                       "is solved on) is chosen", default="BUDGET",
                           update=_field_update)
    density: FloatProperty(name="Surfels per m²",
                           description="More surfels: finer bounced light and contact shadows; "
                                       "the solve's time grows about in proportion",
                           default=_DEFAULTS["density"], **field_bounds("density"),
                           update=_field_update)
    budget: IntProperty(name="Surfel Count", default=_DEFAULTS["budget"], **field_bounds("budget"),
                        update=_field_update,
                        description="Surfels over all objects, whatever the scene's scale: "
                                    "more give finer bounced light and contact shadows; the "
                                    "solve's time grows about in proportion")
    seed: IntProperty(name="Random Seed",
                      description="Another seed places the surfels differently (another noise "
                                  "pattern, the same light on average); no cost. The same seed "
                                  "gives the same picture every time",
                      default=0, **field_bounds("seed"), update=_field_update)
    use_target_error: BoolProperty(
        name="Target Error", default=False, update=_field_update,
        description="Ask for an accuracy instead of a preset: Illumap chooses the surfels, "
                    "the solver settings and the rays for it. Smaller errors take longer "
                    "(roughly 3-4× per halving)")
    target_error: FloatProperty(
        name="Error", default=0.05, **field_bounds("target_error"), precision=3,
        update=_field_update,
        description="Relative RMS error wanted in the light at the meshes (0.05 = 5%); chooses "
                    "the surfels, their solver settings and the rays per vertex")
    adaptive: BoolProperty(
        name="Refine Where Light Changes", default=True, update=_field_update,
        description="With a target error: solve once with half the surfels, then resample "
                    "denser where that illumination varies (shadow edges, near lights, corners) "
                    "and solve again with the same total count")
    # Solver
    method: EnumProperty(name="Light Exchange", items=METHOD_ITEMS, default="FMM",
                         update=_field_update,
                         description="How the light every surfel sends to every other is added "
                                     "up")
    order: IntProperty(name="Far Light Accuracy (order)",
                       description="Fast mode: how finely light from distant surfaces is "
                                   "summed up (the multipole order). Higher is more accurate "
                                   "and slower (each step adds about a third to the solve)",
                       default=_DEFAULTS["order"], **field_bounds("order"), update=_field_update)
    theta: FloatProperty(name="Far Light Distance (angle)",
                         description="Fast mode: how far a group of surfaces must be before its "
                                     "light is summed up as a group (the opening angle). Smaller "
                                     "is more accurate and slower",
                         default=_DEFAULTS["theta"], **field_bounds("theta"), update=_field_update)
    leaf_size: IntProperty(name="Surfels per Group",
                           description="Fast mode: surfels handled together (the octree's leaf "
                                       "size). Changes the speed, not the picture", default=32,
                           **field_bounds("leaf_size"), update=_field_update)
    visibility: EnumProperty(name="Shadows Between Surfaces", items=VISIBILITY_ITEMS,
                             description="How the bounced light between surfaces is shadowed",
                             default=_DEFAULTS["visibility"], update=_field_update)
    occluder_shape: EnumProperty(
        name="Point Cloud Blockers", items=OCCLUDER_SHAPE_ITEMS, default="DISC",
        update=_field_update,
        description="Point clouds: the shape each point blocks light with, for shadows "
                    "(meshes block with their own faces; with Target Error: discs)")
    tol: FloatProperty(name="Solver Precision",
                       description="When the bounced light counts as settled (the solver's "
                                   "relative residual). Smaller is more exact; each 10× smaller "
                                   "costs a few more solver steps",
                       default=_DEFAULTS["tol"], **field_bounds("tol"),
                       precision=6, update=_field_update)
    max_iterations: IntProperty(name="Most Solver Steps", default=200,
                                description="The solve stops here even if not settled (a "
                                            "warning says so)",
                                **field_bounds("max_iterations"), update=_field_update)
    solver: EnumProperty(name="Solver Method", items=SOLVER_ITEMS, default="AUTO",
                         update=_field_update,
                         description="The method that settles the bounced light: the same "
                                     "picture, a different time")
    # Light
    lamps: BoolProperty(name="Lamps", description="Light from Blender's lamps (point, spot, "
                                                  "sun, area). Off: emissive objects and the "
                                                  "world only",
                        default=True, update=_field_update)
    lamp_shadows: BoolProperty(
        name="Lamp Shadows", default=True, update=_field_update,
        description="Lamps cast shadows: rays from every surfel toward each lamp, against the "
                    "objects' own faces (and point clouds' points). Off: faster, lamps light "
                    "through objects")
    shadow_samples: IntProperty(
        name="Soft Shadow Rays (bounce)", default=16, **field_bounds("shadow_samples"), update=_field_update,
        description="Rays per surfel toward each lamp with a size (radius, area, sun angle), "
                    "for the light that bounces: more give smoother soft shadows in the "
                    "bounced light; cost grows in proportion")
    world_ambient: BoolProperty(
        name="World Light", default=True, update=_field_update,
        description="Light from the world's Background (a colour, or an environment image's "
                    "mean), shadowed by the scene as Cycles does; a black world adds nothing")
    gather_rays: IntProperty(
        name="Bounced Light Rays", default=_DEFAULTS["gather_rays"], **field_bounds("gather_rays"),
        update=_field_update,
        description="Rays per corner (or point) that collect the light bounced by the scene: "
                    "more give smoother, less blotchy bounced light; time grows in proportion")
    gather_cache: FloatProperty(
        name="Point Cloud Light Sharing", default=_DEFAULTS["gather_cache"],
        **field_bounds("gather_cache"), update=_field_update,
        description="Point clouds: nearby points share the bounced light they collect (an "
                    "irradiance cache of this accuracy). Smaller: sharper bounced light, "
                    "slower; 0: every point collects its own (slowest)")
    receiver_shadow_samples: IntProperty(
        name="Soft Shadow Rays (objects)", default=_DEFAULTS["receiver_shadow_samples"],
        **field_bounds("receiver_shadow_samples"), update=_field_update,
        description="Rays per corner (or point) toward each lamp or glowing object with a "
                    "size: more give smoother soft shadows on your objects; time grows in "
                    "proportion")
    # Output
    transfer: BoolProperty(name="Write to Objects",
                           description="Evaluate the light at the objects' own corners (points "
                                       "of point clouds) and write it there as the colour "
                                       "attribute 'illumination'. Off: the light stays on the "
                                       "surfel object only",
                           default=True, update=_field_update)
    transfer_domain: EnumProperty(name="Store Per", items=DOMAIN_ITEMS, default="CORNER",
                                  update=_field_update,
                                  description="Where the attribute holds its values")
    # Preview
    build_preview: BoolProperty(
        name="Preview After Compute", default=True, update=_touch,
        description="After Compute, show the light on the computed objects themselves (Object "
                    "Preview): meshes through their 'illumination' attribute, scans as a splat "
                    "in each point's tangent plane. Renders (F12) show it too; Off in the "
                    "Preview panel gives the objects back as they were")
    show_surfels: BoolProperty(
        name="Show Surfels", default=False, update=_touch,
        description="Diagnostic: after Compute, also show the solve's surfels as discs (the "
                    "'Illumap Surfels' object). Off, that object stays hidden in the viewport "
                    "and in renders")
    preview_mode: EnumProperty(name="Shading", items=PREVIEW_MODE_ITEMS, default="ILLUMINATION",
                               update=_touch,
                               description="What the surfels' discs show (a diagnostic): all "
                                           "their light, or the light they reflect")
    disc_scale: FloatProperty(name="Disc Scale",
                              description="Disc radius relative to the surfel's own radius "
                                          "(1: each disc has exactly its surfel's area; larger "
                                          "values close the gaps between discs)",
                              default=DEFAULT_DISC_SCALE, **field_bounds("disc_scale"),
                              update=_touch)

    stats: PointerProperty(type=IllumapStats)


# Names of the scene settings and the lower-case spelling the core uses for enum values.
_SETTINGS_FIELDS = ("density", "budget", "seed", "method", "order", "theta", "leaf_size",
                    "visibility", "occluder_shape", "tol", "max_iterations", "solver",
                    "lamps",
                    "lamp_shadows", "shadow_samples", "world_ambient", "transfer",
                    "transfer_domain", "target_error", "adaptive", "gather_rays",
                    "gather_cache", "receiver_shadow_samples")
_LOWER_ENUMS = ("visibility", "occluder_shape", "solver", "method")
# Alternative field names a Settings dataclass may use for the same knob.
_ALIASES = {
    "world_ambient": ("world_ambient", "world", "ambient", "use_world"),
    "lamps": ("lamps", "use_lamps"),
    "transfer": ("transfer", "transfer_to_meshes"),
    "transfer_domain": ("transfer_domain", "domain"),
    "tol": ("tol", "tolerance"),
    "order": ("order", "fmm_order"),
}


def settings_values(props):
    """The scene settings as a plain dict with the core's spelling (lower-case enums)."""
    values = {name: getattr(props, name) for name in _SETTINGS_FIELDS}
    for name in _LOWER_ENUMS:
        values[name] = values[name].lower()
    if props.use_target_error:
        # The target chooses the count; the budget field (a preset's count) would cap it.
        values["budget"] = values["density"] = None
    elif props.sampling == "DENSITY":
        values["budget"] = None
    else:
        values["density"] = None
    values["target_error"] = float(props.target_error) if props.use_target_error else None
    return values


def make_settings(props, settings_cls):
    """Build ``settings_cls`` (the pipeline's Settings dataclass) from the scene settings.

    Only fields the dataclass declares are passed, so a knob the pipeline does not have yet is
    left at its default instead of failing.
    """
    values = settings_values(props)
    if not dataclasses.is_dataclass(settings_cls):
        return settings_cls(**values)
    fields = {f.name for f in dataclasses.fields(settings_cls) if f.init}
    kwargs = {}
    for name, value in values.items():
        for alias in _ALIASES.get(name, (name,)):
            if alias in fields:
                kwargs[alias] = value
                break
    if kwargs.get("budget", 0) is None and "budget" in fields:
        # Keep the dataclass default for "no budget" rather than imposing None.
        del kwargs["budget"]
    if kwargs.get("density", 0) is None and "density" in fields:
        del kwargs["density"]
    return settings_cls(**kwargs)


classes = (IllumapPhaseTime, IllumapStats, IllumapSettings)
