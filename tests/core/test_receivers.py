"""Evaluation at receivers (illumap.receivers): triangle rays, cosine directions, final gather.

Exact cases: a receiver under a centred parallel unit square at height 1 sees it with form
factor 0.23945 (DESIGN.md §4), so a gather of a field that is 1 on the square and a black
background must return that; inside a closed box whose walls all send 1, every ray returns 1.
"""

import numpy as np
import pytest

import illumap
from illumap import receivers as rc

SQUARE_FORM_FACTOR = 0.23945   # point to a centred parallel unit square at height 1


def quad(c0, c1, c2, c3):
    """Two triangles c0 c1 c2, c0 c2 c3 (normal by their winding)."""
    return np.array([[c0, c1, c2], [c0, c2, c3]], dtype=np.float64)


def grid_square(z, n, facing_down=True):
    """An n×n grid of the unit square [-0.5, 0.5]² at height z as 2n² triangles."""
    s = np.linspace(-0.5, 0.5, n + 1)
    tris = []
    for i in range(n):
        for j in range(n):
            a, b = (s[i], s[j], z), (s[i + 1], s[j], z)
            c, d = (s[i + 1], s[j + 1], z), (s[i], s[j + 1], z)
            tris.append(quad(a, d, c, b) if facing_down else quad(a, b, c, d))
    return np.concatenate(tris)


def closed_box(lo=-1.0, hi=1.0):
    """The six faces of a cube as 12 triangles facing inwards."""
    L, H = lo, hi
    faces = [
        quad((L, L, L), (H, L, L), (H, H, L), (L, H, L)),      # floor, +z
        quad((L, L, H), (L, H, H), (H, H, H), (H, L, H)),      # ceiling, -z
        quad((L, L, L), (L, H, L), (L, H, H), (L, L, H)),      # x = L, +x
        quad((H, L, L), (H, L, H), (H, H, H), (H, H, L)),      # x = H, -x
        quad((L, L, L), (L, L, H), (H, L, H), (H, L, L)),      # y = L, +y
        quad((L, H, L), (H, H, L), (H, H, H), (L, H, H)),      # y = H, -y
    ]
    return np.concatenate(faces)


def surfels_on(tris, per_triangle=4, value=1.0):
    """A field of surfels at points inside each triangle with its normal and ``value``."""
    w = np.array([[0.6, 0.2, 0.2], [0.2, 0.6, 0.2], [0.2, 0.2, 0.6], [1 / 3, 1 / 3, 1 / 3]])
    w = w[:per_triangle]
    pos = np.einsum("kc,tcd->tkd", w, tris).reshape(-1, 3)
    n = np.cross(tris[:, 1] - tris[:, 0], tris[:, 2] - tris[:, 0])
    n /= np.linalg.norm(n, axis=1, keepdims=True)
    nrm = np.repeat(n, len(w), axis=0)
    return rc.SurfelField(pos, nrm, np.full((len(pos), 3), value))


def test_segments_blocked_by_a_triangle_and_trimmed_at_the_end():
    occ = rc.MeshOccluders(quad((0, 0, 1), (1, 0, 1), (1, 1, 1), (0, 1, 1)))
    o = np.array([[0.5, 0.5, 0.0], [2.0, 2.0, 0.0], [0.5, 0.5, 0.0]])
    t = np.array([[0.5, 0.5, 2.0], [2.0, 2.0, 2.0], [0.5, 0.5, 1.0]])
    np.testing.assert_array_equal(occ.visible(o, t), [0.0, 1.0, 0.0])
    # A segment that ends on the triangle is free once its last part is left out.
    np.testing.assert_array_equal(occ.visible(o, t, end_trim=1e-4), [0.0, 1.0, 1.0])
    # A sun: the target 1e9 scene sizes away, clipped in double precision.
    far = np.array([[0.5, 0.5, 1e9]])
    assert occ.visible(o[:1], far)[0] == 0.0


