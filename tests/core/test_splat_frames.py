"""The preview's splat frames (illumap.splats.splat_frames, native) against the numpy
reference they were ported from (splat_frames_reference.py), on synthetic scans that take
every rule: a plane (its rims), a box corner (three faces: creases and a corner), a crease
(two planes at 35°)."""

import numpy as np
import pytest

import illumap
from illumap import splats
from illumap.neighbours import knn

pytestmark = pytest.mark.skipif(not illumap.native_available(), reason="needs the native core")

#: Both compute the same float64 arithmetic (up to the order of a few sums) and round to
#: float32: differences beyond a few float32 ulps of the splat's size are a real disagreement.
RELATIVE = 1e-5


def jittered(n, rng):
    """n × n points jittered within the cells of the unit square (no two distances tie, so
    neither version's choice among equal candidates depends on rounding)."""
    i, j = (a.ravel() for a in np.meshgrid(np.arange(n), np.arange(n)))
    return (np.column_stack([i, j]) + rng.uniform(0.1, 0.9, (n * n, 2))) / n


def plane(rng):
    uv = jittered(40, rng)
    return np.column_stack([uv, np.zeros(len(uv))])


def box_corner(rng):
    faces = []
    for axis in range(3):
        uv = jittered(20, rng)
        q = np.zeros((len(uv), 3))
        q[:, [a for a in range(3) if a != axis]] = uv
        faces.append(q)
    return np.concatenate(faces)


def crease(rng):
    a = rng.random((3000, 2))
    x = 2.0 * a[:, 0] - 1.0
    return np.column_stack([x, a[:, 1], np.where(x < 0, 0.0, np.tan(np.radians(35)) * x)])


CLOUDS = {"plane": plane, "box corner": box_corner, "crease": crease}


def assert_same(native, reference):
    assert native["clipped"].tolist() == reference["clipped"].tolist()
    size = float(np.abs(reference["scale"]).max())
    for key, tol in (("normal", RELATIVE), ("axis", RELATIVE), ("scale", RELATIVE * size),
                     ("offset", RELATIVE * size)):
        assert native[key].shape == reference[key].shape
        np.testing.assert_allclose(native[key], reference[key], rtol=0, atol=tol, err_msg=key)


@pytest.mark.parametrize("name", sorted(CLOUDS))
@pytest.mark.parametrize("given", [False, True], ids=["estimated normals", "given normals"])
def test_native_frames_match_numpy(name, given):
    import splat_frames_reference as ref
    p = CLOUDS[name](np.random.default_rng(7))
    normals = radius = None
    if given:
        # The scan's own normals (the fitted ones, flipped at random: orientation must not
        # matter) and radii.
        rng = np.random.default_rng(8)
        normals = ref.splat_frames(p)["normal"] * rng.choice([-1.0, 1.0], (len(p), 1))
        radius = rng.uniform(0.01, 0.03, len(p))
    reference = ref.splat_frames(p, normals, radius)
    native = splats.splat_frames(p, normals, radius)
    assert_same(native, reference)
    # The clouds take the rules being compared: some splats clipped, some not.
    assert 0 < native["clipped"].sum() < len(p)


def test_frames_do_not_depend_on_threads():
    p = box_corner(np.random.default_rng(3))
    one = splats.splat_frames(p, threads=1)
    two = splats.splat_frames(p, threads=2)
    for key in one:
        assert np.array_equal(one[key], two[key]), key


@pytest.mark.parametrize("given", [False, True], ids=["estimated normals", "given normals"])
def test_frames_on_a_tied_grid_do_not_depend_on_threads(given):
    """A regular grid (every point's neighbours tie in distance) large enough that its tree is
    built on two workers: the same frames as on one, bit for bit, rims included."""
    i, j = (a.ravel() for a in np.meshgrid(np.arange(260), np.arange(260)))
    p = np.column_stack([i, j, np.zeros(len(i))]) * 0.01
    normals = np.tile([0.0, 0.0, 1.0], (len(p), 1)) if given else None
    one = splats.splat_frames(p, normals, threads=1)
    two = splats.splat_frames(p, normals, threads=2)
    for key in one:
        assert np.array_equal(one[key], two[key]), key
    assert one["clipped"].any()  # the grid's rims are cut


