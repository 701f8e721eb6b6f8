"""Shared fixtures for the tests that run through bpy (the bpy module, or ``blender -b``).

* The add-on is registered once per session from the checkout: the repository root goes on
  sys.path and ``import addon; addon.register()`` runs. Classes and ``Scene.illumap`` live on
  the RNA types, so they survive factory resets; ``registered_addon`` re-registers if a reset
  ever dropped them.
* Every test starts from ``bpy.ops.wm.read_factory_settings(use_empty=True)`` (autouse).
* Helpers (importable as ``illumap_bpy_testing``) build small scenes: meshes, a surfel object with the attributes of
  docs/architecture.md, a scan as users bring one (``scan_object``), an orthographic top camera, and a tiny Cycles render read back as
  linear float pixels.
"""

import os
import sys
import tempfile

import numpy as np
import pytest

REPO_ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
if REPO_ROOT not in sys.path:
    sys.path.insert(0, REPO_ROOT)

import bpy  # noqa: E402

EEVEE_ENV = "ILLUMAP_TEST_EEVEE"

# scripts/blender (the stand-in for Blender's binary) runs on the bpy of this test run, so the
# tests on .venv-blender50 exercise bpy 5.0 there too.
os.environ.setdefault("ILLUMAP_PYTHON", sys.executable)

# Test modules import the helpers below as ``from illumap_bpy_testing import ...``: several
# conftest.py files may exist (tests/core too), so the name "conftest" is ambiguous.
sys.modules.setdefault("illumap_bpy_testing", sys.modules[__name__])


def _addon_registered():
    return hasattr(bpy.types.Scene, "illumap") and hasattr(bpy.types, "VIEW3D_PT_illumap")


@pytest.fixture(scope="session")
def addon_module():
    """The ``addon`` package, registered for the whole session."""
    import addon
    bpy.ops.wm.read_factory_settings(use_empty=True)
    addon.register()
    yield addon
    try:
        addon.unregister()
    except Exception:
        pass


@pytest.fixture(autouse=True)
def factory_reset(addon_module):
    """A clean, empty scene for every test, with the add-on registered."""
    bpy.ops.wm.read_factory_settings(use_empty=True)
    if not _addon_registered():
        addon_module.register()
    yield


@pytest.fixture
def registered_addon(addon_module):
    return addon_module


def core_available():
    """True when the native core and the pipeline import (the full add-on)."""
    try:
        import illumap
        if hasattr(illumap, "native_available") and not illumap.native_available():
            return False
        from addon import pipeline  # noqa: F401
    except Exception:
        return False
    return True


requires_core = pytest.mark.skipif(not core_available(),
                                   reason="the native module 'illumap' or addon/pipeline.py is "
                                          "not available")


# --- scene builders ------------------------------------------------------------------------

def link(obj, scene=None):
    (scene or bpy.context.scene).collection.objects.link(obj)
    return obj


def select_only(*objects):
    for obj in bpy.context.view_layer.objects:
        obj.select_set(False)
    for obj in objects:
        obj.select_set(True)
    if objects:
        bpy.context.view_layer.objects.active = objects[0]


def add_lamp(kind, location=(0, 0, 1), rotation=(0, 0, 0), **props):
    """A lamp object of ``kind`` (POINT, SPOT, SUN, AREA) with the given light properties."""
    light = bpy.data.lights.new("L" + kind, kind)
    for k, v in props.items():
        setattr(light, k, v)
    obj = link(bpy.data.objects.new("L" + kind, light))
    obj.location, obj.rotation_euler = location, rotation
    return obj


def make_plane(name, size=1.0, location=(0.0, 0.0, 0.0), flip=False, material=None):
    """A square quad of side ``size`` centred at ``location``, normal +Z (−Z when ``flip``)."""
    h = size / 2.0
    verts = [(-h, -h, 0.0), (h, -h, 0.0), (h, h, 0.0), (-h, h, 0.0)]
    faces = [(0, 3, 2, 1)] if flip else [(0, 1, 2, 3)]
    mesh = bpy.data.meshes.new(name)
    mesh.from_pydata(verts, [], faces)
    mesh.update()
    if material is not None:
        mesh.materials.append(material)
    obj = bpy.data.objects.new(name, mesh)
    obj.location = location
    return link(obj)


def diffuse_material(name, color):
    mat = bpy.data.materials.new(name)
    if mat.node_tree is None:
        mat.use_nodes = True
    nodes = mat.node_tree.nodes
    nodes.clear()
    out = nodes.new("ShaderNodeOutputMaterial")
    bsdf = nodes.new("ShaderNodeBsdfDiffuse")
    bsdf.inputs["Color"].default_value = (*color, 1.0)
    mat.node_tree.links.new(bsdf.outputs["BSDF"], out.inputs["Surface"])
    return mat


