"""Precision independent of placement: the same scene gives the same light wherever it sits,
at any scale, and with a far outlier beside it (docs/stability.md, "Placement and scale").

The kernel only sees differences of positions, the native core stores coordinates against the
median of the scene (operator and ray scenes alike; the operator's snapped to a power of two as
coarse as the bulk's spread, so that a few surfels more leave it as it is), ray offsets follow
the size of the bulk of the scene rather than its bounding box, surfels whose planes lie within
rounding of each other (the two sides of one open surface) are in contact and exchange no
light, and each octree node is split by its own points' box, so that a cluster of surfels gets
the same cells, lists and visibility samples whatever lies far from it.
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


def box_triangles(lo, hi, inward):
    """The 12 triangles of an axis-aligned box, wound so that their normals face in (or out)."""
    lo, hi = np.asarray(lo, float), np.asarray(hi, float)
    c = np.array([[lo[0] if i & 1 == 0 else hi[0], lo[1] if i & 2 == 0 else hi[1],
                   lo[2] if i & 4 == 0 else hi[2]] for i in range(8)])
    quads = [(0, 2, 6, 4), (1, 5, 7, 3), (0, 4, 5, 1), (2, 3, 7, 6), (0, 1, 3, 2), (4, 6, 7, 5)]
    tri = []
    for a, b, cc, d in quads:        # wound for inward normals
        tri += [(a, b, cc), (a, cc, d)]
    tri = c[np.array(tri)]
    return tri if inward else tri[:, ::-1]


def mesh_room():
    """A closed 4 × 3 × 2.5 m room with a block standing on its floor and a 1 m² light in its
    ceiling, sampled as the add-on samples meshes: (surfels, their triangles as occluders)."""
    from illumap.sampling import sample_triangles
    tri = np.concatenate([box_triangles((0, 0, 0), (4, 3, 2.5), True),
                          box_triangles((1.2, 0.8, 0), (2.2, 1.8, 1.2), False)])
    smp = sample_triangles(tri, 2500, np.random.default_rng(5))
    p = smp.positions
    light = (p[:, 2] > 2.5 - 1e-9) & (np.abs(p[:, 0] - 2.6) < 0.5) & (np.abs(p[:, 1] - 1.5) < 0.5)
    emission = np.zeros((len(p), 3))
    emission[light] = (5.0, 4.0, 3.0)
    albedo = np.full((len(p), 3), 0.7)
    albedo[light] = 0.0
    return illumap.Surfels(p, smp.normals, smp.areas, albedo, emission), tri


def far_patch(at, facing):
    """A 1 cm square of 2 × 2 surfels at ``at`` facing ``facing`` (albedo 0.5): its two
    triangles and its surfel arrays."""
    f = np.asarray(facing, float) / np.linalg.norm(facing)
    u = np.cross(f, [0.0, 0.0, 1.0] if abs(f[2]) < 0.9 else [1.0, 0.0, 0.0])
    u /= np.linalg.norm(u)
    v = np.cross(f, u)
    pos = np.array([at + 0.005 * (a * u + b * v) for a in (-0.5, 0.5) for b in (-0.5, 0.5)])
    corners = [at + 0.005 * (a * u + b * v) for a, b in ((-1, -1), (1, -1), (1, 1), (-1, 1))]
    tri = np.array([[corners[0], corners[1], corners[2]], [corners[0], corners[2], corners[3]]])
    return pos, np.tile(f, (4, 1)), np.full(4, 0.25e-4), tri


ROOM_CASES = {"plate": {}, "room": {}, "room-discs": dict(visibility="exact"),
              "room-triangles": dict(visibility="exact")}


def room_case(case):
    if case == "plate":
        pos, nrm, area, albedo, emission, _ = plate_scene()
        return illumap.Surfels(pos, nrm, area, albedo, emission), None
    s, tri = mesh_room()
    return s, (tri if case == "room-triangles" else None)


@pytest.mark.parametrize("case", list(ROOM_CASES))
def test_a_far_object_does_not_change_the_room(case):
    """A 1 cm object 1e2…1e8 m away, facing the room (so it takes and returns a little light),
    listed after the room's surfels or before them, changes no surfel of the room by more than
    1e-9 of the room's brightest non-emitting surfel, with exact visibility (the surfels as discs,
    or the room's triangles) and without: each octree node is split by its own points' box, so
    the room's cells, lists, visibility samples and sums are those it has alone; only the far
    object's own light is added (measured: at most 5e-13). (Cells against the scene's bounding
    cube moved a surfel of the room by up to 0.35% of that maximum without visibility and 35%
    with it: other cells sampled visibility elsewhere.)"""
    s, tri = room_case(case)
    kw = dict(ROOM_CASES[case], method="fmm", order=4, theta=0.5, tol=1e-10)
    occ = {} if tri is None else dict(occluder_triangles=tri)
    base = np.asarray(illumap.solve(s, **kw, **occ).radiosity)
    lit = ~(s.emission.max(axis=1) > 0)
    assert base[lit].max() > 0.01
    centre = np.median(s.positions, axis=0)
    direction = np.array([0.8, 0.36, 0.48])
    for far in (1e2, 1e4, 1e6, 1e8):
        pos, nrm, area, ftri = far_patch(centre + far * direction, -direction)
        for first in (False, True):
            def join(room, extra):
                return np.concatenate([extra, room] if first else [room, extra])
            q = illumap.Surfels(join(s.positions, pos), join(s.normals, nrm), join(s.areas, area),
                                join(s.albedo, np.full((4, 3), 0.5)),
                                join(s.emission, np.zeros((4, 3))))
            occ = {} if tri is None else dict(occluder_triangles=join(tri, ftri))
            got = np.asarray(illumap.solve(q, **kw, **occ).radiosity)
            got = got[4:] if first else got[:-4]
            assert np.abs(got - base).max() <= 1e-9 * base[lit].max(), (far, first)


@pytest.mark.parametrize("visibility", ["none", "exact"])
def test_a_far_surfel_leaves_the_operator_as_it_is(visibility):
    """K x at the room's surfels is the same to the bit with one more surfel 1e4 m away that
    sends nothing: the room's octree cells, interaction lists, visibility samples and sums,
    and the origin the core measures positions from, do not depend on it."""
    s, _ = mesh_room()
    x = np.random.default_rng(2).random((s.n, 3))
    op = illumap.TransportOperator(s, method="fmm", order=4, theta=0.5, visibility=visibility)
    y = np.asarray(op.apply(x))
    q = illumap.Surfels(np.vstack([s.positions, [1e4, 2e3, 5e3]]),
                        np.vstack([s.normals, [0, 0, 1.0]]),
                        np.append(s.areas, 1e-4), np.vstack([s.albedo, [0.5] * 3]),
                        np.vstack([s.emission, [0.0] * 3]))
    op2 = illumap.TransportOperator(q, method="fmm", order=4, theta=0.5, visibility=visibility)
    assert op2.stats["nodes"] > op.stats["nodes"]
    y2 = np.asarray(op2.apply(np.vstack([x, np.zeros((1, 3))])))[:-1]
    assert np.array_equal(y, y2)


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
