"""The irradiance cache (illumap.irradiance_cache): a dense set of receivers gathers in full
only at records, and every other receiver takes what the valid records say. Here the gather
is a known field, so what the cache makes of it can be checked exactly: records keep their
own values, a sloping field is followed to first order, light does not spill across a change
in the surroundings (the ceiling behind an emitter hung just under it), a record serves only
its own group, and the cache gathers far fewer points than there are."""

import numpy as np
import pytest

import illumap
from illumap.irradiance_cache import DEFAULT_ACCURACY, PROBE_RAYS, cached_gather
from illumap.receivers import GatherResult


def floor(spacing=0.01, size=1.0):
    """A square floor of points on a grid, facing up."""
    g = np.arange(0.0, size, spacing)
    x, y = np.meshgrid(g, g, indexing="ij")
    p = np.c_[x.ravel(), y.ravel(), np.zeros(x.size)]
    return p, np.tile([0.0, 0.0, 1.0], (len(p), 1))


class Field:
    """gather_rows over a known field: value(points) (R, 3) and reach(points) (R,) m; counts
    the rows it was asked for at full rays."""

    def __init__(self, points, value, reach, rays=512):
        self.points, self.value, self.reach, self.rays = points, value, reach, rays
        self.full = np.zeros(len(points), dtype=int)

    def __call__(self, rows, rays=None):
        q = self.points[rows]
        if rays is None:
            self.full[rows] += 1
        k = self.rays if rays is None else rays
        return GatherResult(radiance=self.value(q), stderr=np.full(len(rows), 1e-3),
                            rays=len(rows) * k, reach=self.reach(q), open=0.5 * q[:, 0],
                            halves=0.01 * q[:, 1])


def test_records_keep_their_values_and_a_slope_is_followed():
    p, n = floor()
    slope = lambda q: np.c_[1.0 + 0.5 * q[:, 0], 1.0 + 0.2 * q[:, 1], np.full(len(q), 0.7)]
    field = Field(p, slope, lambda q: np.full(len(q), 2.0))
    got = cached_gather(field, p, n, max_reach=2.0)
    rec = got.records
    assert 0 < rec.sum() < 0.1 * len(p)                 # a tenth at most gathered in full
    assert (field.full[rec] == 1).all() and (field.full[~rec] == 0).all()
    want = slope(p)
    np.testing.assert_array_equal(got.radiance[rec], want[rec])
    # Inside the records' hull the fitted plane is exact; at the rim, where it would
    # extrapolate, it stays within the records' range.
    inner = np.all((p[:, :2] > 0.15) & (p[:, :2] < 0.85), axis=1)
    np.testing.assert_allclose(got.radiance[inner], want[inner], atol=1e-9)
    assert np.abs(got.radiance - want).max() < 0.05
    assert got.rays == rec.sum() * 512 + len(p) * PROBE_RAYS
    # the share of rays that leave: the records' own, a weighted mean of theirs elsewhere
    np.testing.assert_array_equal(got.open[rec], 0.5 * p[rec, 0])
    assert np.abs(got.open - 0.5 * p[:, 0]).max() < 0.1
    # the lattice halves likewise (the gather's error where the receiver takes the records')
    np.testing.assert_array_equal(got.halves[rec], 0.01 * p[rec, 1])
    assert np.abs(got.halves - 0.01 * p[:, 1]).max() < 0.002


def test_light_does_not_spill_where_the_surroundings_change_close_by():
    """A panel hung just under part of the ceiling: there every ray meets it within a
    millimetre and sees black; around it the ceiling is lit and its rays reach far."""
    p, n = floor()
    n = -n
    under = lambda q: (q[:, 0] > 0.3) & (q[:, 0] < 0.6) & (q[:, 1] > 0.3) & (q[:, 1] < 0.6)
    field = Field(p, lambda q: np.where(under(q)[:, None], 0.0, 1.0) * np.ones((len(q), 3)),
                  lambda q: np.where(under(q), 1e-3, 2.0))
    got = cached_gather(field, p, n, max_reach=2.0)
    hidden = under(p)
    assert (got.radiance[hidden] == 0).all()
    assert (got.radiance[~hidden] == 1).all()
    assert got.records[hidden].all()       # each point under the panel gathers itself
    assert got.records[~hidden].mean() < 0.2


