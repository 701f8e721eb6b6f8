"""illumap.sampling: stratified area-weighted surfels on triangles, regions, adaptive weights."""

import numpy as np
import pytest

from illumap import InputError
from illumap import sampling as S

SQUARE = np.array([[[0, 0, 0], [1, 0, 0], [1, 1, 0]],
                   [[0, 0, 0], [1, 1, 0], [0, 1, 0]]], dtype=np.float64)


def mixed_mesh(seed=0, t=60):
    """Random triangles of very different sizes in 3-D."""
    rng = np.random.default_rng(seed)
    c = rng.normal(size=(t, 3, 3)) * rng.uniform(0.01, 2.0, size=(t, 1, 1))
    return c


def test_uniform_areas_are_equal_and_sum_to_the_mesh_area():
    c = mixed_mesh()
    s = S.sample_triangles(c, 1000, np.random.default_rng(1))
    assert s.areas.sum() == pytest.approx(S.triangle_areas(c).sum(), rel=1e-12)
    assert np.ptp(s.areas) == 0.0
    # Points lie in their triangles, normals are unit.
    assert np.all(s.bary >= -1e-12) and np.allclose(s.bary.sum(1), 1)
    assert np.allclose(np.einsum("nk,nkc->nc", s.bary, c[s.triangle]), s.positions)
    assert np.allclose(np.linalg.norm(s.normals, axis=1), 1)


def test_counts_per_triangle_follow_area_within_one():
    c = mixed_mesh(2)
    n = 5000
    s = S.sample_triangles(c, n, np.random.default_rng(0))
    a = S.triangle_areas(c)
    counts = np.bincount(s.triangle, minlength=len(c))
    assert np.all(np.abs(counts - n * a / a.sum()) <= 1.0 + 1e-9)


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_weighted_areas_sum_exactly_and_density_follows_weights(seed):
    c = mixed_mesh(seed)
    rng = np.random.default_rng(seed)
    w = rng.uniform(1, 4, len(c))
    s = S.sample_triangles(c, 4000, np.random.default_rng(seed), weights=w)
    a = S.triangle_areas(c)
    assert s.areas.sum() == pytest.approx(a.sum(), rel=1e-12)
    assert np.all(s.areas > 0)
    counts = np.bincount(s.triangle, minlength=len(c))
    expected = 4000 * a * w / (a * w).sum()
    assert np.all(np.abs(counts - expected) <= 1.0 + 1e-9)
    # Area per surfel is the inverse of the local density (away from stratum boundaries).
    big = counts > 20
    per = np.bincount(s.triangle, weights=s.areas, minlength=len(c))
    assert np.allclose(per[big], a[big], rtol=2.0 / counts[big].min())


def test_same_seed_same_surfels_and_weights_one_change_nothing():
    a = S.sample_triangles(SQUARE, 300, np.random.default_rng(7))
    b = S.sample_triangles(SQUARE, 300, np.random.default_rng(7), weights=np.ones(2))
    assert np.array_equal(a.positions, b.positions)
    assert np.allclose(a.areas, b.areas, rtol=1e-12)


def test_corner_normals_interpolated_and_cancelling_normals_fall_back():
    cn = np.tile(np.array([0, 0, 1.0]), (2, 3, 1))
    cn[0, 0] = [0, 0, -1.0]      # opposite normals somewhere inside triangle 0 cancel
    s = S.sample_triangles(SQUARE, 2000, np.random.default_rng(0), corner_normals=cn)
    assert np.allclose(np.linalg.norm(s.normals, axis=1), 1)
    assert np.all(s.normals[s.triangle == 1] == [0, 0, 1])


def test_regions_cover_each_triangle_and_locate_finds_them():
    c = mixed_mesh(3, t=20)
    reg = S.Regions.build(c, max_area=0.05, max_level=5)
    a = S.triangle_areas(c)
    assert np.allclose(np.bincount(reg.parent, weights=reg.area), a)
    assert np.all(reg.area <= np.maximum(0.05, a[reg.parent] / 4 ** 5) * (1 + 1e-9))
    assert np.allclose(S.triangle_areas(reg.corners), reg.area)
    s = S.sample_triangles(c, 3000, np.random.default_rng(0))
    r = reg.locate(s.triangle, s.bary)
    assert np.array_equal(reg.parent[r], s.triangle)
    # The point's barycentric coordinates in its region are all ≥ 0.
    local = np.linalg.solve(np.transpose(reg.bary_corners[r], (0, 2, 1)), s.bary[..., None])[..., 0]
    assert local.min() >= -1e-9
    # to_parent inverts it.
    tri, bary = reg.to_parent(r, local)
    assert np.array_equal(tri, s.triangle) and np.allclose(bary, s.bary)


