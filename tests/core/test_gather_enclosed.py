"""The gather keeps sealed surfels dark (``illumap.gather.straddling``): an open part's
back surfel whose light reaches it only along first hits (``Solved.enclosed``) keeps its solved
value, even where its disc reaches through another surface and the gather re-evaluates the
surfels there; a sealed front surfel that the gather re-evaluates takes no light from a lit
surfel behind a triangle (the field's lookup, ``SurfelField.at``, where no neighbour that faces
the hit's surface sees it).

The scene: an open box (two-sided, both faces carry surfels, as an open mesh's back surfels
do) that is geometrically closed, with a two-sided plate pushed through one wall, under a
white sky at albedo 0.9 (``illumap.run``'s stages from plain data, default settings). No
path reaches the box's inside: its walls' inner faces and the plate's underside within read
exactly 0. 1e-3 is far above rounding and far below what re-gathering those that straddle
the plate or a wall gave them (0.010, 0.157 and 0.298 on these seeds, measured 2026-12-07), or
what the plate's sealed upper face read where the lookup fell back to the nearest surfel
whatever its side (0.114 and 0.0074 on seeds 0 and 1, measured 2026-12-08).
"""

from __future__ import annotations

import numpy as np
import pytest

import illumap
from illumap import lights
from illumap.settings import Settings
from illumap.stages import passes
from illumap.stages.light import light
from illumap.stages.scene import Receivers, Scene, Source

pytestmark = pytest.mark.skipif(not illumap.native_available(), reason="needs the native core")

RHO = 0.9
SPACING = 0.08                   # m between surfels, about


def _quad(origin, u, v, front) -> np.ndarray:
    """Two triangles (2, 3, 3) of the parallelogram origin + [0,1]u + [0,1]v, facing
    ``front``."""
    o, u, v = (np.asarray(x, dtype=np.float64) for x in (origin, u, v))
    tris = np.array([[o, o + u, o + u + v], [o, o + u + v, o + v]])
    return tris if np.dot(np.cross(u, v), front) > 0 else tris[:, ::-1]


def _unit_box() -> np.ndarray:
    """The unit cube's 12 triangles facing out."""
    ex, ey, ez = np.eye(3)
    zero = np.zeros(3)
    return np.concatenate([_quad(zero, ey, ez, -ex), _quad(ex, ey, ez, ex),
                           _quad(zero, ex, ez, -ey), _quad(ey, ex, ez, ey),
                           _quad(zero, ex, ey, -ez), _quad(ez, ex, ey, ez)])


def _surfels(tris: np.ndarray, rng: np.random.Generator):
    """Random surfels about SPACING apart on each triangle: positions, unit normals, areas
    and each one's triangle."""
    pos, nrm, area, tri = [], [], [], []
    for k, t in enumerate(tris):
        cross = np.cross(t[1] - t[0], t[2] - t[0])
        a = 0.5 * np.linalg.norm(cross)
        m = max(1, round(a / SPACING ** 2))
        s, r = np.sqrt(rng.random(m)), rng.random(m)
        pos.append(t[0] + (s * (1 - r))[:, None] * (t[1] - t[0]) + (s * r)[:, None] * (t[2] - t[0]))
        nrm.append(np.tile(cross / (2 * a), (m, 1)))
        area.append(np.full(m, a / m))
        tri.append(np.full(m, k, dtype=np.int64))
    return np.concatenate(pos), np.concatenate(nrm), np.concatenate(area), np.concatenate(tri)


