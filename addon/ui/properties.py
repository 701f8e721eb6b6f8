"""Scene settings (``scene.illumap``) and the last run's statistics.

Every run setting's property is generated from its one declaration in ``illumap.settings``
(label, description, default, choices; the range from ``illumap.limits``). Quality presets
(``illumap.settings.QUALITY_PRESETS``) copy their values into the advanced settings, so the
user sees what a preset means; editing an advanced setting switches the preset to "Custom".
The operator always reads the advanced settings (``settings_values``), so what is shown is
what runs.
"""

import math

import bpy
from bpy.props import (BoolProperty, CollectionProperty, EnumProperty, FloatProperty,
                       IntProperty, PointerProperty, StringProperty)

from ..preview.surfel_preview import DEFAULT_DISC_SCALE

# The settings are declared once, in illumap.settings (pure Python: it imports without the
# native module); their ranges come from illumap.limits. Without the package at all (a wheel
# that Blender did not install) the reduced UI declares only what its panel shows.
try:
    from illumap.limits import limit as _limit
    from illumap.settings import DEFAULT_PRESET, QUALITY_PRESETS, specs
except ImportError:  # pragma: no cover - the reduced UI without the package
    _limit, DEFAULT_PRESET, QUALITY_PRESETS, specs = None, "MEDIUM", {}, (lambda: ())


def field_bounds(name: str) -> dict:
    """The property keywords of the limit ``name`` (``illumap.limits.Limit.ui``)."""
    return _limit(name).ui() if _limit is not None else {}


#: The quality presets as property values: enum values in capitals.
PRESET_PROPERTY_VALUES = {name: {key: (value.upper() if isinstance(value, str) else value)
                                 for key, value in values.items()}
                          for name, values in QUALITY_PRESETS.items()}

PRESET_ITEMS = [
    ("DRAFT", "Draft", "Few surfels, low FMM order, loose tolerance: quick look"),
    ("MEDIUM", "Medium", "Balanced density, FMM order and tolerance"),
    ("HIGH", "High", "Dense surfels, high FMM order, tight tolerance"),
    ("CUSTOM", "Custom", "Use the advanced settings as set"),
]
SAMPLING_ITEMS = [
    ("DENSITY", "Per Square Metre", "A number of surfels per square metre of surface"),
    ("BUDGET", "Total Count", "A total number of surfels, spread by area"),
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


#: Display precision of the float settings that need more than Blender's default.
_PRECISION = {"target_error": 3, "tol": 6}


def _run_property(spec):
    """The scene property of one run setting (``illumap.settings.Spec``)."""
    common = dict(name=spec.label, description=spec.description, update=_field_update)
    default = spec.property_default
    if spec.choices:
        items = [(c.value.upper(), c.label, c.description) for c in spec.choices if c.offered]
        return EnumProperty(items=items, default=str(default).upper(), **common)
    if spec.kind is bool:
        return BoolProperty(default=bool(default), **common)
    if spec.kind is int:
        return IntProperty(default=int(default), **field_bounds(spec.name), **common)
    if spec.kind is float:
        if spec.name in _PRECISION:
            common["precision"] = _PRECISION[spec.name]
        return FloatProperty(default=float(default), **field_bounds(spec.name), **common)
    raise TypeError(f"no scene property for setting {spec.name} of kind {spec.kind}")


def _settings_properties() -> dict:
    """The scene settings' properties: the view's own (preset, how the surfel count is set,
    whether a target error is asked for, the preview) around every run setting the panel
    shows, generated from ``illumap.settings``."""
    properties = {
        "initialized": BoolProperty(
            name="Initialized", default=False, options={"HIDDEN"},
            description="Set once the settings were taken from the add-on preferences or "
                        "edited"),
        "preset": EnumProperty(name="Quality", items=PRESET_ITEMS, default=DEFAULT_PRESET,
                               update=_preset_update),
        "sampling": EnumProperty(name="Surfels Set By", items=SAMPLING_ITEMS,
                                 description="How the number of surfels (the small discs the "
                                             "light is solved on) is chosen", default="BUDGET",
                                 update=_field_update),
        "use_target_error": BoolProperty(
            name="Target Error", default=False, update=_field_update,
            description="Ask for an accuracy instead of a preset: Illumap chooses the surfels, "
                        "the solver settings and the rays for it. Smaller errors take longer "
                        "(roughly 3-4× per halving)"),
    }
    properties.update({spec.name: _run_property(spec) for spec in specs() if spec.ui})
    properties.update({
        "build_preview": BoolProperty(
            name="Preview After Compute", default=True, update=_touch,
            description="After Compute, show the light on the computed objects themselves "
                        "(Object Preview): meshes through their 'illumination' attribute, "
                        "scans as a splat in each point's tangent plane. Renders (F12) show it "
                        "too; Off in the Preview panel gives the objects back as they were"),
        "show_surfels": BoolProperty(
            name="Show Surfels", default=False, update=_touch,
            description="Diagnostic: after Compute, also show the solve's surfels as discs "
                        "(the 'Illumap Surfels' object). Off, that object stays hidden in the "
                        "viewport and in renders"),
        "preview_mode": EnumProperty(
            name="Shading", items=PREVIEW_MODE_ITEMS, default="ILLUMINATION", update=_touch,
            description="What the surfels' discs show (a diagnostic): all their light, or the "
                        "light they reflect"),
        "disc_scale": FloatProperty(
            name="Disc Scale", default=DEFAULT_DISC_SCALE, **field_bounds("disc_scale"),
            update=_touch,
            description="Disc radius relative to the surfel's own radius (1: each disc has "
                        "exactly its surfel's area; larger values close the gaps between "
                        "discs)"),
        "stats": PointerProperty(type=IllumapStats),
    })
    return properties


IllumapSettings = type("IllumapSettings", (bpy.types.PropertyGroup,), {
    "__doc__": "Illumap's settings of a scene (``scene.illumap``)",
    "__annotations__": _settings_properties()})


def settings_values(props) -> dict:
    """The scene settings as keyword arguments of ``illumap.settings.Settings``: every run
    setting the panel shows, enums as a run spells them, and the surfel count or density
    that the view's choices leave unset as None."""
    values = {}
    for spec in specs():
        if spec.ui:
            value = getattr(props, spec.name)
            values[spec.name] = spec.canonical(value) if spec.choices else value
    if props.use_target_error:
        # The target chooses the count; the budget field (a preset's count) would cap it.
        values["budget"] = values["density"] = None
    elif props.sampling == "DENSITY":
        values["budget"] = None
    else:
        values["density"] = None
    values["target_error"] = float(props.target_error) if props.use_target_error else None
    return values


def make_settings(props, settings_cls=None):
    """The run's ``Settings`` from the scene settings (``settings_cls``: that class, by
    default ``illumap.settings.Settings``)."""
    if settings_cls is None:
        from illumap.settings import Settings as settings_cls
    return settings_cls(**settings_values(props))


classes = (IllumapPhaseTime, IllumapStats, IllumapSettings)
