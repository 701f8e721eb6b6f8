"""Add-on preferences: the defaults new scenes start from, and the native module's status.

``bl_idname`` of AddonPreferences must be the name Blender registered the add-on under, which
for an extension is its top-level package: ``bl_ext.<repo>.illumap`` when installed. This module
lives in the ``addon`` subpackage, so the top-level package is our package's parent. Imported
from a checkout as ``addon`` (repository root on sys.path), there is no parent; the name is then
``addon`` itself, no add-on of that name is enabled, and ``get_preferences`` returns None so
callers fall back to the built-in defaults.
"""

import bpy
from bpy.props import BoolProperty, EnumProperty, FloatProperty

from ..preview import surfel_preview as preview
from . import properties
from ..core_status import core_error


def _addon_package(package=None):
    """The add-on's registered name: ``bl_ext.<repo>.illumap`` for ``bl_ext.<repo>.illumap.addon``,
    ``addon`` for a checkout imported as ``addon``."""
    # This module lives in the add-on's ui/ folder: the add-on is the package above it.
    package = package or (__package__ or __name__.rpartition(".")[0]).rpartition(".")[0]
    head, _, tail = package.rpartition(".")
    return head if head and tail == "addon" else package


ADDON_PACKAGE = _addon_package()


def get_preferences(context=None):
    """This add-on's preferences, or None when it is not enabled as an add-on (checkout)."""
    context = context or bpy.context
    addon = context.preferences.addons.get(ADDON_PACKAGE)
    return None if addon is None else addon.preferences


class IllumapPreferences(bpy.types.AddonPreferences):
    bl_idname = ADDON_PACKAGE

    default_preset: EnumProperty(name="Default Quality", items=properties.PRESET_ITEMS[:3],
                                 default=properties.DEFAULT_PRESET)
    default_lamps: BoolProperty(name="Lamps", default=True,
                                description="Add Blender lamps as direct light in new scenes")
    default_lamp_shadows: BoolProperty(name="Lamp Shadows", default=True,
                                       description="Shadow lamp light in new scenes")
    default_world_ambient: BoolProperty(name="World Light", default=True,
                                        description="Light from the world in new scenes")
    default_build_preview: BoolProperty(name="Preview After Compute", default=True)
    default_disc_scale: FloatProperty(name="Disc Scale", default=preview.DEFAULT_DISC_SCALE,
                                       **properties.field_bounds("disc_scale"))

    def draw(self, context):
        layout = self.layout
        error = core_error()
        if error:
            box = layout.box()
            box.alert = True
            for index, line in enumerate(error.splitlines()):
                box.label(text=line, icon="ERROR" if index == 0 else "BLANK1")
        col = layout.column()
        col.use_property_split = True
        col.prop(self, "default_preset")
        col.prop(self, "default_lamps")
        col.prop(self, "default_lamp_shadows")
        col.prop(self, "default_world_ambient")
        col.prop(self, "default_build_preview")
        col.prop(self, "default_disc_scale")


def apply_defaults(scene_settings, prefs=None):
    """Initialise a scene's settings from the preferences (built-in defaults without them)."""
    preset = prefs.default_preset if prefs else properties.DEFAULT_PRESET
    scene_settings.preset = preset
    properties.apply_preset(scene_settings, preset)
    if prefs is not None:
        scene_settings.lamps = prefs.default_lamps
        scene_settings.lamp_shadows = prefs.default_lamp_shadows
        scene_settings.world_ambient = prefs.default_world_ambient
        scene_settings.build_preview = prefs.default_build_preview
        scene_settings.disc_scale = prefs.default_disc_scale
        # Setting fields marks the preset Custom; the preferences' defaults belong to the preset.
        properties.apply_preset(scene_settings, preset)
        if scene_settings.preset != preset:
            scene_settings.preset = preset
    scene_settings.initialized = True


def initialize_scenes(context=None):
    """Apply the preferences to every scene whose Illumap settings were never set."""
    prefs = get_preferences(context)
    for scene in bpy.data.scenes:
        settings = getattr(scene, "illumap", None)
        if settings is not None and not settings.initialized:
            apply_defaults(settings, prefs)


classes = (IllumapPreferences,)


def register():
    for cls in classes:
        bpy.utils.register_class(cls)


def unregister():
    for cls in reversed(classes):
        bpy.utils.unregister_class(cls)
