"""Every scene users have: mirrored, deformed, instanced and far-flung geometry lit right
(issue "Every scene users have"). Each case asserts an invariance against what the light must
not depend on: live modifiers and shape keys against the same deformation applied, a
mirroring scale against the mirror applied, a far object against none, selection order,
instances against real copies; and after every run, that nothing negative, NaN or infinite
was written. Refusals and their clean files are the business of test_bad_scenes.py.
"""

import math

import bpy
import numpy as np
import pytest

from illumap_bpy_testing import (add_lamp, diffuse_material, emission_material, link,
                                 make_plane, requires_core, select_only, sky_world)

from addon import pipeline

pytestmark = requires_core

ATTRIBUTE = "illumination"


# --- scenes and runs -------------------------------------------------------------------------

def settings(**overrides):
    values = dict(budget=1500, gather_rays=64, receiver_shadow_samples=16, transfer=True,
                  transfer_domain="POINT")
    values.update(overrides)
    return pipeline.settings_from_preset("draft", **values)


def written(obj) -> np.ndarray:
    """The ``illumination`` values (elements, 3) written onto ``obj``."""
    attr = obj.data.color_attributes.get(ATTRIBUTE)
    assert attr is not None, f"nothing written to '{obj.name}'"
    out = np.empty(len(attr.data) * 4, dtype=np.float32)
    attr.data.foreach_get("color", out)
    return out.reshape(-1, 4)[:, :3].astype(np.float64)


def check_written() -> None:
    """Nothing negative, NaN or infinite on any mesh or point cloud of the file."""
    for data in list(bpy.data.meshes) + list(bpy.data.pointclouds):
        attrs = getattr(data, "color_attributes", None) or data.attributes
        attr = attrs.get(ATTRIBUTE)
        if attr is None:
            continue
        values = np.empty(len(attr.data) * 4, dtype=np.float32)
        attr.data.foreach_get("color", values)
        assert np.all(np.isfinite(values)), data.name
        assert values.min() >= 0.0, (data.name, float(values.min()))


def compute(objects, **overrides):
    select_only(*objects)
    result = pipeline.compute(bpy.context, objects, settings(**overrides))
    check_written()
    return result


def grid(name, size=2.0, cells=8, location=(0.0, 0.0, 0.0)):
    bpy.ops.mesh.primitive_grid_add(x_subdivisions=cells, y_subdivisions=cells, size=size,
                                    location=location)
    obj = bpy.context.object
    obj.name = obj.data.name = name
    return obj


def box(name, size=0.5, location=(0.0, 0.0, 0.25)):
    bpy.ops.mesh.primitive_cube_add(size=size, location=location)
    obj = bpy.context.object
    obj.name = obj.data.name = name
    return obj


def sphere(name, radius=0.3, location=(0.0, 0.0, 0.3)):
    bpy.ops.mesh.primitive_uv_sphere_add(radius=radius, location=location, segments=16,
                                         ring_count=8)
    obj = bpy.context.object
    obj.name = obj.data.name = name
    bpy.ops.object.shade_smooth()
    return obj


def cylinder(name, location=(0.0, 0.0, 0.3)):
    bpy.ops.mesh.primitive_cylinder_add(vertices=12, radius=0.25, depth=0.6, location=location)
    obj = bpy.context.object
    obj.name = obj.data.name = name
    return obj


def panel(z=1.5, strength=8.0):
    return make_plane("Panel", size=0.8, location=(0.2, 0.1, z), flip=True,
                      material=emission_material("Glow", (1.0, 1.0, 1.0), strength))


SHAPES = {"floor": lambda: grid("Shape", 1.6, 6, (0.0, 0.0, 0.05)), "box": lambda: box("Shape"),
          "sphere": lambda: sphere("Shape"), "cylinder": lambda: cylinder("Shape")}


def lit_scene(shape):
    """A floor under an emitting panel, with ``shape`` on it; returns (shape, objects)."""
    bpy.ops.wm.read_factory_settings(use_empty=True)
    floor = grid("Floor", 4.0, 10)
    obj = SHAPES[shape]()
    obj.data.materials.append(diffuse_material("Paint", (0.7, 0.5, 0.3)))
    return obj, [floor, obj, panel()]


