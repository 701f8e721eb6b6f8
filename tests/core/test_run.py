"""``illumap.run`` without Blender: a scene built as plain data goes light → solve → gather and
returns values (``Scene`` → ``Lit`` → ``Solved`` → ``Gathered``), checked against closed forms:

* a receiver under an emitting unit square at height 1 (DESIGN.md §4, point over square:
  F = 0.23945): its light is ρ L F, nothing else reaches it;
* the inside of a closed cube with uniform emission E and albedo ρ (a furnace): every surfel
  and every receiver on its walls reads E / (1 − ρ).

And the stages as values: a stage writes into none of its inputs, the gather gives the same
values twice, and the one pass loop asks for a second pass only where the scene has one.
"""

from __future__ import annotations

import hashlib

import numpy as np
import pytest

import illumap
from illumap import lights
from illumap.scenes import POINT_OVER_SQUARE_F
from illumap.settings import Settings
from illumap.stages import passes
from illumap.stages.light import light
from illumap.stages.scene import Receivers, Scene, Source

pytestmark = pytest.mark.skipif(not illumap.native_available(), reason="needs the native core")


def _square(lo: float, hi: float, z: float, up: bool) -> np.ndarray:
    """Two triangles (2, 3, 3) of the square [lo, hi]² at height z, wound to face +z (``up``)
    or −z."""
    a, b, c, d = ([lo, lo, z], [hi, lo, z], [hi, hi, z], [lo, hi, z])
    tri = np.array([[a, b, c], [a, c, d]], dtype=np.float64)
    return tri if up else tri[:, ::-1]


def _grid_surfels(lo: float, hi: float, z: float, n: int):
    """n × n midpoint surfels of the square [lo, hi]² at height z facing +z, with the
    triangle of ``_square`` each lies in."""
    s = lo + (np.arange(n) + 0.5) * (hi - lo) / n
    x, y = np.meshgrid(s, s, indexing="ij")
    pos = np.column_stack([x.ravel(), y.ravel(), np.full(n * n, z)])
    nrm = np.tile([0.0, 0.0, 1.0], (n * n, 1))
    area = np.full(n * n, ((hi - lo) / n) ** 2)
    triangle = np.where(pos[:, 0] - lo >= pos[:, 1] - lo, 0, 1).astype(np.int64)
    return pos, nrm, area, triangle


def _receivers(name: str, points: np.ndarray, normals: np.ndarray, albedo: float) -> Receivers:
    m = len(points)
    return Receivers(name, np.arange(m, dtype=np.int64), points, normals,
                     np.full((m, 3), albedo), np.zeros((m, 3)), m)


def _floor_under_emitter(rho: float = 0.5, radiance: float = 2.0) -> Scene:
    """A 4 × 4 m floor (one-sided, albedo ``rho``) under an emitting unit square at height 1
    facing down (a lamp of ``radiance``), a receiver at the floor's centre."""
    pos, nrm, area, triangle = _grid_surfels(-2.0, 2.0, 0.0, 40)
    n = len(area)
    emitter = lights.mesh_light("Emitter", _square(-0.5, 0.5, 1.0, up=False),
                                np.full((2, 3), radiance), two_sided=False)
    centre = np.array([[1e-3, 2e-3, 0.0]])
    return Scene(settings=Settings(), positions=pos, normals=nrm, areas=area,
                 albedo=np.full((n, 3), rho), emission=np.zeros((n, 3)),
                 solve_emission=np.zeros((n, 3)),
                 sources=(Source("Floor", "MESH", 0, n, 16.0),), emitters=(emitter,),
                 triangle=triangle, bary=np.full((n, 3), 1 / 3), uv=np.full((n, 2), np.nan),
                 material_index=np.zeros(n, dtype=np.int64),
                 triangles=_square(-2.0, 2.0, 0.0, up=True), two_sided=np.zeros(2, dtype=bool),
                 mesh_triangle_start=np.array([0]),
                 receivers=(_receivers("Floor", centre, np.array([[0.0, 0.0, 1.0]]), rho),))


