"""Stable identities (``illumap.identities``): what samples and rays follow from, the same
whatever order Blender keeps faces and loops in (tests/blender/light/test_determinism.py runs them
through the add-on)."""

import numpy as np

from illumap.identities import canonical_triangles, combined_ids, corner_ids, object_ids, object_rng


def test_canonical_triangles_follow_the_vertices():
    tri = np.array([[5, 2, 9], [1, 2, 3], [9, 5, 2], [3, 4, 1]])
    order, turn = canonical_triangles(tri)
    turned = np.take_along_axis(tri, turn, axis=1)[order]
    # each starts at its lowest vertex, winding kept; sorted by vertex set
    assert turned.tolist() == [[1, 2, 3], [1, 3, 4], [2, 9, 5], [2, 9, 5]]
    rng = np.random.default_rng(0)
    shuffled = tri[rng.permutation(4)]
    shuffled = np.array([np.roll(t, s) for t, s in zip(shuffled, [1, 2, 0, 1])])
    order2, turn2 = canonical_triangles(shuffled)
    assert np.array_equal(np.take_along_axis(shuffled, turn2, axis=1)[order2], turned)


def test_corner_ids_name_one_corner_each():
    vertex = np.repeat(np.arange(1000), 4)
    following = np.tile(np.arange(4), 1000) + 1000
    ids = corner_ids(vertex, following)
    assert len(np.unique(ids)) == len(ids)
    assert ids.min() >= 0 and ids.max() < 2 ** 40
    assert np.array_equal(ids, corner_ids(vertex.copy(), following.copy()))
    assert corner_ids(np.array([3]), np.array([4]))[0] != corner_ids(np.array([4]), np.array([3]))[0]
    # With both neighbours, on a grid of quads: one identity per corner, and a face's reversed
    # winding (a mirror applied) keeps each.
    n = 30
    k = lambda i, j: i * (n + 1) + j  # noqa: E731
    faces = np.array([[k(i, j), k(i + 1, j), k(i + 1, j + 1), k(i, j + 1)]
                      for i in range(n) for j in range(n)])
    here, after, before = faces.ravel(), np.roll(faces, -1, 1).ravel(), np.roll(faces, 1, 1).ravel()
    ids = corner_ids(here, after, before)
    assert len(np.unique(ids)) == len(ids)
    assert np.array_equal(ids, corner_ids(here, before, after))


def test_object_identities_follow_the_name_and_the_row_alone():
    rows = np.arange(1000)
    a = object_ids("Floor", rows)
    assert len(np.unique(a)) == len(a) and a.min() >= 0 and a.max() < 2 ** 40
    assert np.array_equal(a[500:], object_ids("Floor", rows[500:]))   # not the row's place
    assert not np.intersect1d(a, object_ids("Wall", rows)).size
    assert np.array_equal(combined_ids(a[:10], np.arange(10)), combined_ids(a[:10], np.arange(10)))
    assert len(np.unique(combined_ids(np.repeat(a[:10], 10), np.tile(np.arange(10), 10)))) == 100


def test_an_objects_random_stream_is_its_own():
    assert np.array_equal(object_rng(3, "Sphere").random(5), object_rng(3, "Sphere").random(5))
    assert not np.array_equal(object_rng(3, "Sphere").random(5), object_rng(3, "Box").random(5))
    assert not np.array_equal(object_rng(3, "Sphere").random(5), object_rng(4, "Sphere").random(5))
    assert not np.array_equal(object_rng(3, "Sphere", 1).random(5), object_rng(3, "Sphere").random(5))