def apply(obj, **kw):
    for other in bpy.context.view_layer.objects:
        other.select_set(False)
    obj.select_set(True)
    bpy.context.view_layer.objects.active = obj
    bpy.ops.object.transform_apply(**kw)


# --- mirroring by scale ----------------------------------------------------------------------

def apply_mirror(obj):
    """Apply ``obj``'s mirroring scale to its vertices as Blender's Apply Scale does in 5.2:
    the coordinates mirrored and, for an odd number of mirrors, the faces flipped so that they
    face the way they did (5.0's Apply left them inside out)."""
    scale = np.array(obj.scale, dtype=np.float64)
    mesh = obj.data
    co = np.empty(len(mesh.vertices) * 3, dtype=np.float32)
    mesh.vertices.foreach_get("co", co)
    mesh.vertices.foreach_set("co", (co.reshape(-1, 3) * scale).astype(np.float32).ravel())
    if np.prod(scale) < 0:
        mesh.flip_normals()
    mesh.update()
    obj.scale = (1.0, 1.0, 1.0)

MIRRORS = {"x": (-1, 1, 1), "y": (1, -1, 1), "z": (1, 1, -1), "xy": (-1, -1, 1),
           "xz": (-1, 1, -1), "yz": (1, -1, -1), "xyz": (-1, -1, -1)}


@pytest.mark.parametrize("axes", list(MIRRORS))
@pytest.mark.parametrize("shape", list(SHAPES))
def test_a_mirroring_scale_lights_as_the_mirror_applied(shape, axes):
    """Live: the shape scaled by −1 along ``axes``; applied: the same scale applied to its
    vertices (Blender flips the faces' winding). Every vertex reads the same to 1e-4 of the
    scene's light, and a lit shape is not black."""
    values = []
    for applied in (False, True):
        obj, objects = lit_scene(shape)
        obj.scale = MIRRORS[axes]
        if applied:
            apply_mirror(obj)
        compute(objects)
        values.append(written(obj))
    live, baked = values
    top = max(float(baked.max()), 1e-12)
    assert np.abs(live - baked).max() <= 1e-4 * top
    if shape != "floor" or "z" not in axes:   # a floor turned upside down faces away
        assert live.max() > 0.01


# --- deformation: shape keys and modifiers ---------------------------------------------------

def _shape_key(obj, move):
    obj.shape_key_add(name="Basis")
    key = obj.shape_key_add(name="Pose")
    co = np.array([v.co for v in obj.data.vertices])
    key.data.foreach_set("co", move(co).astype(np.float32).ravel())
    key.value = 1.0


def _modifier(kind, **props):
    def add(obj):
        mod = obj.modifiers.new(kind.title(), kind)
        for k, v in props.items():
            if k == "texture":
                v = bpy.data.textures.new("Noise", "CLOUDS")
                v.noise_scale = 0.6
            setattr(mod, k, v)
    return add


DEFORMS = {
    "shape_key_raise": ("box", lambda o: _shape_key(o, lambda c: c + [0.0, 0.0, 0.3])),
    "shape_key_squash": ("sphere", lambda o: _shape_key(o, lambda c: c * [1.3, 1.3, 0.6])),
    "shape_key_lean": ("cylinder", lambda o: _shape_key(o, lambda c: c + np.outer(c[:, 2], [0.4, 0, 0]))),
    "displace": ("floor", _modifier("DISPLACE", texture=True, strength=0.3)),
    "displace_box": ("box", _modifier("DISPLACE", strength=0.1)),
    "simple_deform_bend": ("floor", _modifier("SIMPLE_DEFORM", deform_method="BEND", angle=0.8)),
    "simple_deform_twist": ("box", _modifier("SIMPLE_DEFORM", deform_method="TWIST", angle=0.7)),
    "smooth": ("box", _modifier("SMOOTH", factor=0.8, iterations=4)),
    "cast": ("box", _modifier("CAST", factor=0.7)),
    "wave": ("floor", _modifier("WAVE", height=0.15, width=0.8)),
    "laplacian_smooth": ("cylinder", _modifier("LAPLACIANSMOOTH", lambda_factor=0.8)),
    "subsurf": ("box", _modifier("SUBSURF", levels=2, render_levels=2)),
    "subsurf_simple_displace": ("floor", lambda o: (_modifier("SUBSURF", levels=2, render_levels=2,
                                                              subdivision_type="SIMPLE")(o),
                                                    _modifier("DISPLACE", texture=True,
                                                              strength=0.3)(o))),
    "subsurf_sphere": ("sphere", _modifier("SUBSURF", levels=1, render_levels=1)),
}


