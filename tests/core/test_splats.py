"""Splats: the surface of a point cloud as triangles (illumap.splats)."""

import numpy as np
import pytest

from illumap import splats
from illumap.receivers import MeshOccluders

pytestmark = pytest.mark.skipif(not __import__("illumap").native_available(),
                                reason="needs the native core")


#: How far (m) a splat may reach past a plane that clips it in these 0.1 m scans: the overlap
#: with neighbours a few spacings away (unclipped, splats reach about 0.1 m over).
OVERLAP_SLACK = 0.01


def jittered_grid(n, size, rng, z=0.0):
    """n × n jittered points on the square [0, size]² at height z, their cell areas."""
    cell = size / n
    i, j = (a.ravel() for a in np.meshgrid(np.arange(n), np.arange(n)))
    xy = (np.column_stack([i, j]) + rng.uniform(0.1, 0.9, (n * n, 2))) * cell
    return np.column_stack([xy, np.full(n * n, z)]), np.full(n * n, cell * cell)


def cube_surface(n, rng):
    """Jittered points on the five faces of the unit cube [0, 1]³ other than its bottom (an
    open rim at z = 0), with their true outward normals and areas."""
    pts, nrm, area = [], [], []
    for axis, value, normal in ((2, 1.0, (0, 0, 1)), (0, 0.0, (-1, 0, 0)), (0, 1.0, (1, 0, 0)),
                                (1, 0.0, (0, -1, 0)), (1, 1.0, (0, 1, 0))):
        p, a = jittered_grid(n, 1.0, rng)
        q = np.zeros_like(p)
        others = [k for k in range(3) if k != axis]
        q[:, others[0]], q[:, others[1]], q[:, axis] = p[:, 0], p[:, 1], value
        pts.append(q)
        nrm.append(np.tile(normal, (len(q), 1)).astype(float))
        area.append(a)
    return np.concatenate(pts), np.concatenate(nrm), np.concatenate(area)


def test_splats_of_a_jittered_plane_leave_no_holes():
    rng = np.random.default_rng(1)
    p, a = jittered_grid(30, 1.0, rng)
    tri = splats.splat_triangles(p, np.tile([0.0, 0, 1], (len(p), 1)), a)
    assert tri.shape == (len(p) * splats.DEFAULT_SIDES, 3, 3)
    occ = MeshOccluders(tri)
    # Inside the sampled square (at its rim the splats end where the scan does).
    probes = np.column_stack([rng.uniform(0.05, 0.95, (4000, 2)), np.full(4000, -1.0)])
    hit, _, _ = occ.intersect(probes, np.tile([0.0, 0, 1], (len(probes), 1)))
    assert (hit >= 0).all()
    # Neighbours meet about half-way: the splats' total area is the plane's, plus the overlap
    # the corners need (CORNER_SLACK) and the rim's overhang, not the unclipped discs' 4 times.
    e1, e2 = tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]
    total = 0.5 * np.linalg.norm(np.cross(e1, e2), axis=1).sum()
    assert 1.0 < total < 1.9


def test_splats_follow_the_normal_and_not_its_sign():
    rng = np.random.default_rng(2)
    p, n, a = cube_surface(8, rng)
    up = splats.splat_triangles(p, n, a)
    down = splats.splat_triangles(p, -n, a)
    # The same outline either way, wound to face the given normal.
    np.testing.assert_allclose(np.sort(up.reshape(-1, 3), axis=0), np.sort(down.reshape(-1, 3), axis=0),
                               atol=1e-12)
    face = np.cross(up[:, 1] - up[:, 0], up[:, 2] - up[:, 0])
    owner = np.repeat(np.arange(len(p)), splats.DEFAULT_SIDES)
    big = np.linalg.norm(face, axis=1) > 1e-12
    assert (np.einsum("ij,ij->i", face[big], n[owner[big]]) > 0).all()


