"""The point-instanced preview: oriented discs shaded by the surfel attributes.

Renders are tiny (32×32, 4 samples, Cycles CPU). EEVEE's first headless render takes about a
minute, so its test runs only with ILLUMAP_TEST_EEVEE=1.
"""

import os

import numpy as np
import pytest

import bpy

from illumap_bpy_testing import (EEVEE_ENV, black_world, grid_positions, make_surfels,
                                 render_pixels, requires_core, top_camera)

RED = (0.8, 0.05, 0.05)
GREEN = (0.05, 0.8, 0.05)


def _two_colour_surfels(n=16, pointcloud=False, normal=(0.0, 0.0, 1.0)):
    """n×n surfels on the unit square at z=0: red where x<0, green where x>0."""
    pos = grid_positions(n)
    illum = np.where((pos[:, 0] < 0.0)[:, None], RED, GREEN)
    return make_surfels(pos, normal, radius=0.75 / n, illumination=illum, pointcloud=pointcloud)


def _scene_for_render():
    black_world()
    top_camera(ortho_scale=2.0)  # the unit square fills the middle half of the image


def test_build_twice_replaces_and_reuses(registered_addon):
    from addon.preview import surfel_preview as preview
    obj = _two_colour_surfels(n=4)
    mod1 = preview.build_preview(bpy.context, obj)
    mod2 = preview.build_preview(bpy.context, obj)
    assert mod1 == mod2
    assert [m.name for m in obj.modifiers] == [preview.MODIFIER_NAME]
    assert [g.name for g in bpy.data.node_groups] == [preview.NODE_GROUP_NAME]
    assert [m.name for m in bpy.data.materials] == [preview.MATERIAL_NAMES["ILLUMINATION"]]
    # A second surfel object shares the node group and the material.
    other = make_surfels(grid_positions(2), (0, 0, 1), 0.1, (1, 1, 1), name="Other")
    preview.build_preview(bpy.context, other)
    assert len(bpy.data.node_groups) == 1 and len(bpy.data.materials) == 1
    # Stray copies (e.g. a duplicated modifier) are folded back into one.
    copy = obj.modifiers.new("Illumap Preview", "NODES")
    copy.node_group = preview.preview_node_group()
    preview.build_preview(bpy.context, obj)
    assert [m.name for m in obj.modifiers] == [preview.MODIFIER_NAME]
    assert preview.remove_preview(obj) == 1 and len(obj.modifiers) == 0


def test_instances_are_oriented_and_sized(registered_addon):
    """One surfel facing +X with radius 0.2: its disc lies in the YZ plane, area pi r^2."""
    from addon.preview import surfel_preview as preview
    obj = make_surfels([(1.0, 2.0, 3.0)], (1.0, 0.0, 0.0), 0.2, (1, 1, 1))
    preview.build_preview(bpy.context, obj, disc_scale=1.0)
    depsgraph = bpy.context.evaluated_depsgraph_get()
    found = []
    for inst in depsgraph.object_instances:
        if inst.is_instance and inst.parent and inst.parent.original == obj:
            found.append(np.array(inst.matrix_world))
    assert len(found) == 1
    m = found[0]
    np.testing.assert_allclose(m[:3, 3], (1.0, 2.0, 3.0), atol=1e-6)
    # The disc's local +Z (its normal) maps to +X, scaled by the radius.
    np.testing.assert_allclose(m[:3, 2], (0.2, 0.0, 0.0), atol=1e-6)
    np.testing.assert_allclose(np.linalg.norm(m[:3, :3], axis=0), 0.2, rtol=1e-6)
    # The default disc scale enlarges the discs by DEFAULT_DISC_SCALE.
    preview.build_preview(bpy.context, obj)
    depsgraph = bpy.context.evaluated_depsgraph_get()
    scales = [np.linalg.norm(np.array(i.matrix_world)[:3, 2]) for i in depsgraph.object_instances
              if i.is_instance and i.parent and i.parent.original == obj]
    assert scales == [pytest.approx(0.2 * preview.DEFAULT_DISC_SCALE, rel=1e-6)]
    # Disc area: the 16-gon is enlarged so its area is exactly pi * 1^2 before scaling.
    n = preview.DISC_VERTICES
    area = 0.5 * n * preview._AREA_SCALE ** 2 * np.sin(2 * np.pi / n)
    assert area == pytest.approx(np.pi, rel=1e-9)