def emission_material(name, color, strength=1.0):
    mat = bpy.data.materials.new(name)
    if mat.node_tree is None:
        mat.use_nodes = True
    nodes = mat.node_tree.nodes
    nodes.clear()
    out = nodes.new("ShaderNodeOutputMaterial")
    em = nodes.new("ShaderNodeEmission")
    em.inputs["Color"].default_value = (*color, 1.0)
    em.inputs["Strength"].default_value = strength
    mat.node_tree.links.new(em.outputs["Emission"], out.inputs["Surface"])
    return mat


def _set_attribute(data, name, kind, values):
    attr = data.attributes.new(name, kind, "POINT")
    key = {"FLOAT_COLOR": "color", "FLOAT_VECTOR": "vector", "FLOAT": "value"}[kind]
    attr.data.foreach_set(key, np.ascontiguousarray(values, dtype=np.float32).ravel())
    return attr


def _rgba(values, n):
    values = np.asarray(values, dtype=np.float64)
    if values.ndim == 1:
        values = np.tile(values, (n, 1))
    if values.shape[1] == 3:
        values = np.concatenate([values, np.ones((n, 1))], axis=1)
    return values


def make_surfels(positions, normals, radius, illumination, albedo=(0.5, 0.5, 0.5),
                 emission=(0.0, 0.0, 0.0), name="Illumap Surfels", pointcloud=False):
    """A surfel object with the attributes of docs/architecture.md (vertex-only mesh, or a
    point cloud converted from it when ``pointcloud``)."""
    positions = np.asarray(positions, dtype=np.float64).reshape(-1, 3)
    n = len(positions)
    normals = np.broadcast_to(np.asarray(normals, dtype=np.float64), (n, 3))
    radius = np.broadcast_to(np.asarray(radius, dtype=np.float64), (n,))
    mesh = bpy.data.meshes.new(name)
    mesh.vertices.add(n)
    mesh.vertices.foreach_set("co", positions.astype(np.float32).ravel())
    _set_attribute(mesh, "illumination", "FLOAT_COLOR", _rgba(illumination, n))
    _set_attribute(mesh, "normal", "FLOAT_VECTOR", normals)
    _set_attribute(mesh, "radius", "FLOAT", radius)
    _set_attribute(mesh, "albedo", "FLOAT_COLOR", _rgba(albedo, n))
    _set_attribute(mesh, "emission", "FLOAT_COLOR", _rgba(emission, n))
    mesh.update()
    obj = link(bpy.data.objects.new(name, mesh))
    if pointcloud:
        select_only(obj)
        bpy.ops.object.convert(target="POINTCLOUD")
        obj = bpy.context.view_layer.objects.active
    return obj


def scan_object(positions, albedo, normals=None, name="Scan"):
    """A scan as users bring one: a vertex-only object at ``positions`` (V, 3) m with its
    albedo (RGB, or (V, 3)) in a POINT "Col" colour attribute, no radii, and with ``normals``
    (V, 3) a "normal" attribute (else none: Illumap estimates them)."""
    positions = np.asarray(positions, dtype=np.float64).reshape(-1, 3)
    n = len(positions)
    data = bpy.data.meshes.new(name)
    data.vertices.add(n)
    data.vertices.foreach_set("co", positions.astype(np.float32).ravel())
    colour = data.color_attributes.new("Col", "FLOAT_COLOR", "POINT")
    colour.data.foreach_set("color", _rgba(albedo, n).astype(np.float32).ravel())
    data.color_attributes.active_color = colour
    if normals is not None:
        data.attributes.new("normal", "FLOAT_VECTOR", "POINT").data.foreach_set(
            "vector", np.asarray(normals, np.float32).ravel())
    return link(bpy.data.objects.new(name, data))


def grid_positions(n, size=1.0, z=0.0):
    """n×n cell centres of a square of side ``size`` centred at the origin, at height z."""
    xs = (np.arange(n) + 0.5) / n * size - size / 2.0
    x, y = np.meshgrid(xs, xs, indexing="ij")
    return np.stack([x.ravel(), y.ravel(), np.full(n * n, z)], axis=1)


def top_camera(ortho_scale=2.0, height=5.0):
    cam = bpy.data.cameras.new("Top")
    cam.type = "ORTHO"
    cam.ortho_scale = ortho_scale
    obj = link(bpy.data.objects.new("Top", cam))
    obj.location = (0.0, 0.0, height)
    bpy.context.scene.camera = obj
    return obj


