"""The Illumap sidebar panel (3D Viewport > Sidebar > Illumap).

With the native module: at most eight controls an artist decides (quality as a preset or a
target error, lamps, world light, Compute, the preview on/off, Clear) and what the last run
says; everything else under Advanced (closed by default), with the preview options and the
last run's details as its subpanels. Without it: a reduced panel that says why and what to do.
The draw code is written against a ``layout`` argument so that tests can draw into a recorder.
"""

import bpy

from ..preview import solid_preview
from ..core_status import core_error


def draw_native_missing(layout, error):
    box = layout.box()
    box.alert = True
    lines = error.splitlines() or ["The native module is missing"]
    box.label(text="Illumap is unavailable", icon="ERROR")
    for line in lines:
        box.label(text=line)
    layout.label(text="Reinstall the Illumap extension built for this platform,")
    layout.label(text="or build the core: see README (pip install ./core).")


#: The most controls the main panel holds (issue 55): what an artist decides. Everything
#: else is under Advanced.
MAIN_PANEL_CONTROLS = 8


def preview_is_on(context) -> bool:
    """Whether any object in the scene shows its light through the Object Preview."""
    from ..preview import mesh_preview
    return any(mesh_preview.has_mesh_preview(o) for o in context.scene.objects)


def draw_main(layout, context):
    """What an artist decides, in at most ``MAIN_PANEL_CONTROLS`` controls: quality (a preset,
    or a target error), lamps and world light, Compute, the preview on or off, Clear; then
    what the last run says (time, estimated error, warnings, where the result is)."""
    props = context.scene.illumap
    col = layout.column(align=True)
    row = col.row(align=True)
    row.active = not props.use_target_error
    row.prop(props, "preset", text="Quality")
    row = col.row(align=True)
    row.prop(props, "use_target_error", text="Target Error")
    sub = row.row(align=True)
    sub.active = props.use_target_error
    sub.prop(props, "target_error", text="")
    row = layout.row(align=True)
    row.prop(props, "lamps", toggle=True, icon="LIGHT")
    row.prop(props, "world_ambient", toggle=True, icon="WORLD", text="World")
    from .operators import current_task
    task = current_task()
    if task is not None:
        box = layout.box()
        box.label(text=f"Computing: {task.phase} {100.0 * task.fraction:.0f} %", icon="TIME")
        box.label(text="Esc in the viewport cancels")
        return
    row = layout.row()
    row.scale_y = 1.5
    row.operator("illumap.compute_illumination_map", icon="LIGHT_SUN", text="Compute")
    row = layout.row(align=True)
    on = preview_is_on(context)
    op = row.operator("illumap.mesh_preview", icon="SHADING_RENDERED",
                      text="Preview On" if on else "Preview Off", depress=on)
    op.show = not on
    row.operator("illumap.clear_results", icon="TRASH", text="Clear")
    draw_result(layout, context)


def draw_result(layout, context):
    """The last run in words: the Info line's parts, one per line."""
    stats = context.scene.illumap.stats
    if not stats.valid or not stats.summary:
        n = len(context.selected_objects) if hasattr(context, "selected_objects") else 0
        layout.label(text=f"{n} object{'s' * (n != 1)} selected")
        return
    col = layout.column(align=True)
    for i, part in enumerate(stats.summary.split("; ")):
        warn = "warning" in part or "stopped" in part
        col.label(text=part[:1].upper() + part[1:],
                  icon="ERROR" if warn else ("CHECKMARK" if i == 0 else "NONE"))


def draw_object_preview(layout, context):
    """The preview a user meets: the light on their own objects (on after every Compute
    while Preview After Compute is set), and Off, which gives the objects back."""
    row = layout.row(align=True)
    row.operator("illumap.mesh_preview", icon="SHADING_RENDERED", text="Object Preview").show = True
    row.operator("illumap.mesh_preview", icon="X", text="Off").show = False


def draw_advanced(layout, context):
    """Every other setting, in plain words (the tooltips say what each changes in the picture
    and what it costs). Comparison-only modes are not offered (``pipeline.Settings`` has
    them)."""
    props = context.scene.illumap
    layout.use_property_split = True
    layout.use_property_decorate = False
    col = layout.column(heading="Light")
    sub = col.column()
    sub.active = props.lamps
    sub.prop(props, "lamp_shadows")
    sub2 = sub.column()
    sub2.active = props.lamps and props.lamp_shadows
    sub2.prop(props, "shadow_samples")
    col = layout.column(heading="Detail")
    sub = col.column()
    sub.active = not props.use_target_error     # the target chooses the surfel count
    sub.prop(props, "sampling")
    sub.prop(props, "density" if props.sampling == "DENSITY" else "budget")
    sub = col.column()
    sub.active = props.use_target_error
    sub.prop(props, "adaptive")
    col.prop(props, "seed")
    col = layout.column(heading="On Your Objects")
    col.prop(props, "transfer")
    sub = col.column()
    sub.active = props.transfer
    sub.prop(props, "transfer_domain")
    sub.prop(props, "gather_rays")
    sub.prop(props, "receiver_shadow_samples")
    sub.prop(props, "gather_cache")
    sub.operator("illumap.export_lightmaps", icon="TEXTURE")
    col = layout.column(heading="Solver")
    col.prop(props, "method")
    sub = col.column()
    sub.active = props.method == "FMM"
    sub.prop(props, "order")
    sub.prop(props, "theta")
    sub.prop(props, "leaf_size")
    col.prop(props, "visibility")
    sub = col.column()
    sub.active = (not props.use_target_error
                  and (props.visibility == "EXACT" or (props.lamps and props.lamp_shadows)))
    sub.prop(props, "occluder_shape")
    col.prop(props, "tol")
    col.prop(props, "max_iterations")
    col.prop(props, "solver")
    layout.operator("illumap.reset_settings", icon="LOOP_BACK")