def _form_factor(x: float, y: float, cells: int = 2000) -> float:
    """View factor from a point (x, y, 0) facing +z to the unit square centred at height 1,
    by the midpoint rule: F = ∫ cos θ cos θ' / (π r²) dA = ∫ 1 / (π r⁴) dA."""
    s = -0.5 + (np.arange(cells) + 0.5) / cells
    gx, gy = np.meshgrid(s, s)
    r2 = (gx - x) ** 2 + (gy - y) ** 2 + 1.0
    return float((1.0 / (np.pi * r2 ** 2)).sum() / cells ** 2)


def _digest(*arrays) -> str:
    h = hashlib.sha256()
    for a in arrays:
        h.update(np.ascontiguousarray(a).tobytes())
    return h.hexdigest()


def test_a_receiver_under_an_emitting_square_reads_rho_l_f():
    """Point over square (DESIGN.md §4): nothing but the square lights the floor, whose
    light the square does not return (it is a lamp of albedo 0), so the centre reads
    ρ L F to the exactness of Lambert's polygon formula."""
    rho, radiance = 0.5, 2.0
    got = illumap.run(_floor_under_emitter(rho, radiance))
    assert isinstance(got, illumap.Gathered)
    value = got.corners["Floor"]
    assert value.shape == (1, 3)
    np.testing.assert_allclose(value, rho * radiance * POINT_OVER_SQUARE_F, rtol=2e-4)
    # The four surfels nearest the centre, at (±0.05, ±0.05), read ρ L F there (F by the
    # midpoint rule over the square, 2000² cells: 1e-7 relative); nothing is negative.
    below = np.linalg.norm(got.scene.positions[:, :2], axis=1) < 0.08
    assert below.sum() == 4
    np.testing.assert_allclose(got.radiosity[below], rho * radiance * _form_factor(0.05, 0.05),
                               rtol=2e-4)
    assert got.stats["negative_receivers"] == 0 and (got.radiosity >= 0).all()


def _closed_cube(n: int, rho: float, emission: float) -> Scene:
    """The inside of a unit cube, n × n surfels per face (inward), its twelve triangles wound
    inward, and a receiver near the middle of each face."""
    box = illumap.scenes.closed_box(n, albedo=rho, emission=emission)
    pos, nrm, area = box.positions, box.normals, box.areas
    count = len(area)
    tris, rec_points, rec_normals = [], [], []
    for face in range(6):
        rows = slice(face * n * n, (face + 1) * n * n)
        normal = nrm[rows][0]
        p = pos[rows]
        axis = int(np.argmax(np.abs(normal)))
        plane = float(p[0, axis])
        u, v = [i for i in range(3) if i != axis]
        corners = np.zeros((4, 3))
        for k, (a, b) in enumerate(((0, 0), (1, 0), (1, 1), (0, 1))):
            corners[k, axis], corners[k, u], corners[k, v] = plane, a, b
        tri = np.array([[corners[0], corners[1], corners[2]], [corners[0], corners[2], corners[3]]])
        if np.cross(tri[0, 1] - tri[0, 0], tri[0, 2] - tri[0, 0]) @ normal < 0:
            tri = tri[:, ::-1]
        tris.append(tri)
        middle = np.full(3, 0.5) + 0.013 * np.eye(3)[u] - 0.021 * np.eye(3)[v]
        middle[axis] = plane
        rec_points.append(middle)
        rec_normals.append(normal)
    triangles = np.concatenate(tris)
    # each surfel's triangle: the one of its face's two that holds it
    triangle = np.zeros(count, dtype=np.int64)
    for face in range(6):
        for t in (2 * face, 2 * face + 1):
            a, b, c = triangles[t]
            rows = np.arange(face * n * n, (face + 1) * n * n)
            q = pos[rows]
            e1, e2, r = b - a, c - a, q - a
            d00, d01, d11 = e1 @ e1, e1 @ e2, e2 @ e2
            d20, d21 = r @ e1, r @ e2
            den = d00 * d11 - d01 * d01
            bv = (d11 * d20 - d01 * d21) / den
            bw = (d00 * d21 - d01 * d20) / den
            inside = (bv >= -1e-12) & (bw >= -1e-12) & (bv + bw <= 1 + 1e-12)
            triangle[rows[inside]] = t
    receivers = _receivers("Cube", np.array(rec_points), np.array(rec_normals), rho)
    receivers = Receivers(receivers.name, receivers.corner_vertex, receivers.points,
                          receivers.normals, receivers.albedo, np.full((6, 3), emission), 6)
    return Scene(settings=Settings(), positions=pos, normals=nrm, areas=area,
                 albedo=box.albedo.copy(), emission=box.emission.copy(),
                 solve_emission=box.emission.copy(),
                 sources=(Source("Cube", "MESH", 0, count, 6.0),), triangle=triangle,
                 bary=np.full((count, 3), 1 / 3), uv=np.full((count, 2), np.nan),
                 material_index=np.zeros(count, dtype=np.int64), triangles=triangles,
                 two_sided=np.zeros(12, dtype=bool), mesh_triangle_start=np.array([0]),
                 receivers=(receivers,))


