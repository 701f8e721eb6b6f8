"""A receiver's smooth normal tilted off its face (illumap.receivers.gather, ``faces``).

A renderer's diffuse surface samples the hemisphere of its shading normal but drops the
directions that leave below the geometric face. Exact case: with cosine-distributed
directions about a normal at angle θ to the face normal, the share below the face is the
half-disk less the half-ellipse (semi-axes 1 and cos θ) that the face's great circle projects
to, over the disk: (1 − cos θ) / 2. In a white furnace (every surface and the sky send 1) a
receiver then gets 1 − (1 − cos θ) / 2, whatever its rays meet above the face.
"""

import numpy as np
import pytest

from illumap import receivers as rc

#: A 4,096-ray lattice estimates a share of 0.25 well within this (independent rays: 0.007).
TOLERANCE = 0.02


def floor_grid(n=8, half=2.0):
    """An n×n grid of the square [-half, half]² at z = 0 facing +z (2n² triangles)."""
    s = np.linspace(-half, half, n + 1)
    tris = []
    for i in range(n):
        for j in range(n):
            a, b = (s[i], s[j], 0.0), (s[i + 1], s[j], 0.0)
            c, d = (s[i + 1], s[j + 1], 0.0), (s[i], s[j + 1], 0.0)
            tris += [[a, b, c], [a, c, d]]
    return np.array(tris, dtype=np.float64)


def white_floor():
    """The floor as occluders and a field that sends 1 from every triangle."""
    tris = floor_grid()
    occ = rc.MeshOccluders(tris)
    field = rc.SurfelField(tris.mean(axis=1), np.tile([0.0, 0.0, 1.0], (len(tris), 1)),
                           np.ones((len(tris), 3)))
    return occ, field


@pytest.mark.parametrize("tilt_deg", [0.0, 30.0, 60.0, 85.0])
def test_directions_below_the_face_take_nothing(tilt_deg):
    occ, field = white_floor()
    t = np.radians(tilt_deg)
    p = np.array([[0.1, 0.05, 0.0]])
    n = np.array([[np.sin(t), 0.0, np.cos(t)]])
    g = rc.gather(occ, field, p, n, rays=4096, background=[1.0, 1.0, 1.0],
                  faces=np.array([[0.0, 0.0, 1.0]]))
    expected = 1.0 - (1.0 - np.cos(t)) / 2.0
    assert g.radiance[0] == pytest.approx(np.full(3, expected), abs=TOLERANCE)


def test_a_face_along_the_normal_changes_nothing():
    """A flat face (shading normal = face normal): the same rays and values as without."""
    tris = floor_grid()
    occ = rc.MeshOccluders(tris)
    field = rc.SurfelField(tris.mean(axis=1), np.tile([0.0, 0.0, 1.0], (len(tris), 1)),
                           np.full((len(tris), 3), 0.5))
    rng = np.random.default_rng(3)
    p = np.column_stack([rng.uniform(-1, 1, (20, 2)), np.zeros(20)])
    n = np.tile([0.0, 0.0, 1.0], (20, 1))
    plain = rc.gather(occ, field, p, n, rays=64, background=[1.0, 0.5, 0.25])
    faced = rc.gather(occ, field, p, n, rays=64, background=[1.0, 0.5, 0.25], faces=n)
    np.testing.assert_array_equal(faced.radiance, plain.radiance)


def test_faces_must_match_the_receivers():
    occ, field = white_floor()
    p = np.zeros((2, 3))
    n = np.tile([0.0, 0.0, 1.0], (2, 1))
    with pytest.raises(Exception, match="faces"):
        rc.gather(occ, field, p, n, rays=8, faces=n[:1])
