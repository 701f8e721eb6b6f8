"""The light evaluated at the meshes' own corners (illumap.gather): emission semantics as in
Cycles, open surfaces lit on both faces, results that do not depend on the run.

Analytic values: a Lambertian emitter of radiance L that fills a receiver's hemisphere gives
it incident radiance L; a unit square of radiance L at height h above a point on its axis
gives L·F with F the point-to-square form factor (0.23945 at h = 1 for a unit square).
"""

import math

import bpy

import numpy as np
import pytest

from illumap_bpy_testing import diffuse_material, emission_material, link, make_plane, requires_core

from addon import pipeline

pytestmark = requires_core
ALBEDO = 0.5
RADIANCE = 4.0


def illumination(obj, domain="POINT"):
    attr = obj.data.color_attributes["illumination"]
    assert attr.domain == domain
    out = np.empty(len(attr.data) * 4, np.float32)
    attr.data.foreach_get("color", out)
    return out.reshape(-1, 4)[:, :3].astype(np.float64)


def one_sided_emission(name, value):
    """Emission on the front face, black on the back: Geometry ▸ Backfacing into a Mix."""
    from addon import compat
    mat = bpy.data.materials.new(name)
    tree = compat.node_tree(mat)
    nodes, links = tree.nodes, tree.links
    nodes.clear()
    out = nodes.new("ShaderNodeOutputMaterial")
    emit = nodes.new("ShaderNodeEmission")
    emit.inputs["Color"].default_value = (value, value, value, 1.0)
    black = nodes.new("ShaderNodeEmission")
    black.inputs["Color"].default_value = (0.0, 0.0, 0.0, 1.0)
    geometry = nodes.new("ShaderNodeNewGeometry")
    mix = nodes.new("ShaderNodeMixShader")
    links.new(geometry.outputs["Backfacing"], mix.inputs["Fac"])
    links.new(emit.outputs[0], mix.inputs[1])
    links.new(black.outputs[0], mix.inputs[2])
    links.new(mix.outputs[0], out.inputs["Surface"])
    return mat


def panel_under_ceiling(material):
    """A 2 m ceiling facing down at z = 1 and a 1 m emitter facing down 1 cm below it."""
    ceiling = make_plane("Ceiling", size=2.0, location=(0, 0, 1.0), flip=True,
                         material=diffuse_material("White", (ALBEDO,) * 3))
    bpy.ops.object.mode_set(mode="OBJECT") if bpy.context.object else None
    panel = make_plane("Panel", size=1.0, location=(0, 0, 0.99), flip=True, material=material)
    return ceiling, panel


def centre_value(obj, radius=0.3):
    """Mean illumination of the vertices within ``radius`` m of the object's axis."""
    co = np.empty(len(obj.data.vertices) * 3)
    obj.data.vertices.foreach_get("co", co)
    near = np.linalg.norm(co.reshape(-1, 3)[:, :2], axis=1) < radius
    return illumination(obj)[near].mean(), int(near.sum())


def subdivided(obj, cuts=8):
    bpy.context.view_layer.objects.active = obj
    bpy.ops.object.mode_set(mode="EDIT")
    bpy.ops.mesh.select_all(action="SELECT")
    bpy.ops.mesh.subdivide(number_cuts=cuts)
    bpy.ops.object.mode_set(mode="OBJECT")
    return obj


def plate_over_floor(cuts):
    """A 6 m floor (``cuts`` subdivisions) under a 2 m single plane at 1 m, both facing up,
    in a straight-down sun; returns (floor, plate)."""
    floor = subdivided(make_plane("Floor", size=6.0, material=diffuse_material("F", (ALBEDO,) * 3)),
                       cuts=cuts)
    plate = make_plane("Plate", size=2.0, location=(0, 0, 1.0),
                       material=diffuse_material("P", (ALBEDO,) * 3))
    sun = bpy.data.lights.new("Sun", "SUN")
    sun.energy = 3.0
    link(bpy.data.objects.new("Sun", sun))
    bpy.context.view_layer.update()
    return floor, plate


