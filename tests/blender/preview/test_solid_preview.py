"""Solid Preview: ``illumination`` shown in Solid shading (Color ▸ Attribute) on the user's
request, reversibly: the active colour attribute and the viewports' colour type are recorded and
put back; the render (default) colour attribute is never touched, so the next run reads the
user's own colours, not the light."""

import os
import tempfile

import bpy
import numpy as np
import pytest

from illumap_bpy_testing import (diffuse_material, emission_material, make_plane, requires_core,
                                 select_only)

from addon.preview import solid_preview

MATERIAL = "MATERIAL"


def _painted(name="Floor", size=1.0, location=(0.0, 0.0, 0.0), flip=False, material=None,
             paint=(0.2, 0.4, 0.6), lit=True):
    """A plane with a byte colour attribute ``Paint`` (active and render, as Blender makes the
    first one) and, when ``lit``, Illumap's FLOAT_COLOR ``illumination`` (made as the
    Transfer makes it: neither active nor render)."""
    obj = make_plane(name, size=size, location=location, flip=flip, material=material)
    ca = obj.data.color_attributes
    paint_attr = ca.new("Paint", "BYTE_COLOR", "CORNER")
    paint_attr.data.foreach_set("color", np.tile([*paint, 1.0], len(paint_attr.data))
                                .astype(np.float32))
    if lit:
        attr = ca.new("illumination", "FLOAT_COLOR", "CORNER")
        attr.data.foreach_set("color", np.tile([0.9, 0.1, 0.1, 1.0], len(attr.data))
                              .astype(np.float32))
    assert (ca.active_color_name, ca.default_color_name) == ("Paint", "Paint")
    return obj


def _names(obj):
    ca = obj.data.color_attributes
    return ca.active_color_name or "", ca.default_color_name or ""


def _viewports():
    return [a.spaces.active.shading for a in bpy.context.screen.areas if a.type == "VIEW_3D"]


def test_on_then_off_puts_back_what_was_recorded():
    floor = _painted()
    bare = _painted("Bare", location=(3, 0, 0), lit=False)
    views = _viewports()
    assert views and all(v.color_type == MATERIAL for v in views)
    assert solid_preview.enable([floor, bare], bpy.context.screen) == ["Floor"]
    assert _names(floor) == ("illumination", "Paint")        # active, never the render one
    assert floor.data[solid_preview.RECORD] == "Paint"
    assert _names(bare) == ("Paint", "Paint") and solid_preview.RECORD not in bare.data
    assert all(v.color_type == "VERTEX" for v in views)
    assert solid_preview.is_on(bpy.data)
    # On twice: the first record (the user's own) is kept, not the preview's own state.
    solid_preview.enable([floor], bpy.context.screen)
    assert floor.data[solid_preview.RECORD] == "Paint"
    assert dict(bpy.context.screen[solid_preview.SCREEN_RECORD]) == {
        str(i): MATERIAL for i, a in enumerate(bpy.context.screen.areas) if a.type == "VIEW_3D"}
    assert solid_preview.disable(bpy.data) == 1
    assert _names(floor) == ("Paint", "Paint")
    assert solid_preview.RECORD not in floor.data
    assert solid_preview.SCREEN_RECORD not in bpy.context.screen
    assert all(v.color_type == MATERIAL for v in views)
    assert not solid_preview.is_on(bpy.data)


def test_a_mesh_without_an_active_colour_gets_none_back_and_the_render_one_is_kept():
    """No active colour before: none after; a render colour other than the active one stays
    what it was throughout."""
    floor = _painted()
    ca = floor.data.color_attributes
    ca.new("Dirt", "FLOAT_COLOR", "POINT")
    ca.default_color_name = "Dirt"
    ca.active_color_name = ""
    assert _names(floor) == ("", "Dirt")
    solid_preview.enable([floor], bpy.context.screen)
    assert _names(floor) == ("illumination", "Dirt")
    solid_preview.disable(bpy.data)
    assert _names(floor) == ("", "Dirt") and ca.active_color is None