def _apply_deformation(obj):
    bpy.context.view_layer.objects.active = obj
    for other in bpy.context.view_layer.objects:
        other.select_set(other == obj)
    if obj.data.shape_keys is not None:
        bpy.ops.object.shape_key_remove(all=True, apply_mix=True)
    for mod in list(obj.modifiers):
        bpy.ops.object.modifier_apply(modifier=mod.name)


@pytest.mark.parametrize("case", list(DEFORMS))
def test_live_deformation_lights_as_the_deformation_applied(case):
    """The light at each vertex on the live, deformed surface against the same deformation
    applied (Subdivision keeps the original vertices first, so vertex v is vertex v): the mean
    within 2% and each vertex within 10% of the brightest."""
    shape, deform = DEFORMS[case]
    values = []
    for applied in (False, True):
        obj, objects = lit_scene(shape)
        deform(obj)
        if applied:
            _apply_deformation(obj)
        compute(objects)
        values.append(written(obj))
    live, baked = values
    baked = baked[:len(live)]
    assert live.mean() > 0.01
    assert abs(live.mean() - baked.mean()) <= 0.02 * baked.mean()
    assert np.abs(live - baked).max() <= 0.1 * baked.max()


def test_a_modifier_that_changes_the_faces_is_named():
    """A Bevel changes the faces: the corners have no place on the evaluated surface, so the
    mesh gets no attribute and a warning names the modifier; the rest is lit."""
    obj, objects = lit_scene("box")
    obj.modifiers.new("Edges", "BEVEL").width = 0.05
    result = compute(objects)
    assert ATTRIBUTE not in obj.data.color_attributes
    assert any("'Edges'" in w and "Shape" in w for w in result.warnings), result.warnings
    assert written(bpy.data.objects["Floor"]).max() > 0.01


# --- far objects -----------------------------------------------------------------------------

LIGHTS = ("panel", "point", "sun", "sky")


def room(light):
    """A closed room (inward faces) lit by ``light``; returns (room, objects)."""
    bpy.ops.wm.read_factory_settings(use_empty=True)
    bpy.ops.mesh.primitive_cube_add(size=4.0, location=(0.0, 0.0, 2.0))
    obj = bpy.context.object
    obj.name = "Room"
    bpy.ops.object.mode_set(mode="EDIT")
    bpy.ops.mesh.subdivide(number_cuts=3)
    if light in ("panel", "point"):
        bpy.ops.mesh.flip_normals()
    bpy.ops.object.mode_set(mode="OBJECT")
    objects = [obj]
    if light == "panel":
        objects.append(panel(z=3.5, strength=5.0))
    elif light == "point":
        add_lamp("POINT", location=(0.3, 0.2, 3.0), energy=300.0)
    elif light == "sun":
        add_lamp("SUN", rotation=(0.5, 0.2, 0.3), energy=2.0)
    else:
        sky_world((0.5, 0.6, 0.9))
    return obj, objects


@pytest.mark.parametrize("far", [1e2, 1e4, 1e6])
@pytest.mark.parametrize("light", LIGHTS)
def test_a_far_object_leaves_the_corners_alone(light, far):
    """A 1 cm plane selected ``far`` metres away changes no corner by more than 1e-3 of the
    room's light: the exact solve, converged far below that (an iterative solve stops within
    its tolerance of the answer, wherever that is), so that what is measured is the corners'
    evaluation."""
    values = []
    for with_far in (False, True):
        obj, objects = room(light)
        if with_far:
            objects.append(make_plane("Far", size=0.01, location=(far, 0.0, 0.0)))
        compute(objects, method="direct", tol=1e-6)
        values.append(written(obj))
    alone, beside = values
    assert alone.max() > 0.01
    assert np.abs(alone - beside).max() <= 1e-3 * alone.max()