def test_missing_attributes_is_a_clear_error(registered_addon):
    from addon.preview import surfel_preview as preview
    mesh = bpy.data.meshes.new("Bare")
    mesh.vertices.add(3)
    obj = bpy.data.objects.new("Bare", mesh)
    bpy.context.scene.collection.objects.link(obj)
    with pytest.raises(ValueError, match="illumination, normal, radius"):
        preview.build_preview(bpy.context, obj)
    with pytest.raises(ValueError, match="surfel object"):
        preview.build_preview(bpy.context, None)


@pytest.mark.parametrize("pointcloud", [False, True], ids=["mesh", "pointcloud"])
def test_cycles_render_shows_illumination(registered_addon, pointcloud):
    from addon.preview import surfel_preview as preview
    obj = _two_colour_surfels(pointcloud=pointcloud)
    assert obj.type == ("POINTCLOUD" if pointcloud else "MESH")
    preview.build_preview(bpy.context, obj)
    _scene_for_render()
    px = render_pixels(size=32, engine="CYCLES")
    # Image x in [-1, 1] m maps to columns 0..31; the square covers columns 8..23.
    left = px[10:22, 9:15, :3].reshape(-1, 3)
    right = px[10:22, 17:23, :3].reshape(-1, 3)
    np.testing.assert_allclose(left.mean(axis=0), RED, atol=0.03)
    np.testing.assert_allclose(right.mean(axis=0), GREEN, atol=0.03)
    # Background where there are no discs: the black world.
    for corner in (px[:6, :6], px[:6, -6:], px[-6:, :6], px[-6:, -6:]):
        assert corner[..., :3].max() < 1e-3


def test_discs_face_their_normals(registered_addon):
    """Discs facing away from the camera are seen from behind; discs seen edge-on cover
    almost nothing."""
    from addon.preview import surfel_preview as preview
    obj = _two_colour_surfels(normal=(1.0, 0.0, 0.0))  # edge-on from the top camera
    preview.build_preview(bpy.context, obj)
    _scene_for_render()
    px = render_pixels(size=32, engine="CYCLES")
    assert px[8:24, 8:24, :3].mean() < 0.05


def test_albedo_irradiance_mode(registered_addon):
    """Emission shows albedo × irradiance: with illumination 0.5, emission 0.1 and albedo 0.8,
    irradiance = (0.5−0.1)/0.8 = 0.5 and the disc shows 0.4."""
    from addon import compat
    from addon.preview import surfel_preview as preview
    pos = grid_positions(12)
    obj = make_surfels(pos, (0, 0, 1), 0.75 / 12, illumination=(0.5, 0.5, 0.5),
                       albedo=(0.8, 0.4, 0.2), emission=(0.1, 0.1, 0.1))
    preview.build_preview(bpy.context, obj, mode="ALBEDO_IRRADIANCE")
    material_input = preview._socket_identifier(preview.preview_node_group(), "Material")
    assert compat.get_modifier_input(obj.modifiers[0], material_input) \
        == bpy.data.materials[preview.MATERIAL_NAMES["ALBEDO_IRRADIANCE"]]
    _scene_for_render()
    px = render_pixels(size=32, engine="CYCLES")
    np.testing.assert_allclose(px[10:22, 10:22, :3].reshape(-1, 3).mean(axis=0),
                               (0.4, 0.4, 0.4), atol=0.02)
    # With a stored 'irradiance' attribute, that is used instead: albedo × 0.25.
    attr = obj.data.attributes.new("irradiance", "FLOAT_COLOR", "POINT")
    attr.data.foreach_set("color", np.tile([0.25, 0.25, 0.25, 1.0], len(pos)).astype(np.float32))
    obj.data.update()
    px = render_pixels(size=32, engine="CYCLES")
    np.testing.assert_allclose(px[10:22, 10:22, :3].reshape(-1, 3).mean(axis=0),
                               (0.2, 0.1, 0.05), atol=0.02)


def test_build_preview_operator(registered_addon):
    obj = _two_colour_surfels(n=4)
    assert bpy.ops.illumap.build_preview() == {"FINISHED"}
    assert len(obj.modifiers) == 1
    assert bpy.ops.illumap.build_preview() == {"FINISHED"}
    assert len(obj.modifiers) == 1
    assert bpy.ops.illumap.clear_results() == {"FINISHED"}
    assert "Illumap Surfels" not in bpy.data.objects
    with pytest.raises(RuntimeError, match="compute an illumination map first"):
        bpy.ops.illumap.build_preview()


