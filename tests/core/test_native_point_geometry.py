"""The point clouds' plane fits and splats run natively (normals.cpp, splats.cpp): they must
give what the whole-array numpy formulation gave (``numpy_reference``, LAPACK's eigen-solver),
on a scan with the cases the rules exist for: a floor meeting a wall, a box standing on the
floor, a sphere, noise, duplicates and a rim; and refuse bad input clearly."""

import os
import sys

import numpy as np
import pytest

import illumap
from illumap import _core, pointcloud, splats

sys.path.insert(0, os.path.dirname(__file__))
import numpy_reference as ref  # noqa: E402


def scan(seed=3, count=6000):
    """A floor along a wall, a box on the floor, a sphere; jittered, a little noisy, with a
    few duplicated points."""
    rng = np.random.default_rng(seed)
    floor = np.c_[rng.uniform(-1, 1, count), rng.uniform(-1, 1, count), np.zeros(count)]
    floor = floor[~((np.abs(floor[:, 0]) < 0.2) & (np.abs(floor[:, 1]) < 0.2))]
    wall = np.c_[rng.uniform(-1, 1, count // 2), np.ones(count // 2), rng.uniform(0, 1, count // 2)]
    side = rng.uniform(-0.2, 0.2, (count // 4, 2))
    box = np.concatenate([np.c_[side, np.full(len(side), 0.4)],                      # top
                          np.c_[np.full(len(side), 0.2), side[:, 0], side[:, 1] + 0.2],   # a side
                          np.c_[side[:, 0], np.full(len(side), -0.2), side[:, 1] + 0.2]])
    d = rng.normal(size=(count // 2, 3))
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    ball = 0.25 * d + [0.6, 0.4, 0.5]
    p = np.concatenate([floor, wall, box, ball])
    p += rng.normal(scale=2e-4, size=p.shape)
    return np.concatenate([p, p[:5]])                  # duplicates: zero offsets


def agree(a, b):
    """1 - |cos| between unoriented normals."""
    return 1.0 - np.abs(np.einsum("ij,ij->i", a, b))


@pytest.fixture(scope="module")
def points():
    return scan()


@pytest.fixture(scope="module")
def oriented(points):
    return pointcloud.estimate_normals(points, 8)


@pytest.mark.parametrize("k", [6, 8, 12])
def test_plane_normals_are_the_numpy_fits(points, k):
    idx = np.asarray(_core.knn(points, points, k + 1)[0])
    native = pointcloud.plane_normals(points, idx)
    numpy = ref._plane_normals(points[idx] - points[:, None, :])
    np.testing.assert_allclose(np.linalg.norm(native, axis=1), 1.0, atol=1e-12)
    assert agree(native, numpy).max() < 1e-10
    # The rule matters here: along the floor-wall line plain PCA tilts by tens of degrees.
    line = np.flatnonzero((np.abs(points[:, 1] - 1.0) < 0.02) & (points[:, 2] < 0.02))
    assert len(line) and agree(native[line], ref.pca_normals(points, k)[line]).max() > 0.05


def test_pca_normals_are_the_covariance_eigenvectors(points):
    native = pointcloud.pca_normals(points, 8)
    assert agree(native, ref.pca_normals(points, 8)).max() < 1e-10


def test_settled_normals_are_the_numpy_refit(points, oriented):
    np.testing.assert_allclose(pointcloud.settled_normals(points, oriented),
                               ref.settled_normals(points, oriented), atol=1e-10)


def test_splats_are_the_numpy_outlines(points, oriented):
    area = np.full(len(points), 4e-4)
    radii, u, v = splats.splat_radii(points, oriented, area)
    want, wu, wv = ref.splat_radii(points, oriented, area)
    np.testing.assert_allclose(radii, want, rtol=1e-12, atol=1e-15)
    # Every rule fired somewhere: bisectors, tangent planes, the rim and the full reach.
    own = np.sqrt(area / np.pi)[:, None]
    assert (radii < splats.DEFAULT_REACH * own - 1e-12).mean() > 0.5
    assert (radii == splats.DEFAULT_REACH * own).any()
    np.testing.assert_allclose(splats.splat_triangles(points, oriented, area),
                               ref.splat_triangles(points, oriented, area), rtol=0, atol=1e-14)
    # Unclipped options too.
    np.testing.assert_allclose(splats.splat_radii(points, oriented, area, neighbours=3, sides=7)[0],
                               ref.splat_radii(points, oriented, area, neighbours=3, sides=7)[0],
                               rtol=1e-12, atol=1e-15)


def test_fans_face_along_the_given_normals(oriented, points):
    area = np.full(len(points), 4e-4)
    for sign in (1.0, -1.0):
        tri = splats.splat_triangles(points, sign * oriented, area)
        face = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
        facing = np.repeat(sign * oriented, splats.DEFAULT_SIDES, axis=0)
        big = np.linalg.norm(face, axis=1) > 1e-12
        assert (np.einsum("ij,ij->i", face[big], facing[big]) > 0).all()


def test_bad_tables_are_refused(points):
    idx = np.asarray(_core.knn(points, points, 9)[0]).copy()
    idx[7, 3] = len(points)
    with pytest.raises(IndexError, match="neighbour index out of range"):
        _core.plane_normals(points, idx, inlier=0.2, share=0.5, spread=0.05)
    with pytest.raises(IndexError, match="neighbour index out of range"):
        _core.covariance_normals(points, idx)
    with pytest.raises(ValueError, match="one row per point"):
        _core.covariance_normals(points, idx[:-1])
    with pytest.raises(ValueError, match="int64"):
        _core.covariance_normals(points, idx.astype(np.int32))
    n = np.tile([0.0, 0.0, 1.0], (len(points), 1))
    with pytest.raises(ValueError, match="same length"):
        _core.splat_radii(points, n, n, n[:-1], np.ones(len(points)), np.ones(len(points)),
                          idx, sides=12, corner_slack=1.3, edge_cos=0.9, rim_cos=0.5,
                          junction_tolerance=0.05, edge_overlap=0.02)


def test_the_fits_can_be_cancelled(points):
    idx = np.asarray(_core.knn(points, points, 13)[0])
    with pytest.raises(illumap.Cancelled):
        pointcloud.plane_normals(points, idx, progress=lambda fraction, phase: False)
    with pytest.raises(illumap.Cancelled):
        pointcloud.estimate_normals(points, progress=lambda fraction, phase: False)