def test_rims_and_creases_are_cut():
    """On the box corner, splats along the open rims and at the creases are clipped, those in
    the middle of a face are whole discs."""
    p = box_corner(np.random.default_rng(4))
    frames = splats.splat_frames(p)
    scale = frames["scale"]
    on_face = p.max(axis=1)                       # distance to the faces' far rims
    in_face = np.sort(p, axis=1)[:, 1]            # distance to the nearest crease
    middle = (on_face < 0.8) & (in_face > 0.2)
    edge = (on_face > 0.97) | (in_face < 0.03)
    assert not frames["clipped"][middle].any()
    np.testing.assert_allclose(scale[middle, 0], scale[middle, 1], rtol=1e-6)
    assert frames["clipped"][edge].mean() > 0.9


def test_progress_can_cancel():
    p = plane(np.random.default_rng(5))
    seen = []
    splats.splat_frames(p, progress=lambda f, phase: seen.append((f, phase)))
    assert seen and all(0.0 <= f <= 1.0 for f, _ in seen)
    with pytest.raises(illumap.Cancelled):
        splats.splat_frames(p, progress=lambda f, phase: False)


def test_bad_input_is_named():
    with pytest.raises(illumap.InputError, match="positions"):
        splats.splat_frames(np.zeros((10, 2)))
    with pytest.raises(illumap.InputError, match="normals"):
        splats.splat_frames(np.zeros((10, 3)), normals=np.zeros((9, 3)))


def welded_box(rng, cell=0.02):
    """The five faces (no bottom) of a 0.3 m box as jittered 2 cm grids (edge points moved
    along their edge), each with its face's outward normal; the corners shared by three faces
    (a welded mesh's vertices) with the mean of those faces' normals."""
    lo, hi = np.zeros(3), np.full(3, 0.3)
    points, normals = [], []
    m = round(0.3 / cell)
    s, t = (a.ravel() for a in np.meshgrid(np.arange(m + 1), np.arange(m + 1)))
    inner = lambda a: (a > 0) & (a < m)  # noqa: E731
    s = s + np.where(inner(s), rng.uniform(-0.35, 0.35, len(s)), 0.0)
    t = t + np.where(inner(t), rng.uniform(-0.35, 0.35, len(t)), 0.0)
    corner = ~inner(np.round(s)) & ~inner(np.round(t))
    for axis in range(3):
        for end in ((0, 1) if axis < 2 else (1,)):
            q = np.empty((len(s), 3))
            q[:, axis] = (lo if end == 0 else hi)[axis]
            u, v = [a for a in range(3) if a != axis]
            q[:, u], q[:, v] = s * cell, t * cell
            n = np.zeros((len(s), 3))
            n[:, axis] = 1.0 if end else -1.0
            keep = ~corner
            points.append(q[keep])
            normals.append(n[keep])
    c = np.array([[x, y, 0.3] for x in (0, 0.3) for y in (0, 0.3)]
                 + [[x, y, 0.0] for x in (0, 0.3) for y in (0, 0.3)])
    mean = np.where(c > 0.15, 1.0, -1.0) * np.array([1.0, 1.0, 1.0])
    mean[4:, 2] = 0.0  # the bottom corners: two side faces only
    points.append(c)
    normals.append(mean / np.linalg.norm(mean, axis=1, keepdims=True))
    return np.concatenate(points), np.concatenate(normals)


def outside_reach(frames, p):
    """How far each splat (its ellipse, in its plane) reaches outside the box [0, 0.3]^3, m."""
    n = frames["normal"].astype(float)
    ax = frames["axis"].astype(float)
    bx = np.cross(n, ax)
    centre = p + frames["offset"]
    a, b = frames["scale"][:, 0:1], frames["scale"][:, 1:2]
    reach = np.zeros(len(p))
    for d in range(3):
        extent = np.sqrt((a[:, 0] * ax[:, d]) ** 2 + (b[:, 0] * bx[:, d]) ** 2)
        reach = np.maximum(reach, centre[:, d] + extent - 0.3)
        if d < 2:
            reach = np.maximum(reach, -(centre[:, d] - extent))
    return reach


