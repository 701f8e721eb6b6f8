"""Point-cloud normals (illumap.pointcloud): PCA plus a consistent orientation.

A per-point rule (face away from the centroid) turns every surface that faces its centroid
inwards: the inside of a torus, the far side of the bunny's ears. The spanning-tree
orientation must keep each side on its side, decide each connected part's sign on its own,
and say clearly what is wrong with bad input.
"""

import os
import sys

import numpy as np
import pytest

import illumap
from illumap import pointcloud

sys.path.insert(0, os.path.join(os.path.dirname(__file__), "..", "..", "bench"))
from scenes import surfels as S  # noqa: E402


def torus(count, R=1.0, r=0.3, seed=0):
    rng = np.random.default_rng(seed)
    u, v = rng.random(count) * 2 * np.pi, rng.random(count) * 2 * np.pi
    p = np.c_[(R + r * np.cos(v)) * np.cos(u), (R + r * np.cos(v)) * np.sin(u), r * np.sin(v)]
    n = np.c_[np.cos(v) * np.cos(u), np.cos(v) * np.sin(u), np.sin(v)]
    return p, n


def sphere(count, centre=(0, 0, 0), radius=1.0, seed=0):
    d = np.random.default_rng(seed).normal(size=(count, 3))
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    return np.asarray(centre, float) + radius * d, d


def heuristic_only(points, normals):
    """Each normal flipped on its own towards its hint (the rule the tree replaces)."""
    hints = pointcloud.orientation_hints(points, normals)
    return normals * np.sign(np.einsum("ij,ij->i", normals, hints) + 1e-300)[:, None]


def test_the_inside_of_a_torus_faces_outwards_of_the_tube():
    p, truth = torus(6000)
    n = pointcloud.estimate_normals(p)
    assert np.allclose(np.linalg.norm(n, axis=1), 1.0)
    cos = np.einsum("ij,ij->i", n, truth)
    assert np.all(cos > 0.9)
    # the per-point rule gets the inner half wrong
    assert np.mean(np.einsum("ij,ij->i", heuristic_only(p, n), truth) > 0) < 0.75


def test_randomly_flipped_normals_are_made_consistent():
    p, truth = torus(4000, seed=1)
    flips = np.where(np.random.default_rng(2).random(len(p)) < 0.5, -1.0, 1.0)
    n, parts = pointcloud.orient_normals(p, truth * flips[:, None])
    assert parts == 1
    assert np.all(np.einsum("ij,ij->i", n, truth) > 0.999)


def test_each_connected_part_takes_its_own_sign():
    a, na = sphere(1500, centre=(-5, 0, 0), seed=3)
    b, nb = sphere(1500, centre=(5, 0, 0), seed=4)
    p, truth = np.concatenate([a, b]), np.concatenate([na, nb])
    n, parts = pointcloud.orient_normals(p, -truth)
    assert parts == 2
    assert np.all(np.einsum("ij,ij->i", n, truth) > 0.999)


def test_a_flat_patch_faces_up_and_duplicates_agree():
    g = (np.arange(30) + 0.5) / 30
    x, y = np.meshgrid(g, g)
    p = np.c_[x.ravel(), y.ravel(), np.zeros(x.size)]
    p = np.concatenate([p, p[:50]])   # coincident points
    n = pointcloud.estimate_normals(p)
    assert np.all(n[:, 2] > 0.999)


@pytest.mark.skipif(not os.path.exists(S.BUNNY_PLY), reason="the Stanford bunny scan is absent")
@pytest.mark.parametrize("k", [8, 12])
def test_the_bunny_scan_agrees_with_its_mesh(k):
    pts = S.bunny_points()
    with open(S.BUNNY_PLY) as f:
        while f.readline().strip() != "end_header":
            pass
        for _ in range(len(pts)):
            f.readline()
        faces = np.loadtxt(f, usecols=(1, 2, 3), dtype=np.int64)
    a, b, c = (pts[faces[:, i]] for i in range(3))
    area_normals = np.cross(b - a, c - a)
    mesh = np.zeros_like(pts)
    for i in range(3):
        np.add.at(mesh, faces[:, i], area_normals)
    on_mesh = np.linalg.norm(mesh, axis=1) > 0
    n = pointcloud.estimate_normals(pts, k)
    agree = np.einsum("ij,ij->i", n[on_mesh], mesh[on_mesh]) > 0
    assert agree.all(), f"{(~agree).sum()} of {on_mesh.sum()} normals face into the bunny"
    per_point = np.einsum("ij,ij->i", heuristic_only(pts, n)[on_mesh], mesh[on_mesh]) > 0
    assert per_point.mean() < 0.95   # the ears: what the tree fixes