def test_records_serve_their_own_group_and_minus_one_gathers_itself():
    p, n = floor(0.02)
    group = (np.arange(len(p)) % 3).astype(np.int64) - 1       # -1, 0, 1 interleaved
    field = Field(p, lambda q: np.ones((len(q), 3)), lambda q: np.full(len(q), 2.0))
    value = np.where(group[:, None] == 0, 2.0, 5.0) * np.ones((len(p), 3))
    field.value = lambda q: _lookup(p, value, q)
    got = cached_gather(field, p, n, max_reach=2.0, groups=group)
    assert got.records[group == -1].all()
    np.testing.assert_array_equal(got.radiance, value)
    assert got.records[group >= 0].mean() < 0.5


def _lookup(p, value, q):
    from illumap import _core
    idx, _ = _core.knn(p, np.ascontiguousarray(q), 1)
    return value[np.asarray(idx)[:, 0]]


def test_a_finer_accuracy_places_more_records_errs_less_and_repeats():
    p, n = floor()
    wave = lambda q: np.c_[1.0 + 0.3 * np.sin(6 * q[:, 0]), np.ones(len(q)), np.ones(len(q))]
    counts, errors = [], []
    for a in (0.3, DEFAULT_ACCURACY, 0.05):
        field = Field(p, wave, lambda q: np.full(len(q), 1.0))
        first = cached_gather(field, p, n, max_reach=1.0, accuracy=a)
        again = cached_gather(field, p, n, max_reach=1.0, accuracy=a)
        np.testing.assert_array_equal(first.radiance, again.radiance)
        counts.append(first.records.sum())
        errors.append(np.sqrt(((first.radiance - wave(p)) ** 2).mean()))
    assert counts[0] < counts[1] < counts[2] < len(p) / 4, counts
    assert errors[0] > errors[1] > errors[2], errors
    assert errors[1] < 0.01, errors


def test_bad_arguments_are_refused():
    p, n = floor(0.1)
    field = Field(p, lambda q: np.ones((len(q), 3)), lambda q: np.ones(len(q)))
    with pytest.raises(illumap.InputError, match="accuracy"):
        cached_gather(field, p, n, max_reach=1.0, accuracy=0.0)
    with pytest.raises(illumap.InputError, match="max_reach"):
        cached_gather(field, p, n, max_reach=np.inf)
    with pytest.raises(illumap.InputError, match="groups must have"):
        cached_gather(field, p, n, max_reach=1.0, groups=np.zeros(3))
    with pytest.raises(illumap.InputError, match=r"shape \(M, 3\)"):
        cached_gather(field, p[:, :2], n, max_reach=1.0)


