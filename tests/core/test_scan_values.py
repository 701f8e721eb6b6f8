"""Values at scan points: isolated specks replaced, shadow edges and gradients kept
(``remove_specks``); the outside of each smooth patch chosen as a whole (``outward_sides``);
the faces that meet at a crease point (``crease_surfaces``)."""

import numpy as np
import pytest

import illumap
from illumap.pointcloud import pca_normals
from illumap.scan_values import (Creases, ScanPatches, crease_surfaces, outward_sides,
                                 remove_specks)

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


def test_specks_found_with_the_patches_neighbours_are_the_same():
    """``ScanPatches`` keeps the neighbours it searched; ``remove_specks`` given them finds
    the same specks and values as searching them itself."""
    pts, nrm = jittered_plane(seed=3)
    values = 0.4 + 0.4 * pts[:, :1] * np.ones((1, 3))
    values[[10, 500, 1500]] = 0.01
    own = remove_specks(pts, nrm, values)
    shared = remove_specks(pts, nrm, values, neighbours=ScanPatches(pts, nrm).neighbours)
    assert own[1] == shared[1] == 3
    np.testing.assert_array_equal(own[0], shared[0])


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
    out = np.where(outward_sides(pts, nrm, front, back)[:, None], front, back)
    np.testing.assert_array_equal(out, outside)
    per_point = np.where(((back - front).sum(1) > 0)[:, None], back, front)
    assert (per_point != outside).any()          # what a point-by-point choice would give


def test_a_probe_settles_a_patch_only_where_its_sides_differ_beyond_their_noise():
    """Two flat patches far apart: one lit on one side only, one lit alike on both sides.
    The first is settled from values with a small standard error, not from the same values
    with a large one; the second never is, and its side is what outward_sides gives."""
    rng = np.random.default_rng(5)
    uv = rng.random((200, 2))
    pts = np.vstack([np.insert(uv, 2, 0.0, axis=1), np.insert(uv, 2, 0.0, axis=1) + [10, 0, 0]])
    nrm = np.tile([0.0, 0.0, 1.0], (400, 1))
    front = np.full((400, 3), 0.6)
    back = np.where((np.arange(400) < 200)[:, None], 0.02, 0.6 + 1e-3) * np.ones((1, 3))
    patches = ScanPatches(pts, nrm)
    assert len(np.unique(patches.part)) == 2
    small, large = np.full(400, 0.01), np.full(400, 2.0)
    side, settled = patches.sides(front, back, small, small)
    np.testing.assert_array_equal(settled, np.arange(400) < 200)
    np.testing.assert_array_equal(side[:200], True)
    np.testing.assert_array_equal(side, outward_sides(pts, nrm, front, back))
    assert not patches.sides(front, back, large, large)[1].any()
    assert not patches.sides(front, back)[1].any()   # no noise given: nothing settled


def test_a_patch_is_judged_on_a_sample_of_its_points():
    """``ScanPatches.sample`` keeps a small patch whole and about a share of a large one (at
    least ``whole`` points of each); ``sides`` judged on the sample's values alone settles
    the same patches the same way as on every point's."""
    rng = np.random.default_rng(7)
    big = np.insert(rng.random((2000, 2)), 2, 0.0, axis=1)
    small = np.insert(rng.random((40, 2)) * 0.2, 2, 0.0, axis=1) + [10, 0, 0]
    pts = np.vstack([big, small])
    nrm = np.tile([0.0, 0.0, 1.0], (len(pts), 1))
    patches = ScanPatches(pts, nrm)
    assert len(np.unique(patches.part)) == 2
    rows = patches.sample(0.25, 64)
    assert (np.diff(rows) > 0).all()
    in_small = rows >= 2000
    assert in_small.sum() == 40 and 450 <= (~in_small).sum() <= 550
    front = np.full((len(pts), 3), 0.6) + rng.normal(0, 0.01, (len(pts), 3))
    back = np.where((np.arange(len(pts)) < 2000)[:, None], 0.02, 0.9) * np.ones((1, 3))
    noise = np.full(len(pts), 0.01)
    full = patches.sides(front, back, noise, noise)
    sampled = patches.sides(front[rows], back[rows], noise[rows], noise[rows], rows=rows)
    np.testing.assert_array_equal(sampled[0], full[0])
    np.testing.assert_array_equal(sampled[1], full[1])
    assert full[1].all() and full[0][:2000].all() and not full[0][2000:].any()


