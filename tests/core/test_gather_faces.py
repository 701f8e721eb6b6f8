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


# --- a vertex's corners in two face planes sharing one gather (``shares``) ---------------------

#: The ridge's faces fall away from its top edge (the y axis) at these angles to +z: a smooth
#: vertex there (normal +z) has a corner in each face, below whose plane its rays take nothing.
RIDGE_TILTS_DEG = (40.0, 60.0)


def ridge(tilts_deg=RIDGE_TILTS_DEG, size=3.0):
    """Two triangles meeting along the y axis at z = 0, facing up: one falls towards +x at the
    first tilt, the other towards -x at the second. Returns (triangles (2, 3, 3), each face's
    unit normal (2, 3), a corner of each at the origin moved 1 mm into its face (2, 3))."""
    a, b = np.radians(tilts_deg)
    down_a = np.array([np.cos(a), 0.0, -np.sin(a)])      # along face A, away from the edge
    down_b = np.array([-np.cos(b), 0.0, -np.sin(b)])
    y = np.array([0.0, 1.0, 0.0])
    tris = np.array([[-size * y, size * down_a, size * y],
                     [-size * y, size * y, size * down_b]])
    normals = np.cross(tris[:, 1] - tris[:, 0], tris[:, 2] - tris[:, 0])
    normals /= np.linalg.norm(normals, axis=1)[:, None]
    corners = np.stack([1e-3 * down_a, 1e-3 * down_b])
    return tris, normals, corners


def test_ridge_faces_point_up():
    _, normals, _ = ridge()
    assert (normals[:, 2] > 0).all()
    np.testing.assert_allclose(np.degrees(np.arccos(normals[:, 2])), RIDGE_TILTS_DEG)


def test_shared_rays_give_each_face_its_exact_share_of_the_sky():
    """A black convex ridge under a white sky (exact): a corner in a face at θ to the vertex
    normal sees the sky through every ray above its face, 1 − (1 − cos θ) / 2. Its rays are
    its neighbour's, cast from the neighbour's point: those below the neighbour's face would
    meet the neighbour's own triangle (black) unless cast again from the corner's point."""
    tris, faces, corners = ridge()
    occ = rc.MeshOccluders(tris)
    field = rc.SurfelField(tris.mean(axis=1), faces, np.zeros((2, 3)))
    up = np.array([[0.0, 0.0, 1.0]])
    g = rc.Gatherer(occ, field, background=[1.0, 1.0, 1.0]).gather(
        corners[:1], up, rays=4096, ids=np.array([7]), faces=faces[:1],
        shares=(np.array([0, 1]), corners[1:], faces[1:]))
    assert g.radiance.shape == (2, 3)
    expected = 1.0 - (1.0 - np.cos(np.radians(RIDGE_TILTS_DEG))) / 2.0
    np.testing.assert_allclose(g.radiance[:, 0], expected, atol=TOLERANCE)
    np.testing.assert_allclose(g.open, g.radiance[:, 0], atol=1e-12)   # only the sky is lit
    # Cast again: the rays below the first face (none of which is below the second, as the
    # faces fall away on either side), a share (1 − cos θ₁) / 2 of the 4,096.
    again = (1.0 - np.cos(np.radians(RIDGE_TILTS_DEG[0]))) / 2.0
    assert g.rays - 4096 == pytest.approx(again * 4096, abs=TOLERANCE * 4096)


