"""Generate Illumap's sample scenes (deterministic; run again to rebuild them).

    .venv-blender50/bin/python sample_blends/make_samples.py  # bpy module, as shipped
    blender -b --factory-startup --python sample_blends/make_samples.py
    .venv/bin/python sample_blends/make_samples.py -- /some/folder   # write elsewhere

The shipped files are written by the oldest Blender the tests run (bpy 5.0.1), so that it
opens them without "File written by newer Blender binary, expect loss of data!" (a file from
5.2 also left "Not freed memory blocks" in 5.0); newer versions read older files as usual.

Writes next to this script:

``cornell_box.blend``
    The Cornell box from Cornell's published measurements
    (https://www.graphics.cornell.edu/online/box/data.html), converted from millimetres to
    metres (a 0.556 m box). Cornell's frame is y-up with the camera looking along +z; here
    Blender X = 0.278 − x, Y = z − 0.2796, Z = y (a proper rotation, so the red wall stays on the
    camera's left), which centres the box on the Z axis with its floor at Z = 0.
    Reflectances (Diffuse BSDF colours): white (0.725, 0.71, 0.68), red (0.63, 0.065, 0.05),
    green (0.14, 0.45, 0.091). The light is an emissive quad (Emission colour (17, 12, 4),
    strength 1: radiance in those units) 1 mm below the ceiling (Cornell puts it in the ceiling
    plane; the gap keeps renders free of z-fighting), facing down. All faces are oriented to
    face into the box (block faces outwards). Camera: Cornell's pinhole at (278, 273, −800) mm,
    35 mm lens, 25 mm film. World: black. Engine: Cycles, CPU, 16 samples at 256×256 (small,
    for tests and the README job). All the box's objects are selected (the light too, since it
    is an emitter surface) with the floor active.

``two_rooms.blend``
    Two 2 × 2 × 2.5 m rooms side by side (X from −2 to 2 m), separated by a closed 2 cm thick
    wall at X = 0 (two one-sided quads, one facing each room). A 0.5 m square emitter
    (white, strength 10) hangs 1 cm below the left room's ceiling. With exact visibility the
    right room receives no light at all; without visibility light leaks through the wall, which
    is what visibility work must fix. Top orthographic camera; the ceilings are hidden from the
    camera (Cycles ray visibility) so that both rooms show. All surfaces are white (0.8).
"""

import math
import os
import sys

import bpy

HERE = os.path.dirname(os.path.abspath(__file__))
if os.path.dirname(HERE) not in sys.path:     # the repository root: the scene library
    sys.path.insert(0, os.path.dirname(HERE))

from bench.scenes import cornell  # noqa: E402  (the one Cornell box: numpy only)

WHITE, RED, GREEN, LIGHT = cornell.WHITE, cornell.RED, cornell.GREEN, cornell.RADIANCE
#: The sample's object names for the published surfaces.
_NAMES = {"BackWall": "Back Wall", "RightWall": "Right Wall", "LeftWall": "Left Wall",
          "ShortBlock": "Short Block", "TallBlock": "Tall Block"}
_MATERIALS = {WHITE: "White", RED: "Red", GREEN: "Green"}
#: The published geometry (mm, y up) as (name, material, quads), the light 1 mm below the
#: ceiling (Cornell: in the ceiling plane, y = 548.8).
CORNELL = [(_NAMES.get(name, name), _MATERIALS.get(cornell.COLOURS.get(name), "Light"),
            [[(x, y - 1.0, z) for x, y, z in quad] for quad in quads] if name == "Light"
            else quads)
           for name, quads in cornell.PUBLISHED_MM.items()]
CORNELL_CAMERA_MM = (278.0, 273.0, -800.0)
#: Grid cell of the walls and blocks (m): the light lands on their vertices, so they are fine
#: enough to show the blocks' soft shadows in the mesh preview.
CORNELL_CELL = 0.015
_DEPTH_CENTRE_MM = 279.6


