"""The scenes built as meshes, declared as plain data (``spec.Scene``; numpy, no bpy):
``blender.build`` turns them into Blender objects.

Reference scenes (``REFERENCE``), scored against Cycles bakes by ``bench/reference``:

* ``cornell``: the Cornell box from Cornell's published measurements (``cornell.py``) × 0.005,
  i.e. a 2.8 m room, Z up (x_blender = (556 − x), y_blender = z, z_blender = y, a rotation, so
  the red wall is on the left seen from the open front at y = 0). Radiometry is scale-free, but
  Illumap's default density is per m², so the scale sets its surfel count: 0.005 makes the box
  a room of the size users light. Walls are grids of ~0.1 m cells, the blocks' five published
  faces (no bottom, as published) grids of ~0.1 m cells resting exactly on the floor; the light
  the published 130 × 105 mm quad (0.65 × 0.525 m here) 1 mm under the ceiling, one-sided,
  radiance (17, 12, 4).
* ``room``: a closed 5 × 4 × 2.6 m room (walls + ceiling one object, 0.25 m cells), a floor with a
  packed 56 × 56 px sRGB checker image (0.1 m cells, UVs 0–1), a 1 m area lamp under the
  ceiling and a small point lamp, a subdivided box, a triangulated tall box and a UV sphere on
  the floor.
* ``lamps``: an open scene: a 12 m floor, a single-plane wall and a tilted single-plane awning
  (open surfaces: Cycles reflects on both faces), a box and a sphere on the floor, a spot lamp
  and a sun lamp.
* ``world``: an open scene under a constant sky (Background colour × strength, no lamps): a
  floor, a box resting on it, a sphere, a single-plane wall and a two-sided emissive panel
  (a plain Emission shader, which Cycles emits from both faces).
* ``scan_room``: the Cornell box given to Illumap as a scan, its walls' and blocks' vertices
  as one point cloud without normals, scored at those points against ``cornell``'s reference.
* ``scan_object``: the Stanford bunny (a real range scan; test data, credited in
  ``shapes.BUNNY_CREDIT``) on a floor under the sky and a sun, the bunny's vertices given to
  Illumap as a point cloud without normals, Cycles baking the scan's own triangles.
* ``window``: a 4 × 3 × 2.5 m room lit only through a 1.6 × 1.2 m window, by the sky and a sun
  whose patch falls on a wood floor around a table; a cabinet against a wall (open at its
  back, which the wall closes) and a ball on the floor. Most of its light has bounced several
  times off the walls. Built after the constants of the automatic mode were set, to check
  them on a scene they were not fitted to (the first run found two biases, both fixed).
* ``monkey``: Blender's Suzanne, subdivided once (smoothed) and smooth-shaded, resting on a
  floor, an area and a point lamp and a dim sky. The mesh is what users test with, and it is
  not closed (84 boundary edges; the eyes are separate parts pushed into the head): Illumap
  gives it two sides. A known failure (docs/stability.md, known limits), kept to reproduce it.
* ``near``: stability cases side by side, 20 m apart: an emitter 1 mm under a ceiling above a
  floor; a room corner lit by a point lamp; a floor strip against a wall under an area lamp; a
  thin plate (a 5 mm slab, what Solidify makes) lit from one side by a spot above a floor; a
  sphere lit by a point lamp.

Preview scenes (``preview_room``, ``preview_bunny``; ``preview.py`` builds and scans them):
a 1 m room like Cornell's with a block and a one-sided emitter, its grids optionally jittered
in their planes (the points of a scan that still lie on the surfaces), and the bunny on a
finer floor, each with a camera.

Materials are Diffuse BSDF, or Principled BSDF with its specular layer off (a matte paint), so
both renderers see a purely diffuse surface. One-sided emitters emit along their normal only,
as Illumap's surfels do.
"""

from __future__ import annotations

import math

import numpy as np

from . import cornell as cornell_box
from .shapes import (box_faces, box_parts, bunny_scan, facing, grid_patch, jittered_patch,
                     quad_parts)
from .spec import Camera, Lamp, Material, Mesh, Scene, raw_part