@pytest.mark.parametrize("far", [1e2, 1e6])
def test_a_far_object_leaves_the_fmm_solve_alone(far):
    """The same with the FMM at the preset's own settings."""
    values = []
    for with_far in (False, True):
        obj, objects = room("panel")
        if with_far:
            objects.append(make_plane("Far", size=0.01, location=(far, 0.0, 0.0)))
        compute(objects)
        values.append(written(obj))
    alone, beside = values
    assert np.abs(alone - beside).max() <= 1e-3 * alone.max()


# --- selections ------------------------------------------------------------------------------

def _selection_scene():
    obj, objects = lit_scene("box")
    cam = link(bpy.data.objects.new("Camera", bpy.data.cameras.new("Camera")))
    lamp = add_lamp("POINT", location=(1.0, -1.0, 2.0), energy=50.0)
    empty = link(bpy.data.objects.new("Helper", None))
    return obj, objects, [cam, lamp, empty]


@pytest.mark.parametrize("extra", ["reversed", "with_camera", "with_lamp", "with_empty",
                                   "all_helpers", "active_last"])
def test_what_else_is_selected_changes_nothing(extra):
    """The order of the selection and the helpers selected with it leave every value as it
    is, bit for bit."""
    obj, objects, helpers = _selection_scene()
    compute(objects)
    base = written(obj).copy()
    chosen = {"reversed": objects[::-1], "with_camera": objects + helpers[:1],
              "with_lamp": objects + helpers[1:2], "with_empty": objects + helpers[2:],
              "all_helpers": helpers + objects, "active_last": objects[1:] + objects[:1]}[extra]
    result = compute(chosen)
    assert np.array_equal(written(obj), base)
    assert not any("left out" in w for w in result.warnings), result.warnings


def test_an_unreadable_object_is_named():
    """A selected Text object is read as a mesh; a selected Volume or hair is not geometry
    Illumap reads: named in a warning, the rest lit."""
    obj, objects = lit_scene("box")
    volume = link(bpy.data.objects.new("Fog", bpy.data.volumes.new("Fog")))
    result = compute(objects + [volume])
    assert any("'Fog'" in w and "left out" in w for w in result.warnings), result.warnings
    assert written(obj).max() > 0.01


# --- instances -------------------------------------------------------------------------------

def _blocker_collection():
    col = bpy.data.collections.new("Blocker")
    quad = make_plane("Quad", size=1.0)
    bpy.context.scene.collection.objects.unlink(quad)
    col.objects.link(quad)
    return col, quad


def _instance_scene(kind):
    """A floor under a point lamp with a 1 m quad 1 m above it: a real quad, or a collection
    instance of it (``kind``: 'real', 'instance', 'rotated', 'nested'). Returns (floor,
    objects)."""
    bpy.ops.wm.read_factory_settings(use_empty=True)
    add_lamp("POINT", location=(0.0, 0.0, 3.0), energy=500.0)
    floor = grid("Floor", 4.0, 20)
    col, quad = _blocker_collection()
    if kind == "real":
        bpy.context.scene.collection.objects.link(quad)
        quad.location = (0.0, 0.0, 1.0)
        return floor, [floor, quad]
    source = col
    if kind == "nested":
        outer = bpy.data.collections.new("Outer")
        inner = link(bpy.data.objects.new("InnerInstance", None))
        bpy.context.scene.collection.objects.unlink(inner)
        outer.objects.link(inner)
        inner.instance_type, inner.instance_collection = "COLLECTION", col
        source = outer
    empty = link(bpy.data.objects.new("Instance", None))
    empty.instance_type, empty.instance_collection = "COLLECTION", source
    empty.location = (0.0, 0.0, 1.0)
    if kind == "rotated":
        empty.rotation_euler = (0.0, 0.0, math.pi / 4)
        empty.scale = (-1.0, 1.0, 1.0)
    return floor, [floor, empty]


def _centre(floor, values):
    co = np.array([v.co for v in floor.data.vertices])
    return values[np.linalg.norm(co[:, :2], axis=1) < 0.25].mean()