def test_shared_rays_give_what_separate_gathers_give():
    """The ridge lit by a wall beside it and a grey sky: each corner's value from the shared
    gather is that of a gather of its own (other rays, the same light) within the lattice's
    noise at 4,096 rays (well under TOLERANCE, as in the exact cases above)."""
    tris, faces, corners = ridge()
    wall = np.array([[[-1.5, -3.0, -2.0], [-1.5, 3.0, -2.0], [-1.5, 3.0, 2.0]],
                     [[-1.5, -3.0, -2.0], [-1.5, 3.0, 2.0], [-1.5, -3.0, 2.0]]])
    # the wall faces +x, towards the ridge; its light grows upwards
    every = np.concatenate([tris, wall])
    occ = rc.MeshOccluders(every)
    spots = np.concatenate([tris.mean(axis=1),
                            np.column_stack([np.full(9, -1.5), np.zeros(9),
                                             np.linspace(-2.0, 2.0, 9)])])
    spot_normals = np.concatenate([faces, np.tile([1.0, 0.0, 0.0], (9, 1))])
    values = np.concatenate([np.full((2, 3), 0.2),
                             np.linspace(0.5, 3.0, 9)[:, None] * [1.0, 0.8, 0.6]])
    field = rc.SurfelField(spots, spot_normals, values)
    gatherer = rc.Gatherer(occ, field, background=[0.4, 0.5, 0.6])
    normal = np.array([[-0.2, 0.0, 1.0]]) / np.hypot(0.2, 1.0)   # leaning towards the wall
    shared = gatherer.gather(corners[:1], normal, rays=4096, ids=np.array([3]), faces=faces[:1],
                             shares=(np.array([0, 1]), corners[1:], faces[1:]))
    apart = gatherer.gather(corners, np.repeat(normal, 2, axis=0), rays=4096,
                            ids=np.array([11, 12]), faces=faces)
    # the faces see different light: the comparison can tell one corner from the other
    assert abs(apart.radiance[0, 0] - apart.radiance[1, 0]) > 3 * TOLERANCE
    np.testing.assert_allclose(shared.radiance, apart.radiance, atol=TOLERANCE)


def test_a_receiver_without_shares_is_unchanged_by_others_shares():
    """The receivers' own values do not depend on the corners that take their rays."""
    tris, faces, corners = ridge()
    occ = rc.MeshOccluders(tris)
    field = rc.SurfelField(tris.mean(axis=1), faces, np.full((2, 3), 0.3))
    gatherer = rc.Gatherer(occ, field, background=[1.0, 1.0, 1.0])
    up = np.array([[0.0, 0.0, 1.0]])
    alone = gatherer.gather(corners[:1], up, rays=256, faces=faces[:1])
    shared = gatherer.gather(corners[:1], up, rays=256, faces=faces[:1],
                             shares=(np.array([0, 1]), corners[1:], faces[1:]))
    np.testing.assert_array_equal(shared.radiance[:1], alone.radiance)
    np.testing.assert_array_equal(shared.halves[:1], alone.halves)


def test_shares_need_faces_and_consistent_offsets():
    tris, faces, corners = ridge()
    occ = rc.MeshOccluders(tris)
    field = rc.SurfelField(tris.mean(axis=1), faces, np.ones((2, 3)))
    gatherer = rc.Gatherer(occ, field)
    up = np.array([[0.0, 0.0, 1.0]])
    with pytest.raises(Exception, match="faces"):
        gatherer.gather(corners[:1], up, rays=8, shares=(np.array([0, 1]), corners[1:], faces[1:]))
    with pytest.raises(Exception, match="share_start"):
        gatherer.gather(corners[:1], up, rays=8, faces=faces[:1],
                        shares=(np.array([0, 2]), corners[1:], faces[1:]))


def test_a_vertex_casts_once_and_its_other_face_planes_take_its_rays():
    """``face_rows``: the corners joined to one lead are a row per face plane; the lead's plane
    casts (its caster is itself), the others take its rays; a corner that joined none casts."""
    from types import SimpleNamespace

    from illumap.gather.corners import face_rows
    up = [0.0, 0.0, 1.0]
    tilted = [0.0, np.sin(0.3), np.cos(0.3)]
    other = [np.sin(0.3), 0.0, np.cos(0.3)]
    # corners 0-3 join lead 1 (faces: up, tilted, up, other); corner 4 joined none
    rec = SimpleNamespace(normals=np.tile(up, (5, 1)),
                          faces=np.array([up, tilted, up, other, up]),
                          ids=np.array([5, 1, 7, 3, 9]))
    rows, index, casters = face_rows(rec, np.array([1, 1, 1, 1, 4]))
    np.testing.assert_array_equal(rows, [0, 1, 3, 4])        # up (least id 5), tilted, other, 4
    np.testing.assert_array_equal(rows[index], [0, 1, 0, 3, 4])
    np.testing.assert_array_equal(casters, [1, 1, 1, 3])      # the lead's row casts for its vertex
    flat = SimpleNamespace(normals=rec.normals, faces=None, ids=rec.ids)
    rows, index, casters = face_rows(flat, np.array([1, 1, 1, 1, 4]))
    np.testing.assert_array_equal(rows, [1, 4])
    np.testing.assert_array_equal(casters, [0, 1])