def grid_cube(n=11):
    """The surface of the unit cube as a scan of a mesh's vertices: a regular n × n grid per
    face, each edge's and corner's points once (as a shared vertex is), no normals."""
    t = np.linspace(0.0, 1.0, n)
    g = np.stack(np.meshgrid(t, t, t, indexing="ij"), -1).reshape(-1, 3)
    on_surface = ((g == 0.0) | (g == 1.0)).any(axis=1)
    return g[on_surface]


def outward_pca(points):
    n = pca_normals(points, 8)
    return n * np.where(np.einsum("ij,ij->i", n, points - 0.5) < 0, -1.0, 1.0)[:, None]


def test_a_box_edge_point_is_lit_as_the_mean_of_its_faces():
    """On a cube scanned as its vertices, a point on an edge (its PCA normal tilted between
    the faces) stands for the two faces: it is evaluated along each face's normal, a hair
    inside and off that face, and not along its own tilted normal; points inside a face,
    however near the edge, keep their own normal only. A corner, with too few neighbours on
    each face to tell them, keeps its own normal or takes two faces, never one alone."""
    p = grid_cube()
    n = outward_pca(p)
    c = crease_surfaces(p, n)
    ones = (np.isclose(p, 0.0) | np.isclose(p, 1.0)).sum(axis=1)
    edge = np.flatnonzero(ones == 2)
    corner = np.flatnonzero(ones == 3)
    face = np.flatnonzero(ones == 1)
    assert c.own[face].all() and not np.isin(face, c.rows).any()
    assert not c.own[edge].any()
    for i in edge:
        k = c.rows == i
        assert k.sum() == 2
        axes = [(np.isclose(p[i], 0.0) | np.isclose(p[i], 1.0))]
        want = np.zeros((2, 3))
        for row, a in zip(want, np.flatnonzero(axes[0])):
            row[a] = 1.0 if p[i, a] == 1.0 else -1.0
        got = c.normals[k]
        assert np.allclose(np.sort(np.abs(got @ want.T).max(axis=1)), 1.0, atol=1e-9)
        # a hair into and off each face: inside the cube's face plane by no more than the hair
        spacing = 0.1
        off = c.points[k] - p[i]
        assert (np.linalg.norm(off, axis=1) < 0.1 * spacing).all()
        assert (np.einsum("ec,ec->e", off, got) > 0).all()
    assert all(c.own[i] != ((c.rows == i).sum() >= 2) for i in corner)


