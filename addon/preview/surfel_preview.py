"""Point-instanced preview of an illumination map.

``build_preview(context, surfel_object)`` puts a Geometry Nodes modifier on the surfel object
(docs/architecture.md: a point cloud or vertex-only mesh with point attributes ``illumination``,
``normal``, ``radius``, ``albedo``, ``emission``). The node group instances one disc per point:

* a Mesh Circle (filled n-gon) whose *area* equals pi*radius^2 (the polygon is enlarged slightly
  so that a disc stands for exactly the area of its surfel),
* rotated with Align Rotation to Vector so that its +Z (the disc normal) follows ``normal``,
* scaled by the ``radius`` point attribute (metres) times the modifier's "Disc Scale" input
  (``DEFAULT_DISC_SCALE`` = 1.7 unless told otherwise; 1 gives each disc exactly its surfel's
  area, which leaves visible gaps between randomly placed surfels).

Point attributes carry over to the instances; the material reads them with Attribute nodes in
INSTANCER mode (the Color Attribute node cannot) and shows them through an Emission shader, so
the preview renders the same in Cycles and EEVEE.

Shading modes (``mode``):

``'ILLUMINATION'``     Emission = ``illumination`` (outgoing radiance, what the solver computed).
``'ALBEDO_IRRADIANCE'`` Emission = ``albedo`` x irradiance, where irradiance (as incident
                       radiance, irradiance/pi, the convention of Cycles' diffuse bake) is the
                       ``irradiance`` attribute when the surfel object has one, and otherwise
                       ``(illumination - emission) / albedo`` (a safe divide: zero where the
                       albedo is zero). This is the reflected light alone: emitters show dark
                       unless they also receive light.

The node group and the materials are created once and reused; building again on the same
object replaces the modifier instead of stacking another.
"""

import math

import bpy

from .. import compat
from ..kinds import RESULT_TYPES

NODE_GROUP_NAME = "Illumap Disc Preview"
MODIFIER_NAME = "Illumap Preview"
MATERIAL_NAMES = {
    "ILLUMINATION": "Illumap Preview",
    "ALBEDO_IRRADIANCE": "Illumap Preview (Albedo x Irradiance)",
}
MODES = tuple(MATERIAL_NAMES)

# Bumped whenever the node tree or the materials change, so that files made by an older
# version get their data-blocks rebuilt instead of silently reused.
_VERSION = 1
_VERSION_KEY = "illumap_preview_version"

# Discs of exactly the surfel's area (scale 1) leave gaps: a stratified surfel set's holes reach
# 1.7 of a surfel's radius inside a surface (more along triangle edges, whose lattices do not
# line up). 1.7 is also the occluder discs' radius (pipeline.SURFEL_COVERAGE), so the preview
# shows the walls visibility sees; on the sample Cornell box it leaves 0.05% of the frame
# black where 1.5 left 0.17% in thin slits. Preview only: the solver uses the areas.
DEFAULT_DISC_SCALE = 1.7

DISC_VERTICES = 16
# A regular n-gon inscribed in radius R has area (n/2) R^2 sin(2 pi / n); scale it so its
# area is pi R^2 (1.3 % for 16 vertices).
_AREA_SCALE = math.sqrt(math.pi / (0.5 * DISC_VERTICES * math.sin(2.0 * math.pi / DISC_VERTICES)))


def _socket_identifier(node_group, name):
    for item in node_group.interface.items_tree:
        if getattr(item, "in_out", None) == "INPUT" and item.name == name:
            return item.identifier
    raise KeyError(name)


