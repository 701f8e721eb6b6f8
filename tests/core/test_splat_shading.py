"""The preview splats' linear shading (illumap.splat_shading): a linear light shown exactly, no
overshoot at a shadow's edge, no light taken across a crease."""

import numpy as np
import pytest

import illumap
from illumap import splats
from illumap.neighbours import knn
from illumap.splat_shading import splat_shading

pytestmark = pytest.mark.skipif(not illumap.native_available(), reason="needs the native core")


def grid(n, spacing=0.01):
    i, j = (a.ravel() for a in np.meshgrid(np.arange(n), np.arange(n)))
    return np.column_stack([i, j, np.zeros(len(i))]) * spacing


def evaluate(shading, frames, origin, at, points):
    """base + X dx + Y dy of splat ``at`` at ``points``: X, Y the instanced unit disc's
    coordinates (centre origin + offset, X along axis × a, Y across it × b)."""
    axis = frames["axis"][at].astype(float)
    across = np.cross(frames["normal"][at].astype(float), axis)
    rel = points - (origin[at] + frames["offset"][at])
    x = np.einsum("ij,ij->i", rel, axis) / frames["scale"][at, 0]
    y = np.einsum("ij,ij->i", rel, across) / frames["scale"][at, 1]
    return (shading["base"][at] + x[:, None] * shading["dx"][at]
            + y[:, None] * shading["dy"][at])


def test_a_linear_light_is_shown_exactly():
    """On a regular grid (interior points, and those at the rims whose splats are cut), light
    rising linearly across the plane: each splat's shading is that light, at its own point and
    across the splat."""
    p = grid(40)
    gradient = np.array([[3.0, -1.0, 0.0], [0.5, 2.0, 0.0], [0.0, 0.0, 0.0]])  # RGB rows
    values = 0.5 + p @ gradient.T
    frames = splats.splat_frames(p)
    shading = splat_shading(p, frames, values)
    inner = np.flatnonzero((p[:, :2].min(1) > 0.015) & (p[:, :2].max(1) < 0.375))
    np.testing.assert_allclose(evaluate(shading, frames, p, inner, p[inner]), values[inner],
                               rtol=0, atol=1e-4)
    step = 0.9 * frames["scale"][inner, :1] * np.array([[0.6, 0.8, 0.0]])
    np.testing.assert_allclose(evaluate(shading, frames, p, inner, p[inner] + step),
                               0.5 + (p[inner] + step) @ gradient.T, rtol=0, atol=1e-4)


@pytest.mark.parametrize("width", [0.0, 0.2], ids=["sharp", "penumbra"])
def test_a_shadow_edge_does_not_overshoot(width):
    """Light that falls from 1 to 0 across x = 0.5, at once or over a penumbra ``width`` wide:
    no splat's shading leaves [0, 1] half-way to its neighbours, splats away from the edge are
    flat, and inside the penumbra they follow its slope."""
    rng = np.random.default_rng(2)
    p = np.column_stack([rng.random((3000, 2)), np.zeros(3000)])
    x = p[:, :1]
    light = (x < 0.5) * 1.0 if width == 0 else np.clip((0.5 + width / 2 - x) / width, 0, 1)
    values = np.repeat(light, 3, axis=1)
    frames = splats.splat_frames(p)
    shading = splat_shading(p, frames, values)
    near = knn(p, p, 9)[0][:, 1:]
    for j in range(near.shape[1]):
        half_way = 0.5 * (p + p[near[:, j]])
        shown = evaluate(shading, frames, p, np.arange(len(p)), half_way)
        assert shown.min() >= -1e-6 and shown.max() <= 1 + 1e-6
    far = np.abs(p[:, 0] - 0.5) > width / 2 + 0.1
    assert np.abs(shading["dx"][far]).max() == 0 and np.abs(shading["dy"][far]).max() == 0
    if width:
        # Inside the penumbra (away from its ends) the slope is -1 / width along x.
        inside = np.flatnonzero((np.abs(p[:, 0] - 0.5) < width / 2 - 0.05)
                                & (np.abs(p[:, 1] - 0.5) < 0.4))
        step = np.array([[0.01, 0.0, 0.0]])
        slope = (evaluate(shading, frames, p, inside, p[inside] + step)
                 - evaluate(shading, frames, p, inside, p[inside])) / 0.01
        np.testing.assert_allclose(slope[:, 0], -1 / width, rtol=0.05)


