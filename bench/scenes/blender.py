"""The Blender builder: a scene declared as data (``spec.Scene``, ``meshes.py``) made into
Blender objects in an empty file, the way users build them (subdivided grids with shared
vertices, Blender's UV sphere, Diffuse or matte Principled materials, one-sided emitters, a
black or sky world, lamps), and the reference bench's view of it (``ReferenceScene``).

A built scene's meshes carry their materials' albedo (and emission) as custom properties, so
that ``vertex_materials`` turns Cycles' baked incident radiance into outgoing radiance
(``bench/reference/bake.py``). Vertices are not surfel positions: Illumap samples its own
surfels on these meshes and writes its result back to the vertices, as it does for users.

One-sided emitters use Geometry ▸ Backfacing as the factor of a Mix Shader between the
emission (front) and black (back): an Emission shader alone emits from both faces in Cycles,
while Illumap's surfels emit along their normal only.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import bpy  # before bmesh: the bpy module provides it
import bmesh
import numpy as np

from . import meshes, spec
from .meshes import SKY
# What the furnace cases (bench/reference/furnace.py) build their own scenes with:
from .meshes import BUNNY_SCALE  # noqa: F401
from .shapes import BUNNY_CREDIT, BUNNY_PLY, box_parts, bunny_scan, quad_parts  # noqa: F401

#: The reference scenes by name (``meshes.REFERENCE``).
SCENES = meshes.REFERENCE


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


def build(name: str) -> ReferenceScene:
    """Build the reference scene ``name`` (one of SCENES) in a fresh, empty file."""
    return build_scene(SCENES[name]())


def cornell_scan(cell: float = 0.1) -> ReferenceScene:
    """The Cornell box of ``cell`` m grids to be given to Illumap as one scan
    (``meshes.cornell_scan``), built."""
    return build_scene(meshes.cornell_scan(cell))


def build_scene(scene: spec.Scene) -> ReferenceScene:
    """``scene`` in a fresh, empty file, with the albedo and emission of its scored vertices."""
    objects = build_objects(scene)
    built = finish(scene.name, [objects[m.name] for m in scene.meshes("scored")], [], [],
                   scene.notes, scene.groups)
    built.emitters = [objects[m.name] for m in scene.meshes("emitter")]
    built.lamps = [objects[lamp.name] for lamp in scene.lamps()]
    built.scan = list(scene.scan)
    built.reference, built.reference_samples = scene.reference, scene.reference_samples
    built.only_settings, built.cycles_samples = scene.only_settings, scene.cycles_samples
    return built


def build_objects(scene: spec.Scene) -> dict:
    """Every object of ``scene`` made in a fresh, empty file, in its order: name → object."""
    reset()
    if scene.sky is not None:
        sky_world(*scene.sky)
    materials, out = {}, {}
    for item in scene.objects:
        if isinstance(item, spec.Lamp):
            obj = add_lamp(item.kind, item.location, item.rotation, name=item.name,
                           **item.props)
            if item.aim is not None:
                aim(obj, item.aim)
        else:
            made = materials.get(item.material.name)
            if made is None:
                made = materials[item.material.name] = (item.material, material(item.material))
            elif made[0] != item.material:
                raise ValueError(f"scene {scene.name!r}: two materials named "
                                 f"{item.material.name!r}")
            obj = mesh(item, made[1])
        out[item.name] = obj
    if scene.camera is not None:
        out["Camera"] = camera(scene.camera)
    bpy.context.view_layer.update()
    return out


def mesh(item: spec.Mesh, mat) -> "bpy.types.Object":
    """The mesh object of ``item`` with material ``mat``."""
    if item.shape == "parts":
        return mesh_object(item.name, item.parts, mat, weld=item.weld,
                           triangulate=item.triangulate, uv=item.uv)
    if item.shape == "uv_sphere":
        return uv_sphere(item.name, item.centre, item.radius, mat)
    if item.shape == "monkey":
        return monkey(item.name, mat)
    raise ValueError(f"mesh {item.name!r}: unknown shape {item.shape!r}")


def finish(name: str, scored: list, emitters: list, lamps: list, notes: str,
           groups: dict | None = None) -> ReferenceScene:
    """A built scene of these objects, with the albedo and emission of its scored vertices."""
    bpy.context.view_layer.update()
    albedo, emission = {}, {}
    for obj in scored:
        albedo[obj.name], emission[obj.name] = vertex_materials(obj)
    return ReferenceScene(name, scored, emitters, lamps, albedo, emission, notes, groups or {})


def reset() -> None:
    """An empty file with a black world."""
    bpy.ops.wm.read_factory_settings(use_empty=True)
    black_world()


# --- materials ------------------------------------------------------------------------------

def material(m: spec.Material) -> "bpy.types.Material":
    """The Blender material of ``m``."""
    if m.kind == "diffuse":
        return diffuse_material(m.name, m.color)
    if m.kind == "matte":
        image = checker_image() if m.image == "checker" else None
        return matte_principled(m.name, m.color, image=image)
    if m.kind == "emit":
        return one_sided_emission(m.name, m.radiance)
    if m.kind == "emit_both":
        return two_sided_emission(m.name, m.radiance)
    raise ValueError(f"material {m.name!r}: unknown kind {m.kind!r}")


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


# --- worlds, lamps, camera -------------------------------------------------------------------

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
    """Point an object's −Z axis (a lamp's or a camera's view) at ``target`` (m)."""
    from mathutils import Vector
    direction = Vector(target) - obj.location
    obj.rotation_euler = direction.to_track_quat("-Z", "Y").to_euler()