def _build_node_group(ng):
    ng.nodes.clear()
    for item in list(ng.interface.items_tree):
        ng.interface.remove(item)
    ng.interface.new_socket("Geometry", in_out="INPUT", socket_type="NodeSocketGeometry")
    scale_socket = ng.interface.new_socket("Disc Scale", in_out="INPUT", socket_type="NodeSocketFloat")
    scale_socket.default_value = DEFAULT_DISC_SCALE
    scale_socket.min_value = 0.0
    ng.interface.new_socket("Material", in_out="INPUT", socket_type="NodeSocketMaterial")
    ng.interface.new_socket("Geometry", in_out="OUTPUT", socket_type="NodeSocketGeometry")
    ng.is_modifier = True

    nodes, links = ng.nodes, ng.links
    group_in = nodes.new("NodeGroupInput")
    group_in.location = (-800, 0)
    group_out = nodes.new("NodeGroupOutput")
    group_out.location = (600, 0)

    circle = nodes.new("GeometryNodeMeshCircle")
    circle.location = (-400, 200)
    circle.fill_type = "NGON"
    circle.inputs["Vertices"].default_value = DISC_VERTICES
    circle.inputs["Radius"].default_value = _AREA_SCALE

    normal = nodes.new("GeometryNodeInputNamedAttribute")
    normal.location = (-800, -200)
    normal.data_type = "FLOAT_VECTOR"
    normal.inputs["Name"].default_value = "normal"

    align = nodes.new("FunctionNodeAlignRotationToVector")
    align.location = (-400, -150)
    align.axis = "Z"
    links.new(normal.outputs["Attribute"], align.inputs["Vector"])

    radius = nodes.new("GeometryNodeInputNamedAttribute")
    radius.location = (-800, -400)
    radius.data_type = "FLOAT"
    radius.inputs["Name"].default_value = "radius"

    scale = nodes.new("ShaderNodeMath")
    scale.location = (-400, -400)
    scale.operation = "MULTIPLY"
    links.new(radius.outputs["Attribute"], scale.inputs[0])
    links.new(group_in.outputs["Disc Scale"], scale.inputs[1])

    instance = nodes.new("GeometryNodeInstanceOnPoints")
    instance.location = (0, 0)
    links.new(group_in.outputs["Geometry"], instance.inputs["Points"])
    links.new(circle.outputs["Mesh"], instance.inputs["Instance"])
    links.new(align.outputs["Rotation"], instance.inputs["Rotation"])
    links.new(scale.outputs["Value"], instance.inputs["Scale"])

    set_material = nodes.new("GeometryNodeSetMaterial")
    set_material.location = (300, 0)
    links.new(instance.outputs["Instances"], set_material.inputs["Geometry"])
    links.new(group_in.outputs["Material"], set_material.inputs["Material"])
    links.new(set_material.outputs["Geometry"], group_out.inputs["Geometry"])
    ng[_VERSION_KEY] = _VERSION


def preview_node_group():
    """The shared preview node group, created (or rebuilt if outdated) on first use."""
    ng = bpy.data.node_groups.get(NODE_GROUP_NAME)
    if ng is not None and ng.bl_idname != "GeometryNodeTree":
        ng.name = NODE_GROUP_NAME + " (not Illumap)"
        ng = None
    if ng is None:
        ng = bpy.data.node_groups.new(NODE_GROUP_NAME, "GeometryNodeTree")
    if ng.get(_VERSION_KEY) != _VERSION:
        _build_node_group(ng)
    return ng


def _attribute(nodes, name, location):
    node = nodes.new("ShaderNodeAttribute")
    node.attribute_type = "INSTANCER"
    node.attribute_name = name
    node.location = location
    return node


def _build_material(mat, mode):
    tree = compat.node_tree(mat)
    nodes, links = tree.nodes, tree.links
    nodes.clear()
    out = nodes.new("ShaderNodeOutputMaterial")
    out.location = (400, 0)
    emission = nodes.new("ShaderNodeEmission")
    emission.location = (200, 0)
    emission.inputs["Strength"].default_value = 1.0
    links.new(emission.outputs["Emission"], out.inputs["Surface"])

    if mode == "ILLUMINATION":
        illum = _attribute(nodes, "illumination", (0, 0))
        links.new(illum.outputs["Color"], emission.inputs["Color"])
    else:
        albedo = _attribute(nodes, "albedo", (-600, 200))
        illum = _attribute(nodes, "illumination", (-800, 0))
        emis = _attribute(nodes, "emission", (-800, -200))
        irr_attr = _attribute(nodes, "irradiance", (-600, -400))
        reflected = nodes.new("ShaderNodeVectorMath")
        reflected.operation = "SUBTRACT"
        reflected.location = (-600, 0)
        links.new(illum.outputs["Vector"], reflected.inputs[0])
        links.new(emis.outputs["Vector"], reflected.inputs[1])
        derived = nodes.new("ShaderNodeVectorMath")  # Blender's vector divide is safe: x/0 = 0
        derived.operation = "DIVIDE"
        derived.location = (-400, 0)
        links.new(reflected.outputs["Vector"], derived.inputs[0])
        links.new(albedo.outputs["Vector"], derived.inputs[1])
        # Use the stored 'irradiance' attribute where the surfel object has one: the INSTANCER
        # Attribute node's Alpha is 1 where the attribute exists and 0 where it does not.
        choose = nodes.new("ShaderNodeMix")
        choose.data_type = "VECTOR"
        choose.location = (-200, 0)
        links.new(irr_attr.outputs["Alpha"], choose.inputs["Factor"])
        links.new(derived.outputs["Vector"], choose.inputs[4])
        links.new(irr_attr.outputs["Vector"], choose.inputs[5])
        product = nodes.new("ShaderNodeVectorMath")
        product.operation = "MULTIPLY"
        product.location = (0, 0)
        links.new(albedo.outputs["Vector"], product.inputs[0])
        links.new(choose.outputs[1], product.inputs[1])
        links.new(product.outputs["Vector"], emission.inputs["Color"])
    mat[_VERSION_KEY] = _VERSION


