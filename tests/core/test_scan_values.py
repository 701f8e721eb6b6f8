"""Values at scan points: isolated specks replaced, shadow edges and gradients kept
(``remove_specks``); the outside of each smooth patch chosen as a whole (``brighter_sides``)."""

import numpy as np
import pytest

import illumap
from illumap.receivers import brighter_sides, remove_specks

pytestmark = pytest.mark.skipif(not illumap.native_available(), reason="needs the native core")


def jittered_plane(n=40, seed=0):
    rng = np.random.default_rng(seed)
    u = (np.stack(np.meshgrid(np.arange(n), np.arange(n)), -1).reshape(-1, 2) + 0.5
         + 0.3 * (rng.random((n * n, 2)) - 0.5)) / n
    return np.column_stack([u, np.zeros(len(u))]), np.tile([0.0, 0.0, 1.0], (len(u), 1))


def test_isolated_specks_take_their_neighbours_light():
    pts, nrm = jittered_plane()
    light = 0.4 + 0.4 * pts[:, :1] * np.ones((1, 3))        # a smooth gradient along x
    values = light.copy()
    dark, bright = [100, 700, 1234], [333, 901]
    values[dark] = 0.02
    values[bright] = 3.0
    out, replaced = remove_specks(pts, nrm, values)
    assert replaced == 5
    np.testing.assert_allclose(out[dark + bright], light[dark + bright], atol=0.03)
    keep = np.setdiff1d(np.arange(len(pts)), dark + bright)
    np.testing.assert_array_equal(out[keep], values[keep])


def test_shadow_edges_and_extremes_are_kept():
    """A hard shadow edge across the plane and a bright spot with a smooth peak: no point of
    either is a speck."""
    pts, nrm = jittered_plane(seed=1)
    edge = np.where(pts[:, :1] < 0.5, 0.05, 0.8) * np.ones((1, 3))
    peak = (0.2 + np.exp(-((pts[:, :2] - 0.5) ** 2).sum(1) / 0.02))[:, None] * np.ones((1, 3))
    for values in (edge, peak):
        out, replaced = remove_specks(pts, nrm, values)
        assert replaced == 0
        np.testing.assert_array_equal(out, values)


def test_a_lone_corner_point_is_judged_by_its_own_surface_only():
    """Neighbours across a crease (a wall meeting the floor) are another surface: a dark floor
    row by a bright wall is not a speck."""
    floor, up = jittered_plane(20)
    wall = floor[:, [0, 2, 1]] + [0.0, 1.0, 0.0]
    side = np.tile([0.0, -1.0, 0.0], (len(wall), 1))
    pts, nrm = np.vstack([floor, wall]), np.vstack([up, side])
    values = np.vstack([np.full((len(floor), 3), 0.1), np.full((len(wall), 3), 0.9)])
    out, replaced = remove_specks(pts, nrm, values)
    assert replaced == 0


def test_each_smooth_patch_takes_its_brighter_side_as_a_whole():
    """A closed box seen from outside: its faces are separate patches. On each, the outer
    side is brighter over the face, though a few points (light through a hole) read brighter
    inside: they take their face's choice."""
    rng = np.random.default_rng(2)
    pts, nrm, outward = [], [], []
    for axis in range(3):
        for sign in (-1.0, 1.0):
            uv = rng.random((300, 2)) * 0.9 + 0.05
            p = np.insert(uv, axis, 0.5 + 0.5 * sign, axis=1)
            n = np.zeros((300, 3))
            n[:, axis] = sign
            flip = rng.random(300) < 0.5          # unknown orientation: random signs
            pts.append(p)
            nrm.append(np.where(flip[:, None], -n, n))
            outward.append(~flip)
    pts, nrm, outward = np.vstack(pts), np.vstack(nrm), np.concatenate(outward)
    outside = np.full((len(pts), 3), 0.7)
    inside = np.full((len(pts), 3), 0.05)
    leak = rng.random(len(pts)) < 0.03
    inside[leak] = 0.9                           # brighter inside at 3% of the points
    front = np.where(outward[:, None], outside, inside)
    back = np.where(outward[:, None], inside, outside)
    out = brighter_sides(pts, nrm, front, back)
    np.testing.assert_array_equal(out, outside)
    per_point = np.where(((back - front).sum(1) > 0)[:, None], back, front)
    assert (per_point != outside).any()          # what a point-by-point choice would give