def test_intersect_reports_triangle_distance_and_face():
    occ = rc.MeshOccluders(quad((0, 0, 1), (1, 0, 1), (1, 1, 1), (0, 1, 1)))   # normal +z
    o = np.array([[0.25, 0.75, 0.0], [0.25, 0.75, 2.0], [3.0, 3.0, 0.0]])
    d = np.array([[0, 0, 1.0], [0, 0, -1.0], [0, 0, 1.0]])
    tri, dist, front = occ.intersect(o, d)
    assert tri[0] in (0, 1) and tri[1] == tri[0] and tri[2] == -1
    np.testing.assert_allclose(dist[:2], [1.0, 1.0], rtol=1e-6)
    assert not front[0] and front[1]          # from below: the back face


def test_neighbouring_triangles_share_vertices_and_leave_no_gap_between_them():
    """The scene stores each distinct corner once (a splat's fan of 12 triangles: 13), and a
    ray through any shared corner or edge of a tiled square still meets it."""
    from illumap.splats import DEFAULT_SIDES, splat_triangles
    rng = np.random.default_rng(3)
    n = 400
    pts = np.column_stack([rng.random(n), rng.random(n), np.zeros(n)])
    fans = splat_triangles(pts, np.tile([0.0, 0.0, 1.0], (n, 1)), np.full(n, 1.0 / n))
    assert rc.MeshOccluders(fans)._scene.vertices == n * (DEFAULT_SIDES + 1)

    tiles = grid_square(1.0, 8)
    occ = rc.MeshOccluders(tiles)
    assert occ._scene.vertices < 3 * len(tiles)
    s = np.linspace(-0.5, 0.5, 17)[1:-1]          # the grid's inner corners and edge midpoints
    x, y = np.meshgrid(s, s)
    o = np.column_stack([x.ravel(), y.ravel(), np.zeros(x.size)])
    tri, dist, front = occ.intersect(o, np.tile([0.0, 0.0, 1.0], (len(o), 1)))
    assert (tri >= 0).all()
    np.testing.assert_allclose(dist, 1.0, rtol=1e-6)
    assert front.all()                            # grid_square faces down, towards the rays


def test_precision_does_not_depend_on_placement():
    """The same rays 1e7 m from the origin give the same answers (box-centred floats)."""
    base = quad((0, 0, 1), (1, 0, 1), (1, 1, 1), (0, 1, 1))
    o = np.array([[0.5, 0.5, 0.999], [0.5, 0.5, 0.99999]])
    d = np.array([[0, 0, 1.0], [0, 0, 1.0]])
    for shift in (0.0, 1e7):
        occ = rc.MeshOccluders(base + shift)
        tri, dist, _ = occ.intersect(o + shift, d)
        np.testing.assert_allclose(dist, [1e-3, 1e-5], rtol=2e-3)


def test_cosine_directions_are_unit_upper_and_cosine_distributed():
    normals = np.array([[0, 0, 1.0], [1, 0, 0], [0, -0.6, 0.8]])
    d = rc.cosine_directions(normals, 1024, np.arange(3))
    np.testing.assert_allclose(np.linalg.norm(d, axis=2), 1.0, atol=1e-12)
    cos = np.einsum("mkc,mc->mk", d, normals)
    assert cos.min() >= 0
    np.testing.assert_allclose(cos.mean(axis=1), 2 / 3, atol=2e-3)   # E[cos] under cos/π


def test_directions_depend_on_the_receiver_id_not_its_row():
    normals = np.tile([[0, 0, 1.0]], (4, 1))
    a = rc.cosine_directions(normals, 16, np.array([7, 8, 9, 10]), seed=3)
    b = rc.cosine_directions(normals[::-1], 16, np.array([10, 9, 8, 7]), seed=3)
    np.testing.assert_array_equal(a, b[::-1])
    assert not np.allclose(a[0], a[1])
    assert not np.allclose(a, rc.cosine_directions(normals, 16, np.array([7, 8, 9, 10]), seed=4))


def test_gather_under_a_square_gives_its_form_factor():
    square = grid_square(1.0, 8)                     # faces down, towards the receiver
    occ = rc.MeshOccluders(square)
    field = surfels_on(square)
    p = np.array([[0.0, 0.0, 0.0]])
    n = np.array([[0.0, 0.0, 1.0]])
    g = rc.gather(occ, field, p, n, rays=4096)
    np.testing.assert_allclose(g.radiance[0], SQUARE_FORM_FACTOR, rtol=0.01)
    assert g.rays == 4096
    # Seen from behind (the square faces up), one-sided surfaces send nothing.
    occ_up = rc.MeshOccluders(grid_square(1.0, 8, facing_down=False))
    assert rc.gather(occ_up, field, p, n, rays=256).radiance.max() == 0.0


