"""The panel an artist reads without a manual (issue 55): at most eight controls on the main
panel, everything else under Advanced in plain words with tooltips that say what a setting
changes in the picture and what it costs, no comparison-only modes in the UI (they stay in
``pipeline.Settings``), and an Info line that says the time, the estimated error at the
objects, the warnings and where the result is."""

import re

import bpy
import pytest

from illumap_bpy_testing import diffuse_material, emission_material, make_plane, requires_core

from test_ui import LayoutRecorder

pytestmark = requires_core
#: Algorithm names a label may carry only beside plain words (in parentheses).
ALGORITHM_WORDS = ("FMM", "Multipole", "GMRES", "Jacobi", "Ward", "Octree", "Residual",
                   "Opening Angle", "Leaf Size", "Tolerance", "Near Field", "Gather",
                   "Receiver", "Budget", "Density")


def lit_floor():
    floor = make_plane("Floor", size=2.0, material=diffuse_material("F", (0.5,) * 3))
    em = make_plane("Emitter", size=0.5, location=(0, 0, 1), flip=True,
                    material=emission_material("E", (1, 1, 1), 1.0))
    for o in bpy.data.objects:
        o.select_set(o in (floor, em))
    return floor


def controls(layout):
    return [v for k, v in layout.log if k in ("prop", "operator")]


def test_the_main_panel_holds_at_most_eight_controls(registered_addon):
    from addon.ui import panel
    props = bpy.context.scene.illumap
    lit_floor()
    props.preset = "DRAFT"
    for target in (False, True):
        props.use_target_error = target
        for run in (False, True):
            if run:
                assert bpy.ops.illumap.compute_illumination_map() == {"FINISHED"}
            layout = LayoutRecorder()
            panel.draw_main(layout, bpy.context)
            drawn = controls(layout)
            assert len(drawn) <= panel.MAIN_PANEL_CONTROLS == 8, drawn
            assert {"preset", "use_target_error", "target_error", "lamps", "world_ambient",
                    "illumap.compute_illumination_map", "illumap.mesh_preview",
                    "illumap.clear_results"} == set(drawn)
    # The quality is a preset or a target error: the preset greys out under a target.
    assert "preset" in layout.inactive_props()


def test_comparison_modes_leave_the_ui_and_stay_in_the_api(registered_addon):
    from addon import checks, pipeline
    from addon.ui import properties
    rna = bpy.context.scene.illumap.bl_rna.properties
    assert "JACOBI" not in rna["solver"].enum_items.keys()
    assert "NONE" not in rna["visibility"].enum_items.keys()
    assert "near_field" not in rna.keys()
    # The Python API keeps them.
    settings = pipeline.Settings(solver="jacobi", near_field="point", visibility="none")
    assert (settings.solver, settings.near_field, settings.visibility) == ("jacobi", "point", "none")
    checks.check_settings(settings)       # accepted by the settings check
    assert properties.make_settings(bpy.context.scene.illumap, pipeline.Settings).near_field == "disc"


def test_advanced_labels_are_plain_words_with_tooltips(registered_addon):
    """Every setting under Advanced: a label without a bare algorithm name (one may follow in
    parentheses), and a tooltip; none says rays are cast against the surfels."""
    from addon.ui import panel
    layout = LayoutRecorder()
    panel.draw_advanced(layout, bpy.context)
    panel.draw_preview(layout, bpy.context)
    rna = bpy.context.scene.illumap.bl_rna.properties
    names = [v for k, v in layout.log if k == "prop"]
    assert len(names) >= 15
    for name in names:
        prop = rna[name]
        plain = re.sub(r"\(.*?\)", "", prop.name)
        assert not any(w.lower() in plain.lower() for w in ALGORITHM_WORDS), prop.name
        assert len(prop.description) > 20, name
        assert "against the surfels" not in prop.description, name
        if prop.type == "ENUM":
            for item in prop.enum_items:
                assert item.description, (name, item.identifier)
    # What a setting costs is said where it costs: the count and ray settings.
    for name in ("budget", "density", "gather_rays", "receiver_shadow_samples",
                 "shadow_samples", "order", "tol"):
        text = rna[name].description.lower()
        assert any(w in text for w in ("time", "slower", "cost")), name


def test_the_info_line_says_time_error_warnings_and_where(registered_addon):
    from addon.ui import panel
    floor = lit_floor()
    props = bpy.context.scene.illumap
    props.preset = "DRAFT"
    props.use_target_error, props.target_error = True, 0.1
    props.budget = 400
    assert bpy.ops.illumap.compute_illumination_map() == {"FINISHED"}
    summary = props.stats.summary
    assert re.match(r"done in \d+\.\d s; ", summary), summary
    assert re.search(r"estimated error (at the objects|of the surfels) \d+\.\d%", summary), summary
    assert "result in the 'illumination' colour attribute of 'Emitter', 'Floor'" in summary
    layout = LayoutRecorder()
    panel.draw_main(layout, bpy.context)
    labels = layout.texts("label")
    assert labels[0].startswith("Done in ") and any("Estimated error" in t for t in labels)
    # Transfer off: the result is on the surfel object, and the line says so.
    props.transfer = False
    assert bpy.ops.illumap.compute_illumination_map() == {"FINISHED"}
    assert "result in the surfel object 'Illumap Surfels'" in props.stats.summary


def test_warnings_are_counted_in_the_info_line():
    from addon.ui import operators
    from types import SimpleNamespace
    stats = SimpleNamespace(total_seconds=1.25, estimated_error_at_objects=0.031,
                            estimated_error=0.0, converged=False, first_pass_surfels=0)
    result = SimpleNamespace(warnings=["a", "b"], receiver_values={"A": 0, "B": 0},
                             point_receiver_values={}, object_name="Illumap Surfels")
    line = operators.run_summary(result, stats)
    assert line == ("done in 1.2 s; estimated error at the objects 3.1%; the solve stopped "
                    "before converging; 2 warnings (see above); result in the 'illumination' "
                    "colour attribute of 'A', 'B'")
