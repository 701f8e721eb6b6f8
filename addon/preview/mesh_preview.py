"""Preview on the objects: the illumination shown on the user's own meshes and point clouds,
in one click.

``build_mesh_preview(objects)`` puts a Geometry Nodes modifier, last in each object's stack,
that gives the evaluated geometry the shared material ``Illumap Illumination``: an Attribute
node (GEOMETRY) reading ``illumination`` into an Emission shader of strength 1, so Cycles and
EEVEE show the light Illumap computed at the object's own corners or points, as a render would
show it.

* Meshes with faces: a Set Material node (``Illumap Mesh Preview``); the renderer interpolates
  the corner or point values across the faces like any colour attribute.
* Point clouds and vertex-only meshes (scans): every point of the object is a splat, coloured
  by the light evaluated at that very point, whatever number of surfels the solve used
  (``Illumap Point Preview``): an ellipse in the point's tangent plane, sized from its
  neighbours and cut back at creases and rims (``point_splats.splat_frames``), drawn as a
  flat double cone so that where splats overlap the nearest point's light shows, instanced from
  four hidden point attributes (``SPLAT_ATTRIBUTES``) that ``build_mesh_preview`` writes and
  ``remove_mesh_preview`` removes; its material reads the point's ``illumination`` through
  an INSTANCER Attribute node. Where those attributes cannot be written (linked data), the
  points render as spheres instead (``point_node_group``): each point's ``radius``, else
  ``point_radius``, the median distance to the 6th nearest neighbour.

The user's material slots are never touched, and removing the modifier (``remove_mesh_preview``,
which removes a scan's splat attributes too) gives the objects back exactly as they were. The material and the
node groups carry the custom property ``illumap_generated``: a user's own datablock that
happens to bear one of these names is left alone.
"""

from __future__ import annotations

import math

import bpy
import numpy as np

from .. import compat
from . import point_splats
from .splat_shading import (
    SHADING_ATTRIBUTES, SHADING_NAMES, vector_attribute, write_shading
)
from ..kinds import RESULT_TYPES
from ..write.output import ATTRIBUTE, MARKER

MODIFIER_NAME = "Illumap Mesh Preview"
NODE_GROUP_NAME = "Illumap Mesh Preview"
POINT_MODIFIER_NAME = "Illumap Point Preview"
POINT_NODE_GROUP_NAME = "Illumap Point Preview"
#: The spheres a scan falls back to where its splats' attributes cannot be written (linked).
SPHERE_NODE_GROUP_NAME = "Illumap Point Preview (Spheres)"
SPLAT_MATERIAL_NAME = "Illumap Splat Illumination"
#: The hidden point attributes (a leading dot: Blender lists them nowhere) that shape each
#: point's splat (``point_splats.splat_frames``); written by ``build_mesh_preview`` and
#: removed with the preview.
SPLAT_ATTRIBUTES = {key: f".illumap_splat_{key}" for key in ("normal", "axis", "scale", "offset")}
# Each splat's linear shading: hidden point attributes (``splat_shading.SHADING_ATTRIBUTES``)
# that the node group copies to the instances under ``SHADING_NAMES`` for the material.
#: Custom property on a scan's data: what its splats were computed from (``_fingerprint``),
#: so that a refresh of an unchanged scan writes nothing again.
SPLAT_KEY = "illumap_splats"
#: Sides of the polygon each splat is drawn as (a double cone: twice as many triangles). 12
#: kept the scan scenes' figures of 16 within their uncertainty (128², the same references:
#: room scan with normals 2.84% against 2.79%, room scan 4.10% against 4.06%, bunny 2.34%
#: both) with a quarter fewer triangles; 10 began to lose (4.15% on the room scan).
SPLAT_SIDES = 12
#: Height of each splat's cone (both sides) in units of its first semi-axis: enough for a
#: renderer's depth to tell neighbours apart, too little to see (0.1 mm on a 2 cm splat; an
#: emitter 1 mm off a wall stays in front).
SPLAT_CONE = 0.005
MODIFIER_NAMES = (MODIFIER_NAME, POINT_MODIFIER_NAME)
MATERIAL_NAME = "Illumap Illumination"
# The material and node groups Illumap made carry MARKER (as its objects do): a user's own
# datablock of the same name is never cleared or reused (a new one, with a suffix, is made
# beside it).
#: Display radius = this × the median distance to the RADIUS_NEIGHBOUR-th nearest point.
RADIUS_FACTOR = 1.0
RADIUS_NEIGHBOUR = 6
#: Points whose neighbours the radius is measured at (a fixed, evenly strided subset).
RADIUS_PROBES = 20000