def test_gather_background_for_rays_that_leave():
    occ = rc.MeshOccluders(grid_square(1.0, 2))
    field = surfels_on(grid_square(1.0, 2))
    p = np.array([[0.0, 0.0, 0.0]])
    g = rc.gather(occ, field, p, np.array([[0.0, 0.0, -1.0]]), rays=64, background=[0.5, 0.25, 1.0])
    np.testing.assert_allclose(g.radiance[0], [0.5, 0.25, 1.0])
    assert g.stderr[0] < 1e-6
    assert g.open[0] == 1.0


def test_the_halves_follow_the_lattices_error_where_the_rays_variance_overstates_it():
    """``halves`` (half the difference of the even and odd rays' mean luminance), pooled over
    receivers, estimates the gather's error: measured as the difference between two seeds
    (independent shifts of the ray lattice, so it is √2 × the error). The rays' variance
    (``stderr``) assumes independent rays and overstates it. A receiver whose rays all see the
    same light has zero halves; one ray has no halves."""
    square = grid_square(1.0, 8)
    occ = rc.MeshOccluders(square)
    rng = np.random.default_rng(5)
    field = rc.SurfelField(square.mean(axis=1), np.tile([0.0, 0.0, -1.0], (len(square), 1)),
                           rng.uniform(0.2, 1.0, (len(square), 3)))
    m = 400
    p = np.c_[rng.uniform(-1.5, 1.5, (m, 2)), np.zeros(m)]
    n = np.tile([0.0, 0.0, 1.0], (m, 1))
    ids = np.arange(m)
    for rays in (64, 512):
        a, b = (rc.gather(occ, field, p, n, rays=rays, ids=ids, seed=seed) for seed in (0, 1))
        lum = np.array([0.2126, 0.7152, 0.0722])
        measured = np.sqrt(np.mean(((a.radiance - b.radiance) @ lum) ** 2) / 2.0)
        pooled = np.sqrt(np.mean(a.halves ** 2))
        independent = np.sqrt(np.mean(a.stderr ** 2))
        assert measured < pooled < 4.0 * measured, (rays, measured, pooled)
        assert pooled < independent
    sky = rc.gather(occ, field, p[:3], -n[:3], rays=64, background=[0.5, 0.25, 1.0])
    assert np.abs(sky.halves).max() < 1e-12
    assert (rc.gather(occ, field, p[:3], n[:3], rays=1).halves == 0.0).all()


def test_the_gathers_open_share_is_the_backgrounds_part():
    """``open``: the share of a receiver's rays that hit nothing, so that its radiance is
    open × background plus what the surfels send (which the same gather without a background
    gives)."""
    square = grid_square(1.0, 8)
    occ = rc.MeshOccluders(square)
    field = surfels_on(square, value=0.3)
    p = np.array([[0.0, 0.0, 0.0], [0.0, 0.0, 0.9], [0.0, 0.0, 2.0]])   # the last above it
    n = np.tile([0.0, 0.0, 1.0], (3, 1))
    bg = np.array([0.5, 0.25, 1.0])
    lit = rc.gather(occ, field, p, n, rays=1024, background=bg)
    dark = rc.gather(occ, field, p, n, rays=1024)
    assert 0.0 < lit.open[1] < lit.open[0] < 1.0 and lit.open[2] == 1.0   # nearer: less sky
    np.testing.assert_allclose(lit.open, dark.open)
    np.testing.assert_allclose(lit.radiance, dark.radiance + lit.open[:, None] * bg, rtol=1e-12)
    assert abs((1.0 - lit.open[0]) - SQUARE_FORM_FACTOR) < 0.03     # the square's form factor


def test_gather_inside_a_closed_box_is_a_furnace():
    box = closed_box()
    occ = rc.MeshOccluders(box)
    field = surfels_on(box, value=0.7)
    rng = np.random.default_rng(1)
    p = rng.uniform(-0.9, 0.9, (50, 3))
    n = rng.normal(size=(50, 3))
    n /= np.linalg.norm(n, axis=1, keepdims=True)
    g = rc.gather(occ, field, p, n, rays=64)
    np.testing.assert_allclose(g.radiance, 0.7, rtol=1e-12)


