"""A scan with one stray point (issue 57): without a 'radius' attribute each point's area is
estimated from its neighbours' distances, so a point moved 50 m to 1,000 km from a 1 m scan
got a disc as wide as that distance and the native build stalled on it (15.9 s at 50 m, no
end at 500 m). Now its area is bounded (``pointcloud.bound_stray_areas``), a warning gives
the count, and the light at every other point is the light without it.

The areas are checked before anything is solved, so a regression fails at once rather than
hanging the run; the core's near field has its own guard (tests/core/test_stray_surfel.py).
"""

import math

import bpy
import numpy as np
import pytest

from illumap_bpy_testing import diffuse_material, emission_material, link, make_plane, requires_core

from addon import pipeline
from addon.read import pointcloud

pytestmark = requires_core


def patch(count=299, seed=1):
    """``count`` jittered points on a 1 m square at z = 0 (spacing about 5.6 cm)."""
    rng = np.random.default_rng(seed)
    g = 18
    xs = (np.arange(g) + 0.5) / g - 0.5
    x, y = np.meshgrid(xs, xs, indexing="ij")
    pos = np.stack([x.ravel(), y.ravel(), np.zeros(g * g)], axis=1)[:count]
    pos[:, :2] += rng.uniform(-0.01, 0.01, (count, 2))
    return pos


def scan_object(positions, name="Scan"):
    """A vertex-only mesh (no radius, no normals: both estimated)."""
    data = bpy.data.meshes.new(name)
    data.vertices.add(len(positions))
    data.vertices.foreach_set("co", np.asarray(positions, np.float32).ravel())
    return link(bpy.data.objects.new(name, data))


def room():
    """An emitter above the patch and two diffuse walls beside it (light bounces onto the
    scan, so its gathers and their cache matter)."""
    make_plane("Emitter", size=0.5, location=(0, 0, 1.0), flip=True,
               material=emission_material("Em", (1, 1, 1), 10.0))
    wall = make_plane("Wall", size=1.0, location=(0.55, 0, 0.5),
                      material=diffuse_material("Red", (0.8, 0.2, 0.2)))
    wall.rotation_euler = (0, -math.pi / 2, 0)
    back = make_plane("Back", size=1.0, location=(0, 0.55, 0.5),
                      material=diffuse_material("Green", (0.2, 0.8, 0.2)))
    back.rotation_euler = (math.pi / 2, 0, 0)


def illumination(obj):
    attr = obj.data.attributes["illumination"]
    out = np.empty(len(attr.data) * 4, np.float32)
    attr.data.foreach_get("color", out)
    return out.reshape(-1, 4)[:, :3].astype(np.float64)


def lit_scan(far):
    """(illumination at the patch's 299 points, the run's warnings, the surfels' areas of the
    scan) in the room, with a 300th point ``far`` metres away along x (None: without it)."""
    bpy.ops.wm.read_factory_settings(use_empty=True)
    pos = patch()
    if far is not None:
        pos = np.vstack([pos, [far, 0.0, 0.0]])
    scan = scan_object(pos)
    room()
    objects = list(bpy.data.objects)
    # The areas first, before anything is solved: a stray disc kilometres wide fails here.
    areas = pointcloud.read_points(scan, bpy.context.evaluated_depsgraph_get(), []).areas
    assert areas.max() < 10.0 * np.median(areas)
    result = pipeline.compute(bpy.context, objects, pipeline.Settings())
    return illumination(scan)[:299], result.warnings, areas


@pytest.mark.parametrize("far", [50.0, 1e6])
def test_a_stray_point_leaves_the_light_at_the_others_and_is_counted(far):
    alone, warnings_alone, _ = lit_scan(None)
    with_stray, warnings, areas = lit_scan(far)
    assert not any("stray" in w for w in warnings_alone)
    stray = [w for w in warnings if "stray" in w]
    assert len(stray) == 1 and "1 point lies far from its neighbours" in stray[0], warnings
    assert "Scan" in stray[0]
    # The stray point stands for one typical point of the scan.
    assert areas[-1] == pytest.approx(np.median(areas), rel=0.05)
    assert alone.min() > 0.05
    assert np.abs(with_stray - alone).max() <= 1e-3 * alone.max()


def test_stray_points_are_told_from_a_scan_whose_density_varies():
    """A floor scanned from one spot gets sparser with distance (spacing 1 to 30 cm): no
    point of it is stray. Three points 200 m away, far from everything but each other, are;
    the warning gives the count."""
    rng = np.random.default_rng(4)
    r = np.geomspace(0.2, 6.0, 60)                  # rings, spacing growing with the range
    rings = [np.c_[rr * np.cos(t), rr * np.sin(t), np.zeros_like(t)]
             for rr in r for t in [np.linspace(0, 2 * np.pi, max(8, int(2 * np.pi * rr /
                                                                     (0.05 * rr))),
                                               endpoint=False) + rng.uniform(0, 0.1)]]
    floor = np.concatenate(rings)
    areas, stray, _ = pointcloud.bound_stray_areas(pointcloud.estimate_areas(floor))
    assert not stray.any()
    spacing = np.sqrt(pointcloud.estimate_areas(floor))
    assert spacing.max() / spacing.min() > 20          # the density does vary that much
    far = np.array([[200.0, 0.0, 0.0], [200.1, 0.0, 0.0], [200.0, 0.1, 0.0]])
    cloud = np.concatenate([floor, far])
    areas, stray, typical = pointcloud.bound_stray_areas(pointcloud.estimate_areas(cloud))
    assert np.flatnonzero(stray).tolist() == [len(floor), len(floor) + 1, len(floor) + 2]
    assert (areas[stray] == typical).all()
    warnings = []
    scan = scan_object(cloud)
    pointcloud.read_points(scan, bpy.context.evaluated_depsgraph_get(), warnings)
    assert any("3 points lie far from their neighbours" in w for w in warnings), warnings
