"""Reference scenes built the way users build them in Blender (bpy, no Illumap code).

Each builder starts from an empty file (``bpy.ops.wm.read_factory_settings(use_empty=True)``),
creates ordinary meshes (subdivided grids, cubes, UV spheres; shared vertices along edges, as
Blender's own primitives have), materials, lamps and a black world (Background strength 0, so
Cycles sees no ambient light that Illumap would not), and returns a ``ReferenceScene``: the
mesh objects to score, the emitting meshes (not scored: their value is their emission), the
lamps, and the albedo and emission of every scored vertex, which turn Cycles' baked incident
radiance into outgoing radiance (``bake.py``).

Vertices are not surfel positions: Illumap samples its own surfels on these meshes and writes
its result back to the vertices, as it does for users.

Materials are Diffuse BSDF, or Principled BSDF with its specular layer off (Specular IOR Level
0: a matte paint), so both renderers see a purely diffuse surface; glossy light is outside
Illumap's model. One-sided emitters use Geometry ▸ Backfacing as the factor of a Mix Shader
between the emission (front) and black (back): an Emission shader alone emits from both faces
in Cycles, while Illumap's surfels emit along their normal only.

Scenes (``SCENES``):

* ``cornell``: the Cornell box from Cornell's published measurements (millimetres, Y up) × 0.005,
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
  ``BUNNY_CREDIT``) on a floor under the sky and a sun, the bunny's vertices given to Illumap
  as a point cloud without normals, Cycles baking the scan's own triangles.
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
"""

from __future__ import annotations

import math
import os
from dataclasses import dataclass, field

import bpy  # before bmesh: the bpy module provides it
import bmesh
import numpy as np

#: Cornell's reflectances and light radiance (RGB values in common use).
WHITE, RED, GREEN = (0.725, 0.71, 0.68), (0.63, 0.065, 0.05), (0.14, 0.45, 0.091)
CORNELL_RADIANCE = (17.0, 12.0, 4.0)
#: Metres per published millimetre of the Cornell box (see the module docstring).
CORNELL_SCALE = 0.005
#: Distance of an emitter below the surface it hangs from, m.
EMITTER_GAP = 0.001
#: The open scenes' sky (linear RGB radiance at strength 1) and the emissive panel's radiance.
SKY = (0.5, 0.65, 1.0)
PANEL_RADIANCE = (4.0, 3.0, 1.5)
#: The Stanford bunny (test data outside the extension, see its README) and its scale.
BUNNY_PLY = os.environ.get("ILLUMAP_BUNNY", "/work/shared/data/stanford-bunny/bun_zipper.ply")
BUNNY_SCALE = 3.3
BUNNY_CREDIT = ("Stanford Bunny: Stanford 3D Scanning Repository, Stanford University Computer "
                "Graphics Laboratory")


@dataclass
class ReferenceScene:
    """A built scene: what to score and how to turn a bake into outgoing radiance."""

    name: str
    scored: list                        # mesh objects whose vertices are scored
    emitters: list                      # emitting meshes (solved, not scored)
    lamps: list                         # lamp objects
    albedo: dict[str, np.ndarray]       # object name -> (V, 3) diffuse albedo per vertex
    emission: dict[str, np.ndarray]     # object name -> (V, 3) emitted radiance per vertex
    notes: str = ""
    groups: dict[str, list[str]] = field(default_factory=dict)  # label -> object names
    # Scored meshes that Illumap is given as one scanned point cloud (their vertices, albedo
    # in a "Col" attribute, no normals, no radii), scored at those points; Cycles bakes the
    # meshes themselves.
    scan: list[str] = field(default_factory=list)
    reference: str = ""                 # the cached reference to use ("": this scene's own)
    reference_samples: int = 0          # samples of its reference (0: the run's); large scans
                                        # bake fewer: the cost grows with the vertices
    only_settings: tuple = ()           # labels of run.ILLUMAP_SETTINGS to run (empty: all)
    cycles_samples: tuple = ()          # the Cycles sweep (empty: the run's)

    @property
    def objects(self) -> list:
        """Every mesh Illumap solves (scored meshes and emitters)."""
        return self.scored + self.emitters

    @property
    def reference_name(self) -> str:
        """The name of the cached Cycles reference this scene is scored against."""
        return self.reference or self.name

    def vertex_count(self) -> int:
        """Number of scored vertices."""
        return sum(len(o.data.vertices) for o in self.scored)


# --- materials ------------------------------------------------------------------------------

def _new_material(name: str):
    mat = bpy.data.materials.new(name)
    if mat.node_tree is None:
        mat.use_nodes = True
    mat.node_tree.nodes.clear()
    out = mat.node_tree.nodes.new("ShaderNodeOutputMaterial")
    return mat, out


def diffuse_material(name: str, color) -> "bpy.types.Material":
    """A Diffuse BSDF of constant linear ``color``."""
    mat, out = _new_material(name)
    bsdf = mat.node_tree.nodes.new("ShaderNodeBsdfDiffuse")
    bsdf.inputs["Color"].default_value = (*color, 1.0)
    mat.node_tree.links.new(bsdf.outputs["BSDF"], out.inputs["Surface"])
    mat["albedo"] = tuple(color)      # the value the reference multiplies the bake with
    return mat


