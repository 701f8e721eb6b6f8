"""The gather's lattice counts each direction once (``illumap.gather.lattice``): where the sky
is cast afresh at a lattice point, the surfels' indirect light there is rescaled to the share
of the hemisphere the sky leaves, so a white furnace's point reads at most its albedo.

In a furnace a surfel that sees the sky over a share v of its hemisphere and surfaces of
radiance L elsewhere reflects ρ v (direct) plus ρ (1 − v) L (indirect); a lattice point that
sees share w ≥ v must read ρ w + ρ (1 − w) L, never more than ρ when L ≤ 1. The identity is
exact (rounding only) wherever the surfels' hidden share is above ``MIN_HIDDEN_SHARE``; where
w < v the surfels' indirect light is kept as it is (``MAX_REST_SCALE``).
"""

import numpy as np

from illumap.gather.lattice import MAX_REST_SCALE, MIN_HIDDEN_SHARE, rest_for_sky_seen


def _furnace(rng, n=2000):
    white = np.ones(3)
    rho = rng.uniform(0.5, 0.999, (n, 1)) * np.ones((1, 3))
    v_surfels = rng.uniform(0.0, 1.0 - MIN_HIDDEN_SHARE, (n, 1)) * np.ones((1, 3))
    v_point = v_surfels + rng.uniform(0.0, 1.0, (n, 1)) * (1.0 - v_surfels)
    radiance = rng.uniform(0.0, 1.0, (n, 1)) * np.ones((1, 3))
    return white, rho, v_surfels, v_point, radiance


def test_a_lattice_point_reads_its_own_share_of_sky():
    white, rho, v_s, v_p, L = _furnace(np.random.default_rng(1))
    rest = rho * (1.0 - v_s) * L
    value = rho * v_p + rest + rest_for_sky_seen(white, v_p * white, rho * v_s * white, rho, rest)
    np.testing.assert_allclose(value, rho * (v_p + (1.0 - v_p) * L), rtol=0, atol=1e-12)
    assert np.all(value <= rho + 1e-12)


def test_without_the_rescale_a_rim_point_reads_above_its_albedo():
    """What the rescale fixes: the sky cast afresh on top of the surfels' own indirect light
    reads above ρ where the point sees more sky than the surfels (L = 1: a furnace)."""
    rho, v_s, v_p = 0.999, 0.6, 0.9
    naive = rho * v_p + rho * (1.0 - v_s) * 1.0
    assert naive > rho
    rest = np.full((1, 3), rho * (1.0 - v_s))
    fixed = rho * v_p + rest + rest_for_sky_seen(np.ones(3), np.full((1, 3), v_p),
                                                 np.full((1, 3), rho * v_s),
                                                 np.full((1, 3), rho), rest)
    np.testing.assert_allclose(fixed, rho, atol=1e-12)


def test_a_black_sky_or_black_surfels_change_nothing_they_cannot():
    rest = np.full((2, 3), 0.3)
    out = rest_for_sky_seen(np.zeros(3), np.zeros((2, 3)), np.zeros((2, 3)),
                            np.full((2, 3), 0.8), rest)
    np.testing.assert_allclose(out, 0.0)          # no sky: nothing seen, nothing rescaled
    out = rest_for_sky_seen(np.ones(3), np.full((2, 3), 0.5), np.zeros((2, 3)),
                            np.zeros((2, 3)), np.zeros((2, 3)))
    np.testing.assert_allclose(out, 0.0)          # black surfels: no indirect light to scale


def test_the_rescale_never_raises_the_light():
    """A point that sees less sky than its surfels keeps their indirect light: raising it
    amplified the solve's noise where the surfels' hidden share is small."""
    assert MAX_REST_SCALE <= 1.0
    white, rho, v_s, _, L = _furnace(np.random.default_rng(2))
    v_p = v_s * np.random.default_rng(3).uniform(0.0, 1.0, v_s.shape)
    rest = rho * (1.0 - v_s) * L
    out = rest_for_sky_seen(white, v_p * white, rho * v_s * white, rho, rest)
    assert np.all(out <= 1e-15)
    assert np.all(rest + out >= -1e-15)
