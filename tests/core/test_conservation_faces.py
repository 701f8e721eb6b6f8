"""What a mesh surfel's hemisphere holds, as a renderer sees it (``illumap.conservation``,
``illumap.sealing``, ``illumap.TransportOperator``):

* a smooth (shading) normal tilted off its triangle sends nothing below the triangle: Cycles
  drops those directions, and so does the corner gather, so the solve must too (without it
  the smooth Suzanne's surfels kept light that Cycles' lose, and only the kernel's leaks
  into sealed pockets had made up for it);
* an open surfel's row couples to enclosed surfels only as much as its first hits meet
  them: the kernel's leaks across an intersection line or through the surface a surfel
  stands on no longer darken it.

Exact cases: the share of a cosine-weighted hemisphere tilted by α that lies below a plane
is (1 − cos α)/2 (the view factor of a tilted element to the half-space behind it).
"""

import numpy as np
import pytest

import illumap
from illumap import conservation, sampling, sealing
from illumap.receivers import MeshOccluders
from illumap_core_testing import requires_native

pytestmark = requires_native


def _ground(half=100.0):
    """A horizontal square at z = 0 facing up, two triangles."""
    a, b, c, d = ([-half, -half, 0.0], [half, -half, 0.0], [half, half, 0.0],
                  [-half, half, 0.0])
    return np.array([[a, b, c], [a, c, d]], dtype=np.float64)


@pytest.mark.parametrize("tilt_deg", [20.0, 40.0, 60.0])
def test_rays_below_the_face_are_neither_hits_nor_open(tilt_deg):
    """Surfels on a face (z = 0, up) whose shading normals lean ``tilt_deg`` off it, under
    an open sky: without the face every ray below it meets the face itself (a hit), with it
    those rays are dropped, and the open share is (1 + cos α)/2 exactly (lattice error of
    64 rays over 200 surfels: ≤ 0.01 on the mean)."""
    tris = _ground()
    occ = MeshOccluders(tris)
    rng = np.random.default_rng(3)
    m = 200
    p = np.column_stack([rng.uniform(-1, 1, m), rng.uniform(-1, 1, m), np.zeros(m)])
    a = np.radians(tilt_deg)
    phi = rng.uniform(0, 2 * np.pi, m)
    n = np.column_stack([np.sin(a) * np.cos(phi), np.sin(a) * np.sin(phi),
                         np.full(m, np.cos(a))])
    faces = np.tile([0.0, 0.0, 1.0], (m, 1))
    below = 0.5 * (1.0 - np.cos(a))
    plain = conservation.hemisphere_hits(occ, p, n)
    assert abs(plain.hits.mean() - below) < 0.01            # the face itself, met
    dropped = conservation.hemisphere_hits(occ, p, n, faces=faces)
    assert dropped.hits.max() == 0.0
    assert abs(dropped.open.mean() - (1.0 - below)) < 0.01
    # A surfel without a face (a scan's point: 0) keeps its whole hemisphere.
    none = conservation.hemisphere_hits(occ, p, n, faces=np.zeros((m, 3)))
    assert np.array_equal(none.hits, plain.hits) and np.array_equal(none.open, plain.open)


def test_linking_rays_below_the_face_meet_nothing():
    """The first-hit links take the same rays: below the face they link no surfel (a
    surfel on the face would otherwise take its own face's hits)."""
    tris = _ground(2.0)
    s = sampling.sample_triangles(tris, 400, np.random.default_rng(1))
    a = np.radians(45.0)
    n = np.tile([np.sin(a), 0.0, np.cos(a)], (len(s.areas), 1))
    occ = MeshOccluders(tris)
    h = conservation.hemisphere_hits(occ, s.positions, n, links=True)
    w = h.linker(np.arange(len(s.areas)))
    assert len(w.rows) > 0                                  # without the face: own hits
    hf = conservation.hemisphere_hits(occ, s.positions, n, links=True,
                                      faces=np.tile([0.0, 0.0, 1.0], (len(s.areas), 1)))
    wf = hf.linker(np.arange(len(s.areas)))
    assert len(wf.rows) == 0


def _box(lo, hi):
    """A closed box's 12 triangles facing out."""
    lo, hi = np.asarray(lo, dtype=np.float64), np.asarray(hi, dtype=np.float64)
    ex, ey, ez = np.diag(hi - lo)

    def quad(o, u, v, front):
        t = np.array([[o, o + u, o + u + v], [o, o + u + v, o + v]])
        return t if np.dot(np.cross(u, v), front) > 0 else t[:, ::-1]
    return np.concatenate([quad(lo, ey, ez, (-1, 0, 0)), quad(lo + ex, ey, ez, (1, 0, 0)),
                           quad(lo, ex, ez, (0, -1, 0)), quad(lo + ey, ex, ez, (0, 1, 0)),
                           quad(lo, ex, ey, (0, 0, -1)), quad(lo + ez, ex, ey, (0, 0, 1))])


def test_open_rows_couple_to_enclosed_surfels_as_their_first_hits_do():
    """Two intersecting closed parts with both faces lit (an eyeball pushed into a head):
    their insides are enclosed. Every open row of the operator couples to the enclosed
    surfels exactly its first hits' share of them (its links), and its row over the open
    surfels carries the rest of its hit share. Before, the kernel leaked across the
    intersection line: 251 of the 2,451 open rows sent over 0.1% into the sealed insides,
    up to 28% (measured 2026-12-07), where their links send nothing."""
    tris = np.r_[_box((0, 0, 0), (1, 1, 1)), _box((0.6, 0.2, 0.2), (1.6, 0.8, 0.8))]
    s = sampling.sample_triangles(tris, 3000, np.random.default_rng(0))
    p = np.r_[s.positions, s.positions]
    n = np.r_[s.normals, -s.normals]
    a = np.r_[s.areas, s.areas]
    h = conservation.hemisphere_hits(MeshOccluders(tris), p, n, links=True)
    enclosed = h.enclosed()
    assert enclosed.sum() > 0.4 * len(p)
    albedo = np.full((len(p), 3), 0.9)
    op = illumap.TransportOperator(illumap.Surfels(p, n, a, albedo, np.zeros_like(albedo)),
                                   visibility="exact", occluder_triangles=tris,
                                   hemisphere_hits=h.hits, hemisphere_enclosed=enclosed,
                                   hemisphere_links=h.links)
    e = enclosed.astype(np.float64)
    w = h.links
    take = enclosed[w.cols] & ~enclosed[w.rows]
    share = np.bincount(w.rows[take], w.weights[take], minlength=len(p))
    to_enclosed = op.apply(np.repeat(e[:, None], 3, axis=1))[:, 0]
    opened = ~enclosed
    assert np.allclose(to_enclosed[opened], share[opened], rtol=0, atol=1e-12)
    rows = op.apply(np.ones((len(p), 3)))[:, 0]
    assert np.all(rows[opened] <= h.hits[opened] + 1e-9)