def matte_principled(name: str, color, image=None) -> "bpy.types.Material":
    """A Principled BSDF with Base Color ``color`` (or an Image Texture of ``image`` on the
    active UV map) and no specular layer (Specular IOR Level 0): a purely diffuse surface."""
    mat, out = _new_material(name)
    nodes, links = mat.node_tree.nodes, mat.node_tree.links
    bsdf = nodes.new("ShaderNodeBsdfPrincipled")
    bsdf.inputs["Base Color"].default_value = (*color, 1.0)
    bsdf.inputs["Specular IOR Level"].default_value = 0.0
    bsdf.inputs["Roughness"].default_value = 1.0
    if image is not None:
        tex = nodes.new("ShaderNodeTexImage")
        tex.image = image
        tex.interpolation = "Linear"
        links.new(tex.outputs["Color"], bsdf.inputs["Base Color"])
        mat["image"] = image.name
    links.new(bsdf.outputs["BSDF"], out.inputs["Surface"])
    mat["albedo"] = tuple(color)
    return mat


def one_sided_emission(name: str, radiance) -> "bpy.types.Material":
    """Emission of ``radiance`` (linear RGB, W/(m² sr) in Blender's units) from the front face
    only: Geometry ▸ Backfacing mixes the emission (factor 0, front) with black (factor 1, back)."""
    mat, out = _new_material(name)
    nodes, links = mat.node_tree.nodes, mat.node_tree.links
    strength = float(max(radiance))
    emission = nodes.new("ShaderNodeEmission")
    emission.inputs["Color"].default_value = (*[c / strength for c in radiance], 1.0)
    emission.inputs["Strength"].default_value = strength
    black = nodes.new("ShaderNodeBsdfDiffuse")   # albedo 0: black, reflects nothing
    black.inputs["Color"].default_value = (0.0, 0.0, 0.0, 1.0)
    geometry = nodes.new("ShaderNodeNewGeometry")
    mix = nodes.new("ShaderNodeMixShader")
    links.new(geometry.outputs["Backfacing"], mix.inputs["Fac"])
    links.new(emission.outputs["Emission"], mix.inputs[1])
    links.new(black.outputs["BSDF"], mix.inputs[2])
    links.new(mix.outputs["Shader"], out.inputs["Surface"])
    mat["albedo"] = (0.0, 0.0, 0.0)
    mat["emission"] = tuple(radiance)
    return mat


def black_world() -> None:
    """A world whose Background has strength 0: no ambient light in Cycles (Blender 5's new
    world renders a grey background of strength 1 otherwise)."""
    world = bpy.data.worlds.new("Black")
    if world.node_tree is None:
        world.use_nodes = True
    background = world.node_tree.nodes.get("Background")
    if background is None:
        background = world.node_tree.nodes.new("ShaderNodeBackground")
        output = world.node_tree.nodes.get("World Output") or \
            world.node_tree.nodes.new("ShaderNodeOutputWorld")
        world.node_tree.links.new(background.outputs[0], output.inputs["Surface"])
    background.inputs["Color"].default_value = (0.0, 0.0, 0.0, 1.0)
    background.inputs["Strength"].default_value = 0.0
    world.color = (0.0, 0.0, 0.0)
    bpy.context.scene.world = world


def checker_image(name: str = "Checker", size: int = 56, cells: int = 7,
                  colors=((0.62, 0.48, 0.33), (0.28, 0.22, 0.16))) -> "bpy.types.Image":
    """A packed sRGB byte image of ``cells`` × ``cells`` squares of two sRGB ``colors``."""
    image = bpy.data.images.new(name, size, size, alpha=False, float_buffer=False)
    image.colorspace_settings.name = "sRGB"
    ij = np.indices((size, size)) * cells // size          # cell row, column of each pixel
    pick = ((ij[0] + ij[1]) % 2)[..., None]
    rgb = np.where(pick == 0, np.array(colors[0]), np.array(colors[1]))
    rgba = np.concatenate([rgb, np.ones((size, size, 1))], axis=2).astype(np.float32)
    image.pixels.foreach_set(rgba.ravel())
    image.pack()
    return image


# --- geometry -------------------------------------------------------------------------------

