"""Enclosed surfels (``illumap.sealing``): light reaches a surfel only along first hits, so a
pocket that no path of first hits joins to the sky or a lamp reads 0, whatever the kernel's
leaks, while open slots, however deep, keep their light.

The scenes are two-sided surfaces (both faces carry surfels and are lit, as an open mesh's
back surfels or a scan's points are) under a white sky, solved at the defaults (FMM, exact
visibility against the triangles). A sealed pocket's exact light is 0; 1e-3 is far below the
kernel's leak (0.01-0.2 without the first-hit rows, measured 2026-12-07) and far above
rounding. An open slot's light is whatever the operator gives it without the first-hit rows:
the check is that none of its surfels is enclosed and its light is unchanged.
"""

import numpy as np
import pytest

import illumap
from illumap import conservation, sampling, scenes, sealing
from illumap.receivers import MeshOccluders
from illumap_core_testing import requires_native

pytestmark = requires_native

RHO = 0.9


def _quad(origin, u, v, front):
    """Two triangles of the parallelogram origin + [0,1]u + [0,1]v, their front along
    ``front``."""
    o, u, v = (np.asarray(x, dtype=np.float64) for x in (origin, u, v))
    tris = np.array([[o, o + u, o + u + v], [o, o + u + v, o + v]])
    return tris if np.dot(np.cross(u, v), front) > 0 else tris[:, ::-1]


def _box(lo, hi, top=None):
    """A closed box's 12 triangles facing out; ``top`` (x0, x1): a slit in its top face."""
    lo, hi = np.asarray(lo, dtype=np.float64), np.asarray(hi, dtype=np.float64)
    ex, ey, ez = np.diag(hi - lo)
    faces = [_quad(lo, ey, ez, (-1, 0, 0)), _quad(lo + ex, ey, ez, (1, 0, 0)),
             _quad(lo, ex, ez, (0, -1, 0)), _quad(lo + ey, ex, ez, (0, 1, 0)),
             _quad(lo, ex, ey, (0, 0, -1))]
    if top is None:
        faces.append(_quad(lo + ez, ex, ey, (0, 0, 1)))
    else:
        a, b = top
        faces.append(_quad(lo + ez, (a - lo[0], 0, 0), ey, (0, 0, 1)))
        faces.append(_quad(lo + ez + (b - lo[0], 0, 0), (hi[0] - b, 0, 0), ey, (0, 0, 1)))
    return np.concatenate(faces)


def _two_sided(tris, count, seed=0):
    """Surfels on both faces of ``tris``: positions, normals, areas, front (bool)."""
    s = sampling.sample_triangles(tris, count, np.random.default_rng(seed))
    front = np.r_[np.ones(len(s.areas), bool), np.zeros(len(s.areas), bool)]
    return (np.r_[s.positions, s.positions], np.r_[s.normals, -s.normals],
            np.r_[s.areas, s.areas], front)


def _inside(p, lo, hi, margin=1e-6):
    return np.all((p > np.asarray(lo) + margin) & (p < np.asarray(hi) - margin), axis=1)


def _white_sky(tris, p, n, a, *, lamp_lit=None, enclose=True, triangles=None):
    """The white furnace at albedo RHO: radiosity (N,), the Hemisphere and the enclosed mask.
    ``triangles`` (N,): each surfel's triangle in ``tris`` (``hemisphere_hits``)."""
    occ = MeshOccluders(tris)
    h = conservation.hemisphere_hits(occ, p, n, links=True, triangles=triangles)
    enclosed = h.enclosed(lamp_lit) if enclose else None
    albedo = np.full((len(p), 3), RHO)
    emission = albedo * h.open[:, None]
    if lamp_lit is not None:
        emission[lamp_lit] += RHO
    s = illumap.Surfels(p, n, a, albedo, emission)
    sol = illumap.solve(s, tol=1e-8, visibility="exact", occluder_triangles=tris,
                        hemisphere_hits=h.hits, hemisphere_enclosed=enclosed,
                        hemisphere_links=h.links if enclose else None)
    assert sol.converged
    return sol.radiosity[:, 0], h, enclosed