def draw_preview(layout, context):
    props = context.scene.illumap
    layout.use_property_split = True
    layout.use_property_decorate = False
    layout.prop(props, "build_preview")
    draw_object_preview(layout, context)
    row = layout.row(align=True)
    on = solid_preview.is_on(context.blend_data)
    row.operator("illumap.solid_preview", icon="SHADING_SOLID", text="Solid Preview",
                 depress=on).show = True
    row.operator("illumap.solid_preview", icon="X", text="Off").show = False
    # The solve's own surfels: a diagnostic, hidden unless asked for.
    col = layout.column(heading="Surfels")
    col.prop(props, "show_surfels")
    sub = col.column()
    sub.prop(props, "preview_mode")
    sub.prop(props, "disc_scale")
    row = layout.row(align=True)
    row.operator("illumap.build_preview", icon="MESH_CIRCLE", text="Show Surfels").show = True
    row.operator("illumap.build_preview", icon="HIDE_ON", text="Hide").show = False


def draw_stats(layout, context):
    stats = context.scene.illumap.stats
    if not stats.valid:
        layout.label(text="No result yet")
        return
    col = layout.column(align=True)
    col.label(text=f"Surfels: {stats.surfels:,}")
    col.label(text=f"Iterations: {stats.iterations}"
                   + ("" if stats.converged else "  (not converged)"))
    col.label(text=f"Final residual: {stats.residual:.3e}")
    if stats.density > 0:
        col.label(text=f"Density for target: {stats.density:,.0f} /m² "
                       f"(predicted {stats.predicted_error:.3f})")
    if stats.chosen_settings:
        col.label(text=f"Chosen: {stats.chosen_settings}")
    if stats.estimated_error_at_objects > 0:
        # What a user compares: the light on their objects (the surfels' part shrinks by the
        # share of it gathered from them).
        col.label(text=f"Estimated error at the objects: {stats.estimated_error_at_objects:.1%}")
    if stats.estimated_error > 0:
        col.label(text=f"Estimated error of the surfels: {stats.estimated_error:.1%}")
    if stats.first_pass_surfels > 0:
        col.label(text=f"Adaptive pass 1: {stats.first_pass_surfels:,} surfels, "
                       f"{stats.first_pass_iterations} iterations")
    if stats.shadow_rays > 0:
        col.label(text=f"Shadow rays: {stats.shadow_rays:,}"
                       + (f" ({stats.occluder_shape})" if stats.occluder_shape else ""))
    col.label(text=f"Total: {stats.total_seconds:.3f} s")
    if len(stats.phases):
        col = layout.column(align=True)
        for phase in stats.phases:
            row = col.row()
            row.label(text=phase.name)
            row.label(text=f"{phase.seconds:.3f} s")


class _IllumapPanel:
    bl_space_type = "VIEW_3D"
    bl_region_type = "UI"
    bl_category = "Illumap"


class VIEW3D_PT_illumap(_IllumapPanel, bpy.types.Panel):
    bl_label = "Illumap"
    bl_idname = "VIEW3D_PT_illumap"

    def draw(self, context):
        error = core_error()
        if error:
            draw_native_missing(self.layout, error)
        else:
            draw_main(self.layout, context)


class _SubPanel(_IllumapPanel):
    bl_parent_id = "VIEW3D_PT_illumap"

    @classmethod
    def poll(cls, context):
        return core_error() is None and context.scene is not None


class VIEW3D_PT_illumap_advanced(_SubPanel, bpy.types.Panel):
    bl_label = "Advanced"
    bl_idname = "VIEW3D_PT_illumap_advanced"
    bl_options = {"DEFAULT_CLOSED"}

    def draw(self, context):
        draw_advanced(self.layout, context)


class VIEW3D_PT_illumap_preview(_SubPanel, bpy.types.Panel):
    bl_label = "Preview Options"
    bl_idname = "VIEW3D_PT_illumap_preview"
    bl_parent_id = "VIEW3D_PT_illumap_advanced"
    bl_options = {"DEFAULT_CLOSED"}

    def draw(self, context):
        draw_preview(self.layout, context)


class VIEW3D_PT_illumap_stats(_SubPanel, bpy.types.Panel):
    bl_label = "Last Run in Detail"
    bl_idname = "VIEW3D_PT_illumap_stats"
    bl_parent_id = "VIEW3D_PT_illumap_advanced"
    bl_options = {"DEFAULT_CLOSED"}

    def draw(self, context):
        draw_stats(self.layout, context)


classes = (VIEW3D_PT_illumap, VIEW3D_PT_illumap_advanced, VIEW3D_PT_illumap_preview,
           VIEW3D_PT_illumap_stats)