def test_given_normals_splats_stay_on_a_boxs_convex_edges():
    """A box scanned with outward normals (corner points with their faces' mean): along its
    edges no splat stands out of the box by more than the convex slack (CONVEX_SLACK × r);
    seen from a little above, anything standing up past the top's edge hides a strip of the
    top, as the concave slack (EDGE_SLACK, 3 × as far) did. The corner points themselves,
    with no neighbour on their own surface, are cut too (they were whole discs, tilted out of
    the box by most of their radius); within a radius of a corner, where three faces' lines
    meet, splats still reach out up to half a radius (measured 0.46 r: an edge point beside
    the corner whose own face's neighbours all lie on the edge, so that its twin's plane, the
    other face's, cannot tell it a side)."""
    p, normals = welded_box(np.random.default_rng(6))
    frames = splats.splat_frames(p, normals)
    radius = np.median(frames["scale"][~frames["clipped"], 0])
    over = outside_reach(frames, p) / radius
    box_corners = np.array([[x, y, z] for x in (0, .3) for y in (0, .3) for z in (0, .3)])
    from_corner = np.linalg.norm(p[:, None] - box_corners[None], axis=2).min(1)
    along_edges = from_corner > radius
    assert np.all(over[along_edges] <= splats.CONVEX_SLACK * 1.02), over[along_edges].max()
    assert splats.CONVEX_SLACK < splats.EDGE_SLACK
    corners = np.flatnonzero(from_corner == 0)
    assert len(corners) == 8 and frames["clipped"][corners].all()
    assert over[corners].max() < 0.3


def test_near_a_corner_the_third_faces_plane_cuts_too():
    """The welded box scanned without normals: within a radius of a corner, where three faces
    meet, no splat reaches out of the box by more than 0.2 of its radius (EDGE_SLACK, and the
    estimated planes' tilt there). Cut only by the lines of the planes that clipped its
    neighbours, an ellipse whose neighbours none took the third face's plane reached over
    it (0.38 r here, 0.47 r on another jitter): the neighbours' own tangent planes cut too."""
    p, _ = welded_box(np.random.default_rng(7))
    frames = splats.splat_frames(p)
    radius = np.median(frames["scale"][~frames["clipped"], 0])
    over = outside_reach(frames, p) / radius
    box_corners = np.array([[x, y, z] for x in (0, .3) for y in (0, .3) for z in (0, .3)])
    from_corner = np.linalg.norm(p[:, None] - box_corners[None], axis=2).min(1)
    near = from_corner <= radius
    assert near.sum() > 40
    assert over[near].max() <= 0.2, over[near].max()


def test_a_point_on_a_crease_keeps_its_own_side():
    """A floor (z = 0, y > 0) meeting a wall (y = 0, z > 0) at a right angle, both scanned on
    jittered grids whose edge rows lie on the crease, normals estimated: no splat reaches
    past the other surface's plane by more than EDGE_SLACK of its radius (the slack that
    closes the slit along an edge). A point on the crease takes either surface's plane; a
    strip centred on it reached CREASE_WIDTH x r past the line, out of the other surface
    with this one's light (the bright rim along a lit box's top-front edge). Left out: the
    points none of whose nearest others has another plane (on the crease row, where every
    point took the same surface's plane, nothing tells them the line: their discs stay
    whole)."""
    rng = np.random.default_rng(11)
    uv = jittered(30, rng)
    uv[uv[:, 1] < 1 / 30, 1] = 0.0                     # the first row on the crease itself
    floor = np.column_stack([uv[:, 0], uv[:, 1], np.zeros(len(uv))])
    wall = np.column_stack([uv[:, 0], np.zeros(len(uv)), uv[:, 1]])
    p = np.concatenate([floor, wall])
    f = splats.splat_frames(p)
    n = f["normal"].astype(float)
    axis = f["axis"].astype(float)
    across = np.cross(n, axis)
    a, b = f["scale"][:, 0].astype(float), f["scale"][:, 1].astype(float)
    centre = p + f["offset"]
    inner = (p[:, 0] > 0.1) & (p[:, 0] < 0.9)          # away from the scan's open ends
    near = knn(p, p, splats.PREVIEW_NEIGHBOURS + 1)[0][:, 1:]
    inner &= (np.abs(np.einsum("ic,ikc->ik", n, n[near])) < splats.PREVIEW_EDGE_COS).any(1)
    for plane_axis, other in ((2, 1), (1, 2)):         # the floor's splats past y = 0, ...
        mine = inner & (np.abs(n[:, plane_axis]) > 0.99)
        reach = -(centre[mine, other] - np.hypot(a[mine] * axis[mine, other],
                                                 b[mine] * across[mine, other]))
        assert mine.sum() > 20                         # the points along the crease
        assert (reach / a[mine]).max() <= splats.EDGE_SLACK * (1 + 1e-4) + 1e-6