def test_splats_end_at_a_box_edge():
    """No splat of the cube's top or sides hangs over an edge, not even of the points right
    on it: every splat corner stays inside the cube (but for the overlap that closes the
    slit along the edge, ``EDGE_OVERLAP`` of a neighbour's distance), except below the open
    rim at z = 0, where the scan ends and nothing clips."""
    rng = np.random.default_rng(3)
    p, n, a = cube_surface(10, rng)
    edge = np.array([[0.5, 0.0, 1.0], [0.5, 1.0, 1.0], [0.0, 0.5, 1.0], [1.0, 0.5, 1.0]])
    p = np.concatenate([p, edge])
    n = np.concatenate([n, np.tile([0.0, 0, 1], (4, 1))])
    a = np.concatenate([a, np.full(4, 0.01)])
    tri = splats.splat_triangles(p, n, a).reshape(-1, 3)
    slack = OVERLAP_SLACK
    assert tri[:, :2].min() > -slack and tri.max() < 1 + slack
    assert tri[:, 2].min() < -0.01                    # the open rim: overhang where the scan ends
    # Unclipped, the top's splats would reach twice their radius beyond the edges.
    free = splats.splat_triangles(p, n, a, neighbours=1).reshape(-1, 3)
    assert free.max() > 1.02


def test_splats_of_a_wall_standing_on_a_floor_that_runs_under_it():
    """A junction, not an edge: the floor continues on both sides of the wall, and the
    wall's lowest splats keep their part above the floor (no slot to see through)."""
    rng = np.random.default_rng(4)
    floor, fa = jittered_grid(20, 2.0, rng)
    floor -= [1.0, 1.0, 0.0]
    wall, wa = jittered_grid(10, 1.0, rng)
    wall = np.column_stack([wall[:, 0] - 0.5, np.zeros(len(wall)), wall[:, 1]])
    wall[:10, 2] = 0.0                                   # a row of the wall's points on the floor
    p = np.concatenate([floor, wall])
    n = np.concatenate([np.tile([0.0, 0, 1], (len(floor), 1)), np.tile([0.0, -1, 0], (len(wall), 1))])
    a = np.concatenate([fa, wa])
    tri = splats.splat_triangles(p, n, a)
    occ = MeshOccluders(tri)
    # Rays along y through the wall just above the floor meet it.
    x = rng.uniform(-0.45, 0.45, 500)
    z = rng.uniform(0.005, 0.05, 500)
    origins = np.column_stack([x, np.full(500, -0.5), z])
    hit, dist, _ = occ.intersect(origins, np.tile([0.0, 1, 0], (500, 1)))
    assert (hit >= 0).all() and np.allclose(dist, 0.5, atol=1e-6)


def test_bad_splat_input_is_refused():
    with pytest.raises(splats.InputError, match="positive"):
        splats.splat_triangles(np.zeros((2, 3)) + [[0, 0, 0], [1, 0, 0]], np.tile([0.0, 0, 1], (2, 1)),
                               np.array([1.0, 0.0]))
    with pytest.raises(splats.InputError, match="finite"):
        splats.splat_triangles(np.array([[0, 0, np.nan]]), np.array([[0.0, 0, 1]]), np.array([1.0]))


