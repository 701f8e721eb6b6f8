"""Lamp shadows shared between a dense scan's points (illumap.shared_shadows): the probe is
cast at sentinels, and a point whose sentinels all agree that the lamp is wholly in view or
wholly hidden takes that answer. Here the probe is a known function of the point, so what
sharing makes of it can be checked exactly: every point gets the value its own probe gives,
across a shadow's edge and in a penumbra, a shadow between sentinels is the documented
limit, receivers of another group or of none probe themselves, and most points cast
nothing."""

import numpy as np

from illumap.shared_shadows import MIN_SHARED_POINTS, SENTINEL_SPACING, shared_probe


def floor(spacing=0.01, size=1.0):
    """A square floor of points on a grid (m)."""
    g = np.arange(0.0, size, spacing)
    x, y = np.meshgrid(g, g, indexing="ij")
    return np.c_[x.ravel(), y.ravel(), np.zeros(x.size)]


class Probe:
    """A probe that answers ``visible(points)`` and counts the receivers it was cast at."""

    def __init__(self, points, visible):
        self.points, self.visible = points, visible
        self.cast = np.zeros(len(points), dtype=int)

    def __call__(self, rows):
        self.cast[rows] += 1
        return self.visible(self.points[rows])


def test_every_point_gets_its_own_probe_across_an_edge_and_a_penumbra():
    p = floor()
    # wholly lit for x < 0.4, a penumbra ramp to 0.6, wholly hidden beyond
    visible = lambda q: np.clip((0.6 - q[:, 0]) / 0.2, 0.0, 1.0)  # noqa: E731
    probe = Probe(p, visible)
    rows = np.arange(len(p))
    got = shared_probe(probe, p, np.zeros(len(p), dtype=np.int64), rows)
    np.testing.assert_array_equal(got, visible(p))
    # Sentinels about every 4th point each way, plus the penumbra and its fringe: far fewer
    # probes than points.
    assert probe.cast.max() <= 2
    assert probe.cast.astype(bool).sum() < 0.45 * len(p)


def test_a_sharp_edge_wider_than_the_sentinels_is_kept():
    p = floor()
    visible = lambda q: (q[:, 0] + 0.3 * q[:, 1] < 0.55).astype(float)  # noqa: E731
    got = shared_probe(Probe(p, visible), p, np.zeros(len(p), dtype=np.int64),
                       np.arange(len(p)))
    np.testing.assert_array_equal(got, visible(p))


def test_a_shadow_between_sentinels_is_the_documented_limit():
    # A shadow one point wide can fall between sentinels (SENTINEL_SPACING points apart)
    # and be missed there; wherever it meets a sentinel, its points probe themselves.
    p = floor()
    spacing = 0.01
    visible = lambda q: (np.abs(q[:, 0] - 0.503) > 0.4 * spacing).astype(float)  # noqa: E731
    got = shared_probe(Probe(p, visible), p, np.zeros(len(p), dtype=np.int64),
                       np.arange(len(p)))
    want = visible(p)
    assert SENTINEL_SPACING > 1
    assert ((got == want) | (want == 0)).all()      # only the thin shadow may be missed


def test_other_groups_and_small_groups_probe_themselves():
    p = floor()
    visible = lambda q: (q[:, 1] < 0.5).astype(float)  # noqa: E731
    groups = np.zeros(len(p), dtype=np.int64)
    groups[: len(p) // 10] = -1                         # receivers that share nothing
    small = np.arange(len(p) // 10, len(p) // 10 + MIN_SHARED_POINTS // 2)
    groups[small] = 7                                   # a group too small to share
    probe = Probe(p, visible)
    rows = np.arange(len(p))
    got = shared_probe(probe, p, groups, rows)
    np.testing.assert_array_equal(got, visible(p))
    assert (probe.cast[groups == -1] == 1).all()
    assert (probe.cast[small] == 1).all()


def test_a_subset_of_rows_is_answered_in_its_order():
    p = floor()
    visible = lambda q: (q[:, 0] > 0.25).astype(float)  # noqa: E731
    rows = np.random.default_rng(3).permutation(len(p))[: len(p) // 2]
    got = shared_probe(Probe(p, visible), p, np.zeros(len(p), dtype=np.int64), rows)
    np.testing.assert_array_equal(got, visible(p[rows]))


def test_first_in_each_cell_is_numpys_unique_rows():
    from illumap.grid_cells import first_in_each_cell
    rng = np.random.default_rng(5)
    for key in (rng.integers(0, 7, (5000, 4)), rng.integers(0, 2 ** 40, (300, 3)),
                np.zeros((0, 3), dtype=np.int64)):
        _, first = np.unique(key, axis=0, return_index=True)
        np.testing.assert_array_equal(first_in_each_cell(key), np.sort(first))