#: Metres per published millimetre of the Cornell box (see the module docstring).
CORNELL_SCALE = 0.005
#: Distance of an emitter below the surface it hangs from, m.
EMITTER_GAP = 0.001
#: The open scenes' sky (linear RGB radiance at strength 1) and the emissive panel's radiance.
SKY = (0.5, 0.65, 1.0)
PANEL_RADIANCE = (4.0, 3.0, 1.5)
#: The bunny's scale in the scenes (about 0.5 m tall).
BUNNY_SCALE = 3.3


def diffuse(name: str, color) -> Material:
    """A Diffuse BSDF of constant linear ``color``."""
    return Material(name, "diffuse", tuple(color))


def matte(name: str, color, image: str | None = None) -> Material:
    """A Principled BSDF without its specular layer, of ``color`` or of texture ``image``."""
    return Material(name, "matte", tuple(color), image=image)


def one_sided(name: str, radiance) -> Material:
    """An emitter of ``radiance`` from its front face only."""
    return Material(name, "emit", radiance=tuple(radiance))


def plane(name: str, corners, toward, cell: float, material: Material, **kw) -> Mesh:
    """A planar quad's grid of ``cell`` m, facing ``toward``."""
    return Mesh(name, material, parts=quad_parts(corners, toward, cell), **kw)


def sphere(name: str, centre, radius: float, material: Material) -> Mesh:
    """Blender's UV sphere (32 × 16)."""
    return Mesh(name, material, shape="uv_sphere", centre=tuple(centre), radius=radius)


# --- the reference scenes --------------------------------------------------------------------

def cornell(cell: float = 0.1) -> Scene:
    """The Cornell box (see the module docstring), walls and blocks as grids of ``cell`` m."""
    mats = {c: diffuse(n, c) for n, c in (("White", cornell_box.WHITE), ("Red", cornell_box.RED),
                                          ("Green", cornell_box.GREEN))}
    quads_of = cornell_box.published_quads(CORNELL_SCALE)
    room_centre = cornell_box.to_blender(cornell_box.ROOM_CENTRE_MM, CORNELL_SCALE)
    objects = []
    for name, colour in cornell_box.COLOURS.items():
        quads = quads_of[name]
        if name.endswith("Block"):
            centre = np.concatenate(quads).mean(axis=0)
            parts = [grid_patch(facing(q, q.mean(axis=0) - centre), cell) for q in quads]
        else:
            parts = [grid_patch(facing(q, room_centre - q.mean(axis=0)), cell) for q in quads]
        objects.append(Mesh(name, mats[colour], parts=parts))
    light_quad = quads_of["Light"][0]
    light_quad[:, 2] -= EMITTER_GAP
    objects.append(Mesh("Light", one_sided("Light", cornell_box.RADIANCE),
                        parts=[grid_patch(facing(light_quad, (0, 0, -1)), 1.0)], role="emitter"))
    return Scene("cornell", objects,
                 f"Cornell's published box x {CORNELL_SCALE} m/mm, {cell} m cells, "
                 f"one-sided light {EMITTER_GAP * 1000:g} mm under the ceiling")


def room() -> Scene:
    """A closed, lamp-lit room with a textured floor, two boxes and a sphere."""
    paint = matte("Paint", (0.8, 0.78, 0.74))
    lo, hi = np.array([-2.5, -2.0, 0.0]), np.array([2.5, 2.0, 2.6])
    objects = [
        Mesh("Walls", paint, parts=box_parts(lo, hi, 0.25, inward=True, skip=("-z",))),
        plane("Floor", [(lo[0], lo[1], 0), (hi[0], lo[1], 0), (hi[0], hi[1], 0),
                        (lo[0], hi[1], 0)], (0, 0, 1), 0.1,
              matte("FloorChecker", (1.0, 1.0, 1.0), image="checker"), uv=True),
        Mesh("Box", diffuse("Orange", (0.8, 0.35, 0.1)),
             parts=box_parts((-1.6, -1.2, 0.0), (-0.8, -0.6, 0.7), 0.1)),
        Mesh("TallBox", matte("Teal", (0.1, 0.5, 0.45)),
             parts=box_parts((0.9, 0.6, 0.0), (1.4, 1.1, 1.2), 0.15), triangulate=True),
        sphere("Sphere", (0.2, -0.6, 0.35), 0.35, diffuse("Blue", (0.15, 0.25, 0.7))),
        Lamp("CeilingArea", "AREA", (0.0, 0.0, 2.55), dict(energy=400.0, size=1.0)),
        Lamp("SmallPoint", "POINT", (-1.8, 1.4, 1.8), dict(energy=60.0, shadow_soft_size=0.05)),
    ]
    return Scene("room", objects, "closed 5 x 4 x 2.6 m room, checker floor, area + point lamp")