PART_P = ((0.0, 0.0, 0.0), (1.0, 1.0, 1.0))
PART_Q = ((0.6, 0.2, 0.2), (1.6, 0.8, 0.8))


def test_a_pocket_between_intersecting_parts_is_dark():
    """Two intersecting closed parts, both faces lit: everything inside either (the inside
    faces, and the outside faces buried in the other part) is sealed, enclosed and reads 0;
    the outside reads what the same solve gives it without the first-hit rows."""
    tris = np.r_[_box(*PART_P), _box(*PART_Q)]
    p, n, a, front = _two_sided(tris, 3000)
    outside = front & ~_inside(p, *PART_P) & ~_inside(p, *PART_Q)
    b, h, enclosed = _white_sky(tris, p, n, a)
    assert not enclosed[outside].any()
    # A surfel none of whose linking rays found a surfel keeps its kernel row (never
    # enclosed); with its whole pocket dark around it, it stays dark too.
    assert enclosed[~outside].mean() > 0.99
    assert b[~outside].max() < 1e-3
    plain, _, _ = _white_sky(tris, p, n, a, enclose=False)
    assert plain[~outside].max() > 1e-2          # the kernel's leak, which this removes
    assert abs(b[outside].mean() / plain[outside].mean() - 1.0) < 0.01


def test_an_open_slot_keeps_its_light():
    """The same part with a 5 cm slit along its top, and a slot 5 cm wide and 1 m deep (20
    times its width): light reaches their insides within ``sealing.BOUNCES`` (the slot's
    bottom to 0.57, over five times ``sealing.THRESHOLD``), and no surfel of them is enclosed, so
    their rows are the kernel's."""
    tris = _box(*PART_P, top=(0.475, 0.525))
    p, n, a, front = _two_sided(tris, 3000)
    b, h, enclosed = _white_sky(tris, p, n, a)
    assert not enclosed.any()
    # Lit through the slit: a twentieth of the lid lets in about what a tenth absorbed per
    # bounce over six faces leaves, 0.05 / (6 × 0.1) ≈ 0.08 (0.069 measured).
    assert b[~front].min() > 0.02
    slot = np.concatenate([_quad((0, 0, 0), (0, 1, 0), (0, 0, 1), (1, 0, 0)),
                           _quad((0.05, 0, 0), (0, 1, 0), (0, 0, 1), (-1, 0, 0)),
                           _quad((0, 0, 0), (0.05, 0, 0), (0, 1, 0), (0, 0, 1)),
                           _quad((0, 0, 0), (0.05, 0, 0), (0, 0, 1), (0, 1, 0)),
                           _quad((0, 1, 0), (0.05, 0, 0), (0, 0, 1), (0, -1, 0))])
    p, n, a, front = _two_sided(slot, 4000, seed=1)
    occ = MeshOccluders(slot)
    h = conservation.hemisphere_hits(occ, p, n, links=True)
    inner = np.einsum("ij,ij->i", n, [0.025, 0.5, 0.5] - p) > 0   # facing into the slot
    assert not h.enclosed()[inner].any()
    r = sealing.reach(h.links, h.open, np.zeros(len(p), bool))
    assert r[inner & (p[:, 2] < 0.1)].min() > sealing.THRESHOLD


def test_a_lamp_inside_a_closed_part_lights_it():
    """A closed part lit inside (its inside surfels near the floor see a lamp) is not sealed:
    the lamp-lit surfels are sources and every inside surfel is reached from them."""
    tris = _box(*PART_P)
    p, n, a, front = _two_sided(tris, 3000)
    lamp_lit = ~front & (p[:, 2] > 0.999)        # the inside of the lid
    b, h, enclosed = _white_sky(tris, p, n, a, lamp_lit=lamp_lit)
    assert not enclosed[~front].any()
    assert b[~front & (p[:, 2] < 1e-6)].min() > 0.1 * RHO
    _, _, dark = _white_sky(tris, p, n, a)
    assert not dark[front].any() and dark[~front].mean() > 0.99   # without the lamp: sealed