def _own(collection, name, new):
    """Illumap's datablock ``name`` (marked, or unmarked but made by an older version: its
    name and a use by an Illumap modifier), else a new marked one."""
    found = collection.get(name)
    if found is not None and (found.get(MARKER) or _used_by_preview(found)):
        found[MARKER] = True
        return found
    for block in collection:
        if block.name.startswith(name + ".") and block.get(MARKER):
            return block
    block = new()
    block[MARKER] = True
    return block


def _used_by_preview(block) -> bool:
    for obj in bpy.data.objects:
        for name in MODIFIER_NAMES:
            mod = obj.modifiers.get(name) if obj.type in RESULT_TYPES else None
            if mod is None or mod.node_group is None:
                continue
            if mod.node_group == block:
                return True
            if any(n.bl_idname == "GeometryNodeSetMaterial" and n.inputs["Material"].default_value
                   == block for n in mod.node_group.nodes):
                return True
    return False


def preview_material() -> bpy.types.Material:
    """The shared material: Attribute ``illumination`` → Emission (strength 1)."""
    return _emission_material(MATERIAL_NAME, "GEOMETRY")


def _emission_material(name: str, attribute_type: str) -> bpy.types.Material:
    """Illumap's material ``name``: the ``illumination`` attribute (read as ``attribute_type``:
    the geometry's own, or the instancing point's) shown as Emission of strength 1."""
    mat = _own(bpy.data.materials, name, lambda: bpy.data.materials.new(name))
    tree = compat.node_tree(mat)
    nodes, links = tree.nodes, tree.links
    nodes.clear()
    out = nodes.new("ShaderNodeOutputMaterial")
    out.location = (400, 0)
    emission = nodes.new("ShaderNodeEmission")
    emission.location = (200, 0)
    emission.inputs["Strength"].default_value = 1.0
    attr = nodes.new("ShaderNodeAttribute")
    attr.attribute_type = attribute_type
    attr.attribute_name = ATTRIBUTE
    links.new(attr.outputs["Color"], emission.inputs["Color"])
    links.new(emission.outputs["Emission"], out.inputs["Surface"])
    return mat


def _empty_group(name: str, radius: bool = False) -> bpy.types.NodeTree:
    """Illumap's modifier node group ``name``, emptied: Geometry in (and a Radius input), out."""
    ng = _own(bpy.data.node_groups, name,
              lambda: bpy.data.node_groups.new(name, "GeometryNodeTree"))
    ng.nodes.clear()
    for item in list(ng.interface.items_tree):
        ng.interface.remove(item)
    ng.interface.new_socket("Geometry", in_out="INPUT", socket_type="NodeSocketGeometry")
    if radius:
        socket = ng.interface.new_socket("Radius", in_out="INPUT", socket_type="NodeSocketFloat")
        socket.default_value, socket.min_value = 0.01, 0.0
    ng.interface.new_socket("Geometry", in_out="OUTPUT", socket_type="NodeSocketGeometry")
    ng.is_modifier = True
    return ng