@pytest.mark.parametrize("given", [True, False], ids=["given normals", "estimated normals"])
def test_no_light_is_taken_across_a_crease(given):
    """Two faces meeting at a right angle, each evenly lit (1 and 0.2): every splat is flat at
    its own face's value (the other face's points are neighbours, not its light). With
    estimated normals a point on the crease itself may take either face's plane: those
    within a spacing of it are left out."""
    rng = np.random.default_rng(4)
    a = rng.random((1500, 2))
    floor = np.column_stack([a, np.zeros(len(a))])
    wall = np.column_stack([a[:, 0], np.zeros(len(a)), a[:, 1]])
    p = np.concatenate([floor, wall])
    values = np.repeat(np.r_[np.ones(len(a)), np.full(len(a), 0.2)][:, None], 3, axis=1)
    normals = np.repeat([[0.0, 0.0, 1.0], [0.0, 1.0, 0.0]], len(a), axis=0) if given else None
    frames = splats.splat_frames(p, normals)
    shading = splat_shading(p, frames, values)
    keep = np.ones(len(p), bool) if given else np.r_[a[:, 1], a[:, 1]] > 0.03
    assert np.abs(shading["dx"][keep]).max() < 1e-9 and np.abs(shading["dy"][keep]).max() < 1e-9
    np.testing.assert_allclose(shading["base"][keep], values[keep], atol=1e-6)


def test_bad_values_are_named():
    p = grid(5)
    frames = splats.splat_frames(p)
    with pytest.raises(illumap.InputError, match="values"):
        splat_shading(p, frames, np.zeros((len(p) - 1, 3)))


def test_native_shading_is_the_numpy_version():
    """The native shading against the numpy version it was ported from, on the box corner
    of test_splat_frames (creases, rims) under light that varies across it."""
    import splat_shading_reference as ref
    from test_splat_frames import box_corner

    p = box_corner(np.random.default_rng(9))
    values = np.column_stack([np.sin(3 * p[:, 0]) + 1, p[:, 1] ** 2, np.exp(-p[:, 2])])
    frames = splats.splat_frames(p)
    native, numpy = splat_shading(p, frames, values), ref.splat_shading(p, frames, values)
    for key in ("base", "dx", "dy"):
        np.testing.assert_allclose(native[key], numpy[key], rtol=0, atol=1e-5, err_msg=key)
    assert np.abs(native["dx"]).max() > 0.01  # the light does change across the splats


def test_the_frames_neighbours_serve_the_shading():
    """splat_frames(with_neighbours=True) gives each point's nearest others (the k-d search's,
    nearest first, itself left out); the shading fitted to them is the one that searches
    its own."""
    from test_splat_frames import box_corner

    p = box_corner(np.random.default_rng(10))
    values = np.column_stack([p[:, 0] + p[:, 2], np.cos(4 * p[:, 1]), p[:, 0] * p[:, 1]])
    frames = splats.splat_frames(p, with_neighbours=True)
    order, neighbours = frames.pop("order"), frames.pop("neighbours")
    assert sorted(order) == list(range(len(p)))
    by_input = np.empty_like(neighbours)
    by_input[order] = order[neighbours]
    np.testing.assert_array_equal(by_input, knn(p, p, splats.PREVIEW_NEIGHBOURS + 1)[0][:, 1:])
    given = splat_shading(p, frames, values, order=order, neighbours=neighbours)
    found = splat_shading(p, frames, values)
    for key in given:
        np.testing.assert_array_equal(given[key], found[key])
    with pytest.raises(illumap.InputError, match="neighbours"):
        splat_shading(p, frames, values, order=order, neighbours=neighbours[:, :3])


def test_float32_points_and_frames_are_read_as_they_are():
    """The preview's float32 points and frames, with the frames' search, go to the core without
    float64 copies: the same shading, to the bit, as from their float64 copies."""
    from test_splat_frames import box_corner

    p = box_corner(np.random.default_rng(12)).astype(np.float32)
    values = np.column_stack([p[:, 0] + p[:, 2], np.cos(4 * p[:, 1]), p[:, 0] * p[:, 1]])
    frames = splats.splat_frames(p, with_neighbours=True)
    order, neighbours = frames.pop("order"), frames.pop("neighbours")
    assert all(frames[key].dtype == np.float32 for key in ("normal", "axis", "scale", "offset"))
    single = splat_shading(p, frames, values, order=order, neighbours=neighbours)
    double = splat_shading(p.astype(np.float64), {k: v.astype(np.float64) for k, v in frames.items()},
                           values, order=order, neighbours=neighbours)
    for key in single:
        np.testing.assert_array_equal(single[key], double[key])
    assert np.abs(single["dx"]).max() > 0.01