@pytest.mark.parametrize("kind", ["instance", "rotated", "nested"])
def test_a_collection_instance_shadows_as_a_real_copy(kind):
    """The floor under an instanced quad is shadowed as under a real quad (its centre within
    5%), far below the unshadowed floor, and a warning says the instances get no attribute."""
    floor, objects = _instance_scene("real")
    compute(objects)
    real = _centre(floor, written(floor))
    floor, objects = _instance_scene(kind)
    result = compute(objects)
    inst = _centre(floor, written(floor))
    assert abs(inst - real) <= 0.05 * real + 1e-3
    bpy.ops.wm.read_factory_settings(use_empty=True)
    add_lamp("POINT", location=(0.0, 0.0, 3.0), energy=500.0)
    bare = grid("Floor", 4.0, 20)
    compute([bare])
    assert inst < 0.2 * _centre(bare, written(bare))
    assert any("'Instance'" in w and "instance" in w for w in result.warnings), result.warnings


def test_an_instance_of_an_empty_collection_is_named():
    floor, objects = _instance_scene("instance")
    empty = objects[1]
    empty.instance_collection = bpy.data.collections.new("Nothing")
    result = compute(objects)
    assert any("'Instance'" in w and "holds no mesh" in w for w in result.warnings), result.warnings


# --- values a renderer can trust -------------------------------------------------------------

def test_interpenetrating_cubes_write_nothing_negative():
    bpy.ops.wm.read_factory_settings(use_empty=True)
    floor = grid("Floor", 3.0, 6)
    a = box("A", 0.6, (0.0, 0.0, 0.3))
    b = box("B", 0.6, (0.2, 0.15, 0.45))
    b.rotation_euler = (0.3, 0.2, 0.4)
    result = compute([floor, a, b, panel()])
    assert {"negative_surfels", "negative_receivers"} <= result.stats.keys()   # reported
    assert written(a).min() >= 0.0 and written(b).min() >= 0.0


def test_a_bevelled_small_curve_writes_nothing_negative():
    bpy.ops.wm.read_factory_settings(use_empty=True)
    floor = grid("Floor", 1.0, 4)
    curve = bpy.data.curves.new("Wire", "CURVE")
    curve.dimensions = "3D"
    curve.bevel_depth = 0.01
    spline = curve.splines.new("POLY")
    spline.points.add(3)
    for p, co in zip(spline.points, [(-0.02, 0, 0.03), (0, 0.02, 0.04), (0.02, 0, 0.05), (0, -0.02, 0.06)]):
        p.co = (*co, 1.0)
    wire = link(bpy.data.objects.new("Wire", curve))
    compute([floor, wire, panel(z=0.5)])


@pytest.mark.parametrize("light", ["panel", "point"])
def test_a_closed_mesh_lit_only_from_inside(light):
    """Outward normals around the light: a point lamp inside is refused (nothing lights any
    surface); an emitting panel inside gets a warning that says to flip the normals."""
    bpy.ops.wm.read_factory_settings(use_empty=True)
    shell = box("Shell", 2.0, (0.0, 0.0, 1.0))
    objects = [shell]
    if light == "panel":
        objects.append(panel(z=1.0))
        result = compute(objects)
        assert any("'Shell'" in w and "Flip" in w for w in result.warnings), result.warnings
    else:
        add_lamp("POINT", location=(0.0, 0.0, 1.0), energy=100.0)
        with pytest.raises(pipeline.IllumapError, match="light"):
            compute(objects)
        assert ATTRIBUTE not in shell.data.color_attributes


# --- point clouds ----------------------------------------------------------------------------

