"""The mesh preview: the illumination on the meshes themselves, reversible, never fed back into
the next run as the meshes' materials."""

import bpy
import numpy as np
import pytest

from illumap_bpy_testing import (black_world, diffuse_material, emission_material, make_plane,
                                 render_pixels, requires_core, top_camera)

from addon.preview import mesh_preview
from addon import pipeline


def test_preview_renders_the_attribute_and_leaves_the_materials():
    """A plane whose corners carry illumination (0.2, 0.5, 0.8): seen from above through the
    preview it renders that colour (emission of strength 1, Standard view); its own material
    stays in its slot, and switching the preview off leaves no modifier."""
    mat = diffuse_material("Paint", (0.3, 0.3, 0.3))
    plane = make_plane("Floor", size=2.0, material=mat)
    attr = plane.data.color_attributes.new("illumination", "FLOAT_COLOR", "CORNER")
    attr.data.foreach_set("color", np.tile([0.2, 0.5, 0.8, 1.0], len(attr.data)).astype(np.float32))
    black_world()
    top_camera(ortho_scale=1.5)
    assert mesh_preview.build_mesh_preview([plane]) == ["Floor"]
    assert mesh_preview.build_mesh_preview([plane]) == ["Floor"]     # refreshed, not stacked
    assert [m.name for m in plane.modifiers] == [mesh_preview.MODIFIER_NAME]
    px = render_pixels(size=16, samples=2)
    np.testing.assert_allclose(px[4:12, 4:12, :3].reshape(-1, 3).mean(axis=0), (0.2, 0.5, 0.8),
                               rtol=0.02)
    assert [s.material for s in plane.material_slots] == [mat]
    assert mesh_preview.remove_mesh_preview([plane]) == 1
    assert len(plane.modifiers) == 0


@requires_core
def test_a_run_with_the_preview_on_reads_the_meshes_own_materials():
    """With the mesh preview on, the evaluated meshes carry the preview's emission material;
    the next run must still see the user's materials (the preview is switched off while the
    scene is read and back on after)."""
    floor = make_plane("Floor", size=2.0, material=diffuse_material("W", (0.6, 0.6, 0.6)))
    light = make_plane("Light", size=0.5, location=(0, 0, 1.0), flip=True,
                       material=emission_material("E", (5.0, 5.0, 5.0), 1.0))
    settings = pipeline.Settings(budget=600, gather_rays=32, transfer_domain="POINT")
    pipeline.compute(bpy.context, [floor, light], settings)
    first = _values(floor)
    assert mesh_preview.build_mesh_preview([floor, light]) == ["Floor", "Light"]
    pipeline.compute(bpy.context, [floor, light], settings)
    np.testing.assert_array_equal(_values(floor), first)
    assert all(obj.modifiers[mesh_preview.MODIFIER_NAME].show_viewport for obj in (floor, light))


def _values(obj):
    attr = obj.data.color_attributes["illumination"]
    out = np.empty(len(attr.data) * 4, np.float32)
    attr.data.foreach_get("color", out)
    return out.reshape(-1, 4)[:, :3]
