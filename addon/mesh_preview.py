"""Preview on the objects: the illumination shown on the user's own meshes and point clouds,
in one click.

``build_mesh_preview(objects)`` puts a Geometry Nodes modifier, last in each object's stack,
that gives the evaluated geometry the shared material ``Illumap Illumination``: an Attribute
node (GEOMETRY) reading ``illumination`` into an Emission shader of strength 1, so Cycles and
EEVEE show the light Illumap computed at the object's own corners or points, as a render would
show it.

* Meshes with faces: a Set Material node (``Illumap Mesh Preview``); the renderer interpolates
  the corner or point values across the faces like any colour attribute.
* Point clouds and vertex-only meshes (scans): every point of the object is a display point,
  coloured by the light evaluated at that very point, whatever number of surfels the solve
  used (``Illumap Point Preview``: Mesh to Points for a mesh's vertices, each point's
  ``radius`` attribute or else the modifier's Radius, then Set Material). Points render as
  small spheres in Cycles and EEVEE; the Radius given (``point_radius``) is the median
  distance to the 6th nearest neighbour: about 1.4 spacings, so spheres close a regularly
  scanned surface with room to spare, and leave ~0.3% of a randomly sampled one open
  (exp(−5.7), the chance that a disc of that radius holds no point).

The user's material slots and data are never touched: removing the modifier
(``remove_mesh_preview``) gives the objects back exactly as they were. The material and the
node groups carry the custom property ``illumap_generated``: a user's own datablock that
happens to bear one of these names is left alone.
"""

from __future__ import annotations

import bpy

from . import compat
from .kinds import RESULT_TYPES
from .output import ATTRIBUTE, MARKER

import numpy as np

MODIFIER_NAME = "Illumap Mesh Preview"
NODE_GROUP_NAME = "Illumap Mesh Preview"
POINT_MODIFIER_NAME = "Illumap Point Preview"
POINT_NODE_GROUP_NAME = "Illumap Point Preview"
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
    mat = _own(bpy.data.materials, MATERIAL_NAME, lambda: bpy.data.materials.new(MATERIAL_NAME))
    tree = compat.node_tree(mat)
    nodes, links = tree.nodes, tree.links
    nodes.clear()
    out = nodes.new("ShaderNodeOutputMaterial")
    out.location = (400, 0)
    emission = nodes.new("ShaderNodeEmission")
    emission.location = (200, 0)
    emission.inputs["Strength"].default_value = 1.0
    attr = nodes.new("ShaderNodeAttribute")
    attr.attribute_type = "GEOMETRY"
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
    ``preview_material()``."""
    ng = _empty_group(POINT_NODE_GROUP_NAME, radius=True)
    nodes, links = ng.nodes, ng.links
    group_in = nodes.new("NodeGroupInput")
    to_points = nodes.new("GeometryNodeMeshToPoints")
    to_points.mode = "VERTICES"
    clouds = nodes.new("GeometryNodeSeparateComponents")
    join = nodes.new("GeometryNodeJoinGeometry")
    given = nodes.new("GeometryNodeInputNamedAttribute")
    given.data_type = "FLOAT"
    given.inputs["Name"].default_value = "radius"
    switch = nodes.new("GeometryNodeSwitch")
    switch.input_type = "FLOAT"
    set_radius = nodes.new("GeometryNodeSetPointRadius")
    set_material = nodes.new("GeometryNodeSetMaterial")
    set_material.inputs["Material"].default_value = preview_material()
    group_out = nodes.new("NodeGroupOutput")
    for x, node in enumerate((group_in, to_points, join, set_radius, set_material, group_out)):
        node.location = (250 * x - 500, 0)
    clouds.location, given.location, switch.location = (-250, -200), (0, -250), (250, -250)
    links.new(group_in.outputs["Geometry"], to_points.inputs["Mesh"])
    links.new(group_in.outputs["Radius"], to_points.inputs["Radius"])
    links.new(group_in.outputs["Geometry"], clouds.inputs["Geometry"])
    links.new(to_points.outputs["Points"], join.inputs["Geometry"])
    links.new(clouds.outputs["Point Cloud"], join.inputs["Geometry"])
    links.new(given.outputs["Exists"], switch.inputs["Switch"])
    links.new(group_in.outputs["Radius"], switch.inputs["False"])
    links.new(given.outputs["Attribute"], switch.inputs["True"])
    links.new(join.outputs["Geometry"], set_radius.inputs["Points"])
    links.new(switch.outputs["Output"], set_radius.inputs["Radius"])
    links.new(set_radius.outputs["Points"], set_material.inputs["Geometry"])
    links.new(set_material.outputs["Geometry"], group_out.inputs["Geometry"])
    return ng


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
    from illumap import _core  # noqa: PLC0415 - native, loaded on use
    pos = np.ascontiguousarray(_positions(obj))
    if len(pos) < 2:
        return 0.01
    k = min(RADIUS_NEIGHBOUR, len(pos) - 1) + 1
    probes = np.ascontiguousarray(pos[::max(1, len(pos) // RADIUS_PROBES)])
    _, dist = _core.knn(pos, probes, k)
    far = dist[:, -1]
    far = far[far > 0]
    return float(RADIUS_FACTOR * np.median(far)) if len(far) else 0.01


def has_mesh_preview(obj) -> bool:
    """Whether ``obj`` carries a preview modifier (meshes or points)."""
    return obj.type in RESULT_TYPES and any(n in obj.modifiers for n in MODIFIER_NAMES)


def build_mesh_preview(objects) -> list[str]:
    """Show each mesh or point cloud of ``objects`` that has an ``illumination`` attribute
    through the preview material (a modifier added last, or refreshed). Returns the names of
    the objects shown."""
    groups = {}
    shown = []
    for obj in objects:
        if obj is None or obj.type not in RESULT_TYPES or \
                ATTRIBUTE not in obj.data.attributes:
            continue
        points = is_point_source(obj)
        name, other = ((POINT_MODIFIER_NAME, MODIFIER_NAME) if points
                       else (MODIFIER_NAME, POINT_MODIFIER_NAME))
        if name not in groups:
            groups[name] = point_node_group() if points else node_group()
        if other in obj.modifiers:
            obj.modifiers.remove(obj.modifiers[other])
        mod = obj.modifiers.get(name)
        if mod is None:
            mod = obj.modifiers.new(name, "NODES")
        mod.node_group = groups[name]
        if points and "radius" not in obj.data.attributes:   # else the points' own radii
            radius = next(item.identifier for item in mod.node_group.interface.items_tree
                          if getattr(item, "in_out", None) == "INPUT" and item.name == "Radius")
            compat.set_modifier_input(mod, radius, point_radius(obj))
        obj.update_tag()
        shown.append(obj.name)
    return shown


def remove_mesh_preview(objects) -> int:
    """Remove the preview modifiers from ``objects``; returns from how many objects."""
    removed = 0
    for obj in objects:
        if obj is None or obj.type not in RESULT_TYPES:
            continue
        mods = [obj.modifiers[n] for n in MODIFIER_NAMES if n in obj.modifiers]
        for mod in mods:
            obj.modifiers.remove(mod)
        removed += bool(mods)
    return removed


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