def test_crease_search_reports_its_chunks_and_can_be_cancelled(monkeypatch):
    """The crease search walks a scan's points in chunks (a 1M-point scan: 31), telling the
    run's progress before each; a cancel there stops it with illumap.Cancelled. Listening
    changes nothing it finds."""
    import illumap.scan_values as sv
    monkeypatch.setattr(sv, "_CREASE_CHUNK", 100)
    p = grid_cube()
    n = outward_pca(p)
    heard = []
    c = crease_surfaces(p, n, progress=lambda f, phase: heard.append((f, phase)))
    quiet = crease_surfaces(p, n)
    assert len(heard) == -(-len(p) // 100) and {ph for _, ph in heard} == {"creases"}
    assert [f for f, _ in heard] == sorted(f for f, _ in heard) and heard[-1][0] < 1.0
    assert np.array_equal(c.rows, quiet.rows) and np.array_equal(c.normals, quiet.normals)
    calls = []
    with pytest.raises(illumap.Cancelled):
        crease_surfaces(p, n, progress=lambda f, phase: calls.append(f) or len(calls) < 2)
    assert len(calls) == 2


def test_crease_means_count_each_face_once():
    c = Creases(rows=np.array([1, 1, 2]), normals=np.zeros((3, 3)), points=np.zeros((3, 3)),
                own=np.array([True, False, True]))
    own = np.array([[1.0], [9.0], [3.0]])
    extra = np.array([[2.0], [4.0], [5.0]])
    np.testing.assert_allclose(c.mean(own, extra), [[1.0], [3.0], [4.0]])


def test_twin_points_where_two_scans_meet_take_the_mean_of_both_faces():
    """A floor and a wall scanned as two objects that share their junction's points: each of
    the coincident pair cannot tell which object it came from, so both stand for both faces,
    though the crease is concave; a point in a floor's open edge (one surface) has none."""
    t = np.linspace(0.0, 1.0, 11)
    u, v = (a.ravel() for a in np.meshgrid(t, t))
    floor = np.column_stack([u, v, np.zeros_like(u)])
    wall = np.column_stack([u, np.zeros_like(u), v])
    p = np.concatenate([floor, wall])
    n = np.concatenate([np.tile([0.0, 0, 1], (len(u), 1)), np.tile([0.0, 1, 0], (len(u), 1))])
    c = crease_surfaces(p, n)
    junction = np.flatnonzero((p[:, 1] == 0.0) & (p[:, 2] == 0.0))
    assert len(junction) == 22
    for i in junction:
        got = c.normals[c.rows == i]
        covered = sorted(int(np.argmax(np.abs(g))) for g in got)
        assert covered in ([1], [2], [1, 2])
        faces = set(covered) | ({int(np.argmax(np.abs(n[i])))} if c.own[i] else set())
        assert faces == {1, 2}
    rim = np.flatnonzero((p[:, 1] == 1.0) & (p[:, 2] == 0.0))
    assert not np.isin(rim, c.rows).any() and c.own[rim].all()


def corner_scan(s=0.1, n=6, drop_side_b=True):
    """Points near the convex corner (0, 0, 0) of a box occupying x, y, z <= 0: its top face
    (+z), side A (+x) and side B (+y) on an s-grid, each edge's points with their fitted
    normal halfway between its two faces, the corner's a third of each. Side B's own points
    near the corner left out where ``drop_side_b``: only its edges with the others remain."""
    t = -s * np.arange(n)
    pts, nrm = [], []
    faces = {"top": (2, np.array([0, 0, 1.0])), "a": (0, np.array([1.0, 0, 0])),
             "b": (1, np.array([0, 1.0, 0]))}
    for name, (axis, normal) in faces.items():
        u, v = np.meshgrid(t, t, indexing="ij")
        grid = np.zeros((u.size, 3))
        others = [a for a in range(3) if a != axis]
        grid[:, others[0]], grid[:, others[1]] = u.ravel(), v.ravel()
        inside = (grid[:, others[0]] < 0) & (grid[:, others[1]] < 0)
        if name == "b" and drop_side_b:
            inside &= (grid[:, others[0]] < -2.5 * s) | (grid[:, others[1]] < -2.5 * s)
        pts.append(grid[inside])
        nrm.append(np.tile(normal, (inside.sum(), 1)))
    for a, b in ((0, 1), (0, 2), (1, 2)):
        line = np.zeros((n - 1, 3))
        rest = 3 - a - b
        line[:, rest] = t[1:]
        pts.append(line)
        nn = np.zeros(3)
        nn[a] = nn[b] = 1 / np.sqrt(2)
        nrm.append(np.tile(nn, (n - 1, 1)))
    pts.append(np.zeros((1, 3)))
    nrm.append(np.full((1, 3), 1 / np.sqrt(3)))
    return np.concatenate(pts), np.concatenate(nrm)


def test_a_box_corner_takes_all_three_faces_even_where_one_is_seen_only_by_its_edges():
    p, n = corner_scan()
    corner = len(p) - 1
    c = crease_surfaces(p, n)
    k = c.rows == corner
    got = np.sort(np.round(np.abs(c.normals[k] @ np.eye(3)).max(axis=1), 6))
    assert k.sum() == 3 and np.allclose(got, 1.0)
    np.testing.assert_allclose(np.sort(np.argmax(np.abs(c.normals[k]), axis=1)), [0, 1, 2])
    # Each face is evaluated a hair into it and off it, never behind another face.
    off = c.points[k] - p[corner]
    assert (np.einsum("ec,ec->e", off, c.normals[k]) > 0).all()
    assert (off <= 1e-12).sum(axis=1).min() >= 2


def noisy_box_on_floor(seed=3):
    """A noisy scan of a box standing on a floor (edges, corners, a concave junction), with
    duplicated points (twins) where two scans overlap, normals fitted without orientation."""
    rng = np.random.default_rng(seed)
    t = np.linspace(-1.0, 1.0, 41)
    u, v = (a.ravel() for a in np.meshgrid(t, t))
    floor = np.column_stack([u, v, np.zeros_like(u)])
    floor = floor[~((np.abs(floor[:, 0]) < 0.3) & (np.abs(floor[:, 1]) < 0.3))]
    box = grid_cube(13) * 0.6 - [0.3, 0.3, 0.0]
    box = box[box[:, 2] > 0.0]
    p = np.concatenate([floor, box, box[::7]]) + rng.normal(0.0, 0.002, (len(floor) + len(box) + len(box[::7]), 3))
    return p, pca_normals(p, 8)


def test_only_points_beside_a_second_face_are_grouped_and_nothing_changes():
    """``crease_surfaces`` groups the neighbours' normals only at points where a neighbour
    whose plane they lie on disagrees with their own normal (or that are missing from their
    own neighbours): the result is the grouping of every point's, to the bit."""
    from illumap import _core
    from illumap import scan_values
    p, n = noisy_box_on_floor()
    got = crease_surfaces(p, n)
    k = scan_values.CREASE_NEIGHBOURS
    idx, dist = _core.knn(p, p, k + 1)
    idx, dist = np.asarray(idx, dtype=np.int64), np.asarray(dist)
    rows = np.arange(len(p))
    crease = np.zeros(len(p), dtype=bool)
    want_rows, want_normals, want_points = scan_values._crease_faces(p, n, rows, idx, dist, crease)
    np.testing.assert_array_equal(got.rows, want_rows)
    np.testing.assert_array_equal(got.normals, want_normals)
    np.testing.assert_array_equal(got.points, want_points)
    np.testing.assert_array_equal(got.own, ~crease)
    looked = scan_values._may_crease(p, n, rows, idx, dist)
    assert crease.sum() > 50 and looked[crease].all() and looked.mean() < 0.5


def block_on_floor(angle_deg=17.0, floor_cell=0.1, block_cell=0.09, size=0.5, height=0.6):
    """A floor grid (``floor_cell``) and an open-bottomed block standing on it (its four
    sides and top on ``block_cell`` grids, each face's rim its own points, as the Cornell
    box's blocks are scanned), turned by ``angle_deg`` about z so that its grids and the
    floor's do not line up. Returns (points, outward normals, block centre (x, y), the
    block's bottom-ring rows, its corner rows)."""
    t = np.arange(0.0, 2.0 + 1e-9, floor_cell)
    u, v = (a.ravel() for a in np.meshgrid(t, t))
    floor = np.column_stack([u, v, np.zeros_like(u)])
    a = np.radians(angle_deg)
    turn = np.array([[np.cos(a), -np.sin(a), 0.0], [np.sin(a), np.cos(a), 0.0], [0, 0, 1.0]])
    centre = np.array([1.03, 0.97, 0.0])
    s = np.linspace(-size / 2, size / 2, int(round(size / block_cell)) + 1)
    h = np.linspace(0.0, height, int(round(height / block_cell)) + 1)
    parts, normals = [], []
    for axis, sign in ((0, 1.0), (0, -1.0), (1, 1.0), (1, -1.0)):
        a1, a2 = np.meshgrid(s, h)
        side = np.zeros((a1.size, 3))
        side[:, axis] = sign * size / 2
        side[:, 1 - axis], side[:, 2] = a1.ravel(), a2.ravel()
        out = np.zeros(3)
        out[axis] = sign
        parts.append(side)
        normals.append(np.tile(out, (len(side), 1)))
    a1, a2 = np.meshgrid(s, s)
    parts.append(np.column_stack([a1.ravel(), a2.ravel(), np.full(a1.size, height)]))
    normals.append(np.tile([0.0, 0.0, 1.0], (a1.size, 1)))
    block = np.concatenate(parts) @ turn.T + centre
    block_n = np.concatenate(normals) @ turn.T
    p = np.concatenate([floor, block])
    n = np.concatenate([np.tile([0.0, 0.0, 1.0], (len(floor), 1)), block_n])
    ring = len(floor) + np.flatnonzero(block[:, 2] == 0.0)
    local = (block[:, :2] - centre[:2]) @ turn[:2, :2]
    corner = len(floor) + np.flatnonzero((block[:, 2] == 0.0) &
                                         (np.abs(local) > size / 2 - 1e-9).all(axis=1))
    return p, n, centre[:2], ring, corner, (turn, size)


def test_a_block_standing_on_a_floor_takes_the_floor_outside_it():
    """Where a block stands on a floor, its bottom ring's points lie on the floor's plane too,
    with floor points all around them (under the block as well). The floor's light there is
    what it receives beside the block: it is evaluated a hair outside the block, on the side
    the block's face faces, never inside the block (where it would read dark)."""
    p, n, centre, ring, corner, (turn, size) = block_on_floor()
    c = crease_surfaces(p, n)
    floor_faces = np.flatnonzero(np.isin(c.rows, ring) & (c.normals[:, 2] > 0.99))
    looked = np.unique(c.rows[floor_faces])
    edges = np.setdiff1d(ring, corner)
    assert np.isin(edges, looked).mean() > 0.9
    local = (c.points[floor_faces, :2] - centre) @ turn[:2, :2]
    outside = (np.abs(local) > size / 2).any(axis=1)
    assert outside.all(), f"{int((~outside).sum())} of {len(outside)} evaluated inside the block"
    assert (c.points[floor_faces, 2] > 0.0).all()


def floor_and_wall(n=11):
    """A floor (z = 0) and a wall (y = 0) scanned as two objects sharing their junction's
    points (twins): points, outward normals, the floor's rows, the wall's."""
    t = np.linspace(0.0, 1.0, n)
    u, v = (a.ravel() for a in np.meshgrid(t, t))
    floor = np.column_stack([u, v, np.zeros_like(u)])
    wall = np.column_stack([u, np.zeros_like(u), v])
    p = np.concatenate([floor, wall])
    nrm = np.concatenate([np.tile([0.0, 0, 1], (len(u), 1)), np.tile([0.0, 1, 0], (len(u), 1))])
    return p, nrm, np.arange(len(u)), len(u) + np.arange(len(u))


def test_twin_points_of_different_colours_take_their_own_surface():
    """Where a red wall meets a white floor, the junction's white point was scanned on the
    floor and the red one on the wall: given the colours, each takes its own surface's light
    alone (one face, that surface's normal), the twins no longer the mean of both."""
    p, n, floor, wall = floor_and_wall()
    albedo = np.where(np.isin(np.arange(len(p)), wall)[:, None], [0.6, 0.05, 0.05], [0.7, 0.7, 0.7])
    c = crease_surfaces(p, n, albedo=albedo)
    junction = np.flatnonzero((p[:, 1] == 0.0) & (p[:, 2] == 0.0))
    assert len(junction) == 22
    for i in junction:
        faces = c.normals[c.rows == i]
        want = 2 if i in floor else 1          # the axis of the point's own surface's normal
        assert not c.own[i] and len(faces) >= 1
        assert (np.abs(faces[:, want]) > 0.99).all(), (i, faces)


def test_twin_points_whose_colour_every_face_has_take_all_faces():
    """A checkered floor meeting a wall of one of its colours: the colour of a twin does not
    tell its surface (both faces have points of it), so it stands for both, as without
    colours; a floor point of the other colour next to the junction, on the floor alone,
    keeps its own normal."""
    p, n, floor, wall = floor_and_wall()
    white, black = [0.8, 0.8, 0.8], [0.05, 0.05, 0.05]
    cell = (np.floor(p[:, 0] * 10 + 1e-9) + np.floor(p[:, 1] * 10 + 1e-9)) % 2
    albedo = np.where(np.isin(np.arange(len(p)), floor)[:, None] & (cell[:, None] == 1), black, white)
    plain = crease_surfaces(p, n)
    c = crease_surfaces(p, n, albedo=albedo)
    junction = np.flatnonzero((p[:, 1] == 0.0) & (p[:, 2] == 0.0))
    white_twins = [i for i in junction if (albedo[i] == white).all()]
    assert len(white_twins) >= 11
    for i in white_twins:
        np.testing.assert_array_equal(c.normals[c.rows == i], plain.normals[plain.rows == i])
    np.testing.assert_array_equal(c.own, plain.own)


def test_twins_of_one_noisy_colour_take_all_faces():
    """A floor and a wall of the same paint scanned with colour noise (±0.05 per channel): a
    twin's colour lies within both faces' spread, so it tells nothing, and each twin stands
    for both faces, as without colours."""
    p, n, floor, wall = floor_and_wall()
    rng = np.random.default_rng(5)
    albedo = np.clip(0.6 + rng.uniform(-0.05, 0.05, (len(p), 3)), 0.0, 1.0)
    plain = crease_surfaces(p, n)
    c = crease_surfaces(p, n, albedo=albedo)
    np.testing.assert_array_equal(c.rows, plain.rows)
    np.testing.assert_array_equal(c.normals, plain.normals)
