"""The world's light: read from the world's nodes, shadowed at the surfels, gathered at the
receivers. (Against a Cycles bake: tests/blender/light/test_reference_cases.py, the world-lit
open scene.)"""

import bpy
import numpy as np
import pytest

from illumap_bpy_testing import diffuse_material, make_plane, requires_core, sky_world

from addon.read import lamps
from addon import pipeline

ALBEDO = 0.5


def set_world(color=(0.2, 0.4, 0.6), strength=2.0):
    return sky_world(color, strength)


def test_constant_background_is_colour_times_strength():
    set_world()
    warnings = []
    sky = lamps.world_light(bpy.context.scene, warnings)
    assert sky.kind == "WORLD" and not warnings
    assert np.allclose(sky.color, [0.4, 0.8, 1.2])


def test_black_or_absent_world_adds_no_light():
    set_world(strength=0.0)
    assert lamps.world_light(bpy.context.scene, []) is None
    bpy.context.scene.world = None
    assert lamps.world_light(bpy.context.scene, []) is None


def test_environment_texture_gives_its_solid_angle_mean():
    """An equirectangular image whose rows grow from the south pole up: rows near the poles
    cover less of the sphere, so the mean is weighted by cos(latitude), not a pixel mean."""
    world = set_world(strength=3.0)
    w, h = 16, 8
    image = bpy.data.images.new("Env", w, h, float_buffer=True)
    band = np.arange(h, dtype=np.float32) ** 2
    rows = band[:, None, None] * np.ones((1, w, 4), np.float32)
    rows[..., 3] = 1.0
    image.pixels.foreach_set(rows.ravel())
    tree = world.node_tree
    env = tree.nodes.new("ShaderNodeTexEnvironment")
    env.image = image
    tree.links.new(env.outputs["Color"], tree.nodes["Background"].inputs["Color"])
    warnings = []
    sky = lamps.world_light(bpy.context.scene, warnings)
    latitude = ((np.arange(h) + 0.5) / h - 0.5) * np.pi
    expected = (np.cos(latitude) * band).sum() / np.cos(latitude).sum()
    assert not warnings
    assert np.allclose(sky.color, 3.0 * expected, rtol=1e-6)
    assert not np.isclose(expected, band.mean(), rtol=1e-2)  # the weights matter here


def test_unevaluated_world_nodes_are_warned_about_and_left_out():
    world = set_world()
    tree = world.node_tree
    gradient = tree.nodes.new("ShaderNodeTexGradient")
    tree.links.new(gradient.outputs["Color"], tree.nodes["Background"].inputs["Color"])
    warnings = []
    assert lamps.world_light(bpy.context.scene, warnings) is None
    assert len(warnings) == 1 and "Gradient Texture" in warnings[0] and "left out" in warnings[0]


@requires_core
def test_world_light_is_shadowed_at_the_surfels():
    """A floor under a much larger roof 0.1 m above it sees almost no sky (the open share,
    cos² of the angle to the roof's edge, is < 1e-3); the roof's top sees all of it. Each
    surfel casts 16 rays here, so a surfel near the floor's edge may see one escape (1/16)."""
    set_world()
    white = diffuse_material("D", (ALBEDO,) * 3)
    floor = make_plane("Floor", size=1.0, material=white)
    roof = make_plane("Roof", size=10.0, location=(0, 0, 0.1), material=white)
    job = pipeline.light(pipeline.prepare(bpy.context.evaluated_depsgraph_get(), [floor, roof],
                                          pipeline.Settings(budget=4000, lamps=False)))
    up = job.normals[:, 2] > 0.5
    under = up & (job.positions[:, 2] < 0.05)
    on_top = up & (job.positions[:, 2] > 0.05)
    sky = ALBEDO * np.array([0.4, 0.8, 1.2])
    assert under.sum() > 20 and on_top.sum() > 100
    assert np.abs(job.direct[under]).mean() < 0.01 * sky.max()
    assert np.abs(job.direct[under]).max() <= 1.0001 * sky.max() / 16
    assert np.allclose(job.direct[on_top], sky)   # nothing above it: exactly the sky
    off = pipeline.light(pipeline.prepare(bpy.context.evaluated_depsgraph_get(), [floor, roof],
                                          pipeline.Settings(budget=4000, lamps=False,
                                                            world_ambient=False)))
    assert np.abs(off.direct).max() == 0.0