@pytest.mark.eevee
@pytest.mark.skipif(os.environ.get(EEVEE_ENV) != "1",
                    reason=f"EEVEE's first headless render takes ~1 min; set {EEVEE_ENV}=1")
def test_eevee_render_shows_illumination(registered_addon):
    from addon.preview import surfel_preview as preview
    obj = _two_colour_surfels()
    preview.build_preview(bpy.context, obj)
    _scene_for_render()
    px = render_pixels(size=32, engine="BLENDER_EEVEE", samples=1)
    left = px[10:22, 9:15, :3].reshape(-1, 3)
    right = px[10:22, 17:23, :3].reshape(-1, 3)
    np.testing.assert_allclose(left.mean(axis=0), RED, atol=0.05)
    np.testing.assert_allclose(right.mean(axis=0), GREEN, atol=0.05)
    assert px[:6, :6, :3].max() < 0.02


# --- the sample scenes ---------------------------------------------------------------------

SAMPLES = os.path.join(os.path.dirname(os.path.dirname(os.path.dirname(os.path.dirname(
    os.path.abspath(__file__))))), "sample_blends")


def _load_make_samples():
    import importlib.util
    spec = importlib.util.spec_from_file_location(
        "illumap_make_samples", os.path.join(SAMPLES, "make_samples.py"))
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def _diffuse_colour(obj):
    mat = obj.data.materials[0]
    node = next(n for n in mat.node_tree.nodes if n.type in {"BSDF_DIFFUSE", "EMISSION"})
    return tuple(round(v, 4) for v in node.inputs["Color"].default_value[:3])


def test_make_samples_writes_small_cornell_and_two_rooms(registered_addon, tmp_path):
    make_samples = _load_make_samples()
    make_samples.main([str(tmp_path)])
    for name in ("cornell_box.blend", "two_rooms.blend"):
        for folder in (SAMPLES, str(tmp_path)):  # the committed files and fresh ones
            assert os.path.getsize(os.path.join(folder, name)) < 300 * 1024, (folder, name)
    bpy.ops.wm.open_mainfile(filepath=str(tmp_path / "cornell_box.blend"))
    scene = bpy.context.scene
    assert scene.render.engine == "CYCLES" and scene.camera is not None
    objs = bpy.data.objects
    assert _diffuse_colour(objs["Left Wall"]) == (0.63, 0.065, 0.05)
    assert _diffuse_colour(objs["Right Wall"]) == (0.14, 0.45, 0.091)
    assert _diffuse_colour(objs["Floor"]) == (0.725, 0.71, 0.68)
    assert _diffuse_colour(objs["Light"]) == (17.0, 12.0, 4.0)
    selected = {o.name for o in bpy.context.selected_objects}
    assert selected == {"Floor", "Ceiling", "Back Wall", "Left Wall", "Right Wall",
                        "Short Block", "Tall Block", "Light"}
    # Cornell's floor is 552.8 × 559.2 mm give or take its slant: about 0.308 m².
    floor_area = sum(p.area for p in objs["Floor"].data.polygons)
    assert floor_area == pytest.approx(0.3082, abs=1e-3)
    # Every wall faces into the box, the light faces down, the red wall is on the camera's left.
    centre = np.array([0.0, 0.0, 0.2744])
    for name in ("Floor", "Ceiling", "Back Wall", "Left Wall", "Right Wall"):
        poly = objs[name].data.polygons[0]
        assert np.dot(np.array(poly.normal), centre - np.array(poly.center)) > 0, name
    assert objs["Light"].data.polygons[0].normal.z < -0.99
    cam_right = np.array(scene.camera.matrix_world.to_3x3().col[0])
    assert np.dot(np.array(objs["Left Wall"].data.polygons[0].center), cam_right) < 0
    bpy.ops.wm.open_mainfile(filepath=str(tmp_path / "two_rooms.blend"))
    assert "Left Divider" in bpy.data.objects and "Right Divider" in bpy.data.objects
    assert bpy.data.objects["Light"].select_get()


@pytest.mark.parametrize("name", ["cornell_box.blend", "two_rooms.blend"])
def test_the_samples_open_in_every_tested_blender_as_files_of_its_own_age_or_older(name):
    """A file from a newer Blender opens with "expect loss of data!" (make_samples.py)."""
    bpy.ops.wm.open_mainfile(filepath=os.path.join(SAMPLES, name))
    assert tuple(bpy.data.version) <= tuple(bpy.app.version_file), (
        tuple(bpy.data.version), bpy.app.version_file)