def test_multipliers_are_bounded_and_higher_where_values_vary():
    # A unit square lit on x < 0.5, dark on x > 0.5: variation only along the edge.
    s = S.sample_triangles(SQUARE, 2000, np.random.default_rng(0))
    values = (s.positions[:, 0] < 0.5).astype(float)
    d2 = ((s.positions[:, None, :] - s.positions[None, :, :]) ** 2).sum(-1)
    nb = np.argsort(d2, axis=1)[:, 1:9]
    var = S.local_variation(values, nb)
    reg = S.Regions.build(SQUARE, max_area=6 / 2000)
    w = S.density_multipliers(reg.locate(s.triangle, s.bary), var, reg.count, max_ratio=4)
    assert w.min() >= 1.0 and w.max() <= 4.0
    centre_x = reg.corners[:, :, 0].mean(1)
    near = np.abs(centre_x - 0.5) < 0.03
    far = np.abs(centre_x - 0.5) > 0.2
    assert w[near].mean() > 3.0 and np.all(w[far] == 1.0)
    s2 = S.sample_triangles(reg.corners, 2000, np.random.default_rng(1), weights=w,
                            areas=reg.area)
    assert s2.areas.sum() == pytest.approx(1.0, rel=1e-12)
    band = np.abs(s2.positions[:, 0] - 0.5) < 0.05
    assert band.mean() > 2.0 * 0.1      # more than twice the uniform share of that band


def test_empty_regions_take_the_fill():
    w = S.density_multipliers(np.array([0, 0, 1]), np.array([0.0, 1.0, 0.5]), 4,
                              fill=np.array([9.0, 9.0, 1.0, 0.0]), quantile=1.0)
    assert np.allclose(w, [4.0, 2.5, 4.0, 1.0])


def test_flat_values_give_multipliers_of_one():
    w = S.density_multipliers(np.array([0, 1, 1]), np.zeros(3), 4)
    assert np.array_equal(w, np.ones(4))


def test_allocate_and_errors():
    assert list(S.allocate([1.0, 3.0], budget=8)) == [2, 6]
    assert list(S.allocate([1.0, 0.001], density=10)) == [10, 1]
    with pytest.raises(InputError, match="budget 1 is smaller than the number of objects"):
        S.allocate([1.0, 1.0], budget=1)
    with pytest.raises(InputError, match="density must be a positive number"):
        S.allocate([1.0], density=-1)
    with pytest.raises(InputError, match=r"corners: expected shape \(T, 3, 3\)"):
        S.sample_triangles(np.zeros((2, 3)), 10, np.random.default_rng(0))
    with pytest.raises(InputError, match="weights: expected 2 positive"):
        S.sample_triangles(SQUARE, 10, np.random.default_rng(0), weights=[1.0, 0.0])


def _nearest_gaps(points):
    from illumap import _core
    _, dist = _core.knn(np.ascontiguousarray(points), np.ascontiguousarray(points), 2)
    return np.asarray(dist)[:, 1]


def _nearest_gaps_to(points, probes):
    from illumap import _core
    _, dist = _core.knn(np.ascontiguousarray(points), np.ascontiguousarray(probes), 1)
    return np.asarray(dist)[:, 0]


def test_thin_points_keeps_the_spacing_even_where_a_random_subset_clumps():
    rng = np.random.default_rng(4)
    # a jittered grid on a plane, as a scanner gives it
    g = np.stack(np.meshgrid(np.arange(120), np.arange(120)), -1).reshape(-1, 2) * 1e-3
    pts = np.column_stack([g + rng.normal(scale=1e-4, size=g.shape), np.zeros(len(g))])
    keep = S.thin_points(pts, 2000)
    assert abs(len(keep) - 2000) <= 20 and np.all(np.diff(keep) > 0)
    random = rng.choice(len(pts), len(keep), replace=False)
    even, clumped = _nearest_gaps(pts[keep]), _nearest_gaps(pts[random])
    # Even: nearest-neighbour gaps vary little, and no hole is much wider than the spacing
    # (holes are where light leaks between surfel discs); a random subset has both.
    assert even.std() / even.mean() < 0.65 * (clumped.std() / clumped.mean())
    probes = np.column_stack([rng.uniform(0.01, 0.11, size=(4000, 2)), np.zeros(4000)])
    hole_even = np.quantile(_nearest_gaps_to(pts[keep], probes), 0.995)
    hole_random = np.quantile(_nearest_gaps_to(pts[random], probes), 0.995)
    assert hole_even < 0.7 * hole_random
    # Another grid shift is another even subset; no count asks for more than there is.
    other = S.thin_points(pts, 2000, np.random.default_rng(1))
    assert abs(len(other) - 2000) <= 20 and not np.array_equal(other, keep)
    assert np.array_equal(S.thin_points(pts, 10 ** 6), np.arange(len(pts)))


def test_thin_points_rejects_bad_input():
    with pytest.raises(InputError, match="shape"):
        S.thin_points(np.zeros((5, 2)), 3)
    with pytest.raises(InputError, match="NaN"):
        S.thin_points(np.array([[0, 0, np.nan]] * 4), 2)
    with pytest.raises(InputError, match="count"):
        S.thin_points(np.zeros((5, 3)), 0)