def test_links_spread_each_share_over_the_resolved_rays():
    """Each surfel's row of the first-hit transport sums to its hit share over the rays that
    found a surfel; a surfel none of whose rays did has an empty row and is not known."""
    src = np.array([0, 0, 0, 1, 1, 2])
    dst = np.array([1, 1, 2, -1, -1, 0])
    w = sealing.links(src, dst, np.array([0.6, 0.5, 0.3]))
    rows = np.bincount(w.rows, w.weights, minlength=3)
    assert np.allclose(rows, [0.6, 0.0, 0.3], rtol=0, atol=1e-15)
    assert np.allclose(w.apply(np.array([0.0, 1.0, 0.0])), [0.4, 0.0, 0.0])
    assert w.known.tolist() == [True, False, True]
    # Reach: 2 sees the sky (0.05, under the threshold) and 0 (0.3); 0 sees 2 (0.2) and 1
    # (0.4), which sees nothing: r0 = 0.2 r2, r2 = 0.05 + 0.3 r0.
    sky = np.array([0.0, 0.0, 0.05])
    r = sealing.reach(w, sky, np.zeros(3, bool))
    assert np.allclose(r, [0.01 / 0.94, 0.0, 0.05 + 0.3 * 0.01 / 0.94], rtol=1e-12, atol=0)
    # 1 is under the threshold but not known; 0 and 2 are enclosed.
    assert sealing.enclosed(w, sky, np.zeros(3, bool)).tolist() == [True, False, True]
    # A surfel that sees enough sky, or a source, holds 1.
    assert np.allclose(sealing.reach(w, np.array([0.0, 0.0, 0.7]), np.zeros(3, bool)),
                       [0.2, 0.0, 1.0], rtol=1e-12, atol=0)
    assert np.allclose(sealing.reach(w, np.zeros(3), np.array([False, True, False])),
                       [0.4 / 0.94, 1.0, 0.3 * 0.4 / 0.94], rtol=1e-12, atol=0)


def test_enclosed_without_links_are_sealed():
    """Enclosed surfels given without first-hit links are sealed: their rows and columns of
    the operator are 0, so nothing reaches them and they send nothing; the other rows keep
    their shares (the scaled kernel over the open surfels)."""
    s = scenes.closed_box(6)
    hits = np.ones(s.n)
    enclosed = np.zeros(s.n, dtype=bool)
    enclosed[::3] = True
    op = illumap.TransportOperator(s, hemisphere_hits=hits, hemisphere_enclosed=enclosed)
    y = op.apply(np.ones((s.n, 3)))[:, 0]
    assert np.all(y[enclosed] == 0.0)
    assert np.allclose(y[~enclosed], 1.0, rtol=1e-9, atol=0)
    x = np.zeros((s.n, 3))
    x[enclosed] = 1.0
    assert np.all(op.apply(x) == 0.0)
    assert op.stats["hemisphere_enclosed"] == int(enclosed.sum())


def test_enclosed_input_is_checked():
    s = scenes.closed_box(4)
    with pytest.raises(illumap.InputError, match="hemisphere_enclosed"):
        illumap.TransportOperator(s, hemisphere_hits=np.ones(s.n),
                                  hemisphere_enclosed=np.zeros(s.n - 1, dtype=bool))
    with pytest.raises(illumap.InputError, match="hemisphere_links"):
        illumap.TransportOperator(s, hemisphere_hits=np.ones(s.n),
                                  hemisphere_enclosed=np.zeros(s.n, dtype=bool),
                                  hemisphere_links=object())