def test_a_recorded_attribute_deleted_meanwhile_restores_to_none():
    floor = _painted()
    solid_preview.enable([floor], bpy.context.screen)
    ca = floor.data.color_attributes
    ca.remove(ca["Paint"])
    solid_preview.disable(bpy.data)          # no error
    assert ca.active_color is None and (ca.active_color_name or "") == ""
    assert "illumination" in ca


def test_a_viewport_the_user_changed_meanwhile_is_left_as_set():
    floor = _painted()
    solid_preview.enable([floor], bpy.context.screen)
    view = _viewports()[0]
    view.color_type = "OBJECT"
    solid_preview.disable(bpy.data)
    assert view.color_type == "OBJECT"


def test_the_operator_on_and_off_and_nothing_to_show():
    floor = _painted()
    bare = _painted("Bare", location=(3, 0, 0), lit=False)
    select_only(bare)
    with pytest.raises(RuntimeError, match="has an 'illumination' attribute"):
        bpy.ops.illumap.solid_preview(show=True)
    assert _names(bare) == ("Paint", "Paint") and not solid_preview.is_on(bpy.data)
    select_only(floor)
    assert bpy.ops.illumap.solid_preview(show=True) == {"FINISHED"}
    assert _names(floor) == ("illumination", "Paint")
    assert all(v.color_type == "VERTEX" for v in _viewports())
    assert bpy.ops.illumap.solid_preview(show=False) == {"FINISHED"}
    assert _names(floor) == ("Paint", "Paint")
    assert all(v.color_type == MATERIAL for v in _viewports())


def test_the_record_survives_save_and_reload():
    floor = _painted()
    solid_preview.enable([floor], bpy.context.screen)
    with tempfile.TemporaryDirectory() as tmp:
        path = os.path.join(tmp, "solid.blend")
        bpy.ops.wm.save_as_mainfile(filepath=path)
        bpy.ops.wm.open_mainfile(filepath=path)
        floor = bpy.data.objects["Floor"]
        assert _names(floor) == ("illumination", "Paint")
        assert solid_preview.is_on(bpy.data)
        assert solid_preview.disable(bpy.data) == 1
        assert _names(floor) == ("Paint", "Paint")
        assert all(v.color_type == MATERIAL for v in _viewports())


def test_undo_takes_the_meshes_back_and_off_still_restores_the_viewports():
    """Undo restores the meshes (their record with them); the viewports are UI, which undo
    leaves alone: Off still puts them back."""
    floor = _painted()
    select_only(floor)
    bpy.ops.ed.undo_push(message="before")     # undo starts disabled in background mode
    assert bpy.ops.illumap.solid_preview(show=True) == {"FINISHED"}
    bpy.ops.ed.undo_push(message="Solid Preview")
    bpy.ops.ed.undo()
    floor = bpy.data.objects["Floor"]
    assert _names(floor) == ("Paint", "Paint") and solid_preview.RECORD not in floor.data
    assert solid_preview.is_on(bpy.data)       # the viewports still show Attribute
    assert bpy.ops.illumap.solid_preview(show=False) == {"FINISHED"}
    assert all(v.color_type == MATERIAL for v in _viewports())
    assert not solid_preview.is_on(bpy.data)


def test_clear_gives_the_recorded_active_colour_back():
    floor = _painted()
    solid_preview.enable([floor], bpy.context.screen)
    select_only(floor)
    assert bpy.ops.illumap.clear_results(transferred=True) == {"FINISHED"}
    assert "illumination" not in floor.data.color_attributes
    assert _names(floor) == ("Paint", "Paint") and solid_preview.RECORD not in floor.data


def _paint_material():
    """Diffuse whose colour is an empty-name Color Attribute node: the render colour."""
    mat = diffuse_material("Painted", (0.8, 0.8, 0.8))
    nodes = mat.node_tree.nodes
    bsdf = next(n for n in nodes if n.type == "BSDF_DIFFUSE")
    vc = nodes.new("ShaderNodeVertexColor")
    vc.layer_name = ""
    mat.node_tree.links.new(vc.outputs["Color"], bsdf.inputs["Color"])
    return mat


def _values(obj):
    attr = obj.data.color_attributes["illumination"]
    out = np.empty(len(attr.data) * 4, np.float32)
    attr.data.foreach_get("color", out)
    return out.reshape(-1, 4)[:, :3]


