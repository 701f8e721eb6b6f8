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
VISIBILITY_ITEMS = [
    ("NONE", "None", "No occlusion: every facing pair exchanges light"),
    ("SEED", "Nearby Surfels", "Occlusion estimated from surfels near each segment (the talk's method)"),
    ("EXACT", "Exact", "Occlusion by ray casting against the surfels as discs"),
]
OCCLUDER_SHAPE_ITEMS = [
    ("DISC", "Disc", "Each surfel occludes as a disc (what the automatic mode is calibrated on)"),
    ("OCTAGON", "Octagon", "Regular octagons of the discs' area: nearly the same shadows, "
                           "faster rays"),
    ("QUAD", "Square", "Squares of the discs' area: the fastest rays; corners reach 1.25× the "
                       "disc radius, so edges shadow a little more"),
]
SOLVER_ITEMS = [
    ("AUTO", "Auto", "Conjugate gradients when the operator is symmetric, GMRES otherwise"),
    ("CG", "CG", "Conjugate gradients on the symmetrized system"),
    ("GMRES", "GMRES", "GMRES, for non-symmetric operators"),
    ("JACOBI", "Jacobi", "Plain fixed-point iteration (slow, for comparison)"),
]
NEAR_FIELD_ITEMS = [
    ("DISC", "Disc", "Bounded point-to-disc rule for close pairs"),
    ("POINT", "Point", "Bare point kernel (diverges for close pairs; for comparison)"),
]
METHOD_ITEMS = [
    ("FMM", "Multipole", "Fast Multipole Method: O(N) per iteration"),
    ("DIRECT", "Direct", "Exact O(N²) sum: a reference for small scenes"),
]
SAMPLING_ITEMS = [
    ("DENSITY", "Density", "Surfels per square metre of surface"),
    ("BUDGET", "Budget", "A total number of surfels, spread by area"),
]
DOMAIN_ITEMS = [
    ("POINT", "Vertex", "Transfer to mesh vertices"),
    ("CORNER", "Face Corner", "Transfer to face corners (no blending across hard edges)"),
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
    sampling: EnumProperty(name="Sampling", items=SAMPLING_ITEMS, default="BUDGET",
                           update=_field_update)
    density: FloatProperty(name="Density", description="Surfels per square metre",
                           default=_DEFAULTS["density"], **field_bounds("density"),
                           update=_field_update)
    budget: IntProperty(name="Budget", default=_DEFAULTS["budget"], **field_bounds("budget"),
                        update=_field_update,
                        description="Surfels over all meshes (front faces; open surfaces add "
                                    "their back faces where these see anything): the same "
                                    "count whatever the scene's scale")
    seed: IntProperty(name="Seed", description="Sampling seed (results are reproducible)",
                      default=0, **field_bounds("seed"), update=_field_update)
    use_target_error: BoolProperty(
        name="Target Error", default=False, update=_field_update,
        description="Choose the surfel count, FMM order, opening angle and tolerance from "
                    "a target error instead of the sampling and solver settings")
    target_error: FloatProperty(
        name="Error", default=0.05, **field_bounds("target_error"), precision=3,
        update=_field_update,
        description="Relative RMS error wanted in the light at the meshes (0.05 = 5%); chooses "
                    "the surfels, their solver settings and the rays per vertex")
    adaptive: BoolProperty(
        name="Adaptive Density", default=True, update=_field_update,
        description="With a target error: solve once with half the surfels, then resample "
                    "denser where that illumination varies (shadow edges, near lights, corners) "
                    "and solve again with the same total count")
    # Solver
    method: EnumProperty(name="Method", items=METHOD_ITEMS, default="FMM", update=_field_update)
    order: IntProperty(name="FMM Order", description="Expansion order p of the multipole method",
                       default=_DEFAULTS["order"], **field_bounds("order"), update=_field_update)
    theta: FloatProperty(name="Opening Angle", description="Separation ratio for the far field",
                         default=_DEFAULTS["theta"], **field_bounds("theta"), update=_field_update)
    leaf_size: IntProperty(name="Leaf Size", description="Surfels per octree leaf", default=32,
                           **field_bounds("leaf_size"), update=_field_update)
    visibility: EnumProperty(name="Visibility", items=VISIBILITY_ITEMS,
                             default=_DEFAULTS["visibility"], update=_field_update)
    occluder_shape: EnumProperty(
        name="Occluder Shape", items=OCCLUDER_SHAPE_ITEMS, default="DISC", update=_field_update,
        description="How each surfel blocks light, for exact visibility and lamp shadows "
                    "(with a target error: discs)")
    tol: FloatProperty(name="Tolerance", description="Relative residual at which to stop",
                       default=_DEFAULTS["tol"], **field_bounds("tol"),
                       precision=6, update=_field_update)
    max_iterations: IntProperty(name="Max Iterations", default=200,
                                **field_bounds("max_iterations"), update=_field_update)
    solver: EnumProperty(name="Solver", items=SOLVER_ITEMS, default="AUTO", update=_field_update)
    near_field: EnumProperty(name="Near Field", items=NEAR_FIELD_ITEMS, default="DISC",
                             update=_field_update)
    # Light
    lamps: BoolProperty(name="Lamps", description="Add Blender lamps as direct light",
                        default=True, update=_field_update)
    lamp_shadows: BoolProperty(
        name="Lamp Shadows", default=True, update=_field_update,
        description="Shadow lamp light by casting rays from every surfel to samples on each "
                    "lamp, against the surfels themselves")
    shadow_samples: IntProperty(
        name="Shadow Samples", default=16, **field_bounds("shadow_samples"), update=_field_update,
        description="Rays per surfel for lamps with a size (radius, area, sun angle): more "
                    "give smoother penumbrae; cost grows in proportion")
    world_ambient: BoolProperty(
        name="World Light", default=True, update=_field_update,
        description="Light from the world's Background (a colour, or an environment image's "
                    "mean), shadowed by the scene as Cycles does; a black world adds nothing")
    gather_rays: IntProperty(
        name="Gather Rays", default=_DEFAULTS["gather_rays"], **field_bounds("gather_rays"),
        update=_field_update,
        description="Rays per mesh vertex or corner that gather the light reflected by the "
                    "scene: more give smoother indirect light; cost grows in proportion")
    gather_cache: FloatProperty(
        name="Gather Cache", default=_DEFAULTS["gather_cache"], **field_bounds("gather_cache"),
        update=_field_update,
        description="A point cloud's points share their final gathers through an irradiance "
                    "cache of this accuracy (Ward's a): smaller gathers at more points; 0: every "
                    "point gathers itself")
    receiver_shadow_samples: IntProperty(
        name="Receiver Shadow Samples", default=_DEFAULTS["receiver_shadow_samples"],
        **field_bounds("receiver_shadow_samples"), update=_field_update,
        description="Shadow rays per mesh vertex or corner for each lamp or light-emitting "
                    "object with a size: more give smoother penumbrae")
    # Output
    transfer: BoolProperty(name="Transfer to Meshes",
                           description="Evaluate the illumination at the source meshes' own "
                                       "vertices or corners and write it there",
                           default=True, update=_field_update)
    transfer_domain: EnumProperty(name="Domain", items=DOMAIN_ITEMS, default="CORNER",
                                  update=_field_update)
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
                               update=_touch)
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
                    "near_field", "lamps",
                    "lamp_shadows", "shadow_samples", "world_ambient", "transfer",
                    "transfer_domain", "target_error", "adaptive", "gather_rays",
                    "gather_cache", "receiver_shadow_samples")
_LOWER_ENUMS = ("visibility", "occluder_shape", "solver", "near_field", "method")
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