def test_bad_points_are_named():
    p, _ = sphere(100)
    p[17, 1] = np.nan
    with pytest.raises(illumap.InputError, match="NaN.*index 17"):
        pointcloud.estimate_normals(p)
    with pytest.raises(illumap.InputError, match=r"shape \(P, 3\)"):
        pointcloud.estimate_normals(np.zeros((10, 2)))
    with pytest.raises(illumap.InputError, match="at least 3 points"):
        pointcloud.estimate_normals(np.zeros((2, 3)))
    with pytest.raises(illumap.InputError, match="normals: expected shape"):
        pointcloud.orient_normals(p[:10] * 0 + 1, np.ones((9, 3)))


def test_orientation_can_be_cancelled():
    p, n = torus(3000)
    with pytest.raises(illumap.Cancelled):
        pointcloud.orient_normals(p, n, progress=lambda fraction, phase: False)


def _floor_and_wall(n=40, seed=12):
    """A floor (z = 0, y > 0) meeting a wall (y = 0, z > 0), each jittered within the cells
    of an n × n grid of the unit square: the points (2n², 3), each one's true normal (±z,
    ±y) and its distance from the crease in spacings."""
    rng = np.random.default_rng(seed)
    i, j = (a.ravel() for a in np.meshgrid(np.arange(n), np.arange(n)))
    uv = (np.column_stack([i, j]) + rng.uniform(0.1, 0.9, (n * n, 2))) / n
    p = np.concatenate([np.column_stack([uv[:, 0], uv[:, 1], np.zeros(len(uv))]),
                        np.column_stack([uv[:, 0], np.zeros(len(uv)), uv[:, 1]])])
    true = np.repeat([[0.0, 0.0, 1.0], [0.0, 1.0, 0.0]], len(uv), axis=0)
    return p, true, np.r_[uv[:, 1], uv[:, 1]] * n


def _tilt(normals, true):
    """Degrees between each of ``normals`` and ``true``, either orientation."""
    return np.degrees(np.arccos(np.clip(np.abs(np.einsum("ij,ij->i", normals, true)), 0, 1)))


@pytest.mark.skipif(not illumap.native_available(), reason="needs the native core")
def test_points_beside_a_crease_are_lit_about_their_own_plane():
    """Beside a crease the PCA over all neighbours tilts towards the other surface (lit about
    that tilt, a point takes the other surface's light); ``receiver_normals`` takes the
    point's own plane there. Between half a spacing and two off the crease, every point whose
    fitted plane is its surface's (within 1°) and whose PCA tilts less than
    RECEIVER_CREASE_TILT is lit within 1° of its surface's normal, where the PCA tilts some
    of them by more than 5°. (Others there keep a fit tilted by the other surface's points
    among their neighbours: the plane fit's own error.) On a sphere, with no crease, the
    receivers are the PCA's, oriented as the fitted planes."""
    p, true, dist = _floor_and_wall()
    k = 8
    near = pointcloud.nearest(p, k)
    planes = pointcloud.estimate_normals(p, k, neighbours=near)
    lit = pointcloud.receiver_normals(p, planes, near)
    pca = pointcloud.pca_normals(p, k, neighbours=near)
    beside = ((dist > 0.5) & (dist < 2) & (p[:, 0] > 0.05) & (p[:, 0] < 0.95)
              & (_tilt(planes, true) < 1) & (_tilt(pca, planes) < pointcloud.RECEIVER_CREASE_TILT))
    assert beside.sum() > 60
    assert (_tilt(pca, true)[beside] > 5).sum() > 10          # the PCA does tilt there
    assert _tilt(lit, true)[beside].max() < 1
    assert (np.einsum("ij,ij->i", lit, planes) > 0).all()       # oriented as the planes
    s, _ = sphere(3000, seed=3)
    near = pointcloud.nearest(s, k)
    planes = pointcloud.estimate_normals(s, k, neighbours=near)
    spread = pointcloud.pca_normals(s, k, neighbours=near)
    spread *= np.sign(np.einsum("ij,ij->i", spread, planes))[:, None]
    np.testing.assert_allclose(pointcloud.receiver_normals(s, planes, near), spread, atol=1e-12)


def test_receiver_normals_refuse_mismatched_input():
    p, _, _ = _floor_and_wall(n=5)
    with pytest.raises(illumap.InputError, match="neighbours"):
        pointcloud.receiver_normals(p, np.zeros_like(p), np.zeros((3, 9), np.int64))
