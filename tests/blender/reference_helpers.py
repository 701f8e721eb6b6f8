"""Small scenes and their Cycles references for the light and preview tests: walls, boxes and
planes of grid meshes, diffuse and one-sided emissive materials, Cycles' outgoing light at
their vertices and Illumap's through the add-on (``tests/blender/light/test_reference_cases.py``
explains the references and their noise)."""

import bpy
import numpy as np

from illumap_bpy_testing import link

from addon import pipeline

SAMPLES = 256
WHITE = (0.8, 0.8, 0.8)


# --- scene helpers (numpy grids; bmesh for the sphere) ---------------------------------------

def diffuse(name, color=WHITE):
    mat = bpy.data.materials.new(name)
    if mat.node_tree is None:
        mat.use_nodes = True
    nodes = mat.node_tree.nodes
    nodes.clear()
    bsdf = nodes.new("ShaderNodeBsdfDiffuse")
    bsdf.inputs["Color"].default_value = (*color, 1.0)
    mat.node_tree.links.new(bsdf.outputs["BSDF"], nodes.new("ShaderNodeOutputMaterial").inputs["Surface"])
    mat["albedo"] = tuple(color)
    return mat


def one_sided_emission(name, radiance):
    """Emission on the front face only (Geometry ▸ Backfacing mixes in black on the back):
    Cycles' Emission alone emits from both faces, Illumap's surfels along their normal."""
    mat = bpy.data.materials.new(name)
    if mat.node_tree is None:
        mat.use_nodes = True
    nodes, links = mat.node_tree.nodes, mat.node_tree.links
    nodes.clear()
    emission = nodes.new("ShaderNodeEmission")
    emission.inputs["Color"].default_value = (1.0, 1.0, 1.0, 1.0)
    emission.inputs["Strength"].default_value = radiance
    black = nodes.new("ShaderNodeBsdfDiffuse")
    black.inputs["Color"].default_value = (0.0, 0.0, 0.0, 1.0)
    mix = nodes.new("ShaderNodeMixShader")
    links.new(nodes.new("ShaderNodeNewGeometry").outputs["Backfacing"], mix.inputs["Fac"])
    links.new(emission.outputs[0], mix.inputs[1])
    links.new(black.outputs[0], mix.inputs[2])
    links.new(mix.outputs[0], nodes.new("ShaderNodeOutputMaterial").inputs["Surface"])
    return mat


def black_world():
    """No ambient light: Blender 5's new world is a grey background of strength 1."""
    world = bpy.data.worlds.new("Black")
    if world.node_tree is None:
        world.use_nodes = True
    background = world.node_tree.nodes["Background"]
    background.inputs["Color"].default_value = (0.0, 0.0, 0.0, 1.0)
    background.inputs["Strength"].default_value = 0.0
    bpy.context.scene.world = world


def grid_parts(corners, cell):
    """Vertices and quads of a grid of ~``cell`` m over the quad ``corners`` (c0 → c1 → c2 → c3,
    normal (c1 − c0) × (c3 − c0))."""
    c = np.asarray(corners, dtype=np.float64)
    nu = max(1, int(round(np.linalg.norm(c[1] - c[0]) / cell)))
    nv = max(1, int(round(np.linalg.norm(c[3] - c[0]) / cell)))
    s, t = (a.ravel()[:, None] for a in np.meshgrid(np.linspace(0, 1, nu + 1), np.linspace(0, 1, nv + 1)))
    verts = (1 - s) * (1 - t) * c[0] + s * (1 - t) * c[1] + s * t * c[2] + (1 - s) * t * c[3]
    i, j = (a.ravel() for a in np.meshgrid(np.arange(nu), np.arange(nv)))
    first = j * (nu + 1) + i
    return verts, np.stack([first, first + 1, first + nu + 2, first + nu + 1], axis=1)


def mesh(name, parts, material):
    """A mesh object from [(verts, quads)], coincident vertices merged (shared edges)."""
    import bmesh
    verts, faces, offset = [], [], 0
    for v, f in parts:
        verts.append(v)
        faces.append(f + offset)
        offset += len(v)
    data = bpy.data.meshes.new(name)
    data.from_pydata(np.concatenate(verts), [], np.concatenate(faces))
    bm = bmesh.new()
    bm.from_mesh(data)
    bmesh.ops.remove_doubles(bm, verts=bm.verts, dist=1e-6)
    bm.to_mesh(data)
    bm.free()
    data.validate()
    data.materials.append(material)
    return link(bpy.data.objects.new(name, data))


