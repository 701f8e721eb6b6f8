"""One search of a scan's own points shared by its consumers (issue 58): the splats' planes
(``settled_normals``, ``splat_triangles``) given the table ``pointcloud.nearest`` made give
the very bits they give when they search themselves, on a regular grid (where neighbours tie
in distance, so a different search could pick a different one) and on jittered points."""

import numpy as np
import pytest

from illumap import pointcloud, splats

pytestmark = pytest.mark.skipif(not __import__("illumap").native_available(),
                                reason="native core not built")


def _floor_and_wall(step: float, jitter: float, seed: int = 3) -> np.ndarray:
    """A floor (z = 0) and a wall (x = 0) meeting at a crease, sampled every ``step`` m."""
    s = np.arange(0.0, 1.0, step)
    a, b = np.meshgrid(s, s, indexing="ij")
    floor = np.stack([a.ravel() + step / 2, b.ravel(), np.zeros(a.size)], axis=1)
    wall = np.stack([np.zeros(a.size), b.ravel(), a.ravel() + step / 2], axis=1)
    pts = np.concatenate([floor, wall])
    return pts + np.random.default_rng(seed).normal(0.0, jitter, pts.shape)


def _normals(pts: np.ndarray) -> np.ndarray:
    return pointcloud.estimate_normals(pts, pointcloud.SETTLE_NEIGHBOURS)


@pytest.mark.parametrize("jitter", [0.0, 0.004])
def test_settled_normals_from_a_shared_table_equal_their_own_search(jitter):
    pts = _floor_and_wall(0.04, jitter)
    normals = _normals(pts)
    table = pointcloud.nearest(pts, pointcloud.SETTLE_NEIGHBOURS)
    own = pointcloud.settled_normals(pts, normals)
    shared = pointcloud.settled_normals(pts, normals, table)
    assert table.shape == (len(pts), pointcloud.SETTLE_NEIGHBOURS + 1)
    np.testing.assert_array_equal(shared, own)


@pytest.mark.parametrize("jitter", [0.0, 0.003])
def test_a_wider_table_serves_and_a_narrower_one_is_not_used(jitter):
    """A table of more columns is read for its first ones (knn keeps ties to the lower
    index, so they are the narrower search's, on the tied grid too); one of fewer is
    searched again rather than read past its end."""
    pts = _floor_and_wall(0.05, jitter)
    normals = _normals(pts)
    own = pointcloud.settled_normals(pts, normals)
    wider = pointcloud.nearest(pts, pointcloud.SETTLE_NEIGHBOURS + 12)
    narrower = pointcloud.nearest(pts, pointcloud.SETTLE_NEIGHBOURS - 3)
    np.testing.assert_array_equal(pointcloud.settled_normals(pts, normals, wider), own)
    np.testing.assert_array_equal(pointcloud.settled_normals(pts, normals, narrower), own)


@pytest.mark.parametrize("jitter", [0.0, 0.004])
def test_splat_outlines_from_a_shared_table_equal_their_own_search(jitter):
    """``splat_radii`` reads the first neighbours + 1 columns of a wider table (the scan's
    one search, ``addon.read.pointcloud.SHARED_NEIGHBOURS``): the very bits of its own."""
    pts = _floor_and_wall(0.04, jitter)
    normals = _normals(pts)
    areas = np.full(len(pts), 0.04 ** 2)
    table = pointcloud.nearest(pts, splats.DEFAULT_NEIGHBOURS + 4)
    for got, want in zip(splats.splat_radii(pts, normals, areas, nearest=table),
                         splats.splat_radii(pts, normals, areas)):
        np.testing.assert_array_equal(got, want)
    assert (splats.splat_radii(pts, normals, areas)[0] <
            splats.DEFAULT_REACH * np.sqrt(areas / np.pi)[:, None]).any()   # clipped: read


@pytest.mark.parametrize("jitter", [0.0, 0.004])
def test_splat_triangles_from_a_shared_table_equal_their_own_search(jitter):
    pts = _floor_and_wall(0.04, jitter)
    normals = _normals(pts)
    areas = np.full(len(pts), 0.04 ** 2)
    table = pointcloud.nearest(pts, pointcloud.SETTLE_NEIGHBOURS)
    np.testing.assert_array_equal(splats.splat_triangles(pts, normals, areas, nearest=table),
                                  splats.splat_triangles(pts, normals, areas))


def test_normals_and_receivers_from_one_table_equal_separate_searches():
    pts = _floor_and_wall(0.04, 0.0)
    k = 8
    table = pointcloud.nearest(pts, k)
    normals = pointcloud.estimate_normals(pts, k, neighbours=table)
    np.testing.assert_array_equal(normals, pointcloud.estimate_normals(pts, k))
    np.testing.assert_array_equal(pointcloud.receiver_normals(pts, normals, table),
                                  pointcloud.receiver_normals(pts, normals,
                                                              pointcloud.nearest(pts, k)))


def test_the_points_own_search_equals_a_search_of_the_same_points_as_other_queries():
    """knn(points, points) visits the queries in the tree's order (no Morton sort); the same
    points permuted as queries take the sorted path: every answer is the same, ties (the
    regular grid) included."""
    from illumap.neighbours import knn
    pts = _floor_and_wall(0.03, 0.0)
    own_idx, own_dist = knn(pts, pts, 13)
    perm = np.random.default_rng(2).permutation(len(pts))
    idx, dist = knn(pts, pts[perm], 13)
    np.testing.assert_array_equal(own_idx[perm], idx)
    np.testing.assert_array_equal(own_dist[perm], dist)