def cornell_to_blender(p):
    """Cornell millimetres (y up) → Blender metres (Z up), box centred on the Z axis."""
    x, y, z = p
    return ((278.0 - x) / 1000.0, (z - _DEPTH_CENTRE_MM) / 1000.0, y / 1000.0)


# --- small builders ----------------------------------------------------------------------

def _sub(a, b):
    return (a[0] - b[0], a[1] - b[1], a[2] - b[2])


def _cross(a, b):
    return (a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0])


def _length(a):
    return math.sqrt(sum(x * x for x in a))


def _dot(a, b):
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]


def _oriented(quad, towards):
    """The quad's corners, reversed if needed so that its normal points along ``towards``
    (a direction, or a callable of the quad's centre returning one)."""
    centre = tuple(sum(c[i] for c in quad) / len(quad) for i in range(3))
    direction = towards(centre) if callable(towards) else towards
    normal = _cross(_sub(quad[1], quad[0]), _sub(quad[2], quad[0]))
    return list(quad) if _dot(normal, direction) >= 0.0 else list(reversed(quad))


def diffuse(name, color):
    mat = bpy.data.materials.new(name)
    if mat.node_tree is None:
        mat.use_nodes = True
    nodes = mat.node_tree.nodes
    nodes.clear()
    out = nodes.new("ShaderNodeOutputMaterial")
    out.location = (200, 0)
    bsdf = nodes.new("ShaderNodeBsdfDiffuse")
    bsdf.inputs["Color"].default_value = (*color, 1.0)
    mat.node_tree.links.new(bsdf.outputs["BSDF"], out.inputs["Surface"])
    mat.diffuse_color = (*color, 1.0)  # viewport solid colour
    return mat


def emission(name, color, strength, one_sided=False):
    """An Emission material; ``one_sided``: the usual one-sided light, Geometry ▸ Backfacing
    mixing it with black (an Emission shader alone emits from both faces in Cycles)."""
    mat = bpy.data.materials.new(name)
    if mat.node_tree is None:
        mat.use_nodes = True
    nodes = mat.node_tree.nodes
    nodes.clear()
    out = nodes.new("ShaderNodeOutputMaterial")
    out.location = (400, 0)
    em = nodes.new("ShaderNodeEmission")
    em.inputs["Color"].default_value = (*color, 1.0)
    em.inputs["Strength"].default_value = strength
    if one_sided:
        black = nodes.new("ShaderNodeEmission")
        black.inputs["Color"].default_value = (0.0, 0.0, 0.0, 1.0)
        facing = nodes.new("ShaderNodeNewGeometry")
        mix = nodes.new("ShaderNodeMixShader")
        mix.location = (200, 0)
        mat.node_tree.links.new(facing.outputs["Backfacing"], mix.inputs["Fac"])
        mat.node_tree.links.new(em.outputs["Emission"], mix.inputs[1])
        mat.node_tree.links.new(black.outputs["Emission"], mix.inputs[2])
        mat.node_tree.links.new(mix.outputs["Shader"], out.inputs["Surface"])
    else:
        mat.node_tree.links.new(em.outputs["Emission"], out.inputs["Surface"])
    peak = max(color)
    mat.diffuse_color = (*(c / peak for c in color), 1.0)
    return mat