def preview_material(mode="ILLUMINATION"):
    """The shared preview material for ``mode``, created (or rebuilt if outdated) once."""
    if mode not in MATERIAL_NAMES:
        raise ValueError(f"unknown preview mode {mode!r}; expected one of {', '.join(MODES)}")
    name = MATERIAL_NAMES[mode]
    mat = bpy.data.materials.get(name)
    if mat is None:
        mat = bpy.data.materials.new(name)
    if mat.get(_VERSION_KEY) != _VERSION or mat.get("illumap_preview_mode") != mode:
        _build_material(mat, mode)
        mat["illumap_preview_mode"] = mode
    return mat


def _is_preview(mod):
    return mod.type == "NODES" and (mod.name.startswith(MODIFIER_NAME) or (
        mod.node_group is not None and mod.node_group.name.startswith(NODE_GROUP_NAME)))


def find_preview_modifier(obj):
    """The object's preview modifier, or None."""
    for mod in obj.modifiers:
        if _is_preview(mod):
            return mod
    return None


def build_preview(context, surfel_object, mode="ILLUMINATION", disc_scale=DEFAULT_DISC_SCALE):
    """Add (or refresh) the disc-instancing preview modifier on ``surfel_object``.

    Returns the Geometry Nodes modifier. Raises ``ValueError`` for an object that cannot carry
    point attributes or lacks the attributes the preview reads.
    """
    if surfel_object is None or surfel_object.type not in RESULT_TYPES:
        kind = "nothing" if surfel_object is None else f"a {surfel_object.type.lower()} object"
        raise ValueError(f"The preview needs the surfel object (a point cloud or mesh), got {kind}")
    names = set(surfel_object.data.attributes.keys())
    missing = [n for n in ("illumination", "normal", "radius") if n not in names]
    if mode == "ALBEDO_IRRADIANCE":
        missing += [n for n in ("albedo", "emission") if n not in names]
    if missing:
        raise ValueError(f"'{surfel_object.name}' has no {', '.join(missing)} attribute"
                         f"{'s' if len(missing) > 1 else ''}; compute an illumination map first")

    ng = preview_node_group()
    mat = preview_material(mode)
    mod = find_preview_modifier(surfel_object)
    if mod is None:
        mod = surfel_object.modifiers.new(MODIFIER_NAME, "NODES")
    if mod.node_group != ng:
        mod.node_group = ng
    compat.set_modifier_input(mod, _socket_identifier(ng, "Material"), mat)
    compat.set_modifier_input(mod, _socket_identifier(ng, "Disc Scale"), float(disc_scale))
    # Duplicates from older runs or manual copies are dropped: one preview per object.
    for other in [m for m in surfel_object.modifiers if m != mod and _is_preview(m)]:
        surfel_object.modifiers.remove(other)
    mod.name = MODIFIER_NAME
    # The material also goes into the object's slots so that it is kept with the file and shows
    # in the material list; Set Material in the node tree is what the render uses.
    if surfel_object.data.materials.find(mat.name) < 0:
        surfel_object.data.materials.clear()
        surfel_object.data.materials.append(mat)
    surfel_object["illumap_preview_mode"] = mode
    surfel_object.update_tag()
    return mod


def remove_preview(surfel_object):
    """Remove every preview modifier from ``surfel_object``; return how many were removed."""
    mods = [m for m in surfel_object.modifiers if _is_preview(m)]
    for m in mods:
        surfel_object.modifiers.remove(m)
    return len(mods)