def test_a_gather_without_a_table_looks_the_field_up_at_each_hit():
    """``tabulate=False``: the same light as through the lattice (exactly, for a field that
    is constant; within the lattice's interpolation otherwise), and per receiver the same
    whatever the batch."""
    box = closed_box()
    occ = rc.MeshOccluders(box)
    rng = np.random.default_rng(3)
    p = rng.uniform(-0.9, 0.9, (40, 3))
    n = rng.normal(size=(40, 3))
    n /= np.linalg.norm(n, axis=1, keepdims=True)
    flat = surfels_on(box, value=0.7)
    np.testing.assert_allclose(rc.gather(occ, flat, p, n, rays=64, tabulate=False).radiance, 0.7,
                               rtol=1e-12)
    square = grid_square(1.0, 8)
    field = surfels_on(square)
    one = np.array([[0.0, 0.0, 0.0]]), np.array([[0.0, 0.0, 1.0]])
    direct = rc.gather(rc.MeshOccluders(square), field, *one, rays=4096, tabulate=False)
    np.testing.assert_allclose(direct.radiance[0], SQUARE_FORM_FACTOR, rtol=0.01)
    face = np.cross(box[:, 1] - box[:, 0], box[:, 2] - box[:, 0])
    varied = rc.SurfelField(box.mean(axis=1), face / np.linalg.norm(face, axis=1, keepdims=True),
                            np.arange(len(box))[:, None] / len(box) * np.ones((1, 3)))
    both = rc.gather(occ, varied, p, n, rays=32, tabulate=False).radiance
    alone = rc.gather(occ, varied, p[:5], n[:5], rays=32, tabulate=False).radiance
    np.testing.assert_array_equal(both[:5], alone)


def test_gather_is_the_same_in_any_order_and_thread_count():
    box = closed_box()
    occ = rc.MeshOccluders(box)
    pos = np.einsum("kc,tcd->tkd", np.array([[0.6, 0.2, 0.2], [0.2, 0.2, 0.6]]), box).reshape(-1, 3)
    values = np.abs(pos) + 0.1                  # a varying field
    nrm = np.repeat(np.cross(box[:, 1] - box[:, 0], box[:, 2] - box[:, 0]), 2, axis=0)
    nrm /= np.linalg.norm(nrm, axis=1, keepdims=True)
    field = rc.SurfelField(pos, nrm, values)
    p = pos + 1e-3 * nrm
    whole = rc.gather(occ, field, p, nrm, rays=32, ids=np.arange(len(p)))
    order = np.random.default_rng(0).permutation(len(p))
    for threads in (1, 2):
        parts = rc.gather(occ, field, p[order], nrm[order], rays=32, ids=order, threads=threads)
        np.testing.assert_array_equal(parts.radiance, whole.radiance[order])
    # Every value is an interpolation of the field: within its range.
    assert values.min() - 1e-12 <= whole.radiance.min() and whole.radiance.max() <= values.max() + 1e-12