def lamps() -> Scene:
    """An open scene lit by a spot and a sun lamp, with open (single-plane) surfaces."""
    white = matte("WhitePaint", (0.8, 0.8, 0.8))
    objects = [
        plane("Floor", [(-6, -6, 0), (6, -6, 0), (6, 6, 0), (-6, 6, 0)], (0, 0, 1), 0.25,
              diffuse("Grey", (0.5, 0.5, 0.5))),
        # A free-standing wall, one plane facing −y (toward the lamps), 4 m × 2.5 m.
        plane("Wall", [(-2, 1.5, 0), (2, 1.5, 0), (2, 1.5, 2.5), (-2, 1.5, 2.5)], (0, -1, 0),
              0.2, white),
        # An awning sloping down from the wall's top, facing up.
        plane("Awning", [(-1.5, 1.5, 2.3), (1.5, 1.5, 2.3), (1.5, 0.0, 1.9), (-1.5, 0.0, 1.9)],
              (0, 0, 1), 0.15, white),
        Mesh("Box", diffuse("Red", (0.7, 0.12, 0.1)),
             parts=box_parts((1.0, -1.5, 0.0), (2.0, -0.5, 0.8), 0.1)),
        sphere("Sphere", (-1.2, -0.8, 0.5), 0.5, diffuse("Yellow", (0.75, 0.6, 0.15))),
        Lamp("Spot", "SPOT", (3.0, -4.0, 5.0),
             dict(energy=3000.0, spot_size=math.radians(60.0), spot_blend=0.2,
                  shadow_soft_size=0.1), aim=(0.0, 0.0, 0.0)),
        Lamp("Sun", "SUN", (0, 0, 10), dict(energy=2.0, angle=math.radians(1.0)),
             rotation=(math.radians(50.0), 0.0, math.radians(-30.0))),
    ]
    return Scene("lamps", objects,
                 "open scene, black world, spot + sun lamps, single-plane wall and awning")