def plane(name, corners, cell, material):
    return mesh(name, [grid_parts(corners, cell)], material)


def closed_box(name, lo, hi, cell, material):
    """The six outward faces of the axis-aligned box lo–hi as grids of ~``cell`` m."""
    lo, hi = np.asarray(lo, float), np.asarray(hi, float)
    parts = []
    for axis in range(3):
        a, b = [k for k in range(3) if k != axis]
        for value, sign in ((lo[axis], -1.0), (hi[axis], 1.0)):
            corners = np.zeros((4, 3))
            corners[:, axis] = value
            corners[:, a] = [lo[a], hi[a], hi[a], lo[a]]
            corners[:, b] = [lo[b], lo[b], hi[b], hi[b]]
            normal = np.cross(corners[1] - corners[0], corners[3] - corners[0])
            if normal[axis] * sign < 0:
                corners = corners[[0, 3, 2, 1]]
            parts.append(grid_parts(corners, cell))
    return mesh(name, parts, material)


def positions(obj):
    co = np.empty(len(obj.data.vertices) * 3)
    obj.data.vertices.foreach_get("co", co)
    m = np.array(obj.matrix_world)
    return co.reshape(-1, 3) @ m[:3, :3].T + m[:3, 3]


def read_colors(obj, name):
    rgba = np.empty(len(obj.data.vertices) * 4, np.float32)
    obj.data.color_attributes[name].data.foreach_get("color", rgba)
    return rgba.reshape(-1, 4)[:, :3].astype(np.float64)


# --- the two renderers -----------------------------------------------------------------------

def cycles_outgoing(scored, samples=SAMPLES, seed=0):
    """Cycles' outgoing radiance per vertex, {name: (V, 3)} (the scored meshes emit nothing)."""
    scene = bpy.context.scene
    scene.render.engine = "CYCLES"
    cyc = scene.cycles
    cyc.device, cyc.samples, cyc.seed = "CPU", samples, seed
    cyc.use_adaptive_sampling = False
    cyc.max_bounces = cyc.diffuse_bounces = 64
    cyc.sample_clamp_direct = cyc.sample_clamp_indirect = 0.0
    for obj in bpy.context.view_layer.objects:
        obj.select_set(False)
    for obj in scored:
        attrs = obj.data.color_attributes
        attrs.active_color = attrs.new("bake", "FLOAT_COLOR", "POINT")
        obj.select_set(True)
    bpy.context.view_layer.objects.active = scored[0]
    bpy.ops.object.bake(type="DIFFUSE", pass_filter={"DIRECT", "INDIRECT"}, target="VERTEX_COLORS")
    out = {}
    for obj in scored:
        albedo = np.asarray(obj.data.materials[0]["albedo"], dtype=np.float64)
        out[obj.name] = albedo * read_colors(obj, "bake")
        obj.data.color_attributes.remove(obj.data.color_attributes["bake"])
    return out


def illumap_outgoing(scored, emitters=()):
    """Illumap's default-settings result at the vertices, {name: (V, 3)}."""
    pipeline.compute(bpy.context, list(scored) + list(emitters),
                     pipeline.Settings(transfer=True, transfer_domain="POINT"))
    return {obj.name: read_colors(obj, "illumination") for obj in scored}


def relative_rms(values, reference):
    return float(np.sqrt(np.sum((values - reference) ** 2) / np.sum(reference ** 2)))


def both(scored, emitters=()):
    """(Illumap, Cycles) per-vertex outgoing radiance, each stacked (ΣV, 3) in ``scored``
    order, and the vertex positions (ΣV, 3)."""
    ref = cycles_outgoing(scored)
    got = illumap_outgoing(scored, emitters)
    stack = lambda d: np.concatenate([d[o.name] for o in scored])  # noqa: E731
    return stack(got), stack(ref), np.concatenate([positions(o) for o in scored])


def report(case, **values):
    print(f"\n{case}: " + ", ".join(f"{k} {v:.4f}" for k, v in values.items()))
