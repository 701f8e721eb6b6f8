"""The add-on's result does not depend on where a scene sits, on its scale, or on a far
outlier beside it (issue: precision independent of placement).

A small open room (ceiling, floor, a one-sided open plate, a box, an emitter 1 mm under the
ceiling) is parented to an empty that moves or scales it; Illumap runs with its default
settings and the ``illumination`` of every vertex is compared with the untransformed run.
Blender stores vertices in single precision, but its object matrices hold 1e8 exactly and
Illumap combines them in double precision, so the scene itself is the same at 1e8 m.
Measured: moved by ±1e8 m, 2e-7 relative RMS (the float32 attribute's own rounding); scaled
by 1e-6…1e8, 3e-7–8e-7; with a 1 cm plate 1e3…1e8 m away, 0.7e-3–1.1e-3, the same as with
that plate 3 m away (a new object changes the surfel budget's split and the octree).
"""

import bpy
import numpy as np
import pytest

from illumap_bpy_testing import black_world, emission_material, link, requires_core
from reference_helpers import closed_box, diffuse, plane, read_colors

from addon import pipeline

pytestmark = requires_core


def build():
    black_world()
    white = diffuse("White")
    parts = [
        plane("Ceiling", [(-.5, -.5, 1), (-.5, .5, 1), (.5, .5, 1), (.5, -.5, 1)], 0.05, white),
        plane("Floor", [(-.5, -.5, 0), (.5, -.5, 0), (.5, .5, 0), (-.5, .5, 0)], 0.05, white),
        plane("Plate", [(-.3, .1, .2), (.3, .1, .2), (.3, .1, .8), (-.3, .1, .8)], 0.05, white),
        closed_box("Box", (-.1, -.3, 0), (.1, -.1, .2), 0.05, white),
    ]
    z = 1 - 0.001
    emitter = plane("Emitter", [(-.15, -.15, z), (-.15, .15, z), (.15, .15, z), (.15, -.15, z)],
                    1.0, emission_material("Emit", (1, 1, 1), 5.0))
    root = link(bpy.data.objects.new("Root", None))
    for obj in parts + [emitter]:
        obj.parent = root
    return root, parts, emitter


def illumination(location=(0.0, 0.0, 0.0), scale=1.0, outlier=None):
    bpy.ops.wm.read_factory_settings(use_empty=True)
    root, parts, emitter = build()
    root.location = location
    root.scale = (scale,) * 3
    extra = []
    if outlier is not None:
        far = plane("Far", [(0, 0, 0), (.01, 0, 0), (.01, .01, 0), (0, .01, 0)], 1.0, diffuse("Grey"))
        far.location = (outlier, 0.0, 0.0)
        extra = [far]
    bpy.context.view_layer.update()
    pipeline.compute(bpy.context, parts + [emitter] + extra,
                     pipeline.Settings(transfer=True, transfer_domain="POINT"))
    return np.concatenate([read_colors(obj, "illumination") for obj in parts])


def relative_rms(got, ref):
    return float(np.sqrt(np.sum((got - ref) ** 2) / np.sum(ref ** 2)))


@pytest.fixture(scope="module")
def reference():
    ref = illumination()
    assert ref.max() > 0.5 and ref.mean() > 0.05
    return ref


@pytest.mark.parametrize("shift", [-1e8, 1e-6, 1e4, 1e8])
def test_moving_the_scene_changes_nothing(reference, shift):
    got = illumination(location=(shift, 0.5 * shift, -0.25 * shift))
    assert relative_rms(got, reference) < 1e-5
    assert np.abs(got - reference).max() < 1e-4


@pytest.mark.parametrize("scale", [1e-6, 1e-3, 1e3, 1e8])
def test_scaling_the_scene_changes_nothing(reference, scale):
    got = illumination(scale=scale)
    assert relative_rms(got, reference) < 1e-5
    assert np.abs(got - reference).max() < 1e-4


def test_a_far_outlier_leaves_the_room_as_it_is():
    """A 1 cm plate 1e4 or 1e8 m away changes the room no more than the same plate 3 m away."""
    near = illumination(outlier=3.0)
    for far in (1e4, 1e8):
        got = illumination(outlier=far)
        assert relative_rms(got, near) < 3e-3, far
        assert np.abs(got - near).max() < 0.03, far


def corner_edge(far_plane: bool):
    """A room corner (floor and two walls, 1 m, 5 cm cells) lit by a point lamp: the
    illumination of the vertices on its three edges, and of all its vertices. With
    ``far_plane``, a small plane of fine cells 40 m away holds most of the scene's triangles
    (and a negligible share of its area, so of the surfels), so the scene's centre, which
    its float coordinates are stored against, lies 40 m from the corner."""
    bpy.ops.wm.read_factory_settings(use_empty=True)
    black_world()
    white = diffuse("White")
    parts = [plane("Floor", [(0, 0, 0), (1, 0, 0), (1, 1, 0), (0, 1, 0)], 0.05, white),
             plane("WallX", [(0, 0, 0), (0, 1, 0), (0, 1, 1), (0, 0, 1)], 0.05, white),
             plane("WallY", [(0, 0, 0), (0, 0, 1), (1, 0, 1), (1, 0, 0)], 0.05, white)]
    extra = []
    if far_plane:
        extra = [plane("Far", [(40, 0, 0), (40.1, 0, 0), (40.1, .1, 0), (40, .1, 0)], 0.002, white)]
    lamp = bpy.data.lights.new("Lamp", "POINT")
    lamp.energy, lamp.shadow_soft_size = 60.0, 0.0
    link(bpy.data.objects.new("Lamp", lamp)).location = (0.4, 0.4, 0.6)
    bpy.context.view_layer.update()
    pipeline.compute(bpy.context, parts + extra,
                     pipeline.Settings(transfer=True, transfer_domain="POINT"))
    values = np.concatenate([read_colors(obj, "illumination") for obj in parts])
    co = np.concatenate([np.array([v.co[:] for v in obj.data.vertices]) for obj in parts])
    edge = (np.abs(co) < 1e-6).sum(axis=1) >= 2
    return values[edge], values


def test_a_corner_far_from_the_scene_centre_still_meets_its_walls():
    """Rays skip the first few float ulps of their origin's distance from the scene's
    centre. A corner's receivers lie inside their faces far enough that a wall standing on
    the edge is beyond that: 40 m out, the edges read as they do with the corner alone
    (they read ~20% dark when the receivers lay a fixed 0.1% of the way into their faces)."""
    alone_edge, alone = corner_edge(False)
    far_edge, far = corner_edge(True)
    assert len(alone_edge) == 3 * 21 * 2 - 3
    assert abs(far_edge.mean() / alone_edge.mean() - 1) < 0.02
    assert relative_rms(far_edge, alone_edge) < 0.03
    assert relative_rms(far, alone) < 0.02