def quads_object(name, quads, material, scene, cell=None):
    """A mesh object of planar quads, each split into a grid of cells about ``cell`` metres
    wide (None: one face each). The illumination lands on the mesh's own corners, so a wall
    needs vertices as fine as the shadows it should show."""
    verts, faces = [], []
    for quad in quads:
        if cell is None:
            faces.append(tuple(range(len(verts), len(verts) + len(quad))))
            verts.extend(quad)
            continue
        a, b, c, d = quad
        n = max(1, math.ceil(max(_length(_sub(b, a)), _length(_sub(d, a))) / cell))
        m = max(1, math.ceil(max(_length(_sub(c, b)), _length(_sub(d, a))) / cell))
        base = len(verts)
        for j in range(m + 1):
            for i in range(n + 1):
                u, v = i / n, j / m
                verts.append(tuple((1 - u) * (1 - v) * a[k] + u * (1 - v) * b[k] + u * v * c[k]
                                   + (1 - u) * v * d[k] for k in range(3)))
        for j in range(m):
            for i in range(n):
                q = base + j * (n + 1) + i
                faces.append((q, q + 1, q + n + 2, q + n + 1))
    mesh = bpy.data.meshes.new(name)
    mesh.from_pydata(verts, [], faces)
    mesh.validate()
    mesh.update()
    mesh.materials.append(material)
    obj = bpy.data.objects.new(name, mesh)
    scene.collection.objects.link(obj)
    return obj


def black_world(scene):
    world = bpy.data.worlds.new("Black")
    if world.node_tree is None:
        world.use_nodes = True
    bg = world.node_tree.nodes.get("Background")
    bg.inputs["Color"].default_value = (0.0, 0.0, 0.0, 1.0)
    bg.inputs["Strength"].default_value = 0.0
    world.color = (0.0, 0.0, 0.0)
    scene.world = world


def cycles_settings(scene, size=256, samples=16):
    scene.render.engine = "CYCLES"
    scene.cycles.device = "CPU"
    scene.cycles.samples = samples
    scene.cycles.preview_samples = 8
    scene.cycles.use_denoising = False
    scene.render.resolution_x = size
    scene.render.resolution_y = size
    scene.render.resolution_percentage = 100
    scene.render.image_settings.file_format = "PNG"
    scene.view_settings.view_transform = "Standard"


def select(objects, active, scene):
    layer = scene.view_layers[0]
    for obj in scene.objects:
        obj.select_set(False, view_layer=layer)
    for obj in objects:
        obj.select_set(True, view_layer=layer)
    layer.objects.active = active


def reset():
    bpy.ops.wm.read_factory_settings(use_empty=True)
    scene = bpy.context.scene
    scene.unit_settings.system = "METRIC"
    scene.unit_settings.scale_length = 1.0
    return scene


def save(path):
    bpy.context.preferences.filepaths.save_version = 0  # no .blend1 backups
    bpy.ops.wm.save_as_mainfile(filepath=path, compress=True, check_existing=False)
    return path


# --- the scenes --------------------------------------------------------------------------

def make_cornell_box(path):
    scene = reset()
    scene.name = "Cornell Box"
    mats = {"White": diffuse("White", WHITE), "Red": diffuse("Red", RED),
            "Green": diffuse("Green", GREEN),
            "Light": emission("Light", LIGHT, 1.0, one_sided=True)}
    centre = (0.0, 0.0, 0.2744)
    objects = {}
    for name, mat, quads in CORNELL:
        quads = [[cornell_to_blender(p) for p in quad] for quad in quads]
        if name == "Light":
            towards = (0.0, 0.0, -1.0)
        elif name.endswith("Block"):
            block_centre = tuple(sum(p[i] for q in quads for p in q) / (4 * len(quads))
                                 for i in range(3))
            towards = (lambda bc: (lambda c: _sub(c, bc)))(block_centre)
        else:
            towards = (lambda c: _sub(centre, c))
        quads = [_oriented(q, towards) for q in quads]
        objects[name] = quads_object(name, quads, mats[mat], scene,
                                     cell=None if name == "Light" else CORNELL_CELL)

    cam_data = bpy.data.cameras.new("Camera")
    cam_data.lens = 35.0
    cam_data.sensor_fit = "HORIZONTAL"
    cam_data.sensor_width = 25.0
    cam_data.clip_start = 0.01
    cam_data.clip_end = 10.0
    cam = bpy.data.objects.new("Camera", cam_data)
    cam.location = cornell_to_blender(CORNELL_CAMERA_MM)
    cam.rotation_euler = (1.5707963267948966, 0.0, 0.0)  # look along +Y, Z up
    scene.collection.objects.link(cam)
    scene.camera = cam

    black_world(scene)
    cycles_settings(scene)
    scene["illumap_sample"] = ("Cornell box, published geometry in metres (mm / 1000); "
                               "see sample_blends/make_samples.py")
    select(list(objects.values()), objects["Floor"], scene)
    return save(path)