def test_gather_does_not_take_light_from_under_a_box():
    """A floor lit (value 1) only under a closed box resting on it, dark (0) outside: a
    receiver beside the box, looking at the floor next to it, must see 0; the surfels under
    the box are the nearest to the hits but a triangle (the box's side) separates them."""
    s = np.linspace(-2, 2, 41)
    floor = []
    for i in range(40):
        for j in range(40):
            a, b = (s[i], s[j], 0.0), (s[i + 1], s[j], 0.0)
            c, d = (s[i + 1], s[j + 1], 0.0), (s[i], s[j + 1], 0.0)
            floor.append(quad(a, b, c, d))
    floor = np.concatenate(floor)
    box = closed_box(-0.5, 0.5)
    box[..., 2] += 0.5                       # resting on the floor, faces inwards...
    box = box[:, ::-1]                        # ...turned outwards
    occ = rc.MeshOccluders(np.concatenate([floor, box]))
    pos = floor.mean(axis=1)
    inside = (np.abs(pos[:, 0]) < 0.5) & (np.abs(pos[:, 1]) < 0.5)
    # The box's own surfels, as dense as the floor's, send nothing.
    g = (np.arange(10) + 0.5) / 10 - 0.5
    a, b = (x.ravel() for x in np.meshgrid(g, g))
    half = np.full_like(a, 0.5)
    box_pos, box_nrm = [], []
    for axis in range(3):
        for sign in (-1.0, 1.0):
            p3 = np.insert(np.column_stack([a, b]), axis, sign * half, axis=1)
            p3[:, 2] += 0.5
            box_pos.append(p3)
            box_nrm.append(np.tile(np.eye(3)[axis] * sign, (len(a), 1)))
    box_pos, box_nrm = np.concatenate(box_pos), np.concatenate(box_nrm)
    field = rc.SurfelField(np.concatenate([pos, box_pos]),
                           np.concatenate([np.tile([[0, 0, 1.0]], (len(pos), 1)), box_nrm]),
                           np.concatenate([np.where(inside[:, None], 1.0, 0.0) * np.ones((1, 3)),
                                           np.zeros((len(box_pos), 3))]))
    p = np.array([[0.55, 0.0, 0.3]])          # beside the box, facing the floor
    g = rc.gather(occ, field, p, np.array([[0.0, 0.0, -1.0]]), rays=1024)
    assert g.radiance.max() < 0.01, g.radiance


def test_gather_can_be_cancelled():
    occ = rc.MeshOccluders(closed_box())
    field = surfels_on(closed_box())
    with pytest.raises(illumap.Cancelled):
        rc.gather(occ, field, np.zeros((3, 3)), np.tile([[0, 0, 1.0]], (3, 1)), rays=8,
                  progress=lambda f, phase: False)


def test_bad_input_is_refused_with_its_name():
    with pytest.raises(illumap.InputError, match="corners of triangle 1"):
        bad = closed_box()[:2].copy()
        bad[1, 2, 0] = np.nan
        rc.MeshOccluders(bad)
    occ = rc.MeshOccluders(closed_box())
    with pytest.raises(illumap.InputError, match=r"targets\[0\]"):
        occ.visible(np.zeros((1, 3)), np.full((1, 3), np.inf))
    with pytest.raises(illumap.InputError, match="rays"):
        rc.gather(occ, surfels_on(closed_box()), np.zeros((1, 3)), np.array([[0, 0, 1.0]]), rays=0)


def test_gather_takes_a_ray_count_per_receiver():
    box = closed_box()
    occ = rc.MeshOccluders(box)
    pos = np.einsum("kc,tcd->tkd", np.array([[0.6, 0.2, 0.2]]), box).reshape(-1, 3)
    nrm = np.cross(box[:, 1] - box[:, 0], box[:, 2] - box[:, 0])
    nrm /= np.linalg.norm(nrm, axis=1, keepdims=True)
    field = rc.SurfelField(pos, nrm, np.abs(pos) + 0.1)
    p = pos + 1e-3 * nrm
    same = rc.gather(occ, field, p, nrm, rays=np.full(len(p), 32))
    np.testing.assert_array_equal(same.radiance, rc.gather(occ, field, p, nrm, rays=32).radiance)
    counts = np.arange(len(p)) % 3 * 16 + 8
    mixed = rc.gather(occ, field, p, nrm, rays=counts)
    assert mixed.rays == counts.sum()
    for k in (8, 24, 40):      # each receiver casts exactly its own count's rays
        rows = np.flatnonzero(counts == k)
        alone = rc.gather(occ, field, p[rows], nrm[rows], rays=k, ids=rows)
        np.testing.assert_array_equal(mixed.radiance[rows], alone.radiance)
    with pytest.raises(illumap.InputError, match="counts"):
        rc.gather(occ, field, p, nrm, rays=np.zeros(len(p), dtype=int))


