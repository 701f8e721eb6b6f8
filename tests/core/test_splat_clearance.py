"""A scan point's receivers start clear of its neighbours' splats
(illumap.gather.scans.SplatClearance)."""

import numpy as np
import pytest

from illumap import splats
from illumap.gather.scans import CLEARANCE_MARGIN, SplatClearance
from illumap.receivers import MeshOccluders

pytestmark = pytest.mark.skipif(not __import__("illumap").native_available(),
                                reason="needs the native core")

#: Spacing of the test grids, m.
STEP = 0.01
UP = np.array([0.0, 0.0, 1.0])


def grid(n: int = 15) -> np.ndarray:
    """An n × n grid of STEP at z = 0, centred on the origin."""
    xs = (np.arange(n) - n // 2) * STEP
    x, y = np.meshgrid(xs, xs, indexing="ij")
    return np.column_stack([x.ravel(), y.ravel(), np.zeros(x.size)])


def centre(p: np.ndarray) -> int:
    return int(np.argmin(np.linalg.norm(p, axis=1)))


def splat_scene(p: np.ndarray, extra=None) -> tuple:
    """The points' splats as occluders (with ``extra`` triangles after them) and each
    triangle's point (−1: the extra ones)."""
    normals = np.tile(UP, (len(p), 1))
    tri = splats.splat_triangles(p, normals, np.full(len(p), STEP ** 2))
    owner = np.repeat(np.arange(len(p)), len(tri) // len(p))
    if extra is not None:
        tri = np.concatenate([tri, extra])
        owner = np.concatenate([owner, np.full(len(extra), -1)])
    return MeshOccluders(tri), owner


def dimpled(depth: float) -> tuple[np.ndarray, int]:
    """A grid whose centre point lies ``depth`` under the rest, and some noise elsewhere (the
    neighbours' planes pass above the centre)."""
    p = grid()
    rng = np.random.default_rng(3)
    p[:, 2] += rng.normal(0.0, 0.01 * STEP, len(p))
    c = centre(p)
    p[c, 2] = -depth
    return p, c


def test_an_exact_plane_moves_no_receiver():
    p = grid()
    clear = SplatClearance(p, np.tile(UP, (len(p), 1)))
    rows = np.arange(len(p))
    for d in (UP, -UP):
        lifted = clear.lift(rows, p, np.tile(d, (len(p), 1)))
        assert np.array_equal(lifted, p)


def test_a_point_under_its_neighbours_splats_starts_above_them():
    depth = 0.15 * STEP
    p, c = dimpled(depth)
    occ, owner = splat_scene(p)
    clear = SplatClearance(p, np.tile(UP, (len(p), 1)), occ, owner)
    lifted = clear.lift(np.array([c]), p[[c]], UP[None, :])[0]
    # Above the planes of its neighbours' splats by the margin, and no farther.
    nb = clear.idx[c]
    n_q = clear.planes[nb] * np.sign(clear.planes[nb, 2])[:, None]
    above = np.einsum("kc,kc->k", n_q, lifted - p[nb])
    assert above.min() >= 0.5 * CLEARANCE_MARGIN * clear.spacing[c]
    assert above.min() <= 1.5 * CLEARANCE_MARGIN * clear.spacing[c]
    assert np.allclose(lifted[:2], p[c, :2])
    # Facing down, the neighbours' planes lie behind it: it stays.
    assert np.array_equal(clear.lift(np.array([c]), p[[c]], -UP[None, :])[0], p[c])
    # Rays low over the surface (3°) meet the neighbours' splats from the point itself in most
    # directions, and pass over them from where its receiver starts, as from a point of an
    # exact plane.
    a = np.linspace(0.0, 2.0 * np.pi, 12, endpoint=False)
    d = np.column_stack([np.cos(a), np.sin(a), np.full(len(a), 0.05)])
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    own = occ.offset * UP
    from_point, _, _ = occ.intersect(np.tile(p[c] + own, (len(a), 1)), d, tmax=3.0 * STEP)
    from_lifted, _, _ = occ.intersect(np.tile(lifted + own, (len(a), 1)), d, tmax=3.0 * STEP)
    assert (from_point >= 0).sum() > len(a) // 2
    assert (from_lifted < 0).all()


def test_no_receiver_is_lifted_towards_another_surface():
    depth = 0.15 * STEP
    p, c = dimpled(depth)
    # A sheet of another surface a spacing above the point (a floor under a scanned base,
    # seen from the base's points).
    z = STEP
    sheet = np.array([[[-1, -1, z], [1, -1, z], [1, 1, z]], [[-1, -1, z], [1, 1, z], [-1, 1, z]]],
                     dtype=np.float64)
    occ, owner = splat_scene(p, sheet)
    clear = SplatClearance(p, np.tile(UP, (len(p), 1)), occ, owner)
    assert np.array_equal(clear.lift(np.array([c]), p[[c]], UP[None, :])[0], p[c])
    # Without the sheet it would move.
    occ, owner = splat_scene(p)
    moved = SplatClearance(p, np.tile(UP, (len(p), 1)), occ, owner)
    assert moved.lift(np.array([c]), p[[c]], UP[None, :])[0, 2] > p[c, 2]