def sky_world(color=(0.6, 0.75, 1.0), strength=1.0, scene=None):
    """A world whose Background is the constant ``color`` × ``strength`` (a uniform sky)."""
    scene = scene or bpy.context.scene
    world = bpy.data.worlds.new("Sky")
    if world.node_tree is None:
        world.use_nodes = True
    background = world.node_tree.nodes["Background"]
    background.inputs["Color"].default_value = (*color, 1.0)
    background.inputs["Strength"].default_value = strength
    scene.world = world
    return world


def black_world(scene=None):
    scene = scene or bpy.context.scene
    world = bpy.data.worlds.new("Black")
    if world.node_tree is None:
        world.use_nodes = True
    bg = world.node_tree.nodes.get("Background")
    if bg is not None:
        bg.inputs["Color"].default_value = (0.0, 0.0, 0.0, 1.0)
    scene.world = world
    return world


def render_pixels(size=32, engine="CYCLES", samples=4, scene=None):
    """Render the scene at size×size and return linear RGBA float pixels, shape (size, size, 4),
    row 0 at the bottom of the image (Blender's order)."""
    scene = scene or bpy.context.scene
    r = scene.render
    r.engine = engine
    r.resolution_x = r.resolution_y = size
    r.resolution_percentage = 100
    r.film_transparent = False
    if engine == "CYCLES":
        scene.cycles.device = "CPU"
        scene.cycles.samples = samples
        scene.cycles.use_denoising = False
        scene.cycles.use_adaptive_sampling = False
    elif engine.startswith("BLENDER_EEVEE"):
        scene.eevee.taa_render_samples = samples
    scene.view_settings.view_transform = "Standard"
    r.image_settings.file_format = "OPEN_EXR"
    r.image_settings.color_depth = "32"
    with tempfile.TemporaryDirectory() as tmp:
        path = os.path.join(tmp, "render.exr")
        r.filepath = path
        bpy.ops.render.render(write_still=True)
        img = bpy.data.images.load(path)
        try:
            px = np.empty(size * size * 4, dtype=np.float32)
            img.pixels.foreach_get(px)
        finally:
            bpy.data.images.remove(img)
    return px.reshape(size, size, 4)


def snapshot():
    """Names of objects, meshes, point clouds, materials, node groups, and each geometry's
    attribute names: what a cancelled or failed run must leave as it was."""
    def attrs(data):
        return tuple(sorted(a.name for a in data.attributes))
    return {
        "objects": sorted(o.name for o in bpy.data.objects),
        "meshes": sorted((m.name, attrs(m)) for m in bpy.data.meshes),
        "pointclouds": sorted((p.name, attrs(p)) for p in bpy.data.pointclouds),
        "materials": sorted(m.name for m in bpy.data.materials),
        "node_groups": sorted(g.name for g in bpy.data.node_groups),
        "modifiers": sorted((o.name, m.name) for o in bpy.data.objects for m in o.modifiers),
    }


def disc_segment_query(positions, normals, areas, coverage=1.3):
    """A brute-force numpy stand-in for the core's segment query: ``visible(origins, targets,
    skip, progress=None)`` is 0 where the open segment crosses a surfel disc (radius coverage·sqrt(A/π))
    other than ``skip``, else 1. O(rays × surfels): small test scenes only."""
    centres = np.asarray(positions, dtype=np.float64)
    nrm = np.asarray(normals, dtype=np.float64)
    rad2 = (coverage * np.sqrt(np.asarray(areas, dtype=np.float64) / np.pi)) ** 2
    plane = np.einsum("ij,ij->i", nrm, centres)
    index = np.arange(len(centres))

    def visible(origins, targets, skip, progress=None):  # progress: not reported
        origins = np.asarray(origins, dtype=np.float64)
        d = np.asarray(targets, dtype=np.float64) - origins
        out = np.ones(len(origins), dtype=np.float32)
        step = max(1, 2_000_000 // max(len(centres), 1))
        for a in range(0, len(origins), step):
            o, dd = origins[a:a + step], d[a:a + step]
            denom = dd @ nrm.T
            safe = np.where(np.abs(denom) > 1e-300, denom, 1.0)
            s = (plane[None, :] - o @ nrm.T) / safe
            hit_pts = o[:, None, :] + s[..., None] * dd[:, None, :]
            dist2 = ((hit_pts - centres[None]) ** 2).sum(-1)
            hit = (np.abs(denom) > 1e-300) & (s > 1e-9) & (s < 1 - 1e-9) & (dist2 < rad2[None]) \
                & (index[None, :] != np.asarray(skip)[a:a + step, None])
            out[a:a + step] = np.where(hit.any(axis=1), 0.0, 1.0)
        return out

    return visible