def test_gather_lattices_lie_on_their_triangles_facing_their_side():
    floor = grid_square(0.0, 4, facing_down=False)
    occ = rc.MeshOccluders(floor)
    field = surfels_on(floor)
    (fp, fn), (bp, bn) = rc.gather_lattices(occ, field, back_field=field)
    assert len(fp) >= 3 * len(floor) and len(bp) == len(fp)
    np.testing.assert_allclose(fp[:, 2], 0.0, atol=1e-12)
    assert (np.abs(fp[:, :2]) <= 0.5 + 1e-12).all()
    np.testing.assert_array_equal(fn, np.tile([0.0, 0.0, 1.0], (len(fn), 1)))
    np.testing.assert_array_equal(bn, -fn)
    # Black back faces and splats that carry their own surfel are not tabulated.
    (_, _), (bp2, _) = rc.gather_lattices(occ, field, back_field=field,
                                          two_sided=np.zeros(len(floor), bool))
    assert len(bp2) == 0
    owners = np.full(len(floor), -1)
    owners[:2] = 0
    (fp3, _), _ = rc.gather_lattices(occ, field, owners=owners)
    assert len(fp3) < len(fp)


def test_an_exact_part_adds_to_the_rest_of_the_field():
    square = grid_square(1.0, 8)
    occ = rc.MeshOccluders(square)
    ones, zeros = surfels_on(square, value=1.0), surfels_on(square, value=0.0)
    (points, _), _ = rc.gather_lattices(occ, ones)
    p, n = np.array([[0.0, 0.0, 0.0]]), np.array([[0.0, 0.0, 1.0]])
    whole = rc.gather(occ, ones, p, n, rays=1024)
    split = rc.gather(occ, ones, p, n, rays=1024,
                      exact=rc.ExactPart(rest=zeros, values=np.ones((len(points), 3))))
    np.testing.assert_allclose(split.radiance, whole.radiance, rtol=1e-12)
    with pytest.raises(ValueError, match="front_lattice must have"):
        rc.gather(occ, ones, p, n, rays=8, exact=rc.ExactPart(rest=zeros, values=np.ones((3, 3))))


def square_with_fields(seed, exact_values=None):
    """A grid square facing down at z = 1 (occluders), a field of random values on it, a
    back field of 0.3 and an exact part over 0.1 (``exact_values`` at the lattice points,
    0.4 by default): (occluders, field, back field, exact part)."""
    square = grid_square(1.0, 8)
    occ = rc.MeshOccluders(square)
    rng = np.random.default_rng(seed)
    field = rc.SurfelField(square.mean(axis=1), np.tile([0.0, 0.0, -1.0], (len(square), 1)),
                           rng.uniform(0.2, 1.0, (len(square), 3)))
    (points, _), _ = rc.gather_lattices(occ, field)
    values = np.full((len(points), 3), 0.4) if exact_values is None else exact_values(len(points))
    exact = rc.ExactPart(rest=surfels_on(square, value=0.1), values=values)
    return occ, field, surfels_on(square, value=0.3), exact


def test_one_gatherer_serves_every_batch_as_a_gather_each():
    """``Gatherer`` tabulates once; each of its calls gives what ``gather`` with the same
    arguments gives, to the bit (an exact part and a back field included), and a refused
    argument leaves nothing behind."""
    occ, field, back, exact = square_with_fields(2)
    rng = np.random.default_rng(2)
    kw = dict(background=[0.2, 0.2, 0.3], back_field=back, exact=exact)
    p = np.c_[rng.uniform(-0.5, 0.5, (30, 2)), rng.uniform(-0.5, 0.9, 30)]
    n = np.tile([0.0, 0.0, 1.0], (30, 1))
    n[::3] *= -1
    once = rc.Gatherer(occ, field, **kw)
    for rows, rays in ((np.arange(0, 10), 64), (np.arange(10, 30), 16), (np.arange(5, 8), 128)):
        got = once.gather(p[rows], n[rows], rays=rays, ids=rows, seed=3)
        want = rc.gather(occ, field, p[rows], n[rows], rays=rays, ids=rows, seed=3, **kw)
        for name in ("radiance", "stderr", "reach", "open", "halves"):
            np.testing.assert_array_equal(getattr(got, name), getattr(want, name), err_msg=name)
        assert got.rays == want.rays == len(rows) * rays
    with pytest.raises(ValueError, match="owner_front"):
        rc.Gatherer(occ, field, owners=np.full(occ.n, 10 ** 6))