def node_group() -> bpy.types.NodeTree:
    """The shared node group: Set Material to ``preview_material()`` on the whole mesh."""
    ng = _empty_group(NODE_GROUP_NAME)
    group_in = ng.nodes.new("NodeGroupInput")
    group_in.location = (-300, 0)
    set_material = ng.nodes.new("GeometryNodeSetMaterial")
    set_material.inputs["Material"].default_value = preview_material()
    group_out = ng.nodes.new("NodeGroupOutput")
    group_out.location = (300, 0)
    ng.links.new(group_in.outputs["Geometry"], set_material.inputs["Geometry"])
    ng.links.new(set_material.outputs["Geometry"], group_out.inputs["Geometry"])
    return ng


def point_node_group() -> bpy.types.NodeTree:
    """The shared node group for points: a mesh's vertices as points (Mesh to Points), each
    point's ``radius`` attribute where it has one, else the Radius input, then Set Material to
    ``preview_material()``: spheres. Used where the splats' attributes cannot be written (a
    linked scan); ``splat_node_group`` otherwise."""
    ng = _empty_group(SPHERE_NODE_GROUP_NAME, radius=True)
    nodes, links = ng.nodes, ng.links
    group_in = nodes.new("NodeGroupInput")
    points = _points(ng, group_in)
    given = nodes.new("GeometryNodeInputNamedAttribute")
    given.data_type = "FLOAT"
    given.inputs["Name"].default_value = "radius"
    switch = nodes.new("GeometryNodeSwitch")
    switch.input_type = "FLOAT"
    set_radius = nodes.new("GeometryNodeSetPointRadius")
    set_material = nodes.new("GeometryNodeSetMaterial")
    set_material.inputs["Material"].default_value = preview_material()
    group_out = nodes.new("NodeGroupOutput")
    for x, node in enumerate((set_radius, set_material, group_out)):
        node.location = (250 * x + 250, 0)
    given.location, switch.location = (0, -250), (250, -250)
    links.new(given.outputs["Exists"], switch.inputs["Switch"])
    links.new(group_in.outputs["Radius"], switch.inputs["False"])
    links.new(given.outputs["Attribute"], switch.inputs["True"])
    links.new(points, set_radius.inputs["Points"])
    links.new(switch.outputs["Output"], set_radius.inputs["Radius"])
    links.new(set_radius.outputs["Points"], set_material.inputs["Geometry"])
    links.new(set_material.outputs["Geometry"], group_out.inputs["Geometry"])
    return ng


def _points(ng, group_in):
    """The group's input as points: a mesh's vertices (Mesh to Points) joined with any point
    cloud; returns the socket that carries them (with every point attribute)."""
    nodes, links = ng.nodes, ng.links
    group_in.location = (-500, 0)
    to_points = nodes.new("GeometryNodeMeshToPoints")
    to_points.mode = "VERTICES"
    to_points.location = (-250, 0)
    clouds = nodes.new("GeometryNodeSeparateComponents")
    clouds.location = (-250, -200)
    join = nodes.new("GeometryNodeJoinGeometry")
    join.location = (0, 0)
    links.new(group_in.outputs["Geometry"], to_points.inputs["Mesh"])
    if "Radius" in group_in.outputs:
        links.new(group_in.outputs["Radius"], to_points.inputs["Radius"])
    links.new(group_in.outputs["Geometry"], clouds.inputs["Geometry"])
    links.new(to_points.outputs["Points"], join.inputs["Geometry"])
    links.new(clouds.outputs["Point Cloud"], join.inputs["Geometry"])
    return join.outputs["Geometry"]