def grid_patch(corners, cell: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """A bilinear grid over the quad ``corners`` (4, 3) (c0, c1, c2, c3 around; m) with cells
    of about ``cell`` m: vertices (V, 3), quads (F, 4) wound c0 → c1 → c2 (normal
    (c1 − c0) × (c3 − c0)), and UVs (V, 2) running 0–1 along c0 → c1 and c0 → c3."""
    c = np.asarray(corners, dtype=np.float64)
    nu = max(1, math.ceil(max(np.linalg.norm(c[1] - c[0]), np.linalg.norm(c[2] - c[3])) / cell))
    nv = max(1, math.ceil(max(np.linalg.norm(c[3] - c[0]), np.linalg.norm(c[2] - c[1])) / cell))
    s, t = np.meshgrid(np.linspace(0, 1, nu + 1), np.linspace(0, 1, nv + 1))
    s, t = s.ravel()[:, None], t.ravel()[:, None]
    verts = (1 - s) * (1 - t) * c[0] + s * (1 - t) * c[1] + s * t * c[2] + (1 - s) * t * c[3]
    i, j = np.meshgrid(np.arange(nu), np.arange(nv))
    first = (j * (nu + 1) + i).ravel()
    quads = np.stack([first, first + 1, first + nu + 2, first + nu + 1], axis=1)
    return verts, quads, np.hstack([s, t])


def _facing(corners, toward) -> np.ndarray:
    """``corners`` reordered, if needed, so the quad's normal points toward ``toward``
    (a direction vector)."""
    c = np.asarray(corners, dtype=np.float64)
    normal = np.cross(c[1] - c[0], c[3] - c[0])
    return c if normal @ np.asarray(toward, float) >= 0 else c[[0, 3, 2, 1]]


def mesh_object(name: str, parts, material, *, weld: bool = True, triangulate: bool = False,
                uv: bool = False):
    """A mesh object from grid ``parts`` [(verts, faces, uvs)] (m) with one material. ``weld``
    merges coincident vertices (shared edges, as a modelled mesh has them); ``triangulate``
    splits the quads (beauty); ``uv`` adds a UV map "UVMap" from the parts' UVs."""
    verts, faces, uvs, offset = [], [], [], 0
    for v, f, t in parts:
        verts.append(v)
        faces.append(f + offset)
        uvs.append(t)
        offset += len(v)
    verts, faces, uvs = np.concatenate(verts), np.concatenate(faces), np.concatenate(uvs)
    mesh = bpy.data.meshes.new(name)
    mesh.from_pydata(verts, [], faces)
    if uv:
        layer = mesh.uv_layers.new(name="UVMap")
        corner_vertex = np.empty(len(mesh.loops), dtype=np.int64)
        mesh.loops.foreach_get("vertex_index", corner_vertex)
        layer.data.foreach_set("uv", uvs[corner_vertex].astype(np.float32).ravel())
    if weld or triangulate:
        bm = bmesh.new()
        bm.from_mesh(mesh)
        if weld:
            bmesh.ops.remove_doubles(bm, verts=bm.verts, dist=1e-6)
        if triangulate:
            bmesh.ops.triangulate(bm, faces=bm.faces, quad_method="BEAUTY")
        bm.to_mesh(mesh)
        bm.free()
    mesh.validate()
    mesh.materials.append(material)
    obj = bpy.data.objects.new(name, mesh)
    bpy.context.scene.collection.objects.link(obj)
    return obj


def box_faces(lo, hi, *, inward: bool = False, skip=()) -> list:
    """The corners (4, 3) of the six faces of the axis-aligned box ``lo``–``hi`` (m), wound for
    outward (or ``inward``) normals; ``skip`` names faces left out ('-x', '+x', '-y', '+y',
    '-z', '+z')."""
    lo, hi = np.asarray(lo, float), np.asarray(hi, float)
    faces = []
    for axis in range(3):
        for side, value in (("-", lo[axis]), ("+", hi[axis])):
            if f"{side}{'xyz'[axis]}" in skip:
                continue
            a, b = [k for k in range(3) if k != axis]
            corners = np.zeros((4, 3))
            corners[:, axis] = value
            corners[:, a] = [lo[a], hi[a], hi[a], lo[a]]
            corners[:, b] = [lo[b], lo[b], hi[b], hi[b]]
            out = np.zeros(3)
            out[axis] = 1.0 if side == "+" else -1.0
            faces.append(_facing(corners, -out if inward else out))
    return faces


def box_parts(lo, hi, cell: float, *, inward: bool = False, skip=()) -> list:
    """Grid parts of the faces of ``box_faces``."""
    return [grid_patch(corners, cell) for corners in box_faces(lo, hi, inward=inward, skip=skip)]


def quad_parts(corners, toward, cell: float) -> list:
    """The one grid part of a planar quad, facing ``toward``."""
    return [grid_patch(_facing(corners, toward), cell)]


def uv_sphere(name: str, centre, radius: float, material, segments: int = 32, rings: int = 16):
    """A UV sphere (Blender's primitive: quads, triangle fans at the poles), outward normals."""
    mesh = bpy.data.meshes.new(name)
    bm = bmesh.new()
    bmesh.ops.create_uvsphere(bm, u_segments=segments, v_segments=rings, radius=radius)
    bmesh.ops.translate(bm, verts=bm.verts, vec=tuple(centre))
    verts = [v.co[:] for v in bm.verts]
    # The primitive's faces come out in an order that differs from one call to the next (its
    # vertices do not): each face from its lowest vertex, the faces sorted, so that the same
    # scene samples the same surfels every time it is built.
    faces = []
    for f in bm.faces:
        ids = [v.index for v in f.verts]
        k = ids.index(min(ids))
        faces.append(ids[k:] + ids[:k])
    bm.free()
    mesh.from_pydata(verts, [], sorted(faces))
    mesh.update()
    mesh.materials.append(material)
    obj = bpy.data.objects.new(name, mesh)
    bpy.context.scene.collection.objects.link(obj)
    return obj


def add_lamp(kind: str, location, rotation=(0.0, 0.0, 0.0), name: str | None = None, **props):
    """A lamp object of ``kind`` (POINT, SPOT, SUN, AREA); ``props`` set on the light data
    (energy in W, or W/m² for the sun)."""
    light = bpy.data.lights.new(name or kind.title(), kind)
    for key, value in props.items():
        setattr(light, key, value)
    obj = bpy.data.objects.new(name or kind.title(), light)
    obj.location, obj.rotation_euler = location, rotation
    bpy.context.scene.collection.objects.link(obj)
    return obj


def aim(obj, target) -> None:
    """Point a lamp's −Z axis at ``target`` (m)."""
    from mathutils import Vector
    direction = Vector(target) - obj.location
    obj.rotation_euler = direction.to_track_quat("-Z", "Y").to_euler()


# --- per-vertex material values --------------------------------------------------------------

def _linear_from_srgb(c: np.ndarray) -> np.ndarray:
    return np.where(c <= 0.04045, c / 12.92, ((c + 0.055) / 1.055) ** 2.4)


def image_bilinear(image, uv: np.ndarray) -> np.ndarray:
    """Linear RGB (N, 3) of ``image`` at ``uv`` (N, 2) with Cycles' Linear interpolation and
    Repeat extension (texel i's centre at (i + 0.5)/W). sRGB byte images are interpolated as
    stored and linearised afterwards, as Cycles does (measured: a bake with 'COLOR' in the
    pass filter equals this albedo × the incident bake to 1e-4 (relative RMS) on the checker floor, where
    linearising texels first is 2% darker on average and up to 12% at cell edges)."""
    w, h = image.size
    px = np.empty(w * h * image.channels, dtype=np.float32)
    image.pixels.foreach_get(px)
    px = px.reshape(h, w, image.channels)[..., :3].astype(np.float64)
    srgb_bytes = image.colorspace_settings.name == "sRGB" and not image.is_float
    x = uv[:, 0] * w - 0.5
    y = uv[:, 1] * h - 0.5
    x0, y0 = np.floor(x).astype(np.int64), np.floor(y).astype(np.int64)
    fx, fy = (x - x0)[:, None], (y - y0)[:, None]
    x1, y1 = (x0 + 1) % w, (y0 + 1) % h
    x0, y0 = x0 % w, y0 % h
    rgb = ((1 - fx) * (1 - fy) * px[y0, x0] + fx * (1 - fy) * px[y0, x1]
           + (1 - fx) * fy * px[y1, x0] + fx * fy * px[y1, x1])
    return _linear_from_srgb(rgb) if srgb_bytes else rgb


def vertex_materials(obj) -> tuple[np.ndarray, np.ndarray]:
    """Albedo and emission (V, 3) per vertex of ``obj`` from its (single) material's recorded
    constants, the image sampled at the vertex's UV for textured materials (the UV of one of its
    corners: the reference meshes have no UV seams on textured objects)."""
    mesh = obj.data
    n = len(mesh.vertices)
    mat = mesh.materials[0]
    albedo = np.tile(np.asarray(mat["albedo"], dtype=np.float64), (n, 1))
    emission = np.tile(np.asarray(mat.get("emission", (0.0, 0.0, 0.0)), dtype=np.float64), (n, 1))
    if "image" in mat:
        corner_vertex = np.empty(len(mesh.loops), dtype=np.int64)
        mesh.loops.foreach_get("vertex_index", corner_vertex)
        corner_uv = np.empty(len(mesh.loops) * 2, dtype=np.float32)
        mesh.uv_layers.active.data.foreach_get("uv", corner_uv)
        uv = np.zeros((n, 2))
        uv[corner_vertex] = corner_uv.reshape(-1, 2)
        albedo = image_bilinear(bpy.data.images[mat["image"]], uv)
    return albedo, emission


def _finish(name: str, scored: list, emitters: list, lamps: list, notes: str,
            groups: dict | None = None) -> ReferenceScene:
    bpy.context.view_layer.update()
    albedo, emission = {}, {}
    for obj in scored:
        albedo[obj.name], emission[obj.name] = vertex_materials(obj)
    return ReferenceScene(name, scored, emitters, lamps, albedo, emission, notes, groups or {})


def _reset() -> None:
    bpy.ops.wm.read_factory_settings(use_empty=True)
    black_world()


# --- the scenes -----------------------------------------------------------------------------

#: Cornell's published geometry (mm, Y up): quads per surface, blocks without bottoms.
CORNELL_MM = {
    "Floor": [[(552.8, 0, 0), (0, 0, 0), (0, 0, 559.2), (549.6, 0, 559.2)]],
    "Ceiling": [[(556, 548.8, 0), (556, 548.8, 559.2), (0, 548.8, 559.2), (0, 548.8, 0)]],
    "BackWall": [[(549.6, 0, 559.2), (0, 0, 559.2), (0, 548.8, 559.2), (556, 548.8, 559.2)]],
    "RightWall": [[(0, 0, 559.2), (0, 0, 0), (0, 548.8, 0), (0, 548.8, 559.2)]],
    "LeftWall": [[(552.8, 0, 0), (549.6, 0, 559.2), (556, 548.8, 559.2), (556, 548.8, 0)]],
    "ShortBlock": [
        [(130, 165, 65), (82, 165, 225), (240, 165, 272), (290, 165, 114)],
        [(290, 0, 114), (290, 165, 114), (240, 165, 272), (240, 0, 272)],
        [(130, 0, 65), (130, 165, 65), (290, 165, 114), (290, 0, 114)],
        [(82, 0, 225), (82, 165, 225), (130, 165, 65), (130, 0, 65)],
        [(240, 0, 272), (240, 165, 272), (82, 165, 225), (82, 0, 225)]],
    "TallBlock": [
        [(423, 330, 247), (265, 330, 296), (314, 330, 456), (472, 330, 406)],
        [(423, 0, 247), (423, 330, 247), (472, 330, 406), (472, 0, 406)],
        [(472, 0, 406), (472, 330, 406), (314, 330, 456), (314, 0, 456)],
        [(314, 0, 456), (314, 330, 456), (265, 330, 296), (265, 0, 296)],
        [(265, 0, 296), (265, 330, 296), (423, 330, 247), (423, 0, 247)]],
    "Light": [[(343, 548.8, 227), (343, 548.8, 332), (213, 548.8, 332), (213, 548.8, 227)]],
}


def cornell_to_blender(mm) -> np.ndarray:
    """Published Cornell coordinates (mm, Y up, x to the left seen from the open front) to
    Blender metres (Z up): (556 − x, z, y) × CORNELL_SCALE (a rotation: orientation kept)."""
    p = np.asarray(mm, dtype=np.float64)
    return np.stack([556.0 - p[..., 0], p[..., 2], p[..., 1]], axis=-1) * CORNELL_SCALE


def cornell(cell: float = 0.1) -> ReferenceScene:
    """The Cornell box (see the module docstring), walls and blocks as grids of ``cell`` m."""
    _reset()
    colours = {"Floor": WHITE, "Ceiling": WHITE, "BackWall": WHITE, "RightWall": GREEN,
               "LeftWall": RED, "ShortBlock": WHITE, "TallBlock": WHITE}
    mats = {c: diffuse_material(n, c) for n, c in (("White", WHITE), ("Red", RED),
                                                  ("Green", GREEN))}
    room_centre = cornell_to_blender((278, 274.4, 279.6))
    scored = []
    for name, colour in colours.items():
        quads = [cornell_to_blender(q) for q in CORNELL_MM[name]]
        if name.endswith("Block"):
            centre = np.concatenate(quads).mean(axis=0)
            parts = [grid_patch(_facing(q, q.mean(axis=0) - centre), cell) for q in quads]
        else:
            parts = [grid_patch(_facing(q, room_centre - q.mean(axis=0)), cell) for q in quads]
        scored.append(mesh_object(name, parts, mats[colour]))
    light_quad = cornell_to_blender(CORNELL_MM["Light"][0])
    light_quad[:, 2] -= EMITTER_GAP
    light = mesh_object("Light", [grid_patch(_facing(light_quad, (0, 0, -1)), 1.0)],
                        one_sided_emission("Light", CORNELL_RADIANCE))
    return _finish("cornell", scored, [light], [],
                   f"Cornell's published box x {CORNELL_SCALE} m/mm, {cell} m cells, "
                   f"one-sided light {EMITTER_GAP * 1000:g} mm under the ceiling")


def room() -> ReferenceScene:
    """A closed, lamp-lit room with a textured floor, two boxes and a sphere."""
    _reset()
    paint = matte_principled("Paint", (0.8, 0.78, 0.74))
    floor_mat = matte_principled("FloorChecker", (1.0, 1.0, 1.0), image=checker_image())
    orange = diffuse_material("Orange", (0.8, 0.35, 0.1))
    teal = matte_principled("Teal", (0.1, 0.5, 0.45))
    blue = diffuse_material("Blue", (0.15, 0.25, 0.7))
    lo, hi = np.array([-2.5, -2.0, 0.0]), np.array([2.5, 2.0, 2.6])
    walls = mesh_object("Walls", box_parts(lo, hi, 0.25, inward=True, skip=("-z",)), paint)
    floor = mesh_object("Floor", quad_parts([(lo[0], lo[1], 0), (hi[0], lo[1], 0),
                                             (hi[0], hi[1], 0), (lo[0], hi[1], 0)],
                                            (0, 0, 1), 0.1), floor_mat, uv=True)
    box = mesh_object("Box", box_parts((-1.6, -1.2, 0.0), (-0.8, -0.6, 0.7), 0.1), orange)
    tall = mesh_object("TallBox", box_parts((0.9, 0.6, 0.0), (1.4, 1.1, 1.2), 0.15), teal,
                       triangulate=True)
    sphere = uv_sphere("Sphere", (0.2, -0.6, 0.35), 0.35, blue)
    area = add_lamp("AREA", (0.0, 0.0, 2.55), name="CeilingArea", energy=400.0, size=1.0)
    point = add_lamp("POINT", (-1.8, 1.4, 1.8), name="SmallPoint", energy=60.0,
                     shadow_soft_size=0.05)
    return _finish("room", [walls, floor, box, tall, sphere], [], [area, point],
                   "closed 5 x 4 x 2.6 m room, checker floor, area + point lamp")


def lamps() -> ReferenceScene:
    """An open scene lit by a spot and a sun lamp, with open (single-plane) surfaces."""
    _reset()
    grey = diffuse_material("Grey", (0.5, 0.5, 0.5))
    white = matte_principled("WhitePaint", (0.8, 0.8, 0.8))
    red = diffuse_material("Red", (0.7, 0.12, 0.1))
    yellow = diffuse_material("Yellow", (0.75, 0.6, 0.15))
    floor = mesh_object("Floor", quad_parts([(-6, -6, 0), (6, -6, 0), (6, 6, 0), (-6, 6, 0)],
                                            (0, 0, 1), 0.25), grey)
    # A free-standing wall, one plane facing −y (toward the lamps), 4 m × 2.5 m.
    wall = mesh_object("Wall", quad_parts([(-2, 1.5, 0), (2, 1.5, 0), (2, 1.5, 2.5),
                                           (-2, 1.5, 2.5)], (0, -1, 0), 0.2), white)
    # An awning sloping down from the wall's top, facing up.
    awning = mesh_object("Awning", quad_parts([(-1.5, 1.5, 2.3), (1.5, 1.5, 2.3),
                                               (1.5, 0.0, 1.9), (-1.5, 0.0, 1.9)],
                                              (0, 0, 1), 0.15), white)
    box = mesh_object("Box", box_parts((1.0, -1.5, 0.0), (2.0, -0.5, 0.8), 0.1), red)
    sphere = uv_sphere("Sphere", (-1.2, -0.8, 0.5), 0.5, yellow)
    spot = add_lamp("SPOT", (3.0, -4.0, 5.0), name="Spot", energy=3000.0,
                    spot_size=math.radians(60.0), spot_blend=0.2, shadow_soft_size=0.1)
    aim(spot, (0.0, 0.0, 0.0))
    sun = add_lamp("SUN", (0, 0, 10), name="Sun", energy=2.0, angle=math.radians(1.0))
    sun.rotation_euler = (math.radians(50.0), 0.0, math.radians(-30.0))
    return _finish("lamps", [floor, wall, awning, box, sphere], [], [spot, sun],
                   "open scene, black world, spot + sun lamps, single-plane wall and awning")


def near() -> ReferenceScene:
    """Stability cases (see the module docstring), 20 m apart along x."""
    _reset()
    white = diffuse_material("White", (0.8, 0.8, 0.8))
    scored, emitters, lamps_, groups = [], [], [], {}

    def plane(name, corners, toward, cell, material=white):
        obj = mesh_object(name, quad_parts(corners, toward, cell), material)
        scored.append(obj)
        return obj

    # 1. An emitter 1 mm under a ceiling, a floor 1 m below.
    x = 0.0
    plane("EmitterCeiling", [(x - 1, -1, 1), (x + 1, -1, 1), (x + 1, 1, 1), (x - 1, 1, 1)],
          (0, 0, -1), 0.1)
    plane("EmitterFloor", [(x - 1, -1, 0), (x + 1, -1, 0), (x + 1, 1, 0), (x - 1, 1, 0)],
          (0, 0, 1), 0.1)
    emitters.append(mesh_object(
        "CeilingEmitter", quad_parts([(x - .25, -.25, 1 - EMITTER_GAP), (x + .25, -.25, 1 - EMITTER_GAP),
                                      (x + .25, .25, 1 - EMITTER_GAP), (x - .25, .25, 1 - EMITTER_GAP)],
                                     (0, 0, -1), 1.0), one_sided_emission("Emit", (5.0, 5.0, 5.0))))
    groups["emitter under a ceiling"] = ["EmitterCeiling", "EmitterFloor"]
    # 2. A room corner (floor + two walls meeting at x = 20, y = 0) lit by a point lamp.
    x = 20.0
    plane("CornerFloor", [(x, 0, 0), (x + 2, 0, 0), (x + 2, 2, 0), (x, 2, 0)], (0, 0, 1), 0.1)
    plane("CornerWallX", [(x, 0, 0), (x, 2, 0), (x, 2, 2), (x, 0, 2)], (1, 0, 0), 0.1)
    plane("CornerWallY", [(x, 0, 0), (x + 2, 0, 0), (x + 2, 0, 2), (x, 0, 2)], (0, 1, 0), 0.1)
    lamps_.append(add_lamp("POINT", (x + 0.7, 0.7, 1.2), name="CornerPoint", energy=100.0,
                           shadow_soft_size=0.05))
    groups["room corner"] = ["CornerFloor", "CornerWallX", "CornerWallY"]
    # 3. A strip of floor against a wall, an area lamp above the strip.
    x = 40.0
    plane("StripFloor", [(x, 0, 0), (x + 3, 0, 0), (x + 3, 0.6, 0), (x, 0.6, 0)], (0, 0, 1), 0.05)
    plane("StripWall", [(x, 0.6, 0), (x + 3, 0.6, 0), (x + 3, 0.6, 1.5), (x, 0.6, 1.5)],
          (0, -1, 0), 0.1)
    area = add_lamp("AREA", (x + 1.5, 0.1, 1.4), name="StripArea", energy=150.0, size=0.5)
    lamps_.append(area)
    groups["floor strip by a wall"] = ["StripFloor", "StripWall"]
    # 4. A thin plate (1 x 1 m, 5 mm thick) standing on a floor, lit by a spot from -y.
    x = 60.0
    plate = mesh_object("Plate", box_parts((x - 0.5, -0.0025, 0.2), (x + 0.5, 0.0025, 1.2), 0.05),
                        white)
    scored.append(plate)
    plane("PlateFloor", [(x - 1.5, -1.5, 0), (x + 1.5, -1.5, 0), (x + 1.5, 1.5, 0),
                         (x - 1.5, 1.5, 0)], (0, 0, 1), 0.1)
    spot = add_lamp("SPOT", (x, -2.0, 1.0), name="PlateSpot", energy=300.0,
                    spot_size=math.radians(50.0), spot_blend=0.1, shadow_soft_size=0.02)
    aim(spot, (x, 0.0, 0.7))
    lamps_.append(spot)
    groups["thin plate"] = ["Plate", "PlateFloor"]
    # 5. A sphere lit by a point lamp, nothing else near it.
    x = 80.0
    scored.append(uv_sphere("LitSphere", (x, 0, 1), 0.5, white))
    lamps_.append(add_lamp("POINT", (x + 1.0, -1.0, 2.0), name="SpherePoint", energy=100.0,
                           shadow_soft_size=0.0))
    groups["sphere and lamp"] = ["LitSphere"]
    return _finish("near", scored, emitters, lamps_, "stability cases 20 m apart", groups)


def sky_world(color=SKY, strength: float = 1.0) -> None:
    """A world whose Background is a constant sky ``color`` × ``strength``: lights every open
    scene in Cycles, and in Illumap (World Light)."""
    world = bpy.data.worlds.new("Sky")
    if world.node_tree is None:
        world.use_nodes = True
    background = world.node_tree.nodes.get("Background")
    background.inputs["Color"].default_value = (*color, 1.0)
    background.inputs["Strength"].default_value = strength
    bpy.context.scene.world = world


def two_sided_emission(name: str, radiance) -> "bpy.types.Material":
    """A plain Emission shader: Cycles emits it from both faces."""
    mat, out = _new_material(name)
    strength = float(max(radiance))
    emission = mat.node_tree.nodes.new("ShaderNodeEmission")
    emission.inputs["Color"].default_value = (*[c / strength for c in radiance], 1.0)
    emission.inputs["Strength"].default_value = strength
    mat.node_tree.links.new(emission.outputs["Emission"], out.inputs["Surface"])
    mat["albedo"] = (0.0, 0.0, 0.0)
    mat["emission"] = tuple(radiance)
    return mat


def world() -> ReferenceScene:
    """An open scene lit by the sky: a floor, a box resting on it, a sphere, a free-standing
    wall, and a two-sided emissive panel (plain Emission) between them; no lamps."""
    _reset()
    sky_world()
    grey = diffuse_material("Grey", (0.6, 0.6, 0.6))
    red = diffuse_material("Red", (0.7, 0.15, 0.1))
    paint = matte_principled("Paint", (0.8, 0.78, 0.74))
    floor = mesh_object("Floor", quad_parts([(-4, -4, 0), (4, -4, 0), (4, 4, 0), (-4, 4, 0)],
                                            (0, 0, 1), 0.2), grey)
    box = mesh_object("Box", box_parts((0.5, -1.0, 0.0), (1.5, 0.0, 0.8), 0.1), red)
    sphere = uv_sphere("Sphere", (-1.2, -0.5, 0.6), 0.6, paint)
    wall = mesh_object("Wall", quad_parts([(-2.5, 1.2, 0), (2.5, 1.2, 0), (2.5, 1.2, 2.0),
                                           (-2.5, 1.2, 2.0)], (0, -1, 0), 0.2), paint)
    panel = mesh_object("Panel", quad_parts([(-0.2, 0.4, 0.3), (0.2, 0.4, 0.3), (0.2, 0.4, 1.1),
                                             (-0.2, 0.4, 1.1)], (0, -1, 0), 1.0),
                        two_sided_emission("Panel", PANEL_RADIANCE))
    return _finish("world", [floor, box, sphere, wall], [panel], [],
                   "open scene under a constant sky (no lamps), box on the floor, "
                   "single-plane wall, two-sided emissive panel")


def window() -> ReferenceScene:
    """A room lit through a window by the sky and a sun (see the module docstring)."""
    _reset()
    sky_world()
    paint = diffuse_material("WallPaint", (0.75, 0.73, 0.7))
    wood = diffuse_material("Wood", (0.45, 0.3, 0.18))
    width, depth, height = 4.0, 3.0, 2.5
    walls = mesh_object("Room", box_parts((0, 0, 0), (width, depth, height), 0.1, inward=True,
                                          skip=("+y", "-z")), paint)
    floor = mesh_object("Floor", quad_parts([(0, 0, 0), (width, 0, 0), (width, depth, 0),
                                             (0, depth, 0)], (0, 0, 1), 0.1), wood)
    x0, x1, z0, z1, y = 1.2, 2.8, 0.8, 2.0, depth          # the window in the wall y = depth
    around = []
    for corners in ([(0, y, 0), (width, y, 0), (width, y, z0), (0, y, z0)],
                    [(0, y, z1), (width, y, z1), (width, y, height), (0, y, height)],
                    [(0, y, z0), (x0, y, z0), (x0, y, z1), (0, y, z1)],
                    [(x1, y, z0), (width, y, z0), (width, y, z1), (x1, y, z1)]):
        around += quad_parts(corners, (0, -1, 0), 0.1)
    window_wall = mesh_object("WindowWall", around, paint)
    table = mesh_object("Table", box_parts((1.6, 1.6, 0.0), (2.4, 2.2, 0.7), 0.1),
                        diffuse_material("Red", (0.65, 0.12, 0.1)))
    cabinet = mesh_object("Cabinet", box_parts((0.0, 0.4, 0.0), (0.5, 1.6, 1.2), 0.1,
                                               skip=("-x",)),
                          matte_principled("Blue", (0.15, 0.25, 0.6)))
    ball = uv_sphere("Ball", (3.0, 1.0, 0.35), 0.35, paint)
    sun = add_lamp("SUN", (2.0, 6.0, 5.0), name="Sun", energy=4.0, angle=math.radians(1.0))
    aim(sun, (2.0, 1.2, 0.0))
    return _finish("window", [walls, floor, window_wall, table, cabinet, ball], [], [sun],
                   "a room lit through a window by the sky and a sun, a table in the sun's "
                   "patch, a cabinet against a wall, a ball")


def monkey() -> ReferenceScene:
    """Suzanne on a floor under an area lamp, a point lamp and a dim sky (see the module
    docstring)."""
    from mathutils import Matrix
    _reset()
    sky_world(strength=0.3)
    floor = mesh_object("Floor", quad_parts([(-2, -2, 0), (2, -2, 0), (2, 2, 0), (-2, 2, 0)],
                                            (0, 0, 1), 0.1), diffuse_material("Grey", (0.6,) * 3))
    mesh = bpy.data.meshes.new("Monkey")
    bm = bmesh.new()
    bmesh.ops.create_monkey(bm)
    bmesh.ops.subdivide_edges(bm, edges=bm.edges[:], cuts=1, use_grid_fill=True, smooth=1.0)
    bmesh.ops.rotate(bm, verts=bm.verts, cent=(0, 0, 0), matrix=Matrix.Rotation(math.pi / 2, 3, "X"))
    bmesh.ops.translate(bm, verts=bm.verts, vec=(0, 0, -min(v.co.z for v in bm.verts)))
    bm.to_mesh(mesh)
    bm.free()
    mesh.shade_smooth()
    mesh.materials.append(diffuse_material("Clay", (0.7, 0.55, 0.45)))
    head = bpy.data.objects.new("Monkey", mesh)
    bpy.context.scene.collection.objects.link(head)
    key = add_lamp("AREA", (1.5, -1.5, 2.5), name="Key", energy=300.0, size=1.0)
    aim(key, (0.0, 0.0, 0.5))
    fill = add_lamp("POINT", (-1.5, -1.0, 1.5), name="Fill", energy=60.0, shadow_soft_size=0.1)
    return _finish("monkey", [head, floor], [], [key, fill],
                   "smooth Suzanne on a floor, area + point lamps, dim sky")


def scan_room() -> ReferenceScene:
    """The Cornell box given to Illumap as a scan: its walls' and blocks' vertices as one
    point cloud without normals (the light kept as a mesh), scored against the Cornell box's
    reference at those points."""
    scene = cornell_scan()
    scene.name, scene.reference = "scan_room", "cornell"
    scene.notes = "the Cornell box's 5,341 vertices as a point cloud without normals; " + scene.notes
    return scene


def cornell_scan(cell: float = 0.1) -> ReferenceScene:
    """The Cornell box with its walls and blocks as grids of ``cell`` m, all of them to be
    given to Illumap as one scan (``run.scan_objects``): 0.02 m makes 123k points, 0.01 m
    486k (the micro-benchmarks of dense scans)."""
    scene = cornell(cell)
    scene.name = f"cornell_scan_{cell:g}"
    scene.scan = [o.name for o in scene.scored]
    return scene


def read_ply(path: str) -> tuple[np.ndarray, np.ndarray]:
    """Vertices (V, 3) and triangles (F, 3) of an ASCII PLY such as the Stanford bunny."""
    with open(path) as f:
        counts, header = {}, 0
        for line in f:
            header += 1
            parts = line.split()
            if parts[:1] == ["element"]:
                counts[parts[1]] = int(parts[2])
            if parts[:1] == ["end_header"]:
                break
        rows = f.read().split("\n")
    nv, nf = counts["vertex"], counts["face"]
    verts = np.array([r.split()[:3] for r in rows[:nv]], dtype=np.float64)
    faces = np.array([r.split()[1:4] for r in rows[nv:nv + nf]], dtype=np.int64)
    return verts, faces


def scan_object() -> ReferenceScene:
    """The Stanford bunny (a real range scan, BUNNY_CREDIT) scaled to 0.5 m, standing on a
    floor under the sky and a sun. Illumap gets the bunny's vertices as a point cloud without
    normals; Cycles bakes the scan's own triangles."""
    _reset()
    sky_world(strength=0.5)
    verts, faces = read_ply(BUNNY_PLY)
    verts = verts[:, [0, 2, 1]] * np.array([1.0, -1.0, 1.0])          # y up -> z up
    verts = (verts - [verts[:, 0].mean(), verts[:, 1].mean(), verts[:, 2].min()]) * BUNNY_SCALE
    mesh = bpy.data.meshes.new("Bunny")
    mesh.from_pydata(verts, [], faces)          # (x, -z, y) is a rotation: winding kept
    mesh.validate()
    mesh.materials.append(diffuse_material("Clay", (0.75, 0.6, 0.45)))
    bunny = bpy.data.objects.new("Bunny", mesh)
    bpy.context.scene.collection.objects.link(bunny)
    floor = mesh_object("Floor", quad_parts([(-1.5, -1.5, 0), (1.5, -1.5, 0), (1.5, 1.5, 0),
                                             (-1.5, 1.5, 0)], (0, 0, 1), 0.1),
                        diffuse_material("Grey", (0.6, 0.6, 0.6)))
    sun = add_lamp("SUN", (0, 0, 5), name="Sun", energy=3.0, angle=math.radians(2.0))
    sun.rotation_euler = (math.radians(40.0), 0.0, math.radians(30.0))
    scene = _finish("scan_object", [bunny, floor], [], [sun],
                    f"Stanford bunny ({len(verts)} vertices) x {BUNNY_SCALE:g} as a point cloud "
                    "without normals on a mesh floor, sky + sun")
    scene.scan = ["Bunny"]
    scene.reference_samples = 1024
    scene.only_settings = ("default", "DRAFT", "HIGH", "target 0.05", "target 0.03")
    scene.cycles_samples = (16, 64, 256)
    return scene


SCENES = {"cornell": cornell, "room": room, "lamps": lamps, "near": near, "world": world,
          "window": window, "monkey": monkey, "scan_room": scan_room,
          "scan_object": scan_object}


def build(name: str) -> ReferenceScene:
    """Build the scene ``name`` (one of SCENES) in a fresh, empty file."""
    return SCENES[name]()
