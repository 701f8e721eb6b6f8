"""addon/compat.py: the calls that differ between Blender 5.0 (Python 3.11) and 5.2 (3.13)."""

import numpy as np
import pytest

import bpy

from illumap_bpy_testing import make_surfels


def _disc_scales(obj):
    depsgraph = bpy.context.evaluated_depsgraph_get()
    return [float(np.linalg.norm(np.array(i.matrix_world)[:3, 2]))
            for i in depsgraph.object_instances
            if i.is_instance and i.parent and i.parent.original == obj]


def test_modifier_inputs_round_trip_and_re_evaluate(registered_addon):
    """Set and read a float and a material input of a Geometry Nodes modifier; the evaluated
    scene follows each write without any other update (on 5.2 the RNA write does not tag)."""
    from addon import compat
    from addon.preview import surfel_preview as preview
    obj = make_surfels([(0.0, 0.0, 0.0)], (0.0, 0.0, 1.0), 0.1, (1, 1, 1))
    ng = preview.preview_node_group()
    mod = obj.modifiers.new("GN", "NODES")
    mod.node_group = ng
    scale_id = preview._socket_identifier(ng, "Disc Scale")
    material_id = preview._socket_identifier(ng, "Material")
    assert compat.get_modifier_input(mod, scale_id) == pytest.approx(preview.DEFAULT_DISC_SCALE)
    for scale in (1.0, 2.5):
        compat.set_modifier_input(mod, scale_id, scale)
        assert compat.get_modifier_input(mod, scale_id) == pytest.approx(scale)
        assert _disc_scales(obj) == [pytest.approx(0.1 * scale, rel=1e-6)]
    mat = bpy.data.materials.new("M")
    compat.set_modifier_input(mod, material_id, mat)
    assert compat.get_modifier_input(mod, material_id) == mat
    with pytest.raises((AttributeError, KeyError)):
        compat.set_modifier_input(mod, "Socket_999", 1.0)


def test_node_tree_of_new_materials_and_worlds(registered_addon):
    from addon import compat
    for idblock in (bpy.data.materials.new("M"), bpy.data.worlds.new("W")):
        tree = compat.node_tree(idblock)
        assert tree is not None and tree == idblock.node_tree
        assert compat.node_tree(idblock) == tree  # a second call keeps the same tree