@pytest.mark.parametrize("one_sided", [False, True])
def test_emitter_faces_as_in_cycles(one_sided):
    """A plain Emission shader emits from both faces, as in Cycles: the ceiling just behind
    the panel sees almost a hemisphere of radiance L (F ≈ 0.96 at 1 cm under a 1 m panel's
    middle). With the Backfacing idiom the back is black and the ceiling behind stays dark."""
    mat = one_sided_emission("OneSided", RADIANCE) if one_sided else \
        emission_material("Emit", (RADIANCE,) * 3, 1.0)
    ceiling, panel = panel_under_ceiling(mat)
    subdivided(ceiling, cuts=15)
    pipeline.compute(bpy.context, [ceiling, panel], pipeline.Settings(
        budget=2000, transfer_domain="POINT", gather_rays=64))
    value, count = centre_value(ceiling)
    assert count >= 9
    if one_sided:
        assert value < 0.02 * ALBEDO * RADIANCE
    else:
        assert 0.9 * ALBEDO * RADIANCE < value < 1.0 * ALBEDO * RADIANCE


def test_open_plane_reflects_from_its_back_face():
    """A single plane (normal up) hangs over a floor lit by an overhead sun: the floor under
    its middle is in its shadow and gets only what the plane's underside, its back face,
    reflects of the lit floor around. Open surfaces reflect on both faces as in Cycles, so
    that is the same light as under a thin closed slab, whose underside is a front face; a
    one-sided plane would leave the floor there black."""
    floor, plate = plate_over_floor(cuts=29)
    settings = pipeline.Settings(budget=3000, transfer_domain="POINT", gather_rays=256)
    result = pipeline.compute(bpy.context, [floor, plate], settings)
    under, n_under = centre_value(floor)
    lit = ALBEDO * 3.0 / np.pi                                # the floor in the open sun
    assert n_under > 0 and under > 0.03 * lit, (under, lit)
    assert result.stats["receivers"]["indirect_share"] > 0
    bpy.data.objects.remove(plate)
    bpy.ops.mesh.primitive_cube_add(size=1.0, location=(0, 0, 1.0))
    slab = bpy.context.active_object
    slab.scale = (2.0, 2.0, 0.002)
    bpy.ops.object.transform_apply(scale=True)
    slab.data.materials.append(bpy.data.materials["P"])
    pipeline.compute(bpy.context, [floor, slab], settings)
    closed, _ = centre_value(floor)
    assert under == pytest.approx(closed, rel=0.1)


def test_an_open_mesh_whose_back_sees_nothing_is_one_sided_to_the_gather(monkeypatch):
    """A floor's underside faces only the black world: it keeps no back surfels, and the
    gather treats its triangles as one-sided (no back lattice looked up from the plate's back
    surfels metres away), while the plate above, whose underside sees the floor, stays
    two-sided. Nothing can see the floor's underside, so the light at the meshes is what the
    whole open mesh's two sides give, to the bit."""
    from illumap.gather import evaluation
    from illumap.gather.ids import gather_sides
    floor, plate = plate_over_floor(cuts=9)
    settings = pipeline.Settings(budget=3000, transfer_domain="POINT", gather_rays=64)
    job = pipeline.prepare(bpy.context.evaluated_depsgraph_get(), [floor, plate], settings)
    assert {src.name for src in job.sources if src.kind == "BACK"} == {"Plate"}
    sides = gather_sides(pipeline.to_scene(job))
    start = {src.name: int(a) for src, a in zip(
        [src for src in job.sources if src.kind == "MESH"], job.mesh_triangle_start)}
    floor_rows = slice(start["Floor"], start["Floor"] + 2 * 10 * 10)
    plate_rows = slice(start["Plate"], start["Plate"] + 2)
    assert job.two_sided[floor_rows].all() and not sides[floor_rows].any()
    assert sides[plate_rows].all() and len(sides) == len(job.two_sided)
    result = pipeline.run(job)
    monkeypatch.setattr(evaluation, "gather_sides", lambda scene: scene.two_sided)
    both = pipeline.run(job)
    for name, values in result.receiver_values.items():
        np.testing.assert_array_equal(values, both.receiver_values[name], err_msg=name)