def test_a_closed_cube_is_a_furnace():
    """Uniform emission E and albedo ρ inside a closed cube: the exact light is E / (1 − ρ)
    everywhere. The surfels' transport rows are scaled to their hemispheres' share
    (``illumap.conservation``): each row sums to 1, so the uniform light is the solve's fixed
    point, to rounding; each receiver's gather meets only the walls, whose light it
    interpolates from surfels that all hold that value, so it reads it to rounding too."""
    rho, emission = 0.8, 0.25
    got = illumap.run(_closed_cube(12, rho, emission))
    exact = emission / (1.0 - rho)
    np.testing.assert_allclose(got.solved.radiosity, exact, rtol=1e-10)
    np.testing.assert_allclose(got.corners["Cube"], exact, rtol=1e-10)


def test_the_stages_write_into_none_of_their_inputs():
    """Each stage returns a new value: the scene's arrays, the lit light and the solved light
    are as they were after the next stage ran, and gathering twice gives the same values."""
    scene = _floor_under_emitter()
    before = _digest(scene.positions, scene.normals, scene.areas, scene.albedo, scene.emission,
                     scene.solve_emission)
    lit = light(scene)
    assert lit.scene is not scene and scene.occluders is None and lit.scene.occluders is not None
    solved = passes.solve_lit(lit)
    lit_before, solved_before = _digest(lit.direct, lit.direct_lamps), _digest(solved.radiosity)
    first, second = passes.gather(solved), passes.gather(solved)
    assert _digest(scene.positions, scene.normals, scene.areas, scene.albedo, scene.emission,
                   scene.solve_emission) == before
    assert _digest(lit.direct, lit.direct_lamps) == lit_before
    assert _digest(solved.radiosity) == solved_before
    np.testing.assert_array_equal(first.corners["Floor"], second.corners["Floor"])
    np.testing.assert_array_equal(first.radiosity, second.radiosity)
    # and the run from the start gives the same values as the stages one by one
    np.testing.assert_array_equal(illumap.run(scene).corners["Floor"], first.corners["Floor"])


def test_the_pass_loop_asks_for_a_second_pass_only_where_there_is_one():
    """A scene with a further pass (``refine`` set) is solved, handed to ``next_pass``, and
    the scene it returns is lit, solved and gathered; without ``next_pass`` the first pass
    ends the run, solved only (no receivers); a last pass never asks."""
    last = _floor_under_emitter()
    first = Scene(**{**last.__dict__, "refine": "pass 2 follows"})
    asked = []

    def next_pass(solved):
        asked.append(solved.lit.scene.refine)
        return last

    got = illumap.run(first, next_pass=next_pass)
    assert asked == ["pass 2 follows"] and got.scene.refine is None
    assert set(got.corners) == {"Floor"}
    alone = illumap.run(first)
    assert alone.corners == {} and "receivers" not in alone.stats
    np.testing.assert_array_equal(alone.radiosity, alone.solved.radiosity)
    asked.clear()
    illumap.run(last, next_pass=next_pass)
    assert asked == []


def test_a_scene_no_light_reaches_is_refused_before_the_solve():
    scene = _floor_under_emitter()
    dark = Scene(**{**scene.__dict__, "emitters": ()})
    with pytest.raises(illumap.NoLight, match="No light in the scene"):
        illumap.run(dark)


def test_cancelling_stops_the_run():
    with pytest.raises(illumap.Cancelled):
        illumap.run(_floor_under_emitter(), lambda fraction, phase: False)