def test_hit_values_are_what_the_gather_takes_at_its_hits():
    """The gather's mean over its rays is the background for a miss and ``hit_values`` at
    each hit (front or back face, table or lookup, an exact part included): recomputed from
    the same rays in Python. A triangle the scene lacks is refused."""
    rng = np.random.default_rng(5)
    occ, field, back, exact = square_with_fields(5, lambda m: rng.uniform(0.0, 0.5, (m, 3)))
    background = np.array([0.2, 0.2, 0.3])
    gatherer = rc.Gatherer(occ, field, background=background, back_field=back, exact=exact)
    p = np.c_[rng.uniform(-0.7, 0.7, (12, 2)), rng.uniform(0.2, 1.8, 12)]
    n = np.tile([0.0, 0.0, 1.0], (12, 1))
    n[p[:, 2] > 1.0] *= -1                          # above the square: looking down on it
    ids, rays = np.arange(12), 32
    got = gatherer.gather(p, n, rays=rays, ids=ids, seed=4)
    dirs = rc.cosine_directions(n, rays, ids, seed=4).reshape(-1, 3)
    origins = np.repeat(p + occ.offset * n, rays, axis=0)
    tri, dist, front = occ.intersect(origins, dirs)
    hit = tri >= 0
    assert hit.any() and (~hit).any() and front[hit].any() and (~front[hit]).any()
    values = np.tile(background, (len(tri), 1))
    values[hit] = gatherer.hit_values(tri[hit], front[hit],
                                      origins[hit] + dist[hit, None] * dirs[hit])
    # (the hits' barycentrics recomputed from float hit points: agreement to 1e-8)
    np.testing.assert_allclose(values.reshape(12, rays, 3).mean(axis=1), got.radiance,
                               rtol=1e-6, atol=1e-12)
    with pytest.raises(ValueError, match="not a triangle of the scene"):
        gatherer.hit_values([occ.n], [True], [[0.0, 0.0, 1.0]])
    with pytest.raises(illumap.InputError, match="front must have"):
        gatherer.hit_values([0, 1], [True], [[0.0, 0.0, 1.0], [0.1, 0.0, 1.0]])


def test_a_field_reaches_its_kth_nearest_surfel():
    """``SurfelField.reach``: the median distance to the LOOKUP_NEIGHBOURS-th nearest surfel,
    which bounds the gather's lattice spacing."""
    rng = np.random.default_rng(6)
    pos = rng.uniform(0.0, 1.0, (500, 3))
    field = rc.SurfelField(pos, np.tile([0.0, 0.0, 1.0], (500, 1)), np.ones((500, 3)))
    d = np.sort(np.linalg.norm(pos[:, None] - pos[None], axis=2), axis=1)
    # the k nearest include the surfel itself, at distance 0
    want = np.median(d[:, rc.LOOKUP_NEIGHBOURS - 1])
    assert field.reach == pytest.approx(want, rel=0.05)


def test_a_back_exact_part_adds_to_the_back_field():
    # A two-sided square seen from behind: the back field's light, split or whole, alike.
    square = grid_square(1.0, 8, facing_down=False)              # faces away from the receiver
    occ = rc.MeshOccluders(square)
    front = surfels_on(square, value=0.0)
    back_ones = surfels_on(square[:, ::-1], value=1.0)           # the back side's own surfels
    back_zeros = surfels_on(square[:, ::-1], value=0.0)
    _, (points, normals) = rc.gather_lattices(occ, front, back_field=back_ones)
    assert len(points) and np.allclose(normals, [0.0, 0.0, -1.0])
    p, n = np.array([[0.0, 0.0, 0.0]]), np.array([[0.0, 0.0, 1.0]])
    whole = rc.gather(occ, front, p, n, rays=1024, back_field=back_ones)
    split = rc.gather(occ, front, p, n, rays=1024, back_field=back_ones,
                      back_exact=rc.ExactPart(rest=back_zeros, values=np.ones((len(points), 3))))
    np.testing.assert_allclose(whole.radiance, SQUARE_FORM_FACTOR, rtol=0.01)
    np.testing.assert_allclose(split.radiance, whole.radiance, rtol=1e-12)
    with pytest.raises(ValueError, match="back_lattice must have"):
        rc.gather(occ, front, p, n, rays=8, back_field=back_ones,
                  back_exact=rc.ExactPart(rest=back_zeros, values=np.ones((3, 3))))


