"""The point preview: a scan's own points shown with the light evaluated at each of them,
whatever number of surfels the solve used; reversible, fast at a million points."""

import bpy
import numpy as np
import pytest

from illumap_bpy_testing import (black_world, link, make_surfels, render_pixels, requires_core,
                                 select_only, top_camera)

from addon import mesh_preview, pipeline


def scan_mesh(n, size=1.0, seed=0, name="Scan"):
    """A vertex-only mesh of n random points on the square of side ``size`` at z = 0, with an
    ``illumination`` point attribute that grows with x (0.1 … 0.9 in red)."""
    rng = np.random.default_rng(seed)
    pts = np.column_stack([(rng.random((n, 2)) - 0.5) * size, np.zeros(n)])
    mesh = bpy.data.meshes.new(name)
    mesh.vertices.add(n)
    mesh.vertices.foreach_set("co", pts.astype(np.float32).ravel())
    colors = np.column_stack([0.5 + 0.8 * pts[:, 0] / size, np.full(n, 0.5), np.full(n, 0.2),
                              np.ones(n)])
    attr = mesh.color_attributes.new("illumination", "FLOAT_COLOR", "POINT")
    attr.data.foreach_set("color", colors.astype(np.float32).ravel())
    return link(bpy.data.objects.new(name, mesh)), pts, colors[:, :3]


def evaluated_points(obj):
    """(positions (n, 3), radius (n,), material names) of obj's evaluated point cloud."""
    ev = obj.evaluated_get(bpy.context.evaluated_depsgraph_get())
    geometry = ev.evaluated_geometry()      # owns the point cloud below
    cloud = geometry.pointcloud
    pos = np.empty(len(cloud.points) * 3)
    cloud.attributes["position"].data.foreach_get("vector", pos)
    radius = np.empty(len(cloud.points))
    cloud.attributes["radius"].data.foreach_get("value", radius)
    return pos.reshape(-1, 3), radius, [m.name for m in cloud.materials if m is not None]


def test_every_point_of_a_scan_is_shown_with_its_own_light_and_a_closing_radius():
    obj, pts, _ = scan_mesh(4000)
    assert mesh_preview.build_mesh_preview([obj]) == ["Scan"]
    assert [m.name for m in obj.modifiers] == [mesh_preview.POINT_MODIFIER_NAME]
    pos, radius, mats = evaluated_points(obj)
    assert len(pos) == len(pts)
    np.testing.assert_allclose(np.sort(pos[:, 0]), np.sort(pts[:, 0]), atol=1e-6)
    assert mats == [mesh_preview.MATERIAL_NAME]
    # Spheres of this radius about random points cover the square but for a few holes
    # (exp(-5.7) ~ 0.3% of it), without swelling far beyond the spacing.
    grid = np.stack(np.meshgrid(np.linspace(-0.45, 0.45, 60), np.linspace(-0.45, 0.45, 60)), -1)
    grid = grid.reshape(-1, 2)
    d = np.sqrt(((grid[:, None, :] - pts[None, :, :2]) ** 2).sum(-1)).min(axis=1)
    assert np.mean(d > radius[0]) < 0.01
    assert radius[0] < 2.0 * np.sqrt(1.0 / len(pts))
    assert mesh_preview.remove_mesh_preview([obj]) == 1 and len(obj.modifiers) == 0


def test_a_point_clouds_own_radius_is_kept():
    obj = make_surfels(np.random.default_rng(1).random((500, 3)), (0, 0, 1), 0.0123,
                       (0.3, 0.3, 0.3), name="Cloud", pointcloud=True)
    assert obj.type == "POINTCLOUD"
    assert mesh_preview.build_mesh_preview([obj]) == ["Cloud"]
    _, radius, mats = evaluated_points(obj)
    np.testing.assert_allclose(radius, 0.0123, rtol=1e-6)
    assert mats == [mesh_preview.MATERIAL_NAME]


def test_the_preview_renders_each_points_light():
    """Seen from above, the preview shows the scan's light: red grows from left to right as
    the attribute does, green and blue are the attribute's."""
    obj, _, _ = scan_mesh(20000)
    black_world()
    top_camera(ortho_scale=0.8)
    mesh_preview.build_mesh_preview([obj])
    px = render_pixels(size=16, samples=4)[..., :3]
    centre = px[4:12, 4:12].reshape(-1, 3).mean(axis=0)
    np.testing.assert_allclose(centre[1:], (0.5, 0.2), rtol=0.05)
    left, right = px[4:12, 3].mean(axis=0), px[4:12, 12].mean(axis=0)
    assert right[0] - left[0] > 0.25      # 0.8 × 0.45 m across those columns


@requires_core
def test_a_scan_only_run_previews_the_scan_itself():
    """Computing a scan with Build Preview on shows every point of the scan (the surfel
    object, whose thinned surfels would overlap it, is hidden)."""
    from illumap_bpy_testing import add_lamp
    obj, pts, _ = scan_mesh(3000, name="Floor Scan")
    obj.data.color_attributes.remove(obj.data.color_attributes["illumination"])
    normal = obj.data.attributes.new("normal", "FLOAT_VECTOR", "POINT")
    normal.data.foreach_set("vector", np.tile([0.0, 0.0, 1.0], len(pts)).astype(np.float32))
    add_lamp("SUN", energy=2.0)
    select_only(obj)
    props = bpy.context.scene.illumap
    props.budget = 500
    assert bpy.ops.illumap.compute_illumination_map() == {"FINISHED"}
    assert mesh_preview.POINT_MODIFIER_NAME in obj.modifiers
    surfels = [o for o in bpy.data.objects if o.get("illumap_generated")]
    assert surfels and all(o.hide_render for o in surfels)
    pos, _, _ = evaluated_points(obj)
    assert len(pos) == len(pts)