def near() -> Scene:
    """Stability cases (see the module docstring), 20 m apart along x."""
    white = diffuse("White", (0.8, 0.8, 0.8))
    objects, groups = [], {}
    # 1. An emitter 1 mm under a ceiling, a floor 1 m below.
    x, z = 0.0, 1 - EMITTER_GAP
    objects += [
        plane("EmitterCeiling", [(x - 1, -1, 1), (x + 1, -1, 1), (x + 1, 1, 1), (x - 1, 1, 1)],
              (0, 0, -1), 0.1, white),
        plane("EmitterFloor", [(x - 1, -1, 0), (x + 1, -1, 0), (x + 1, 1, 0), (x - 1, 1, 0)],
              (0, 0, 1), 0.1, white),
        plane("CeilingEmitter", [(x - .25, -.25, z), (x + .25, -.25, z), (x + .25, .25, z),
                                 (x - .25, .25, z)], (0, 0, -1), 1.0,
              one_sided("Emit", (5.0, 5.0, 5.0)), role="emitter")]
    groups["emitter under a ceiling"] = ["EmitterCeiling", "EmitterFloor"]
    # 2. A room corner (floor + two walls meeting at x = 20, y = 0) lit by a point lamp.
    x = 20.0
    objects += [
        plane("CornerFloor", [(x, 0, 0), (x + 2, 0, 0), (x + 2, 2, 0), (x, 2, 0)], (0, 0, 1),
              0.1, white),
        plane("CornerWallX", [(x, 0, 0), (x, 2, 0), (x, 2, 2), (x, 0, 2)], (1, 0, 0), 0.1, white),
        plane("CornerWallY", [(x, 0, 0), (x + 2, 0, 0), (x + 2, 0, 2), (x, 0, 2)], (0, 1, 0),
              0.1, white),
        Lamp("CornerPoint", "POINT", (x + 0.7, 0.7, 1.2),
             dict(energy=100.0, shadow_soft_size=0.05))]
    groups["room corner"] = ["CornerFloor", "CornerWallX", "CornerWallY"]
    # 3. A strip of floor against a wall, an area lamp above the strip.
    x = 40.0
    objects += [
        plane("StripFloor", [(x, 0, 0), (x + 3, 0, 0), (x + 3, 0.6, 0), (x, 0.6, 0)], (0, 0, 1),
              0.05, white),
        plane("StripWall", [(x, 0.6, 0), (x + 3, 0.6, 0), (x + 3, 0.6, 1.5), (x, 0.6, 1.5)],
              (0, -1, 0), 0.1, white),
        Lamp("StripArea", "AREA", (x + 1.5, 0.1, 1.4), dict(energy=150.0, size=0.5))]
    groups["floor strip by a wall"] = ["StripFloor", "StripWall"]
    # 4. A thin plate (1 x 1 m, 5 mm thick) standing on a floor, lit by a spot from -y.
    x = 60.0
    objects += [
        Mesh("Plate", white, parts=box_parts((x - 0.5, -0.0025, 0.2), (x + 0.5, 0.0025, 1.2),
                                             0.05)),
        plane("PlateFloor", [(x - 1.5, -1.5, 0), (x + 1.5, -1.5, 0), (x + 1.5, 1.5, 0),
                             (x - 1.5, 1.5, 0)], (0, 0, 1), 0.1, white),
        Lamp("PlateSpot", "SPOT", (x, -2.0, 1.0),
             dict(energy=300.0, spot_size=math.radians(50.0), spot_blend=0.1,
                  shadow_soft_size=0.02), aim=(x, 0.0, 0.7))]
    groups["thin plate"] = ["Plate", "PlateFloor"]
    # 5. A sphere lit by a point lamp, nothing else near it.
    x = 80.0
    objects += [
        sphere("LitSphere", (x, 0, 1), 0.5, white),
        Lamp("SpherePoint", "POINT", (x + 1.0, -1.0, 2.0),
             dict(energy=100.0, shadow_soft_size=0.0))]
    groups["sphere and lamp"] = ["LitSphere"]
    return Scene("near", objects, "stability cases 20 m apart", groups=groups)


def world() -> Scene:
    """An open scene lit by the sky: a floor, a box resting on it, a sphere, a free-standing
    wall, and a two-sided emissive panel (plain Emission) between them; no lamps."""
    paint = matte("Paint", (0.8, 0.78, 0.74))
    objects = [
        plane("Floor", [(-4, -4, 0), (4, -4, 0), (4, 4, 0), (-4, 4, 0)], (0, 0, 1), 0.2,
              diffuse("Grey", (0.6, 0.6, 0.6))),
        Mesh("Box", diffuse("Red", (0.7, 0.15, 0.1)),
             parts=box_parts((0.5, -1.0, 0.0), (1.5, 0.0, 0.8), 0.1)),
        sphere("Sphere", (-1.2, -0.5, 0.6), 0.6, paint),
        plane("Wall", [(-2.5, 1.2, 0), (2.5, 1.2, 0), (2.5, 1.2, 2.0), (-2.5, 1.2, 2.0)],
              (0, -1, 0), 0.2, paint),
        plane("Panel", [(-0.2, 0.4, 0.3), (0.2, 0.4, 0.3), (0.2, 0.4, 1.1), (-0.2, 0.4, 1.1)],
              (0, -1, 0), 1.0, Material("Panel", "emit_both", radiance=PANEL_RADIANCE),
              role="emitter"),
    ]
    return Scene("world", objects,
                 "open scene under a constant sky (no lamps), box on the floor, "
                 "single-plane wall, two-sided emissive panel", sky=(SKY, 1.0))