def splat_material() -> bpy.types.Material:
    """The splats' material: Emission (strength 1) of the instancing point's linear shading,
    base + X dx + Y dy (Attributes, INSTANCER; X, Y the splat's own disc coordinates, the
    instance's Object coordinates), never below 0."""
    mat = _emission_material(SPLAT_MATERIAL_NAME, "INSTANCER")
    tree = compat.node_tree(mat)
    nodes, links = tree.nodes, tree.links
    emission = next(n for n in nodes if n.bl_idname == "ShaderNodeEmission")
    for node in [n for n in nodes if n.bl_idname == "ShaderNodeAttribute"]:
        nodes.remove(node)

    def attribute(key, y):
        node = nodes.new("ShaderNodeAttribute")
        node.attribute_type = "INSTANCER"
        node.attribute_name = SHADING_NAMES[key]
        node.location = (-800, y)
        return node.outputs["Vector"]

    def math(operation, a, b, x, y, scale=None):
        node = nodes.new("ShaderNodeVectorMath")
        node.operation = operation
        node.location = (x, y)
        links.new(a, node.inputs[0])
        if scale is not None:
            links.new(scale, node.inputs["Scale"])
        elif b is not None:
            links.new(b, node.inputs[1])
        return node.outputs["Vector"]

    coords = nodes.new("ShaderNodeTexCoord")
    coords.location = (-1000, -300)
    split = nodes.new("ShaderNodeSeparateXYZ")
    split.location = (-800, -300)
    links.new(coords.outputs["Object"], split.inputs["Vector"])
    along = math("SCALE", attribute("dx", -100), None, -550, -100, split.outputs["X"])
    across = math("SCALE", attribute("dy", -250), None, -550, -250, split.outputs["Y"])
    change = math("ADD", along, across, -350, -150)
    total = math("ADD", attribute("base", 50), change, -150, 0)
    floor = nodes.new("ShaderNodeVectorMath")
    floor.operation = "MAXIMUM"
    floor.inputs[1].default_value = (0.0, 0.0, 0.0)
    floor.location = (0, 0)
    links.new(total, floor.inputs[0])
    links.new(floor.outputs["Vector"], emission.inputs["Color"])
    return mat


def splat_node_group() -> bpy.types.NodeTree:
    """The shared node group for scans: every point (a mesh's vertices, a point cloud's
    points) instances a unit disc, turned into its tangent plane (Z to the splat normal, X to
    its axis), scaled to its ellipse and moved to its centre, from the hidden attributes
    ``SPLAT_ATTRIBUTES`` that ``build_mesh_preview`` writes (``point_splats.splat_frames``);
    the discs read the point's ``illumination`` through ``splat_material()``."""
    ng = _empty_group(POINT_NODE_GROUP_NAME)
    nodes, links = ng.nodes, ng.links
    group_in = nodes.new("NodeGroupInput")
    points = _points(ng, group_in)

    def attribute(key, y):
        node = nodes.new("GeometryNodeInputNamedAttribute")
        node.data_type = "FLOAT_VECTOR"
        node.inputs["Name"].default_value = SPLAT_ATTRIBUTES[key]
        node.location = (0, y)
        return node.outputs["Attribute"]

    # The shading under names the material can read from the instances (hidden attributes
    # stay on the points).
    for x, key in enumerate(SHADING_NAMES):
        hidden = nodes.new("GeometryNodeInputNamedAttribute")
        hidden.data_type = "FLOAT_VECTOR"
        hidden.inputs["Name"].default_value = SHADING_ATTRIBUTES[key]
        hidden.location = (-250 + 150 * x, 250)
        store = nodes.new("GeometryNodeStoreNamedAttribute")
        store.data_type = "FLOAT_VECTOR"
        store.domain = "POINT"
        store.inputs["Name"].default_value = SHADING_NAMES[key]
        store.location = (-250 + 150 * x, 100)
        links.new(points, store.inputs["Geometry"])
        links.new(hidden.outputs["Attribute"], store.inputs["Value"])
        points = store.outputs["Geometry"]
    move = nodes.new("GeometryNodeSetPosition")
    move.location = (250, 0)
    links.new(points, move.inputs["Geometry"])
    links.new(attribute("offset", -200), move.inputs["Offset"])
    normal = nodes.new("FunctionNodeAlignRotationToVector")
    normal.axis = "Z"
    normal.location = (250, -350)
    links.new(attribute("normal", -400), normal.inputs["Vector"])
    axis = nodes.new("FunctionNodeAlignRotationToVector")
    axis.axis, axis.pivot_axis = "X", "Z"
    axis.location = (450, -350)
    links.new(normal.outputs["Rotation"], axis.inputs["Rotation"])
    links.new(attribute("axis", -550), axis.inputs["Vector"])
    shape = _splat_shape(ng)
    instance = nodes.new("GeometryNodeInstanceOnPoints")
    instance.location = (700, 0)
    links.new(move.outputs["Geometry"], instance.inputs["Points"])
    links.new(shape, instance.inputs["Instance"])
    links.new(axis.outputs["Rotation"], instance.inputs["Rotation"])
    links.new(attribute("scale", -700), instance.inputs["Scale"])
    set_material = nodes.new("GeometryNodeSetMaterial")
    set_material.location = (950, 0)
    set_material.inputs["Material"].default_value = splat_material()
    group_out = nodes.new("NodeGroupOutput")
    group_out.location = (1200, 0)
    links.new(instance.outputs["Instances"], set_material.inputs["Geometry"])
    links.new(set_material.outputs["Geometry"], group_out.inputs["Geometry"])
    return ng