def box_on_floor(world: bool):
    """A 0.5 m cube resting on a 3 m floor (9 cuts), under a sky (``world``) or, in a black
    world, a straight-down sun; returns (floor, box)."""
    from illumap_bpy_testing import black_world, sky_world
    (sky_world if world else black_world)()
    floor = subdivided(make_plane("Floor", size=3.0, material=diffuse_material("F", (ALBEDO,) * 3)),
                       cuts=9)
    h = 0.25
    verts = [(x, y, z) for z in (0.0, 2 * h) for y in (-h, h) for x in (-h, h)]
    faces = [(0, 2, 3, 1), (4, 5, 7, 6), (0, 1, 5, 4), (2, 6, 7, 3), (0, 4, 6, 2), (1, 3, 7, 5)]
    mesh = bpy.data.meshes.new("Box")
    mesh.from_pydata(verts, [], faces)
    mesh.materials.append(diffuse_material("B", (ALBEDO,) * 3))
    box = link(bpy.data.objects.new("Box", mesh))
    if not world:
        sun = bpy.data.lights.new("Sun", "SUN")
        sun.energy = 3.0
        link(bpy.data.objects.new("Sun", sun))
    bpy.context.view_layer.update()
    return floor, box


def test_beside_contacts_finds_lattice_points_a_facing_surface_nearly_touches():
    """A point on a floor is beside a contact where a surfel of a surface that faces it lies
    within CONTACT_REACH of that surfel's radii: a face just above it looking down, or a wall
    beside it looking back; not a surface facing the same way, one facing away, or one out
    of reach."""
    from illumap.gather import lattice
    up, down = (0.0, 0.0, 1.0), (0.0, 0.0, -1.0)
    points = np.array([[0.0, 0, 0], [0.3, 0, 0], [1.0, 0, 0], [2.0, 0, 0], [3.0, 0, 0]])
    normals = np.tile(up, (len(points), 1))
    pos = np.array([[0.0, 0, 0.05],       # looks down on the first point from 5 cm
                    [1.0, 0, 0.05],       # faces up, as the floor does
                    [2.0, 0.05, 0.05],    # a wall beside the fourth point, looking back
                    [3.0, 0.05, 0.05]])   # a wall beside the fifth, facing away
    nrm = np.array([down, up, (0.0, -1.0, 0.0), (0.0, 1.0, 0.0)])
    areas = np.full(len(pos), np.pi * 0.05 ** 2)           # radius 5 cm: reach 10 cm
    got = lattice.beside_contacts(points, normals, pos, nrm, areas)
    assert got.tolist() == [0, 3]
    assert lattice.beside_contacts(points[:0], normals[:0], pos, nrm, areas).size == 0


def test_under_a_sky_contacts_gather_afresh_and_the_exact_part_takes_the_sky():
    """Under a sky the exact part casts the sky's shadow rays at the lattice points where the
    surfels' light changes sharply (there is no lamp here), and the points beside the box's
    foot gather the light between box and floor afresh; in a black world with a sun neither
    the sky nor the contact gather runs, and the sun's shadow edge still takes its rays."""
    floor, box = box_on_floor(world=True)
    settings = pipeline.Settings(budget=3000, transfer_domain="POINT", gather_rays=64)
    sky = pipeline.compute(bpy.context, [floor, box], settings).stats["receivers"]
    assert sky["lattice_shadowed"] > 0 and sky["contact_points"] > 0
    bpy.ops.wm.read_factory_settings(use_empty=True)
    floor, box = box_on_floor(world=False)
    sun = pipeline.compute(bpy.context, [floor, box], settings).stats["receivers"]
    assert sun["contact_points"] == 0 and sun["lattice_shadowed"] > 0


def test_gap_candidates_face_a_surface_within_reach_in_front():
    """A receiver may face a gap where a surfel of a surface facing it lies within reach in
    front of it: a floor point under a face looking down on it; not one under a surface
    facing the same way, beside a wall, behind it, or out of reach."""
    from illumap.gather import gaps
    up, down = (0.0, 0.0, 1.0), (0.0, 0.0, -1.0)
    points = np.array([[0.0, 0, 0], [1.0, 0, 0], [2.0, 0, 0], [3.0, 0, 0], [4.0, 0, 0]])
    normals = np.tile(up, (len(points), 1))
    pos = np.array([[0.0, 0, 0.05],        # looks down on the first point from 5 cm
                    [1.0, 0, 0.05],        # faces up, as the floor does
                    [2.0, 0.05, 0.01],     # a wall beside the third point, looking back
                    [3.0, 0, -0.05],       # below the fourth point, looking up at it
                    [4.0, 0, 0.3]])        # looks down from 30 cm: out of reach
    nrm = np.array([down, up, (0.0, -1.0, 0.0), up, down])
    got = gaps.gap_candidates(points, normals, pos, nrm, reach=0.1)
    assert got.tolist() == [0]
    assert gaps.gap_candidates(points[:0], normals[:0], pos, nrm, 0.1).size == 0