#: The eye's lid crosses the head's top at x = EYE_CROSS and rises EYE_DEGREES off it.
EYE_CROSS, EYE_DEGREES = 0.65, 6.0


def _tilted_eye():
    """A closed part (the eye) under the first one's top (the head), turned ``EYE_DEGREES``
    about the y axis through (``EYE_CROSS``, y, 1): its lid crosses the head's top there and
    rises 5 mm over it at x = 0.7, as an eyeball's surface leaves its socket."""
    tris = _box((0.3, 0.3, 0.5), (0.7, 0.7, 1.0))
    t = np.radians(EYE_DEGREES)
    rot = np.array([[np.cos(t), 0.0, -np.sin(t)], [0.0, 1.0, 0.0], [np.sin(t), 0.0, np.cos(t)]])
    centre = np.array([EYE_CROSS, 0.0, 1.0])
    return (tris - centre) @ rot.T + centre


def test_a_socket_under_an_eyes_rim_is_dark():
    """The wedge between the head's top and the lid of an eye that rises out of it: the
    socket's rays hit the lid's underside a few mm off, where the eye's surfels that face
    them lie beyond the crossing, inside the head, and the path to them crosses the head's
    top: no surfel sees those hits (Suzanne's sockets, 0.7 against Cycles' 0.002). They go to the lid's own nearest
    surfel facing them, enclosed along the hits that surfels see (``Links.spare``), and the
    socket is sealed: it reads 0, not its kernel rows' leak. Outside, nothing is enclosed."""
    head, eye = _box(*PART_P), _tilted_eye()
    tris = np.r_[head, eye]
    rng = np.random.default_rng(0)
    sh = sampling.sample_triangles(head, 12000, rng)
    se = sampling.sample_triangles(eye, 800, rng)
    p1 = np.r_[sh.positions, se.positions]
    n1 = np.r_[sh.normals, se.normals]
    a1 = np.r_[sh.areas, se.areas]
    t1 = np.r_[sh.triangle, se.triangle + len(head)]
    p, n, a, t = np.r_[p1, p1], np.r_[n1, -n1], np.r_[a1, a1], np.r_[t1, t1]
    front = np.r_[np.ones(len(p1), bool), np.zeros(len(p1), bool)]
    # The lid's underside over the socket carries no surfel: every one facing the socket's
    # hits lies beyond the crossing (the two faces of a wedge without surfels on one of
    # them see none of each other's hits, and neither is known: not handled here).
    keep = front | (t < len(head)) | (p[:, 2] < 1.0)
    p, n, a, t, front = p[keep], n[keep], a[keep], t[keep], front[keep]
    socket = ((t < len(head)) & (p[:, 0] > EYE_CROSS + 0.005) & (p[:, 0] < 0.695)
              & (p[:, 1] > 0.305) & (p[:, 1] < 0.695) & (np.abs(p[:, 2] - 1.0) < 1e-9)
              & (n[:, 2] > 0.5))
    assert socket.sum() > 20
    b, h, enclosed = _white_sky(tris, p, n, a, triangles=t)
    assert enclosed[socket].mean() > 0.95
    assert np.median(b[socket]) < 1e-3
    lit = front & (h.open > 0.5)
    assert not enclosed[lit].any()
    assert b[lit].min() > 0.5 * RHO


def test_triangle_parts_join_triangles_through_shared_corners():
    """Two boxes apart and a third quad touching the second box at one corner: two parts."""
    a, b = _box((0, 0, 0), (1, 1, 1)), _box((2, 0, 0), (3, 1, 1))
    c = _quad((3, 1, 1), (1, 0, 0), (0, 1, 0), (0, 0, 1))
    label = sealing.triangle_parts(np.r_[a, b, c])
    assert len(np.unique(label[:12])) == 1 and len(np.unique(label[12:])) == 1
    assert label[0] != label[12]
