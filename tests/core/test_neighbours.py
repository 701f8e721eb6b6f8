"""illumap.neighbours.knn against a brute force, and its refusals."""

import numpy as np
import pytest

from illumap import InputError
from illumap.neighbours import knn


def test_knn_is_the_brute_force():
    rng = np.random.default_rng(3)
    points, queries = rng.random((500, 3)), rng.random((40, 3))
    idx, dist = knn(points, queries, 7)
    d = np.linalg.norm(queries[:, None] - points[None], axis=2)
    np.testing.assert_allclose(dist, np.sort(d, axis=1)[:, :7], rtol=1e-12)
    np.testing.assert_allclose(np.take_along_axis(d, idx, axis=1), dist, rtol=1e-12)
    assert idx.dtype == np.int64 and dist.dtype == np.float64


def test_knn_finds_a_coincident_point_and_clamps_k():
    points = np.eye(3)
    idx, dist = knn(points, points[1:2], 10)
    assert idx.shape == (1, 3) and idx[0, 0] == 1 and dist[0, 0] == 0.0
    assert knn(points, np.empty((0, 3)), 2)[0].shape == (0, 2)


@pytest.mark.parametrize("points, queries, k, words", [
    (np.zeros((0, 3)), np.zeros((1, 3)), 1, "at least one point"),
    (np.zeros((4, 2)), np.zeros((1, 3)), 1, "points must be an (N, 3) array"),
    (np.zeros((4, 3)), np.array([[0.0, np.nan, 0.0]]), 1, "queries[0] is not finite"),
    (np.zeros((4, 3)), np.zeros((1, 3)), 0, "k >= 1"),
])
def test_knn_refuses_what_it_cannot_search(points, queries, k, words):
    with pytest.raises(InputError) as caught:
        knn(points, queries, k)
    assert words in str(caught.value)