@requires_core
def test_cornell_box_preview_renders_red_left_green_right(registered_addon):
    """The thin slice: sample scene → Compute → preview discs → Cycles render."""
    bpy.ops.wm.open_mainfile(filepath=os.path.join(SAMPLES, "cornell_box.blend"))
    scene = bpy.context.scene
    scene.illumap.preset = "DRAFT"
    scene.illumap.show_surfels = True       # the diagnostic, asked for
    assert bpy.ops.illumap.compute_illumination_map() == {"FINISHED"}
    surfels = bpy.data.objects["Illumap Surfels"]
    assert len(surfels.modifiers) == 1 and not surfels.hide_render
    for obj in scene.objects:
        if obj.type == "MESH":
            obj.hide_render = True  # only the discs
    px = render_pixels(size=32, engine="CYCLES", samples=4)
    left = px[10:22, 1:4, :3].reshape(-1, 3).mean(axis=0)
    right = px[10:22, 28:31, :3].reshape(-1, 3).mean(axis=0)
    assert left[0] > 3 * left[1], left      # the red wall
    assert right[1] > 1.5 * right[0], right  # the green wall
    assert px[..., :3].max() > 0.0 and np.isfinite(px).all()


def _gap_share(px, margin):
    """Share of pixels inside the frame (``margin`` pixels in) where the magenta world
    (``_magenta_world``) shows through a gap between discs in all of the pixel's samples (a
    hole a pixel wide). Not merely dark pixels: surfels that no light reaches (the floor under
    a block, a block's sealed inside) render black and are no gap."""
    inner = px[margin:-margin, margin:-margin, :3]
    r, g, b = inner[..., 0], inner[..., 1], inner[..., 2]
    return float(np.mean((np.minimum(r, b) > 0.9) & (g < 0.05)))


def _magenta_world(scene):
    """A pure magenta background that no disc's colour comes near, seen only through gaps."""
    from addon import compat
    world = bpy.data.worlds.new("Gaps")
    background = next(n for n in compat.node_tree(world).nodes if n.type == "BACKGROUND")
    background.inputs["Color"].default_value = (1.0, 0.0, 1.0, 1.0)
    background.inputs["Strength"].default_value = 1.0
    scene.world = world


@requires_core
def test_default_discs_close_the_walls_of_the_cornell_box(registered_addon):
    """The preview's discs at the default scale cover the walls: the world shows through in
    fewer spots than with the former 1.5 (gaps of a stratified set reach 1.7 of a
    surfel's radius inside a surface, more along triangle edges)."""
    from addon.preview import surfel_preview as preview
    bpy.ops.wm.open_mainfile(filepath=os.path.join(SAMPLES, "cornell_box.blend"))
    scene = bpy.context.scene
    scene.illumap.preset = "HIGH"
    # The density the scales were measured at (3,094 surfels): denser sets leave gaps below a
    # pixel at this size whatever the scale.
    scene.illumap.sampling = "DENSITY"
    scene.illumap.density = 1600.0
    # The light emits from both faces here, as when the scales were measured: behind a
    # one-sided light the ceiling is black, and it would show through the light's own few
    # discs, which is not a gap in the walls.
    mix = next(n for n in bpy.data.materials["Light"].node_tree.nodes if n.type == "MIX_SHADER")
    for link in list(mix.inputs["Fac"].links):
        bpy.data.materials["Light"].node_tree.links.remove(link)
    mix.inputs["Fac"].default_value = 0.0
    assert scene.illumap.disc_scale == pytest.approx(preview.DEFAULT_DISC_SCALE)
    scene.illumap.show_surfels = True
    assert bpy.ops.illumap.compute_illumination_map() == {"FINISHED"}
    surfels = bpy.data.objects["Illumap Surfels"]
    for obj in scene.objects:
        if obj.type == "MESH" and obj != surfels:
            obj.hide_render = True  # only the discs
    _magenta_world(scene)   # after the solve: the world lights nothing that was computed
    shares = {}
    for scale in (1.5, preview.DEFAULT_DISC_SCALE):
        preview.build_preview(bpy.context, surfels, disc_scale=scale)
        shares[scale] = _gap_share(render_pixels(size=160, engine="CYCLES", samples=4), 12)
    assert shares[preview.DEFAULT_DISC_SCALE] < 0.5 * shares[1.5], shares
    assert shares[preview.DEFAULT_DISC_SCALE] < 5e-4, shares   # measured 3.2e-4 against 2.8e-3
