"""The operators beside Compute: Surfel Preview, Object Preview, Solid Preview, Clear Results,
Export Lightmaps and Reset Settings. They need only bpy (and, for lightmaps, numpy), so the
reduced UI keeps them when the native module cannot load."""

import bpy
from bpy.props import BoolProperty, EnumProperty, IntProperty, StringProperty

from ..write import exports, output
from ..preview import mesh_preview, surfel_preview as preview, solid_preview
from . import preferences, properties
from ..kinds import RESULT_TYPES as _RESULT_TYPES
from .operators import counted, error_message, surfel_objects


class ILLUMAP_OT_build_preview(bpy.types.Operator):
    """Diagnostic: show the solve's surfels as oriented discs coloured by their light (the
    'Illumap Surfels' object, shown in the viewport and in renders), or hide them again"""

    bl_idname = "illumap.build_preview"
    bl_label = "Surfel Preview"
    bl_options = {"REGISTER", "UNDO"}

    mode: EnumProperty(name="Shading", items=properties.PREVIEW_MODE_ITEMS,
                       options={"SKIP_SAVE"}, default="ILLUMINATION")
    use_scene_mode: BoolProperty(name="Use Scene Setting", default=True, options={"SKIP_SAVE", "HIDDEN"})
    show: BoolProperty(name="Show", default=True, options={"SKIP_SAVE"})

    def execute(self, context):
        props = context.scene.illumap
        mode = props.preview_mode if self.use_scene_mode else self.mode
        active = context.active_object
        targets = [active] if active is not None and active in surfel_objects() else \
            surfel_objects(context.scene)
        if not targets:
            self.report({"ERROR"}, "No Illumap surfel object in the scene: compute an "
                                   "illumination map first")
            return {"CANCELLED"}
        for obj in targets:
            if not self.show:
                preview.remove_preview(obj)
                obj.hide_viewport = obj.hide_render = True
                continue
            try:
                preview.build_preview(context, obj, mode=mode, disc_scale=props.disc_scale)
            except ValueError as error:
                self.report({"ERROR"}, str(error))
                return {"CANCELLED"}
            # Asked for: the diagnostic shows in the viewport and in renders.
            obj.hide_viewport = obj.hide_render = False
        return {"FINISHED"}


class ILLUMAP_OT_mesh_preview(bpy.types.Operator):
    """Show the illumination on the objects themselves: meshes through an emission material,
    point clouds and scans as every one of their points (a modifier; the objects' own
    materials and data are untouched), or switch that off again"""

    bl_idname = "illumap.mesh_preview"
    bl_label = "Object Preview"
    bl_options = {"REGISTER", "UNDO"}

    show: BoolProperty(name="Show", default=True, options={"SKIP_SAVE"})

    def execute(self, context):
        objects = context.selected_objects or list(context.scene.objects)
        if not self.show:
            removed = mesh_preview.remove_mesh_preview(objects)
            self.report({"INFO"}, f"Illumap: object preview off on {counted(removed, 'object')}")
            return {"FINISHED"}
        shown = mesh_preview.build_mesh_preview(objects)
        if not shown:
            self.report({"ERROR"}, "No selected mesh or point cloud has an 'illumination' "
                                   "attribute: compute an illumination map with Transfer to "
                                   "Meshes first")
            return {"CANCELLED"}
        self.report({"INFO"}, f"Illumap: object preview on {counted(len(shown), 'object')}")
        return {"FINISHED"}


class ILLUMAP_OT_solid_preview(bpy.types.Operator):
    """Show the illumination in Solid shading (Color: Attribute): makes 'illumination' the
    active colour attribute of the lit meshes (never the render one) and sets the 3D
    viewports to Attribute colours, recording what they had; Off puts it all back"""

    bl_idname = "illumap.solid_preview"
    bl_label = "Solid Preview"
    bl_options = {"REGISTER", "UNDO"}

    show: BoolProperty(name="Show", default=True, options={"SKIP_SAVE"})

    def execute(self, context):
        if not self.show:
            restored = solid_preview.disable(context.blend_data)
            self.report({"INFO"}, f"Illumap: solid preview off, {counted(restored, 'mesh')} "
                                  "restored")
            return {"FINISHED"}
        objects = context.selected_objects or list(context.scene.objects)
        shown = solid_preview.enable(objects, context.screen)
        if not shown:
            self.report({"ERROR"}, "No selected mesh with faces has an 'illumination' "
                                   "attribute (point clouds show in the Object Preview): "
                                   "compute an illumination map with Transfer to Meshes first")
            return {"CANCELLED"}
        self.report({"INFO"}, f"Illumap: solid preview on {counted(len(shown), 'mesh')}; "
                              "switch the viewport to Solid")
        return {"FINISHED"}


