"""Mesh preview: the illumination shown on the meshes themselves, in one click.

``build_mesh_preview(objects)`` puts a Geometry Nodes modifier, last in each mesh's stack,
whose Set Material node gives the evaluated mesh the shared material ``Illumap
Illumination``: an Attribute node (GEOMETRY) reading ``illumination`` (corner or point domain,
interpolated by the renderer like any colour attribute) into an Emission shader of strength 1,
so Cycles and EEVEE show the light Illumap computed at the mesh's own corners, as a render
would show it. The user's material slots are never touched: removing the modifier
(``remove_mesh_preview``) gives the meshes back exactly as they were. The material and the
node group carry the custom property ``illumap_generated``: a user's own datablock that happens
to bear one of these names is left alone.
"""

from __future__ import annotations

import bpy

from . import compat

MODIFIER_NAME = "Illumap Mesh Preview"
NODE_GROUP_NAME = "Illumap Mesh Preview"
MATERIAL_NAME = "Illumap Illumination"
ATTRIBUTE = "illumination"


#: Custom property on the material and node group Illumap made: a user's own datablock of
#: the same name is never cleared or reused (a new one, with a suffix, is made beside it).
MARKER = "illumap_generated"


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
        mod = obj.modifiers.get(MODIFIER_NAME) if obj.type == "MESH" else None
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


def node_group() -> bpy.types.NodeTree:
    """The shared node group: Set Material to ``preview_material()`` on the whole mesh."""
    ng = _own(bpy.data.node_groups, NODE_GROUP_NAME,
              lambda: bpy.data.node_groups.new(NODE_GROUP_NAME, "GeometryNodeTree"))
    ng.nodes.clear()
    for item in list(ng.interface.items_tree):
        ng.interface.remove(item)
    ng.interface.new_socket("Geometry", in_out="INPUT", socket_type="NodeSocketGeometry")
    ng.interface.new_socket("Geometry", in_out="OUTPUT", socket_type="NodeSocketGeometry")
    ng.is_modifier = True
    group_in = ng.nodes.new("NodeGroupInput")
    group_in.location = (-300, 0)
    set_material = ng.nodes.new("GeometryNodeSetMaterial")
    set_material.inputs["Material"].default_value = preview_material()
    group_out = ng.nodes.new("NodeGroupOutput")
    group_out.location = (300, 0)
    ng.links.new(group_in.outputs["Geometry"], set_material.inputs["Geometry"])
    ng.links.new(set_material.outputs["Geometry"], group_out.inputs["Geometry"])
    return ng


def has_mesh_preview(obj) -> bool:
    """Whether ``obj`` carries the mesh preview modifier."""
    return obj.type == "MESH" and MODIFIER_NAME in obj.modifiers


def build_mesh_preview(objects) -> list[str]:
    """Show each mesh of ``objects`` that has an ``illumination`` attribute through the preview
    material (a modifier added last, or refreshed). Returns the names of the meshes shown."""
    ng = None
    shown = []
    for obj in objects:
        if obj is None or obj.type != "MESH" or ATTRIBUTE not in obj.data.attributes:
            continue
        ng = ng or node_group()
        mod = obj.modifiers.get(MODIFIER_NAME)
        if mod is None:
            mod = obj.modifiers.new(MODIFIER_NAME, "NODES")
        mod.node_group = ng
        obj.update_tag()
        shown.append(obj.name)
    return shown


def remove_mesh_preview(objects) -> int:
    """Remove the mesh preview modifier from ``objects``; returns how many were removed."""
    removed = 0
    for obj in objects:
        if obj is not None and obj.type == "MESH" and MODIFIER_NAME in obj.modifiers:
            obj.modifiers.remove(obj.modifiers[MODIFIER_NAME])
            removed += 1
    return removed


class suspended:
    """Context manager: the mesh previews of ``objects`` switched off while the scene is read
    (their Set Material would hand the reader the preview's emission instead of the user's
    materials), then switched back as they were."""

    def __init__(self, objects, view_layer) -> None:
        self.mods = [obj.modifiers[MODIFIER_NAME] for obj in objects
                     if obj is not None and has_mesh_preview(obj)]
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
