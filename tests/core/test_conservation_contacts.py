"""Receivers at contacts (``illumap.gather.covered``, ``illumap.gather.corners``): a surface
lying flat against a receiver hides it (no light reaches it, as in Cycles), a surface that
only touches it at a point does not, and a receiver whose lifted ray origin would lie beyond
another surface starts further inside its face.

The geometry is exact: a floor at z = 0 and a triangle of a sphere's pole fan that touches it
at its apex, tilted by a known slope, or a box's bottom lying on it. Whether a receiver is
covered or blocked is a yes/no fact of that geometry, not a tolerance.
"""

import numpy as np

from illumap.gather.corners import lift_blocked
from illumap.gather.covered import FLAT_SLOPE, _covered_by
from illumap.receivers import MeshOccluders
from illumap_core_testing import requires_native

#: A sphere of radius 0.4 with 16 rings: its pole fan rises 0.0077 m over 0.078 m (5.6°).
FAN_RISE, FAN_RUN = 0.0077, 0.078
#: Twice a ray offset of a 3 m scene (``RAY_OFFSET`` × feature length), as the gather asks.
TOLERANCE = 6e-5


def _fan_triangle(apex):
    """A pole-fan triangle with its apex at ``apex``, facing down (its front towards -z)."""
    a = np.asarray(apex, dtype=np.float64)
    b = a + (FAN_RUN, -0.008, FAN_RISE)
    c = a + (FAN_RUN, 0.008, FAN_RISE)
    return np.array([a, c, b])        # wound so that its normal points down


def _floor_triangle(corner=(0.0, 0.0, 0.0), size=0.1):
    """A floor triangle facing up with its right angle at ``corner``."""
    o = np.asarray(corner, dtype=np.float64)
    return np.array([o, o + (size, 0, 0), o + (0, size, 0)])


def _normal(tri):
    n = np.cross(tri[1] - tri[0], tri[2] - tri[0])
    return n / np.linalg.norm(n)


def test_the_fan_and_floor_triangles_face_each_other():
    assert _normal(_fan_triangle((0, 0, 0)))[2] < -0.99
    assert _normal(_floor_triangle())[2] == 1.0


def test_a_point_contact_is_no_cover():
    """A floor receiver a hair from the apex where a tilted fan triangle touches the floor:
    the triangle holds it within the tolerance and faces it, but touches it only there."""
    fan = _fan_triangle((0.0, 0.0, 0.0))
    point = np.array([[4.7e-5, 0.0, 0.0]])      # a floor corner moved 1e-3 of the way in
    up = np.array([[0.0, 0.0, 1.0]])
    assert not _covered_by(fan[None, None], point, up, TOLERANCE)[0]


def test_a_flat_triangle_covers_near_its_corner_and_inside():
    """A box's bottom triangle lying on the floor (coplanar, facing down) covers a floor
    receiver at its corner and one in its middle."""
    bottom = _floor_triangle()[[0, 2, 1]]       # the same triangle facing down
    up = np.array([[0.0, 0.0, 1.0]] * 2)
    points = np.array([[4.7e-5, 4.7e-5, 0.0], [0.03, 0.03, 0.0]])
    assert _covered_by(np.repeat(bottom[None, None], 2, axis=0), points, up, TOLERANCE).all()


def test_a_nearly_flat_triangle_still_covers():
    """A bottom tilted by half of FLAT_SLOPE (a box not quite level) covers the receivers
    near its lowest corner, where it lies within the tolerance."""
    bottom = _floor_triangle()[[0, 2, 1]].copy()
    bottom[:, 2] += 0.5 * FLAT_SLOPE * bottom[:, 0]
    point = np.array([[1e-4, 1e-4, 0.0]])
    assert _covered_by(bottom[None, None], point, np.array([[0.0, 0.0, 1.0]]), TOLERANCE)[0]


def test_a_fan_triangle_in_its_middle_covers():
    """Away from its corners a facing triangle within the tolerance still covers (a smooth
    mesh's shading normal says too little to ask more there)."""
    fan = _fan_triangle((0.0, 0.0, 0.0))
    centre = fan.mean(axis=0)
    point = (centre - (0, 0, 1e-5))[None]
    assert _covered_by(fan[None, None], point, np.array([[0.0, 0.0, 1.0]]), TOLERANCE)[0]


@requires_native
def test_a_lift_through_the_sphere_is_blocked():
    """The floor corner beside the pole lifts its ray origin into the sphere (the fan lies
    4.7e-6 m over it, the lift is 3e-5 m): blocked. 2.3 mm in (RECEIVER_INSET_MAX of the way
    to its face's centroid) the fan lies 0.23 mm up: clear. A corner far from the sphere is
    clear."""
    fan = _fan_triangle((0.0, 0.0, 0.0))
    floor = np.array([[[-1, -1, 0], [1, -1, 0], [1, 1, 0]], [[-1, -1, 0], [1, 1, 0], [-1, 1, 0]]],
                     dtype=np.float64)
    occ = MeshOccluders(np.concatenate([floor, fan[None]]), offset=3e-5)
    points = np.array([[4.7e-5, 0.0, 0.0], [2.3e-3, 0.0, 0.0], [0.5, 0.5, 0.0]])
    up = np.tile([0.0, 0.0, 1.0], (3, 1))
    assert lift_blocked(occ, points, up).tolist() == [True, False, False]


@requires_native
def test_a_receivers_own_face_does_not_block_its_lift():
    """Smooth shading tilts a receiver's normal from its face: the ray cast back along it
    still meets the face only at the full lift."""
    floor = np.array([[[-1, -1, 0], [1, -1, 0], [1, 1, 0]], [[-1, -1, 0], [1, 1, 0], [-1, 1, 0]]],
                     dtype=np.float64)
    occ = MeshOccluders(floor, offset=3e-5)
    tilted = np.array([[0.3, 0.0, 1.0], [0.0, -0.6, 0.8]])
    tilted /= np.linalg.norm(tilted, axis=1, keepdims=True)
    points = np.array([[0.1, 0.1, 0.0], [-0.2, 0.3, 0.0]])
    assert not lift_blocked(occ, points, tilted).any()