def _splat_shape(ng):
    """The shape every splat instances (returns its socket): a flat double cone of unit
    radius about the z axis, its apexes ``SPLAT_CONE`` above and below the rim's plane (the
    polygon circumscribes the unit disc, so it covers all of the ellipse). Where splats
    overlap, the renderer shows the highest cone, the one whose point is nearest: each point's
    light covers its own cell of the surface (the Voronoi cell, as the envelope of equal
    cones is), not whichever disc the renderer happened to meet first."""
    nodes, links = ng.nodes, ng.links
    cone = nodes.new("GeometryNodeMeshCone")
    cone.fill_type = "NONE"
    cone.location = (200, -150)
    cone.inputs["Vertices"].default_value = SPLAT_SIDES
    cone.inputs["Radius Top"].default_value = 0.0
    cone.inputs["Radius Bottom"].default_value = 1.0 / math.cos(math.pi / SPLAT_SIDES)
    cone.inputs["Depth"].default_value = SPLAT_CONE
    up = nodes.new("GeometryNodeTransform")
    up.location = (400, -150)
    up.inputs["Translation"].default_value = (0.0, 0.0, 0.5 * SPLAT_CONE)
    links.new(cone.outputs["Mesh"], up.inputs["Geometry"])
    down = nodes.new("GeometryNodeTransform")
    down.location = (400, -300)
    down.inputs["Scale"].default_value = (1.0, 1.0, -1.0)
    links.new(up.outputs["Geometry"], down.inputs["Geometry"])
    both = nodes.new("GeometryNodeJoinGeometry")
    both.location = (550, -150)
    links.new(down.outputs["Geometry"], both.inputs["Geometry"])
    links.new(up.outputs["Geometry"], both.inputs["Geometry"])
    return both.outputs["Geometry"]


def is_point_source(obj) -> bool:
    """A point cloud, or a mesh of vertices alone (a scan read as a mesh)."""
    return obj.type == "POINTCLOUD" or (obj.type == "MESH" and len(obj.data.polygons) == 0
                                        and len(obj.data.vertices) > 0)


def _positions(obj) -> np.ndarray:
    """The object's points in its own coordinates (n, 3)."""
    data = obj.data
    if obj.type == "POINTCLOUD":
        attr = data.attributes["position"]
        out = np.empty(len(attr.data) * 3)
        attr.data.foreach_get("vector", out)
    else:
        out = np.empty(len(data.vertices) * 3)
        data.vertices.foreach_get("co", out)
    return out.reshape(-1, 3)