def sphere_on_floor(world: bool):
    """The bench's UV sphere (r 0.5 m) resting on a 4 m floor of 0.25 m cells, under a sky
    (``world``) or, in a black world, a sun from 50° off the zenith."""
    from illumap_bpy_testing import black_world, sky_world
    from bench.scenes.blender import uv_sphere
    (sky_world if world else black_world)()
    floor = subdivided(make_plane("Floor", size=4.0, material=diffuse_material("F", (ALBEDO,) * 3)),
                       cuts=15)
    sphere = uv_sphere("Sphere", (0.0, 0.0, 0.5), 0.5, diffuse_material("S", (ALBEDO,) * 3))
    if not world:
        sun = bpy.data.lights.new("Sun", "SUN")
        sun.energy = 2.0
        obj = link(bpy.data.objects.new("Sun", sun))
        obj.rotation_euler = (math.radians(50.0), 0.0, 0.0)
    bpy.context.view_layer.update()
    return floor, sphere


def test_a_lamp_lit_gap_takes_the_lamp_light_across_it():
    """Under a sun, the sphere's lowest receivers face the floor across a gap finer than the
    gather's lattice and take the light at their rays' hits there afresh (the sun's cast at
    the edge of the sphere's shadow, the bounced light gathered), not the lattice's: they
    alone change. Under a sky the
    contact gather does that instead, and no receiver is corrected."""
    from illumap.gather import evaluation
    settings = pipeline.Settings(budget=3000, transfer_domain="POINT", gather_rays=128)
    floor, sphere = sphere_on_floor(world=False)
    stats = pipeline.compute(bpy.context, [floor, sphere], settings).stats["receivers"]
    assert stats["gap_receivers"] > 0
    corrected = illumination(sphere, "POINT")
    real = evaluation.across_gaps
    try:
        evaluation.across_gaps = lambda *a, **k: (0, 0)
        pipeline.compute(bpy.context, [floor, sphere], settings)
    finally:
        evaluation.across_gaps = real
    lattice = illumination(sphere, "POINT")
    z = np.empty(len(sphere.data.vertices) * 3)
    sphere.data.vertices.foreach_get("co", z)
    z = z.reshape(-1, 3)[:, 2]                      # world heights: the object sits at the origin
    low = z < 0.1
    assert low.any()
    # only the receivers just above the floor change (the pole's with them: it touches the
    # floor at a point, which covers nothing, and faces it across the gap), and by more than
    # rounding (whether darker or brighter: test_reference_cases compares them with Cycles)
    assert np.abs(corrected[low] - lattice[low]).max() > 0.01 * lattice[low].max()
    assert np.array_equal(corrected[~low], lattice[~low])
    bpy.ops.wm.read_factory_settings(use_empty=True)
    floor, sphere = sphere_on_floor(world=True)
    sky = pipeline.compute(bpy.context, [floor, sphere], settings).stats["receivers"]
    assert sky["gap_receivers"] == 0 and sky["contact_points"] > 0


def test_same_input_same_result():
    """Two runs of the same scene and settings write the same values (threads, ray order and
    chunking do not enter the result)."""
    ceiling, panel = panel_under_ceiling(emission_material("Emit", (RADIANCE,) * 3, 1.0))
    floor = subdivided(make_plane("Floor", size=2.0, material=diffuse_material("W", (ALBEDO,) * 3)))
    first = None
    for _ in range(2):
        pipeline.compute(bpy.context, [ceiling, panel, floor], pipeline.Settings(
            budget=1500, transfer_domain="CORNER", gather_rays=32))
        values = illumination(floor, "CORNER")
        if first is None:
            first = values
    assert first.max() > 0
    np.testing.assert_array_equal(values, first)