def cache_case(seed=5, m=3000, K=16):
    """Receivers and records on a bumpy floor with a wall, the records' reach and values
    varied, each receiver's K nearest records (as ``cached_gather`` finds them)."""
    from illumap import _core
    rng = np.random.default_rng(seed)
    floor = np.c_[rng.uniform(0, 2, (m, 2)), 0.02 * np.sin(6 * rng.uniform(0, 2, m))]
    wall = np.c_[rng.uniform(0, 2, m // 3), np.zeros(m // 3), rng.uniform(0, 1, m // 3)]
    p = np.concatenate([floor, wall])
    n = np.concatenate([np.tile([0.0, 0, 1], (m, 1)), np.tile([0.0, 1, 0], (m // 3, 1))])
    n += rng.normal(0, 0.05, n.shape)
    n /= np.linalg.norm(n, axis=1, keepdims=True)
    reach = rng.uniform(0.2, 2.0, len(p))
    own = rng.uniform(0.2, 2.0, len(p))
    values = np.c_[1 + p[:, 0], 0.5 + p[:, 1] ** 2, rng.uniform(0.2, 0.3, len(p))]
    records = rng.choice(len(p), len(p) // 6, replace=False)
    rows = np.setdiff1d(np.arange(len(p)), records)
    near, dist = _core.knn(np.ascontiguousarray(p[records]), np.ascontiguousarray(p[rows]), K)
    return p, n, reach, own, values, rows, records[np.asarray(near)], np.asarray(dist)


def test_native_record_lookup_is_the_brute_force_search_and_the_numpy_formulas():
    """The search and the weights in one native pass (``_core.record_lookup``) against a
    brute-force search and the formulas in numpy, with and without a floor on the reach."""
    from illumap import _core
    import numpy_reference as ref
    from illumap.irradiance_cache import BEHIND_SLACK, NEAR_RECORD_FLOORS
    k = 16
    p, n, reach, own, _, rows, near, _ = cache_case(K=k)
    records = np.unique(near)
    raw = np.random.default_rng(5).uniform(0.05, 0.6, len(p))
    for a, floor in ((0.05, 0.0), (0.15, 0.0), (0.5, 0.0), (0.5, 0.2)):
        far = NEAR_RECORD_FLOORS * floor
        got_near, got_w, got_count = _core.record_lookup(
            p, n, reach, own, raw, records, rows, k, accuracy=a, behind_slack=BEHIND_SLACK,
            min_reach=floor, far_reach=far)
        want_near, want_w, want_count = ref.record_lookup(
            p, n, reach, own, raw, records, rows, k, a, BEHIND_SLACK, floor, far)
        np.testing.assert_array_equal(got_near, want_near)
        np.testing.assert_array_equal(got_count, want_count)
        np.testing.assert_allclose(got_w, want_w, rtol=1e-9, atol=1e-12 / a)
        counts, = _core.record_lookup(p, n, reach, own, raw, records, rows, k, accuracy=a,
                                      behind_slack=BEHIND_SLACK, min_reach=floor,
                                      far_reach=far, counts_only=True)
        np.testing.assert_array_equal(counts, want_count)
        if a == 0.5:
            share = want_count.sum() / want_count.size / k
            assert 0.05 < share < 0.95                  # both valid and invalid records occur
    # the floor left out records that its absence kept
    assert ref.record_lookup(p, n, reach, own, raw, records, rows, k, 0.5, BEHIND_SLACK)[2].sum() > \
        ref.record_lookup(p, n, reach, own, raw, records, rows, k, 0.5, BEHIND_SLACK, 0.2, 0.4)[2].sum()
    with pytest.raises(ValueError, match="out of range"):
        _core.record_lookup(p, n, reach, own, raw, records + len(p), rows, k, accuracy=0.5,
                            behind_slack=BEHIND_SLACK)
    with pytest.raises(ValueError, match="k must be"):
        _core.record_lookup(p, n, reach, own, raw, records[:3], rows, k, accuracy=0.5,
                            behind_slack=BEHIND_SLACK)


def test_native_fitted_values_are_the_numpy_formulas():
    from illumap import _core
    import numpy_reference as ref
    from illumap.irradiance_cache import BEHIND_SLACK
    p, n, reach, own, values, rows, near, dist = cache_case()
    w, _ = ref.record_weights(p, n, reach, own, rows, near, dist, 0.5, BEHIND_SLACK)
    keep = w.sum(axis=1) > 0
    rows, near, w = rows[keep], near[keep], w[keep]
    w[::7, 1:], w[::7, 0] = 0.0, 1.0                 # some with too few records: their mean
    got = _core.fitted_values(p, n, values, rows, near, w)
    want = ref.fitted_values(p, n, values, rows, near, w)
    np.testing.assert_allclose(got, want, rtol=1e-9, atol=1e-12)
    with pytest.raises(ValueError, match="positive weight"):
        _core.fitted_values(p, n, values, rows, near, np.zeros_like(w))
    with pytest.raises(ValueError, match="out of range"):
        _core.fitted_values(p, n, values, rows, near + len(p), w)


def test_a_floor_on_the_reach_bounds_the_records_as_the_points_grow_denser():
    """Beside a crease (a wall along x = 0) every point's surroundings are as near as the
    wall: without a floor the records crowd towards it as densely as the points allow, with
    one (``min_reach``) their number stops growing with the points' density, and the smooth
    light is still followed."""
    light = lambda q: np.c_[0.5 + q[:, 0], 0.5 + 0.5 * q[:, 0], np.full(len(q), 0.3)]
    crease = lambda q: 2.0 * np.maximum(q[:, 0], 1e-4)
    counts = {}
    for floor_m in (0.0, 0.2):
        for spacing in (0.01, 0.005):
            p, n = floor(spacing)
            got = cached_gather(Field(p, light, crease), p, n, max_reach=2.0, min_reach=floor_m)
            counts[floor_m, spacing] = int(got.records.sum())
            # first order: off by at most the slope (1 per m) times a record's domain
            # (a × the floor, 0.03 m), and only where the records do not span the plane
            err = np.abs(got.radiance - light(p)).max(axis=1)
            assert err.max() < DEFAULT_ACCURACY * 0.2 and err.mean() < 1e-3, (err.max(), err.mean())
    assert counts[0.0, 0.005] > 1.5 * counts[0.0, 0.01], counts      # the crease's records
    assert counts[0.2, 0.005] < 1.15 * counts[0.2, 0.01], counts     # bounded by the floor
    assert counts[0.2, 0.005] < 0.5 * counts[0.0, 0.005], counts


def test_a_floor_still_keeps_light_from_spilling_under_a_panel():
    """The panel hung 1 mm under the ceiling again, with a floor on the reach 200 times the
    panel's gap and wider than the records' domains: the points under it take only records
    whose own surroundings are as near (``NEAR_RECORD_FLOORS``), never the lit ceiling's."""
    p, n = floor()
    n = -n
    under = lambda q: (q[:, 0] > 0.3) & (q[:, 0] < 0.6) & (q[:, 1] > 0.3) & (q[:, 1] < 0.6)
    field = Field(p, lambda q: np.where(under(q)[:, None], 0.0, 1.0) * np.ones((len(q), 3)),
                  lambda q: np.where(under(q), 1e-3, 2.0))
    got = cached_gather(field, p, n, max_reach=2.0, min_reach=0.2)
    hidden = under(p)
    assert (got.radiance[hidden] == 0).all()
    assert (got.radiance[~hidden] == 1).all()
    assert got.records[hidden].mean() < 0.8          # they share records among themselves now
    with pytest.raises(illumap.InputError, match="min_reach"):
        cached_gather(field, p, n, max_reach=2.0, min_reach=-1.0)


def test_receivers_weighed_in_chunks_take_the_same_values(monkeypatch):
    """The records are weighed a chunk of receivers at a time, for bounded memory: any chunk
    size gives the same bits."""
    import illumap.irradiance_cache as ic
    p, n = floor(0.02)
    wave = lambda q: np.c_[1.0 + 0.3 * np.sin(6 * q[:, 0]), np.ones(len(q)), 0.5 + q[:, 1]]
    crease = lambda q: 2.0 * np.maximum(q[:, 0], 1e-4)
    whole = cached_gather(Field(p, wave, crease), p, n, max_reach=2.0, min_reach=0.1)
    monkeypatch.setattr(ic, "_CHUNK", 97)
    pieces = cached_gather(Field(p, wave, crease), p, n, max_reach=2.0, min_reach=0.1)
    for name in ("radiance", "stderr", "records", "open", "halves"):
        np.testing.assert_array_equal(getattr(whole, name), getattr(pieces, name))
    assert whole.rays == pieces.rays


def test_progress_is_reported_between_chunks_and_a_cancel_stops_the_cache(monkeypatch):
    """Between its gathers and between chunks of the receivers it weighs, the cache reports
    non-decreasing fractions in [0, 1]; a callback that returns False there stops it with
    illumap.Cancelled before another gather is asked for."""
    import illumap.irradiance_cache as ic
    p, n = floor(0.02)
    monkeypatch.setattr(ic, "_CHUNK", 300)
    wave = lambda q: np.c_[1.0 + 0.3 * np.sin(6 * q[:, 0]), np.ones(len(q)), 0.5 + q[:, 1]]
    seen = []
    cached_gather(Field(p, wave, lambda q: np.full(len(q), 2.0)), p, n, max_reach=2.0,
                  progress=lambda f, phase: seen.append((f, phase)))
    fractions = [f for f, _ in seen]
    assert len(seen) > len(p) // 300 and {ph for _, ph in seen} == {ic.PHASE}
    assert fractions == sorted(fractions) and 0.0 <= fractions[0] and fractions[-1] <= 1.0

    calls = []
    field = Field(p, wave, lambda q: np.full(len(q), 2.0))
    with pytest.raises(illumap.Cancelled):
        cached_gather(field, p, n, max_reach=2.0,
                      progress=lambda f, phase: calls.append(f) or len(calls) < 3)
    assert len(calls) == 3 and field.full.sum() <= len(p) // 10


def test_with_a_floor_the_probe_is_shared_through_sentinels_and_the_panel_still_probes():
    """With a floor on the reach, receivers amid sentinels that all reach the floor take the
    least of their reaches instead of probing (``PROBE_SENTINEL_SPACING``): far fewer probe
    rays than points, while every point under the panel (surroundings 1 mm away) still
    probes itself and takes no lit record."""
    from illumap.irradiance_cache import PROBE_SENTINEL_SPACING
    p, n = floor()
    n = -n
    under = lambda q: (q[:, 0] > 0.3) & (q[:, 0] < 0.6) & (q[:, 1] > 0.3) & (q[:, 1] < 0.6)
    probed = np.zeros(len(p), dtype=int)

    class Counting(Field):
        def __call__(self, rows, rays=None):
            if rays is not None:
                probed[rows] += 1
            return super().__call__(rows, rays)

    field = Counting(p, lambda q: np.where(under(q)[:, None], 0.0, 1.0) * np.ones((len(q), 3)),
                     lambda q: np.where(under(q), 1e-3, 2.0))
    got = cached_gather(field, p, n, max_reach=2.0, min_reach=0.2)
    hidden = under(p)
    assert (probed[hidden] == 1).all()
    assert probed.max() == 1
    assert probed.sum() < len(p) * (hidden.mean() + 4.0 / PROBE_SENTINEL_SPACING ** 2)
    assert (got.radiance[hidden] == 0).all()
    assert (got.radiance[~hidden] == 1).all()


def test_the_spacing_from_the_isolation_search_is_the_search_of_all_shared_receivers():
    """``_spacing`` takes each receiver's nearest from ``_isolated``'s search where they are
    one group: the median nearest-other distance over all receivers that share records, as
    one search of them finds it; with several groups, or a stray point set apart (which its
    group's search counted), it searches them all again."""
    from illumap import _core
    from illumap.irradiance_cache import _isolated, _spacing
    rng = np.random.default_rng(11)
    scan = np.c_[rng.uniform(0, 1, (4000, 2)), np.zeros(4000)]
    panel = np.c_[rng.uniform(0.4, 0.5, (300, 2)), np.full(300, 1e-3)]   # close above it
    tiny = np.c_[rng.uniform(0, 1, (5, 2)), np.ones(5)]                   # too few to tell
    for stray, apart in ((False, 1), (True, 1), (False, 0), (True, 0)):
        p = np.concatenate([scan, panel, tiny] + ([[[0.5, 0.5, 40.0]]] if stray else []))
        group = np.r_[np.zeros(4000), np.full(300, apart), np.full(5, 2), [0] if stray else []]
        group = group.astype(np.int64)
        group[7] = -1
        isolated, nearest = _isolated(p, group)
        assert isolated[4300:4305].all() and isolated.sum() == 5 + stray
        shared = np.flatnonzero(np.where(isolated, -1, group) >= 0)
        q = np.ascontiguousarray(p[shared])
        d = np.asarray(_core.knn(q, q, 2)[1])[:, 1]
        want = float(np.median(d[d > 0]))
        assert _spacing(p, np.where(isolated, -1, group), isolated, nearest) == want


def test_one_record_per_cell_is_the_one_nearest_its_centre_per_group():
    """``_one_per_cell`` (one packed sort key) against the six-key sort it replaces."""
    from illumap.irradiance_cache import _one_per_cell
    rng = np.random.default_rng(4)
    p = rng.uniform(0, 3, (20000, 3))
    group = rng.integers(0, 3, len(p))
    rows = np.sort(rng.choice(len(p), 15000, replace=False))
    origin = p.min(axis=0)
    for cell in (0.1, 0.7):
        scaled = (p[rows] - origin) / cell
        key = np.floor(scaled).astype(np.int64)
        off = np.linalg.norm(scaled - key - 0.5, axis=1)
        order = np.lexsort((rows, off, key[:, 2], key[:, 1], key[:, 0], group[rows]))
        k = np.column_stack([group[rows], key])[order]
        first = np.r_[True, (k[1:] != k[:-1]).any(axis=1)]
        want = np.sort(rows[order[first]])
        np.testing.assert_array_equal(_one_per_cell(p, rows, group, cell, origin), want)