def test_splats_of_a_box_scanned_as_its_vertices_stay_inside_it():
    """A cube scanned as a mesh's vertices: a regular grid per face with points right on the
    edges, whose fitted normals pick either face. An edge point's neighbours along the edge
    lie on its own plane, on neither side of it; they do not make the edge a junction (a
    surface running on through the plane), so its splat still ends at the other face."""
    t = np.linspace(0.0, 1.0, 11)
    g = np.stack(np.meshgrid(t, t, t, indexing="ij"), -1).reshape(-1, 3)
    p = g[((g == 0.0) | (g == 1.0)).any(axis=1)]
    # Each point's normal is one of the faces it lies on, alternating along each edge.
    bound = (p == 0.0) | (p == 1.0)
    turn = np.round(p.sum(axis=1) * 10).astype(int)
    pick = np.array([np.flatnonzero(b)[k % b.sum()] for b, k in zip(bound, turn)])
    n = np.zeros_like(p)
    n[np.arange(len(p)), pick] = np.where(p[np.arange(len(p)), pick] == 1.0, 1.0, -1.0)
    # Turned (as a block standing in a room is), so that rounding puts the edge's own
    # neighbours a hair to either side of a point's plane.
    a = 0.3
    turn = np.array([[np.cos(a), -np.sin(a), 0.0], [np.sin(a), np.cos(a), 0.0], [0.0, 0.0, 1.0]])
    tri = splats.splat_triangles(p @ turn.T, n @ turn.T, np.full(len(p), 0.01)).reshape(-1, 3)
    tri = tri @ turn
    assert tri.min() > -OVERLAP_SLACK and tri.max() < 1 + OVERLAP_SLACK


def test_splats_beside_an_edge_lie_in_their_own_surface():
    """A wall standing on a floor, both scanned on a 0.1 m grid with fitted normals: the wall
    points next to the floor fit a plane tilted towards it (the floor's points are among
    their neighbours), but their splats lie in the wall's plane, so a point a hair in front of
    the wall's foot is not behind them."""
    from illumap.pointcloud import pca_normals
    s = 0.1
    t = np.arange(11) * s
    wx, wz = np.meshgrid(t, t[1:], indexing="ij")
    wall = np.column_stack([wx.ravel(), np.zeros(wx.size), wz.ravel()])
    fx, fy = np.meshgrid(t, -t, indexing="ij")
    floor = np.column_stack([fx.ravel(), fy.ravel(), np.zeros(fx.size)])
    p = np.concatenate([wall, floor])
    n = pca_normals(p, 8)
    n *= np.where(n @ np.array([0.0, -1.0, 1.0]) < 0, -1.0, 1.0)[:, None]
    first_row = np.flatnonzero(np.isclose(p[:, 2], s) & (p[:, 1] == 0) & (p[:, 0] > 0) & (p[:, 0] < 1))
    assert (np.abs(n[first_row, 2]) > 0.02).any()            # the fitted normals do tilt
    tri = splats.splat_triangles(p, n, np.full(len(p), s * s))
    sides = len(tri) // len(p)
    mine = tri.reshape(len(p), sides, 3, 3)[first_row]
    assert np.abs(mine[..., 1]).max() < 1e-9                # in the wall's plane y = 0
    from illumap.pointcloud import settled_normals
    np.testing.assert_allclose(settled_normals(p, n)[first_row], [[0.0, -1.0, 0.0]] * len(first_row),
                               atol=1e-9)


def test_splats_written_into_a_callers_array_in_chunks_are_the_same(monkeypatch):
    """Fans built a few points at a time straight into the caller's array (a scan's scene
    holds its splat corners once) are the fans built whole, bit for bit."""
    rng = np.random.default_rng(7)
    p, a = jittered_grid(12, 1.0, rng)
    n = np.tile([0.0, 0.0, 1.0], (len(p), 1))
    whole = splats.splat_triangles(p, n, a)
    monkeypatch.setattr(splats, "FAN_CHUNK", 17)     # 144 points: 9 chunks, the last short
    out = np.full((len(whole) + 24, 3, 3), np.nan)
    got = splats.splat_triangles(p, n, a, out=out[12:-12])
    assert np.shares_memory(got, out)
    assert np.array_equal(out[12:-12], whole)
    assert np.isnan(out[:12]).all() and np.isnan(out[-12:]).all()   # nothing written outside
    with pytest.raises(splats.InputError, match="out must be C-contiguous float64"):
        splats.splat_triangles(p, n, a, out=np.empty((len(whole), 3, 3), dtype=np.float32))