def _quad_x(x, y0, y1, z0, z1):
    return [(x, y0, z0), (x, y1, z0), (x, y1, z1), (x, y0, z1)]


def _quad_y(y, x0, x1, z0, z1):
    return [(x0, y, z0), (x1, y, z0), (x1, y, z1), (x0, y, z1)]


def _quad_z(z, x0, x1, y0, y1):
    return [(x0, y0, z), (x1, y0, z), (x1, y1, z), (x0, y1, z)]


def make_two_rooms(path):
    scene = reset()
    scene.name = "Two Rooms"
    white = diffuse("White", (0.8, 0.8, 0.8))
    light = emission("Light", (1.0, 1.0, 1.0), 10.0)
    h, t = 2.5, 0.01  # room height, half the wall thickness
    objects = []

    def add(name, quad, towards, mat=white):
        obj = quads_object(name, [_oriented(quad, towards)], mat, scene)
        objects.append(obj)
        return obj

    for side, (x0, x1) in (("Left", (-2.0, -t)), ("Right", (t, 2.0))):
        cx = 0.5 * (x0 + x1)
        inward = (lambda c, cx=cx: _sub((cx, 0.0, h / 2), c))
        add(f"{side} Floor", _quad_z(0.0, x0, x1, -1.0, 1.0), (0, 0, 1))
        ceiling = add(f"{side} Ceiling", _quad_z(h, x0, x1, -1.0, 1.0), (0, 0, -1))
        ceiling.visible_camera = False
        add(f"{side} Front Wall", _quad_y(-1.0, x0, x1, 0.0, h), inward)
        add(f"{side} Back Wall", _quad_y(1.0, x0, x1, 0.0, h), inward)
        outer_x = -2.0 if side == "Left" else 2.0
        add(f"{side} Outer Wall", _quad_x(outer_x, -1.0, 1.0, 0.0, h), inward)
        add(f"{side} Divider", _quad_x(-t if side == "Left" else t, -1.0, 1.0, 0.0, h), inward)
    lamp = add("Light", _quad_z(h - 0.01, -1.25, -0.75, -0.25, 0.25), (0, 0, -1), light)

    cam_data = bpy.data.cameras.new("Top")
    cam_data.type = "ORTHO"
    cam_data.ortho_scale = 4.4
    cam_data.clip_end = 20.0
    cam = bpy.data.objects.new("Top", cam_data)
    cam.location = (0.0, 0.0, 6.0)
    scene.collection.objects.link(cam)
    scene.camera = cam

    black_world(scene)
    cycles_settings(scene, size=256, samples=16)
    scene.render.resolution_y = 128
    scene["illumap_sample"] = ("Two rooms separated by a closed thin wall, light in the left "
                               "room; see sample_blends/make_samples.py")
    select(objects, lamp, scene)
    return save(path)


def main(argv=None):
    """``argv``: [output folder]; by default the arguments after ``--`` (or none: this folder)."""
    if argv is None:
        argv = sys.argv[sys.argv.index("--") + 1:] if "--" in sys.argv else []
    out_dir = argv[0] if argv else HERE
    os.makedirs(out_dir, exist_ok=True)
    for maker, name in ((make_cornell_box, "cornell_box.blend"),
                        (make_two_rooms, "two_rooms.blend")):
        path = maker(os.path.join(out_dir, name))
        print(f"wrote {path} ({os.path.getsize(path) / 1024:.0f} KiB)")


if __name__ == "__main__":
    main()