def window() -> Scene:
    """A room lit through a window by the sky and a sun (see the module docstring)."""
    paint = diffuse("WallPaint", (0.75, 0.73, 0.7))
    width, depth, height = 4.0, 3.0, 2.5
    x0, x1, z0, z1, y = 1.2, 2.8, 0.8, 2.0, depth          # the window in the wall y = depth
    around = []
    for corners in ([(0, y, 0), (width, y, 0), (width, y, z0), (0, y, z0)],
                    [(0, y, z1), (width, y, z1), (width, y, height), (0, y, height)],
                    [(0, y, z0), (x0, y, z0), (x0, y, z1), (0, y, z1)],
                    [(x1, y, z0), (width, y, z0), (width, y, z1), (x1, y, z1)]):
        around += quad_parts(corners, (0, -1, 0), 0.1)
    objects = [
        Mesh("Room", paint, parts=box_parts((0, 0, 0), (width, depth, height), 0.1,
                                            inward=True, skip=("+y", "-z"))),
        plane("Floor", [(0, 0, 0), (width, 0, 0), (width, depth, 0), (0, depth, 0)], (0, 0, 1),
              0.1, diffuse("Wood", (0.45, 0.3, 0.18))),
        Mesh("WindowWall", paint, parts=around),
        Mesh("Table", diffuse("Red", (0.65, 0.12, 0.1)),
             parts=box_parts((1.6, 1.6, 0.0), (2.4, 2.2, 0.7), 0.1)),
        Mesh("Cabinet", matte("Blue", (0.15, 0.25, 0.6)),
             parts=box_parts((0.0, 0.4, 0.0), (0.5, 1.6, 1.2), 0.1, skip=("-x",))),
        sphere("Ball", (3.0, 1.0, 0.35), 0.35, paint),
        Lamp("Sun", "SUN", (2.0, 6.0, 5.0), dict(energy=4.0, angle=math.radians(1.0)),
             aim=(2.0, 1.2, 0.0)),
    ]
    return Scene("window", objects,
                 "a room lit through a window by the sky and a sun, a table in the sun's "
                 "patch, a cabinet against a wall, a ball", sky=(SKY, 1.0))


def monkey() -> Scene:
    """Suzanne on a floor under an area lamp, a point lamp and a dim sky (see the module
    docstring)."""
    objects = [
        plane("Floor", [(-2, -2, 0), (2, -2, 0), (2, 2, 0), (-2, 2, 0)], (0, 0, 1), 0.1,
              diffuse("Grey", (0.6,) * 3)),
        Mesh("Monkey", diffuse("Clay", (0.7, 0.55, 0.45)), shape="monkey"),
        Lamp("Key", "AREA", (1.5, -1.5, 2.5), dict(energy=300.0, size=1.0),
             aim=(0.0, 0.0, 0.5)),
        Lamp("Fill", "POINT", (-1.5, -1.0, 1.5), dict(energy=60.0, shadow_soft_size=0.1)),
    ]
    return Scene("monkey", objects, "smooth Suzanne on a floor, area + point lamps, dim sky",
                 sky=(SKY, 0.3), scored=("Monkey", "Floor"))


def cornell_scan(cell: float = 0.1) -> Scene:
    """The Cornell box with its walls and blocks as grids of ``cell`` m, all of them to be
    given to Illumap as one scan (``run.scan_objects``): 0.02 m makes 123k points, 0.01 m
    486k (the micro-benchmarks of dense scans)."""
    scene = cornell(cell)
    scene.name = f"cornell_scan_{cell:g}"
    scene.scan = [m.name for m in scene.meshes("scored")]
    return scene


def scan_room() -> Scene:
    """The Cornell box given to Illumap as a scan: its walls' and blocks' vertices as one
    point cloud without normals (the light kept as a mesh), scored against the Cornell box's
    reference at those points."""
    scene = cornell_scan()
    scene.name, scene.reference = "scan_room", "cornell"
    scene.notes = "the Cornell box's 5,341 vertices as a point cloud without normals; " + scene.notes
    return scene


def _bunny_and_sun(floor_half: float, floor_cell: float) -> list:
    """The bunny scan (× BUNNY_SCALE) as a mesh of its own triangles, a floor and a sun."""
    verts, faces = bunny_scan()
    h = floor_half
    return [
        Mesh("Bunny", diffuse("Clay", (0.75, 0.6, 0.45)),
             parts=[raw_part(verts * BUNNY_SCALE, faces)], weld=False),
        plane("Floor", [(-h, -h, 0), (h, -h, 0), (h, h, 0), (-h, h, 0)], (0, 0, 1), floor_cell,
              diffuse("Grey", (0.6, 0.6, 0.6))),
        Lamp("Sun", "SUN", (0, 0, 5), dict(energy=3.0, angle=math.radians(2.0)),
             rotation=(math.radians(40.0), 0.0, math.radians(30.0))),
    ]


