"""Precision independent of placement: the same scene gives the same light wherever it sits,
at any scale, and with a far outlier beside it (docs/stability.md, "Placement and scale").

The kernel only sees differences of positions, the native core stores coordinates against the
median of the scene (operator and ray scenes alike), ray offsets follow the size of the bulk
of the scene rather than its bounding box, and surfels whose planes lie within rounding of each
other (the two sides of one open surface) are in contact and exchange no light.
"""

import numpy as np
import pytest

import illumap

pytestmark = pytest.mark.skipif(not illumap.native_available(), reason="needs the native core")


def grid(n, z, normal, size=1.0):
    """n×n jittered surfels on the square [-size/2, size/2]² at height z, facing ``normal``
    (±z); the same n gives the same pattern (coincident sheets)."""
    u = np.arange(n) / n
    x, y = np.meshgrid(u, u)
    jitter = np.random.default_rng(n).random((2, n * n)) / n
    pos = np.column_stack([(x.ravel() + jitter[0] - 0.5) * size, (y.ravel() + jitter[1] - 0.5) * size,
                           np.full(n * n, z)])
    nrm = np.tile([0.0, 0.0, normal], (n * n, 1))
    return pos, nrm, np.full(n * n, (size / n) ** 2)


def plate_scene():
    """An open plate (two coincident sheets, up and down) 0.5 m above a floor-sized emitter
    facing up: the plate's underside is lit, its top side sees only the (black) sky."""
    parts = [grid(24, 0.0, 1.0, 2.0),      # emitter, facing up
             grid(24, 0.5, -1.0),          # plate underside, facing down
             grid(24, 0.5, 1.0)]           # plate top, facing up
    pos = np.concatenate([p for p, _, _ in parts])
    nrm = np.concatenate([n for _, n, _ in parts])
    area = np.concatenate([a for _, _, a in parts])
    n = len(pos)
    emission = np.zeros((n, 3))
    emission[:576] = 1.0
    albedo = np.full((n, 3), 0.8)
    albedo[:576] = 0.0
    top = np.arange(n) >= 2 * 576
    return pos, nrm, area, albedo, emission, top


def tilted(pos, nrm):
    """The scene turned by a generic rotation, so that no plane is axis-aligned and rounding
    of its coordinates moves its surfels off their common plane."""
    a, b = 0.3, 0.7
    rz = np.array([[np.cos(a), -np.sin(a), 0], [np.sin(a), np.cos(a), 0], [0, 0, 1]])
    rx = np.array([[1, 0, 0], [0, np.cos(b), -np.sin(b)], [0, np.sin(b), np.cos(b)]])
    r = rz @ rx
    return pos @ r.T, nrm @ r.T


def radiosity(pos, nrm, area, albedo, emission, method="fmm"):
    s = illumap.Surfels(pos, nrm, area, albedo, emission)
    return np.asarray(illumap.solve(s, method=method, tol=1e-8).radiosity)


@pytest.mark.parametrize("shift, single", [(0.0, False), (1e6, False), (1e8, False),
                                           (0.0, True), (1e2, True)])
def test_two_sided_plate_does_not_leak_far_from_the_origin(shift, single):
    """The plate's top reads 0 whether the scene sits at the origin or 1e8 m away, and when its
    positions were rounded to single precision (as Blender stores them; 100 m away that is
    ~8e-6 m): rounding separates the two sheets, which must not open a gap between them."""
    pos, nrm, area, albedo, emission, top = plate_scene()
    pos, nrm = tilted(pos, nrm)
    pos = pos + shift
    if single:
        pos = pos.astype(np.float32).astype(np.float64)
    b = radiosity(pos, nrm, area, albedo, emission)
    lit = b[~top & (albedo[:, 0] > 0)].mean()
    assert lit > 0.1
    assert b[top].max() <= 1e-3 * lit


@pytest.mark.parametrize("method", ["direct", "fmm"])
def test_translation_and_scale_do_not_change_the_solution(method):
    """A small room (the plate scene plus a wall) moved by up to 1e8 m or scaled by 1e-6…1e8
    gives the same radiosity: exactly up to rounding with the direct sum, and within 1e-5 with
    the FMM (1e8 m away, rounding moves a point across an octree cell boundary now and then,
    which changes the expansion error there, itself ~1e-3)."""
    bound = 1e-6 if method == "direct" else 1e-5
    pos, nrm, area, albedo, emission, _ = plate_scene()
    wall, wn, wa = grid(12, 0.0, 1.0)
    wall = wall[:, [2, 0, 1]] + [0.7, 0.0, 0.5]        # the x = 0.7 plane, facing +x
    wn = wn[:, [2, 0, 1]]
    pos, nrm = np.concatenate([pos, wall]), np.concatenate([nrm, wn])
    area = np.concatenate([area, wa])
    albedo = np.concatenate([albedo, np.full((len(wall), 3), 0.5)])
    emission = np.concatenate([emission, np.zeros((len(wall), 3))])
    pos, nrm = tilted(pos, nrm)
    base = radiosity(pos, nrm, area, albedo, emission, method)
    assert base.max() > 0.1
    for shift in (-1e8, -1e3, 1e-6, 1e4, 1e6, 1e8):
        got = radiosity(pos + shift * np.array([1.0, 0.5, -0.25]), nrm, area, albedo, emission, method)
        assert np.abs(got - base).max() <= bound * base.max(), shift
    for scale in (1e-6, 1e-3, 1e3, 1e8):
        got = radiosity(pos * scale, nrm, area * scale ** 2, albedo, emission, method)
        assert np.abs(got - base).max() <= bound * base.max(), scale


def test_a_far_outlier_does_not_change_the_room():
    """One tiny surfel 1e4…1e8 m away leaves the plate scene's radiosity as it is without it,
    to within the FMM's own error (the octree keys the bulk against its own box)."""
    pos, nrm, area, albedo, emission, _ = plate_scene()
    base = radiosity(pos, nrm, area, albedo, emission)
    for far in (1e4, 1e6, 1e8):
        got = radiosity(np.vstack([pos, [far, 0.0, 0.0]]), np.vstack([nrm, [0.0, 0.0, 1.0]]),
                        np.append(area, 1e-6), np.vstack([albedo, [0.5] * 3]),
                        np.vstack([emission, [0.0] * 3]))[:-1]
        rms = np.sqrt(np.sum((got - base) ** 2) / np.sum(base ** 2))
        assert rms <= 2e-3, (far, rms)


def test_local_feature_length_ignores_an_outlier():
    """Ray offsets scale with the bulk of the triangles, not with the box an outlier makes."""
    from illumap.receivers import MeshOccluders
    tri = np.array([[[0, 0, 0], [1, 0, 0], [0, 1, 0]], [[1, 1, 0], [0, 1, 0], [1, 0, 0]]], float)
    tri = np.concatenate([tri + [0, 0, z] for z in np.linspace(0, 1, 50)])
    alone = MeshOccluders(tri)
    far = MeshOccluders(np.concatenate([tri, [[[1e8, 0, 0], [1e8 + 0.01, 0, 0], [1e8, 0.01, 0]]]]))
    assert far.extent > 1e7
    assert far.feature_length == pytest.approx(alone.feature_length, rel=0.05)
    assert far.offset == pytest.approx(alone.offset, rel=0.05)