@requires_core
def test_the_next_run_reads_the_render_colour_not_the_light():
    """With Solid Preview on, ``illumination`` is the active colour attribute; a material whose
    empty-name Color Attribute node reads the render one (``Paint``, dim blue) must give the
    next run the same albedo: the same result, written under the same name, still active. A
    mesh that run lights for the first time joins the preview."""
    floor = _painted(size=2.0, material=_paint_material(), paint=(0.1, 0.2, 0.5), lit=False)
    light = make_plane("Light", size=0.5, location=(0, 0, 1.0), flip=True,
                       material=emission_material("E", (5.0, 5.0, 5.0), 1.0))
    scene = bpy.context.scene.illumap
    scene.budget, scene.gather_rays, scene.transfer = 600, 32, True
    scene.build_preview = False
    select_only(floor, light)
    assert bpy.ops.illumap.compute_illumination_map() == {"FINISHED"}
    first = _values(floor)
    # The light reflected by the painted floor is dim and blue: albedo from Paint.
    assert first.mean() > 0 and first[:, 2].mean() > 2 * first[:, 0].mean()
    select_only(floor)
    assert bpy.ops.illumap.solid_preview(show=True) == {"FINISHED"}
    assert _names(floor) == ("illumination", "Paint")
    assert _names(light)[0] != "illumination"                     # not selected: not shown
    select_only(floor, light)
    assert bpy.ops.illumap.compute_illumination_map() == {"FINISHED"}
    np.testing.assert_array_equal(_values(floor), first)
    assert _names(floor) == ("illumination", "Paint")             # still on, the new result
    assert floor.data[solid_preview.RECORD] == "Paint"
    assert _names(light)[0] == "illumination"                     # lit by the run: joined
    assert light.data[solid_preview.RECORD] == ""
    solid_preview.disable(bpy.data)
    assert _names(floor) == ("Paint", "Paint")
    assert (light.data.color_attributes.active_color_name or "") == ""


@requires_core
def test_the_material_reader_takes_the_render_colour_attribute():
    """Unit check of the fix: an empty-name Color Attribute node reads the default (render)
    colour attribute even when another one is active."""
    from addon.read import sampling
    floor = _painted(paint=(0.1, 0.2, 0.5))
    floor.data.color_attributes.active_color_name = "illumination"
    mesh = sampling.read_mesh(floor, bpy.context.evaluated_depsgraph_get())
    assert mesh.render_color == "Paint"
    rows = np.arange(4)
    samples = sampling.MeshSamples(mesh, np.zeros((4, 3)), np.tile([0.0, 0.0, 1.0], (4, 1)),
                                   np.full(4, 0.25), np.zeros(4, np.int64),
                                   np.tile([1 / 3] * 3, (4, 1)), np.zeros(4, np.int64))
    np.testing.assert_allclose(samples.color()[rows, :3], np.tile([0.1, 0.2, 0.5], (4, 1)),
                               atol=0.01)    # Paint (bytes), not illumination (0.9, 0.1, 0.1)


@requires_core
def test_a_batch_run_joins_newly_lit_meshes_while_it_is_on(tmp_path):
    """A file saved with Solid Preview on and lit again by a batch job: the meshes the job
    lights for the first time show their light in Solid mode too, as after the button."""
    from addon import batch
    shown = _painted("Shown", location=(5, 0, 0))
    assert solid_preview.enable([shown], bpy.context.screen) == ["Shown"]
    floor = make_plane("Floor", size=2.0, material=diffuse_material("F", (0.5,) * 3))
    make_plane("Light", size=0.5, location=(0, 0, 1.0), flip=True,
               material=emission_material("E", (5.0, 5.0, 5.0), 1.0))
    select_only(floor, bpy.data.objects["Light"])
    assert batch.main(["--objects", "Floor,Light", "--budget", "400", "--method", "direct",
                       "--export-npz", str(tmp_path / "x.npz")]) == 0
    assert _names(floor)[0] == "illumination"
    assert floor.data[solid_preview.RECORD] == ""
    solid_preview.disable(bpy.data)
    assert (floor.data.color_attributes.active_color_name or "") == ""
    assert _names(shown) == ("Paint", "Paint")
