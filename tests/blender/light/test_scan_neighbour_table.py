"""A scan without radius and normals is searched once for its own neighbours (issue 58):
the spacing's areas, the normals, the receiver normals and the splats (their planes and
outlines) made from that one table equal what separate searches give, bit for bit."""

from dataclasses import replace

import bpy
import numpy as np

from illumap_bpy_testing import link

from addon.read import pointcloud
from illumap import splats


def _scan_of_a_box_corner(step=0.03, jitter=0.0):
    """A floor and two walls meeting at a corner, on a regular grid (neighbours tie)."""
    s = np.arange(0.0, 0.9, step) + step / 2
    a, b = (g.ravel() for g in np.meshgrid(s, s, indexing="ij"))
    z = np.zeros_like(a)
    pts = np.concatenate([np.stack([a, b, z], 1), np.stack([z, a, b], 1),
                          np.stack([a, z, b], 1)])
    return pts + np.random.default_rng(5).normal(0.0, jitter, pts.shape)


def _read(pts):
    mesh = bpy.data.meshes.new("Scan")
    mesh.vertices.add(len(pts))
    mesh.vertices.foreach_set("co", np.asarray(pts, np.float32).ravel())
    obj = link(bpy.data.objects.new("Scan", mesh))
    return pointcloud.read_points(obj, bpy.context.evaluated_depsgraph_get(), [])


def test_one_search_gives_the_areas_and_normals_separate_searches_give():
    from illumap import pointcloud as core_pointcloud
    for jitter in (0.0, 0.002):
        read = _read(_scan_of_a_box_corner(jitter=jitter))
        k, wide = pointcloud.K_NEIGHBOURS, pointcloud.SHARED_NEIGHBOURS
        assert read.normals is None and read.neighbours.shape == (len(read.positions), wide + 1)
        np.testing.assert_array_equal(read.areas, pointcloud.bound_stray_areas(
            pointcloud.estimate_areas(read.positions, k))[0])
        shared = pointcloud.with_normals(read)
        separate = pointcloud.with_normals(replace(read, neighbours=None))
        np.testing.assert_array_equal(shared.neighbours,
                                      core_pointcloud.nearest(read.positions, wide))
        np.testing.assert_array_equal(shared.normals, separate.normals)
        np.testing.assert_array_equal(shared.receiver_normals, separate.receiver_normals)
        # ... and separate searches of the fits' own width, as they made them before
        narrow = core_pointcloud.nearest(read.positions, k)
        normals = core_pointcloud.estimate_normals(read.positions, k, neighbours=narrow)
        np.testing.assert_array_equal(shared.normals, normals)
        np.testing.assert_array_equal(shared.receiver_normals, core_pointcloud.receiver_normals(
            read.positions, normals, narrow))
        # the splats (planes and outlines) from the table, and searching for themselves
        areas = shared.areas
        np.testing.assert_array_equal(
            splats.splat_triangles(shared.positions, shared.normals, areas,
                                   nearest=shared.neighbours),
            splats.splat_triangles(shared.positions, shared.normals, areas))


def test_a_cloud_with_normals_keeps_no_table():
    pts = _scan_of_a_box_corner(step=0.1)
    mesh = bpy.data.meshes.new("Normals")
    mesh.vertices.add(len(pts))
    mesh.vertices.foreach_set("co", np.asarray(pts, np.float32).ravel())
    attr = mesh.attributes.new("normal", "FLOAT_VECTOR", "POINT")
    attr.data.foreach_set("vector", np.tile([0.0, 0.0, 1.0], len(pts)).astype(np.float32))
    obj = link(bpy.data.objects.new("Normals", mesh))
    read = pointcloud.read_points(obj, bpy.context.evaluated_depsgraph_get(), [])
    assert read.normals is not None and read.neighbours is None