def scan_object() -> Scene:
    """The Stanford bunny (a real range scan, BUNNY_CREDIT) scaled to 0.5 m, standing on a
    floor under the sky and a sun. Illumap gets the bunny's vertices as a point cloud without
    normals; Cycles bakes the scan's own triangles."""
    count = len(bunny_scan()[0])
    return Scene("scan_object", _bunny_and_sun(1.5, 0.1),
                 f"Stanford bunny ({count} vertices) x {BUNNY_SCALE:g} as a point cloud "
                 "without normals on a mesh floor, sky + sun", sky=(SKY, 0.5), scan=["Bunny"],
                 reference_samples=1024,
                 only_settings=("default", "DRAFT", "HIGH", "target 0.05", "target 0.03"),
                 cycles_samples=(16, 64, 256))


#: The reference scenes by name.
REFERENCE = {"cornell": cornell, "room": room, "lamps": lamps, "near": near, "world": world,
             "window": window, "monkey": monkey, "scan_room": scan_room,
             "scan_object": scan_object}


# --- the preview scenes ----------------------------------------------------------------------

#: The preview room's white, its emitter's radiance (the red and green are Cornell's).
PREVIEW_WHITE = (0.73, 0.73, 0.73)
PREVIEW_RADIANCE = (15.0, 15.0, 15.0)


def preview_room(cell: float = 0.05, jitter: float = 0.0, seed: int = 0) -> Scene:
    """A 1 m room like Cornell's, open at the front (red left wall, green right wall, white
    floor, ceiling and back wall, grids of ``cell``, jittered by ``jitter`` cells), a white
    block on the floor, a one-sided 0.3 m emitter 1 mm under the ceiling, and a camera looking
    in through the open side. The scored meshes are the room's surfaces."""
    rng = np.random.default_rng(seed)
    white = diffuse("White", PREVIEW_WHITE)
    quads = {
        "Floor": ([(0, 0, 0), (1, 0, 0), (1, 1, 0), (0, 1, 0)], (0, 0, 1), white),
        "Ceiling": ([(0, 0, 1), (0, 1, 1), (1, 1, 1), (1, 0, 1)], (0, 0, -1), white),
        "Back": ([(0, 1, 0), (1, 1, 0), (1, 1, 1), (0, 1, 1)], (0, -1, 0), white),
        "Left": ([(0, 0, 0), (0, 1, 0), (0, 1, 1), (0, 0, 1)], (1, 0, 0),
                 diffuse("Red", cornell_box.RED)),
        "Right": ([(1, 0, 0), (1, 0, 1), (1, 1, 1), (1, 1, 0)], (-1, 0, 0),
                  diffuse("Green", cornell_box.GREEN)),
    }
    objects = [Mesh(name, mat, parts=[jittered_patch(facing(corners, toward), cell, jitter, rng)])
               for name, (corners, toward, mat) in quads.items()]
    lo, hi = np.array([0.25, 0.35, 0.0]), np.array([0.55, 0.65, 0.35])
    objects.append(Mesh("Block", white, parts=[jittered_patch(corners, cell, jitter, rng)
                                               for corners in box_faces(lo, hi, skip=("-z",))]))
    z = 1 - EMITTER_GAP
    objects.append(plane("Emitter", [(.35, .35, z), (.35, .65, z), (.65, .65, z), (.65, .35, z)],
                         (0, 0, -1), 1.0, one_sided("Emit", PREVIEW_RADIANCE), role="emitter"))
    return Scene("preview_room", objects, "a 1 m Cornell-like room with a block",
                 camera=Camera((0.5, -1.25, 0.5), (0.5, 0.0, 0.5), 35.0))


def preview_bunny(floor_cell: float = 0.05) -> Scene:
    """The bunny on a 4 m floor of ``floor_cell`` grids under a dim sky and a sun (as
    ``scan_object``, whose 0.1 m floor cells are too coarse to show the bunny's shadow through
    their vertices) and a camera looking down at it; scored: the bunny, the floor."""
    return Scene("preview_bunny", _bunny_and_sun(2.0, floor_cell), "the bunny on a floor",
                 sky=(SKY, 0.5), camera=Camera((0.15, -0.95, 1.05), (0.0, 0.0, 0.12), 50.0))