def point_radius(obj) -> float:
    """Display radius of ``obj``'s points in its own units: ``RADIUS_FACTOR`` × the median
    distance from ``RADIUS_PROBES`` evenly strided points to their ``RADIUS_NEIGHBOUR``-th
    nearest point."""
    from illumap.neighbours import knn  # noqa: PLC0415 - native, loaded on use
    pos = np.ascontiguousarray(_positions(obj))
    if len(pos) < 2:
        return 0.01
    k = min(RADIUS_NEIGHBOUR, len(pos) - 1) + 1
    probes = np.ascontiguousarray(pos[::max(1, len(pos) // RADIUS_PROBES)])
    _, dist = knn(pos, probes, k)
    far = dist[:, -1]
    far = far[far > 0]
    return float(RADIUS_FACTOR * np.median(far)) if len(far) else 0.01


def has_mesh_preview(obj) -> bool:
    """Whether ``obj`` carries a preview modifier (meshes or points)."""
    return obj.type in RESULT_TYPES and any(n in obj.modifiers for n in MODIFIER_NAMES)


def _point_vectors(obj, names) -> np.ndarray | None:
    """The first FLOAT_VECTOR point attribute of ``obj`` among ``names`` (n, 3), or None."""
    for name in names:
        attr = obj.data.attributes.get(name)
        if attr is not None and attr.data_type == "FLOAT_VECTOR" and attr.domain == "POINT":
            out = np.empty(len(attr.data) * 3, np.float32)
            attr.data.foreach_get("vector", out)
            return out.reshape(-1, 3)
    return None


def _point_floats(obj, name) -> np.ndarray | None:
    attr = obj.data.attributes.get(name)
    if attr is None or attr.data_type != "FLOAT" or attr.domain != "POINT":
        return None
    out = np.empty(len(attr.data), np.float32)
    attr.data.foreach_get("value", out)
    return out


def splat_inputs(obj) -> tuple:
    """What a scan's splats are computed from: its points in its own coordinates (float32), its
    ``normal`` (or ``N``) and ``radius`` point attributes or None."""
    return (_positions(obj).astype(np.float32), _point_vectors(obj, ("normal", "N")),
            _point_floats(obj, "radius"))


def write_splats(obj) -> bool:
    """Compute ``obj``'s splats (``point_splats.splat_frames``) and store them in its hidden
    point attributes ``SPLAT_ATTRIBUTES``; nothing is written when they already hold the
    splats of these very points. False where the data cannot take attributes (linked)."""
    data = obj.data
    if data.library is not None or getattr(data, "override_library", None) is not None:
        return False
    pos, normals, radius = splat_inputs(obj)
    key = point_splats.fingerprint(pos, normals, radius)
    attrs = data.attributes
    if data.get(SPLAT_KEY) == key and all(
            name in attrs and len(attrs[name].data) == len(pos) for name in SPLAT_ATTRIBUTES.values()):
        write_shading(obj, pos, frames_of(obj), key=key)
        return True
    frames = point_splats.ready_frames(key) or point_splats.splat_frames(pos, normals, radius,
                                                                         key=key)
    for name_key, name in SPLAT_ATTRIBUTES.items():
        vector_attribute(attrs, name).data.foreach_set("vector", frames[name_key].ravel())
    data[SPLAT_KEY] = key
    write_shading(obj, pos, frames, key=key)
    return True


def frames_of(obj) -> dict:
    """The splats' frames as stored in ``obj``'s hidden attributes ``SPLAT_ATTRIBUTES``."""
    frames = {}
    for key, name in SPLAT_ATTRIBUTES.items():
        out = np.empty(len(obj.data.attributes[name].data) * 3, np.float32)
        obj.data.attributes[name].data.foreach_get("vector", out)
        frames[key] = out.reshape(-1, 3)
    return frames


def remove_splats(data) -> None:
    """Remove the splats' hidden attributes and record from a scan's data."""
    if data is None or data.library is not None:
        return
    for name in (*SPLAT_ATTRIBUTES.values(), *SHADING_ATTRIBUTES.values()):
        attr = data.attributes.get(name)
        if attr is not None:
            data.attributes.remove(attr)
    if SPLAT_KEY in data:
        del data[SPLAT_KEY]


def build_mesh_preview(objects) -> list[str]:
    """Show each mesh or point cloud of ``objects`` that has an ``illumination`` attribute
    through the preview material (a modifier added last, or refreshed): meshes with faces
    through their own faces, scans as one splat per point. Returns the names of the objects
    shown."""
    groups = {}
    shown = []
    for obj in objects:
        if obj is None or obj.type not in RESULT_TYPES or \
                ATTRIBUTE not in obj.data.attributes:
            continue
        points = is_point_source(obj)
        name, other = ((POINT_MODIFIER_NAME, MODIFIER_NAME) if points
                       else (MODIFIER_NAME, POINT_MODIFIER_NAME))
        group = NODE_GROUP_NAME
        if points:
            group = POINT_NODE_GROUP_NAME if write_splats(obj) else SPHERE_NODE_GROUP_NAME
        if group not in groups:
            groups[group] = {NODE_GROUP_NAME: node_group, POINT_NODE_GROUP_NAME: splat_node_group,
                             SPHERE_NODE_GROUP_NAME: point_node_group}[group]()
        if other in obj.modifiers:
            obj.modifiers.remove(obj.modifiers[other])
        mod = obj.modifiers.get(name)
        if mod is None:
            mod = obj.modifiers.new(name, "NODES")
        mod.node_group = groups[group]
        if group == SPHERE_NODE_GROUP_NAME and "radius" not in obj.data.attributes:
            radius = next(item.identifier for item in mod.node_group.interface.items_tree
                          if getattr(item, "in_out", None) == "INPUT" and item.name == "Radius")
            compat.set_modifier_input(mod, radius, point_radius(obj))
        obj.update_tag()
        shown.append(obj.name)
    return shown


def remove_mesh_preview(objects) -> int:
    """Remove the preview modifiers (and a scan's splat attributes) from ``objects``; returns
    from how many objects."""
    removed = 0
    for obj in objects:
        if obj is None or obj.type not in RESULT_TYPES:
            continue
        mods = [obj.modifiers[n] for n in MODIFIER_NAMES if n in obj.modifiers]
        for mod in mods:
            obj.modifiers.remove(mod)
        if mods or SPLAT_KEY in obj.data:
            remove_splats(obj.data)
        removed += bool(mods)
    return removed


def show_result(context, lit, surfel_object, *, objects=True, surfels=False,
                mode="ILLUMINATION", disc_scale=None) -> list[str]:
    """What a run shows when it has written its result (the Compute operator and the batch):

    * ``objects``: the lit objects ``lit`` themselves, through the Object Preview
      (``build_mesh_preview``);
    * the solve's surfels (``preview.build_preview`` on ``surfel_object``) only with
      ``surfels``, or where ``objects`` is asked for and no object could show its light (a
      run without Transfer); otherwise the surfel object is hidden in the viewport and in
      renders, a diagnostic the user asks for.

    Returns the names of the objects shown."""
    from . import surfel_preview as preview  # noqa: PLC0415
    shown = build_mesh_preview(lit) if objects else []
    if surfel_object is None:
        return shown
    if surfels or (objects and not shown):
        kwargs = {} if disc_scale is None else {"disc_scale": disc_scale}
        preview.build_preview(context, surfel_object, mode=mode, **kwargs)
        surfel_object.hide_viewport = surfel_object.hide_render = False
    else:
        surfel_object.hide_viewport = surfel_object.hide_render = True
    return shown


class suspended:
    """Context manager: the mesh previews of ``objects`` switched off while the scene is read
    (their Set Material would hand the reader the preview's emission instead of the user's
    materials), then switched back as they were."""

    def __init__(self, objects, view_layer) -> None:
        self.mods = [obj.modifiers[name] for obj in objects
                     if obj is not None and has_mesh_preview(obj)
                     for name in MODIFIER_NAMES if name in obj.modifiers]
        self.view_layer = view_layer
        self.saved = []

    def __enter__(self):
        self.saved = [(m.show_viewport, m.show_render) for m in self.mods]
        for m in self.mods:
            m.show_viewport = m.show_render = False
        if self.mods:
            self.view_layer.update()
        return self

    def __exit__(self, *exc) -> None:
        for m, (viewport, render) in zip(self.mods, self.saved):
            m.show_viewport, m.show_render = viewport, render
        if self.mods:
            self.view_layer.update()