def _plate_through_open_box(seed: int) -> Scene:
    """The unit box, open (two-sided), and a 1.2 × 0.6 m plate at height 0.5 from x = 0.4
    inside it to x = 1.6 outside, both faces of each carrying surfels (MESH then BACK rows);
    white world; receivers on the plate's upper face inside and outside the box."""
    rng = np.random.default_rng(seed)
    box = _unit_box()
    plate = _quad((0.4, 0.2, 0.5), (1.2, 0.0, 0.0), (0.0, 0.6, 0.0), (0.0, 0.0, 1.0))
    bp, bn, ba, bt = _surfels(box, rng)
    pp, pn, pa, pt = _surfels(plate, rng)
    nb, npl = len(ba), len(pa)
    pos, nrm = np.r_[bp, pp, bp, pp], np.r_[bn, pn, -bn, -pn]
    area, tri = np.r_[ba, pa, ba, pa], np.r_[bt, pt, bt, pt]
    n = len(area)
    sources = (Source("Box", "MESH", 0, nb, 6.0), Source("Plate", "MESH", nb, nb + npl, 0.72),
               Source("Box", "BACK", nb + npl, 2 * nb + npl, 6.0),
               Source("Plate", "BACK", 2 * nb + npl, n, 0.72))
    world = lights.Lamp("World", "WORLD", np.ones(3), np.zeros(3), np.array([0.0, 0.0, -1.0]))
    xs = np.array([0.5, 0.7, 0.9, 0.95, 1.05, 1.1, 1.3, 1.5])
    points = np.column_stack([xs, np.full(len(xs), 0.513), np.full(len(xs), 0.5)])
    m = len(xs)
    rec = Receivers("Plate", np.arange(m), points, np.tile([0.0, 0.0, 1.0], (m, 1)),
                    np.full((m, 3), RHO), np.zeros((m, 3)), m)
    return Scene(settings=Settings(), positions=pos, normals=nrm, areas=area,
                 albedo=np.full((n, 3), RHO), emission=np.zeros((n, 3)),
                 solve_emission=np.zeros((n, 3)), sources=sources, world=world, triangle=tri,
                 bary=np.full((n, 3), 1 / 3), uv=np.full((n, 2), np.nan),
                 material_index=np.zeros(n, dtype=np.int64),
                 triangles=np.concatenate([box, plate]), two_sided=np.ones(14, dtype=bool),
                 mesh_triangle_start=np.array([0, 12]), receivers=(rec,))


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_sealed_surfels_stay_dark_where_the_gather_re_evaluates_their_neighbours(seed):
    """Every surfel inside the box (the walls' inner faces, both faces of the plate within)
    is sealed and solves to 0; after the gather (which re-evaluates the surfels whose disc
    reaches through the plate or a wall) each still reads 0; the plate's receivers inside
    read 0 and those outside are lit."""
    scene = _plate_through_open_box(seed)
    solved = passes.solve_lit(light(scene))
    rows = np.arange(scene.count)
    walls = (rows >= scene.sources[2].start) & (rows < scene.sources[2].stop)   # inner faces
    inside = np.all((scene.positions > 1e-6) & (scene.positions < 1 - 1e-6), axis=1)
    on_plate = (rows >= scene.sources[1].start) & (rows < scene.sources[1].stop)
    sealed = (walls | (inside & (rows >= scene.sources[3].start))    # and the plate's underside
              | (inside & on_plate))                                # and its upper face
    assert solved.radiosity[sealed].max() < 1e-3
    gathered = passes.gather(solved)
    assert gathered.radiosity[sealed].max() < 1e-3
    plate = gathered.corners["Plate"][:, 0]
    assert plate[:4].max() < 1e-3
    assert plate[4:].min() > 0.5


def _slab(x0, x1, y0, y1, z0, z1) -> np.ndarray:
    """The closed box [x0, x1] × [y0, y1] × [z0, z1]'s 12 triangles facing out."""
    size = np.array([x1 - x0, y1 - y0, z1 - z0])
    return _unit_box() * size + np.array([x0, y0, z0])


def test_a_field_of_light_does_not_reach_under_an_overhanging_rim():
    """A floor of surfels 1 cm apart, dark (0) under a solid slab that overhangs it 1 mm up
    (x < 0), lit (1) beside it. A point on the floor 1 mm beside the slab's edge is lit: in a
    field of light (``light_field``) each of its neighbours is seen along a segment lifted
    a quarter of their distance, which meets the slab's side for those under it, so it reads
    exactly the lit surfels' 1; the plain field's segments, lifted by the offset only, pass
    under the slab and blend the dark ones in. Points under the slab read 0 either way."""
    from illumap import receivers as rc
    g = (np.arange(20) - 9.5) * 0.01
    x, y = np.meshgrid(g, g, indexing="ij")
    pos = np.column_stack([x.ravel(), y.ravel(), np.zeros(x.size)])
    nrm = np.tile([0.0, 0.0, 1.0], (len(pos), 1))
    values = np.repeat((pos[:, 0] > 0).astype(float)[:, None], 3, axis=1)
    occ = rc.MeshOccluders(_slab(-0.2, 0.0, -0.2, 0.2, 0.001, 0.01), offset=1e-4)
    beside = np.column_stack([np.full(5, 0.001), np.linspace(-0.04, 0.04, 5), np.zeros(5)])
    under = beside - np.array([0.05, 0.0, 0.0])
    up = np.tile([0.0, 0.0, 1.0], (5, 1))
    light = rc.SurfelField(pos, nrm, values, light_field=True)
    plain = rc.SurfelField(pos, nrm, values)
    np.testing.assert_allclose(light.at(beside, up, occ), 1.0, atol=1e-12)
    assert plain.at(beside, up, occ).max() < 0.9
    assert light.at(under, up, occ).max() < 1e-12
    assert plain.at(under, up, occ).max() < 1e-12