class ILLUMAP_OT_clear_results(bpy.types.Operator):
    """Remove Illumap's surfel objects (and optionally the transferred attributes)"""

    bl_idname = "illumap.clear_results"
    bl_label = "Clear Illumap Results"
    bl_options = {"REGISTER", "UNDO"}

    transferred: BoolProperty(
        name="Transferred Attributes", default=False,
        description="Also remove the 'illumination' colour attribute from the selected meshes")

    def execute(self, context):
        removed = 0
        for obj in surfel_objects():
            data = obj.data
            bpy.data.objects.remove(obj)
            if data is not None and data.users == 0:
                if isinstance(data, bpy.types.Mesh):
                    bpy.data.meshes.remove(data)
                elif isinstance(data, bpy.types.PointCloud):
                    bpy.data.pointclouds.remove(data)
            removed += 1
        if self.transferred:
            for obj in context.selected_objects:
                if obj.type not in _RESULT_TYPES or obj.data.library is not None:
                    continue
                attr = obj.data.attributes.get("illumination")
                # Only what Illumap writes (FLOAT_COLOR); the active/render colours are kept.
                if attr is not None and attr.data_type == "FLOAT_COLOR":
                    names = output._colour_names(obj.data)
                    obj.data.attributes.remove(attr)
                    if names is not None:
                        output._restore_colour_names(obj.data, tuple(
                            "" if n == "illumination" else n for n in names))
                    solid_preview.forget(obj.data)   # the active colour it had before
        context.scene.illumap.stats.clear()
        self.report({"INFO"}, f"Illumap: removed {counted(removed, 'surfel object')}")
        return {"FINISHED"}


class ILLUMAP_OT_export_lightmaps(bpy.types.Operator):
    """Write each selected mesh's light as a UV-space lightmap (a linear EXR in its active UV
    map), from the 'illumination' attribute on its corners, grown across the UV seams"""

    bl_idname = "illumap.export_lightmaps"
    bl_label = "Export Lightmaps"
    bl_options = {"REGISTER"}

    directory: StringProperty(name="Folder", subtype="DIR_PATH",
                              description="Folder the lightmaps are written to, one "
                                          "<object>.exr per mesh")
    size: IntProperty(name="Size", default=1024, min=16, max=16384,
                      description="Width and height of each lightmap in pixels: more show "
                                  "finer light, and take longer to write")

    def invoke(self, context, event):
        context.window_manager.fileselect_add(self)
        return {"RUNNING_MODAL"}

    def execute(self, context):
        import os
        folder = bpy.path.abspath(self.directory or "//")
        if not folder or not os.path.isdir(folder):
            self.report({"ERROR"}, f"Illumap: the folder '{folder}' does not exist")
            return {"CANCELLED"}
        values = {}
        for obj in context.selected_objects:
            if obj.type == "MESH":
                corners = exports.corner_values(obj.data)
                if corners is not None:
                    values[obj.name] = corners
        if not values:
            self.report({"ERROR"}, "Illumap: no selected mesh has an 'illumination' attribute: "
                                   "compute with Transfer to Meshes on first")
            return {"CANCELLED"}
        try:
            written, warnings = exports.write_lightmaps(
                values, os.path.join(folder, "{object}.exr"), self.size)
        except Exception as error:  # noqa: BLE001 - a file that cannot be written
            self.report({"ERROR"}, f"Illumap: writing the lightmaps failed: {error_message(error)}")
            return {"CANCELLED"}
        for warning in warnings:
            self.report({"WARNING"}, f"Illumap: {warning}")
        self.report({"INFO"}, f"Illumap: wrote {counted(len(written), 'lightmap')} to {folder}")
        return {"FINISHED"}


class ILLUMAP_OT_reset_settings(bpy.types.Operator):
    """Reset this scene's Illumap settings to the add-on preferences"""

    bl_idname = "illumap.reset_settings"
    bl_label = "Reset Illumap Settings"
    bl_options = {"REGISTER", "UNDO"}

    def execute(self, context):
        preferences.apply_defaults(context.scene.illumap, preferences.get_preferences(context))
        return {"FINISHED"}


# Registered even without the native module (they need only bpy).


#: Registered with or without the native module.
classes = (ILLUMAP_OT_build_preview, ILLUMAP_OT_mesh_preview, ILLUMAP_OT_solid_preview,
           ILLUMAP_OT_clear_results, ILLUMAP_OT_export_lightmaps, ILLUMAP_OT_reset_settings)