def camera(c: spec.Camera):
    """The scene camera of ``c``."""
    cam = bpy.data.cameras.new("Camera")
    cam.lens = c.lens
    obj = bpy.data.objects.new("Camera", cam)
    bpy.context.scene.collection.objects.link(obj)
    obj.location = c.location
    aim(obj, c.target)
    bpy.context.scene.camera = obj
    return obj


# --- meshes ---------------------------------------------------------------------------------

def mesh_object(name: str, parts, material, *, weld: bool = True, triangulate: bool = False,
                uv: bool = False):
    """A mesh object from ``parts`` [(verts, faces, uvs)] (m) with one material. ``weld``
    merges coincident vertices (shared edges, as a modelled mesh has them); ``triangulate``
    splits the quads (beauty); ``uv`` adds a UV map "UVMap" from the parts' UVs."""
    verts, faces, uvs, offset = [], [], [], 0
    for v, f, t in parts:
        verts.append(v)
        faces.append(f + offset)
        uvs.append(t)
        offset += len(v)
    verts, faces = np.concatenate(verts), np.concatenate(faces)
    mesh = bpy.data.meshes.new(name)
    mesh.from_pydata(verts, [], faces)
    if uv:
        uvs = np.concatenate(uvs)
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


def monkey(name: str, material):
    """Blender's Suzanne subdivided once (smoothed), smooth-shaded, standing on z = 0."""
    from mathutils import Matrix
    mesh = bpy.data.meshes.new(name)
    bm = bmesh.new()
    bmesh.ops.create_monkey(bm)
    bmesh.ops.subdivide_edges(bm, edges=bm.edges[:], cuts=1, use_grid_fill=True, smooth=1.0)
    bmesh.ops.rotate(bm, verts=bm.verts, cent=(0, 0, 0), matrix=Matrix.Rotation(math.pi / 2, 3, "X"))
    bmesh.ops.translate(bm, verts=bm.verts, vec=(0, 0, -min(v.co.z for v in bm.verts)))
    bm.to_mesh(mesh)
    bm.free()
    mesh.shade_smooth()
    mesh.materials.append(material)
    obj = bpy.data.objects.new(name, mesh)
    bpy.context.scene.collection.objects.link(obj)
    return obj


# --- per-vertex material values --------------------------------------------------------------

def _linear_from_srgb(c: np.ndarray) -> np.ndarray:
    return np.where(c <= 0.04045, c / 12.92, ((c + 0.055) / 1.055) ** 2.4)


def image_bilinear(image, uv: np.ndarray) -> np.ndarray:
    """Linear RGB (N, 3) of ``image`` at ``uv`` (N, 2) with Cycles' Linear interpolation and
    Repeat extension (texel i's centre at (i + 0.5)/W). sRGB byte images are interpolated as
    stored and linearised afterwards, as Cycles does (measured: a bake with 'COLOR' in the
    pass filter equals this albedo × the incident bake to 1e-4 (relative RMS) on the checker
    floor, where linearising texels first is 2% darker on average and up to 12% at cell edges)."""
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