def scan(name="Scan", normals=False, seed=3):
    """A scanned patch: 400 jittered points on a 1.2 m square at z = 0 (a vertex-only mesh),
    with a ``normal`` attribute (up) when ``normals``."""
    rng = np.random.default_rng(seed)
    xs = (np.arange(20) + 0.5) / 20 * 1.2 - 0.6
    x, y = np.meshgrid(xs, xs, indexing="ij")
    pos = np.column_stack([x.ravel(), y.ravel(), np.zeros(x.size)])
    pos[:, :2] += rng.uniform(-0.015, 0.015, (len(pos), 2))
    mesh = bpy.data.meshes.new(name)
    mesh.vertices.add(len(pos))
    mesh.vertices.foreach_set("co", pos.astype(np.float32).ravel())
    if normals:
        attr = mesh.attributes.new("normal", "FLOAT_VECTOR", "POINT")
        attr.data.foreach_set("vector", np.tile([0.0, 0.0, 1.0], len(pos)).astype(np.float32))
    mesh.update()
    return link(bpy.data.objects.new(name, mesh))


def _mirror_data(obj, scale):
    """Mirror ``obj``'s points (and its ``normal`` attribute) in its data, as applying the
    scale would (Blender's Apply leaves a custom normal attribute as it is)."""
    mesh = obj.data
    co = np.empty(len(mesh.vertices) * 3, dtype=np.float32)
    mesh.vertices.foreach_get("co", co)
    mesh.vertices.foreach_set("co", (co.reshape(-1, 3) * scale).astype(np.float32).ravel())
    attr = mesh.attributes.get("normal")
    if attr is not None:
        n = np.empty(len(mesh.vertices) * 3, dtype=np.float32)
        attr.data.foreach_get("vector", n)
        attr.data.foreach_set("vector", (n.reshape(-1, 3) * scale).astype(np.float32).ravel())
    mesh.update()


@pytest.mark.parametrize("axes", ["x", "y", "xy"])
@pytest.mark.parametrize("normals", [False, True], ids=["estimated", "given"])
def test_a_mirrored_scan_lights_as_the_mirror_applied(normals, axes):
    """A scan under a lamp, mirrored by its object's scale or in its data: every point reads
    the same to 1e-4 of the brightest."""
    values = []
    for applied in (False, True):
        bpy.ops.wm.read_factory_settings(use_empty=True)
        add_lamp("POINT", location=(0.2, 0.1, 1.0), energy=60.0)
        obj = scan(normals=normals)
        if applied:
            _mirror_data(obj, np.array(MIRRORS[axes], dtype=np.float64))
        else:
            obj.scale = MIRRORS[axes]
        compute([obj])
        values.append(written(obj))
    live, baked = values
    assert live.max() > 0.01
    assert np.abs(live - baked).max() <= 1e-4 * baked.max()


@pytest.mark.parametrize("far", [1e3, 1e6])
def test_a_far_object_leaves_a_scan_alone(far):
    values = []
    for with_far in (False, True):
        bpy.ops.wm.read_factory_settings(use_empty=True)
        add_lamp("POINT", location=(0.2, 0.1, 1.0), energy=60.0)
        objects = [scan(normals=True)]
        if with_far:
            objects.append(make_plane("Far", size=0.01, location=(far, 0.0, 0.0)))
        compute(objects, method="direct", tol=1e-6)
        values.append(written(objects[0]))
    alone, beside = values
    assert np.abs(alone - beside).max() <= 1e-3 * alone.max()


# --- lamps -----------------------------------------------------------------------------------

@pytest.mark.parametrize("kind", ["POINT", "SPOT", "AREA", "SUN"])
def test_a_mirrored_lamp_lights_as_the_lamp_itself(kind):
    """A lamp scaled by −1 along x (its own axis across the beam) lights a floor as the same
    lamp unscaled: its beam, cone and area are the same."""
    values = []
    for mirrored in (False, True):
        bpy.ops.wm.read_factory_settings(use_empty=True)
        floor = grid("Floor", 3.0, 10)
        props = dict(energy=3.0) if kind == "SUN" else dict(energy=80.0)
        if kind == "AREA":
            props.update(size=0.5)
        if kind == "SPOT":
            props.update(spot_size=1.0)
        lamp = add_lamp(kind, location=(0.3, 0.2, 1.5), rotation=(0.3, 0.1, 0.0), **props)
        if mirrored:
            lamp.scale = (-1.0, 1.0, 1.0)
        compute([floor])
        values.append(written(floor))
    plain, flipped = values
    assert plain.max() > 0.01
    assert np.abs(plain - flipped).max() <= 1e-4 * plain.max()