@requires_core
def test_world_light_reaches_the_meshes_through_the_gather():
    """One upward floor under the sky, nothing else: every corner reads albedo × sky, all of
    it gathered and none of it from the surfels (what the estimate at the objects weighs
    the surfels' error by)."""
    set_world()
    floor = make_plane("Floor", size=1.0, material=diffuse_material("D", (ALBEDO,) * 3))
    result = pipeline.compute(bpy.context, [floor], pipeline.Settings(budget=500, lamps=False))
    assert result.stats["receivers"]["indirect_share"] == pytest.approx(1.0, rel=1e-9)
    assert result.stats["receivers"]["surfel_share"] == pytest.approx(0.0, abs=1e-12)
    rgba = np.empty(len(floor.data.loops) * 4, np.float32)
    attr = floor.data.color_attributes["illumination"]
    attr.data.foreach_get("color", rgba)
    values = rgba.reshape(-1, 4)[:, :3]
    assert np.allclose(values, ALBEDO * np.array([0.4, 0.8, 1.2]), rtol=1e-5)


@requires_core
def test_only_faces_pressed_together_are_covered():
    """A box resting on a floor, lit by the sky, with few surfels (they are far apart): the
    box's bottom and the floor under it get no light, every floor corner outside the box's
    footprint does, however close to it."""
    from reference_helpers import closed_box, diffuse, plane
    set_world()
    floor = plane("Floor", [(-1, -1, 0), (1, -1, 0), (1, 1, 0), (-1, 1, 0)], 0.05, diffuse("F"))
    box = closed_box("Box", (-0.25, -0.25, 0.0), (0.25, 0.25, 0.4), 0.1, diffuse("B"))
    pipeline.compute(bpy.context, [floor, box], pipeline.Settings(budget=300, lamps=False))
    corner_vertex = np.empty(len(floor.data.loops), np.int64)
    floor.data.loops.foreach_get("vertex_index", corner_vertex)
    co = np.empty(len(floor.data.vertices) * 3)
    floor.data.vertices.foreach_get("co", co)
    co = co.reshape(-1, 3)[corner_vertex]
    rgba = np.empty(len(floor.data.loops) * 4, np.float32)
    floor.data.color_attributes["illumination"].data.foreach_get("color", rgba)
    lum = rgba.reshape(-1, 4)[:, :3].mean(axis=1)
    outside = np.abs(co[:, :2]).max(axis=1) > 0.25 + 1e-6
    inside = np.abs(co[:, :2]).max(axis=1) < 0.25 - 1e-6
    assert outside.sum() > 1000 and inside.sum() > 100
    assert lum[outside].min() > 0.05 * lum[outside].max()
    assert lum[inside].max() == 0.0


@requires_core
@pytest.mark.parametrize("budget", [None, 1500], ids=["default", "sparse"])
def test_a_box_bottom_on_a_coarser_floor_is_covered_everywhere(budget):
    """A box (0.1 m cells) on a floor of 0.2 m cells whose grid lines its bottom's vertices
    lie on, lit by the sky: every corner of the box's bottom is covered, also those at the
    corners of the floor's triangles (few of the nearest surfels, which are mostly the box's
    own, lie in those triangles; with few surfels, most of the floor's triangles hold
    none). Uncovered, such a corner looks down past the floor at the sky below and reads
    lit."""
    from reference_helpers import closed_box, diffuse, plane
    set_world()
    floor = plane("Floor", [(-2, -2, 0), (2, -2, 0), (2, 2, 0), (-2, 2, 0)], 0.2, diffuse("F"))
    box = closed_box("Box", (-0.4, -0.6, 0.0), (0.6, 0.4, 0.8), 0.1, diffuse("B"))
    pipeline.compute(bpy.context, [floor, box], pipeline.Settings(lamps=False, budget=budget))
    mesh = box.data
    normal = np.empty(len(mesh.polygons) * 3)
    mesh.polygons.foreach_get("normal", normal)
    loop_start = np.empty(len(mesh.polygons), np.int64)
    mesh.polygons.foreach_get("loop_start", loop_start)
    loop_total = np.empty(len(mesh.polygons), np.int64)
    mesh.polygons.foreach_get("loop_total", loop_total)
    down = np.repeat(normal.reshape(-1, 3)[:, 2] < -0.9, loop_total)
    rgba = np.empty(len(mesh.loops) * 4, np.float32)
    mesh.color_attributes["illumination"].data.foreach_get("color", rgba)
    values = rgba.reshape(-1, 4)[:, :3]
    assert down.sum() == 400
    assert values[down].max() == 0.0
    assert values[~down].min() > 0.0
