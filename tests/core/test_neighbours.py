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


def tied_grid():
    """A regular 180 x 120 x 3 grid (64,800 points): every point has many neighbours at
    exactly the same distance, so which of them a query keeps is up to the tie rule; large
    enough that the tree's subtrees are built on separate workers."""
    i, j, l = np.meshgrid(np.arange(180), np.arange(120), np.arange(3))
    return np.column_stack([0.5 * i.ravel(), 0.5 * j.ravel(), l.ravel()]).astype(float)


def test_knn_takes_the_lower_index_among_ties_whatever_the_tree():
    """Among equidistant points the lower index is kept: each query's k smallest (distance,
    index) pairs, as a brute force sorts them, whatever the tree's shape (built on one worker
    or two) and the C++ library's nth_element; so a search for fewer neighbours finds the
    first columns of a search for more, and one table serves consumers of several widths."""
    g = tied_grid()
    one, d_one = knn(g, g, 19, threads=1)
    two, d_two = knn(g, g, 19, threads=2)
    assert np.array_equal(one, two) and np.array_equal(d_one, d_two)
    # Ties are decisive here: the 19th and 20th nearest are equidistant for most points.
    wide, d_wide = knn(g, g, 21, threads=2)
    assert (d_wide[:, 18] == d_wide[:, 19]).mean() > 0.5
    assert np.array_equal(wide[:, :19], one) and np.array_equal(d_wide[:, :19], d_one)
    rows = np.random.default_rng(1).choice(len(g), 300, replace=False)
    d2 = ((g[rows][:, None, :] - g[None, :, :]) ** 2).sum(axis=2)
    want = np.argsort(d2, axis=1, kind="stable")[:, :19]    # stable: equal ones by index
    np.testing.assert_array_equal(one[rows], want)
    # queries that are not the points themselves (the Morton-ordered path) keep the same rule
    q = g[rows] + 0.25
    got, _ = knn(g, q, 19)
    d2 = ((q[:, None, :] - g[None, :, :]) ** 2).sum(axis=2)
    np.testing.assert_array_equal(got, np.argsort(d2, axis=1, kind="stable")[:, :19])