def test_an_exact_part_keeps_a_shadow_edge_as_sharp_as_the_lattice():
    # A floor lit for x > 0 only, seen from just above the edge: the value is the share of the
    # receiver's rays that land on the lit half. Sparse surfels blur the edge over their
    # spacing; the same light given exactly at the lattice points does not.
    floor = 8.0 * grid_square(0.0, 16, facing_down=False)
    occ = rc.MeshOccluders(floor)
    w = np.array([[0.6, 0.2, 0.2], [0.2, 0.6, 0.2], [0.2, 0.2, 0.6], [1 / 3, 1 / 3, 1 / 3]])
    pos = np.einsum("kc,tcd->tkd", w, floor).reshape(-1, 3)
    nrm = np.tile([0.0, 0.0, 1.0], (len(pos), 1))
    lit = lambda q: np.repeat((q[:, :1] > 0).astype(float), 3, axis=1)  # noqa: E731
    field = rc.SurfelField(pos, nrm, lit(pos))
    (points, _), _ = rc.gather_lattices(occ, field)
    exact = rc.ExactPart(rest=rc.SurfelField(pos, nrm, np.zeros_like(pos)), values=lit(points))
    p = np.array([[0.04, 0.0, 0.1], [-0.04, 0.0, 0.1]])
    n = np.array([[0.0, 0.0, -1.0]] * 2)
    rays = 4096
    d = rc.cosine_directions(n, rays, np.arange(2))
    t = -p[:, None, 2] / d[..., 2]
    x, y = p[:, None, 0] + t * d[..., 0], p[:, None, 1] + t * d[..., 1]
    on_floor = (np.abs(x) < 4) & (np.abs(y) < 4)
    expected = ((x > 0) & on_floor).mean(axis=1)
    blurred = rc.gather(occ, field, p, n, rays=rays).radiance[:, 0]
    sharp = rc.gather(occ, field, p, n, rays=rays, exact=exact).radiance[:, 0]
    print("expected", expected, "surfels alone", blurred, "with the exact part", sharp)
    np.testing.assert_allclose(sharp, expected, atol=0.02)
    assert (np.abs(blurred - expected) > 2 * np.abs(sharp - expected)).all()


def test_straddling_surfels_are_those_whose_disc_reaches_through_another_surface():
    # A floor and a wall meeting along y = 0: surfels on a 0.1 m grid, disc radius 0.056 m.
    s = 0.1
    u = (np.arange(20) + 0.5) * s
    fx, fy = np.meshgrid(u, np.arange(10) * s + 0.02, indexing="ij")     # 2 cm off the wall
    floor = np.column_stack([fx.ravel(), -fy.ravel(), np.zeros(fx.size)])
    wx, wz = np.meshgrid(u, np.arange(10) * s + 0.07, indexing="ij")     # 7 cm off the floor
    wall = np.column_stack([wx.ravel(), np.zeros(wx.size), wz.ravel()])
    p = np.concatenate([floor, wall])
    n = np.concatenate([np.tile([0.0, 0.0, 1.0], (len(floor), 1)),
                        np.tile([0.0, -1.0, 0.0], (len(wall), 1))])
    a = np.full(len(p), s * s)
    hit = rc.straddling_surfels(p, n, a)
    radius = np.sqrt(s * s / np.pi)
    expect = np.concatenate([fy.ravel() < radius, np.zeros(len(wall), bool)])
    np.testing.assert_array_equal(hit, expect)
    assert hit[:len(floor)].sum() == 20              # the first floor row only
    # Larger discs reach through: the wall's first row too.
    assert rc.straddling_surfels(p, n, np.full(len(p), 4 * s * s))[len(floor):].sum() == 20
    # A flat floor, and a box's bottom facing a floor, are not another surface's edge.
    flat = rc.straddling_surfels(floor, np.tile([0.0, 0.0, 1.0], (len(floor), 1)), a[:len(floor)])
    assert not flat.any()
    lid = floor + [0.0, 0.0, 0.01]
    both = rc.straddling_surfels(np.concatenate([floor, lid]),
                                 np.concatenate([np.tile([0.0, 0.0, 1.0], (len(floor), 1)),
                                                 np.tile([0.0, 0.0, -1.0], (len(floor), 1))]),
                                 np.full(2 * len(floor), s * s))
    assert not both.any()
    with pytest.raises(illumap.InputError, match="areas"):
        rc.straddling_surfels(p, n, a[:3])
