"""Direct light from lamps against analytic values, and against a Cycles bake.

Units: incident radiance H = irradiance/π (what a Cycles DIFFUSE DIRECT bake gives); the job's
``direct`` term is albedo × H."""

import math

import bpy
import numpy as np
import pytest

from illumap import lights
from illumap_bpy_testing import add_lamp, diffuse_material, make_plane

from addon.read import lamps
from addon import pipeline

ALBEDO = 0.5


def floor_job(size=4.0, density=64.0):
    floor = make_plane("Floor", size=size, material=diffuse_material("D", (ALBEDO,) * 3))
    job = pipeline.light(pipeline.prepare(bpy.context.evaluated_depsgraph_get(), [floor],
                                          pipeline.Settings(density=density, lamps=True)))
    return job.positions, job.direct[:, 0] / ALBEDO


def test_point_lamp_inverse_square_and_cosine():
    add_lamp("POINT", location=(0, 0, 2), energy=100.0, shadow_soft_size=0.0)
    p, h = floor_job()
    d2 = (p ** 2).sum(1) - 4 * p[:, 2] + 4  # |p - (0,0,2)|², p on z=0
    expected = 100 / (4 * math.pi ** 2) * (2 / np.sqrt(d2)) / d2
    assert np.allclose(h, expected, rtol=1e-6)
    assert abs(h.max() - 100 / (4 * math.pi ** 2 * 4)) < 0.05 * h.max()


def test_sun_at_an_angle():
    add_lamp("SUN", rotation=(math.radians(60), 0, 0), energy=3.0)
    _, h = floor_job()
    assert np.allclose(h, 3.0 * 0.5 / math.pi, rtol=1e-6)


def test_sun_from_below_gives_nothing():
    add_lamp("SUN", rotation=(math.radians(180), 0, 0), energy=3.0)
    _, h = floor_job()
    assert np.all(h == 0)


def test_spot_cone_and_blend():
    add_lamp("SPOT", location=(0, 0, 1), energy=50.0, shadow_soft_size=0.0,
             spot_size=math.radians(90), spot_blend=0.5)
    p, h = floor_job(size=6.0, density=16.0)
    r = np.hypot(p[:, 0], p[:, 1])
    angle = np.arctan(r)
    point = 50 / (4 * math.pi ** 2) * np.cos(angle) ** 3  # h=1: cos/d² = cos³
    t, t0 = np.cos(angle), math.cos(math.radians(45))
    x = np.clip((t - t0) / ((1 - t0) * 0.5), 0, 1)
    expected = np.where(t > t0, point * x * x * (3 - 2 * x), 0.0)
    assert np.allclose(h, expected, rtol=1e-4, atol=1e-9)  # float32 positions
    assert np.all(h[angle > math.radians(45)] == 0) and (h > 0).sum() > 10


@pytest.mark.parametrize("shape,size,form_factor", [
    ("SQUARE", 1.0, 0.23945),                      # DESIGN §4: point to centred unit square at h=1
    ("DISK", 1.0, 0.25 / (0.25 + 1.0)),           # a²/(a²+h²), a = 0.5
])
def test_area_lamp_form_factor_on_axis(shape, size, form_factor):
    add_lamp("AREA", location=(0, 0, 1), energy=10.0, shape=shape, size=size)
    area = size * size if shape == "SQUARE" else math.pi * size * size / 4
    lamp_list = lamps.read_lamps(bpy.context.evaluated_depsgraph_get(), [])
    h = lights.incident_radiance(lamp_list, np.zeros((1, 3)), np.array([[0, 0, 1.0]]))
    assert abs(h[0, 0] - 10 / (math.pi * area) * form_factor) < 2e-4 * h[0, 0]


def test_area_lamp_clipped_by_receiver_plane_matches_quadrature():
    # A vertical 1×1 area lamp standing on the floor's edge region, facing +x: part of it lies
    # below the tilted receivers' tangent planes, which the clipping must handle.
    add_lamp("AREA", location=(0, 0, 0.3), rotation=(0, math.radians(-90), 0), energy=5.0,
             shape="RECTANGLE", size=1.0, size_y=1.0)
    lamp_list = lamps.read_lamps(bpy.context.evaluated_depsgraph_get(), [])
    lamp = lamp_list[0]
    rng = np.random.default_rng(0)
    p = np.column_stack([rng.uniform(0.2, 1.5, 20), rng.uniform(-1, 1, 20), rng.uniform(-0.2, 0.6, 20)])
    n = rng.normal(size=(20, 3))
    n[:, 0] = -np.abs(n[:, 0]) - 0.2  # roughly facing the lamp, tilted every way
    n /= np.linalg.norm(n, axis=1, keepdims=True)
    h = lights.incident_radiance(lamp_list, p, n)[:, 0]
    # Midpoint quadrature over the lamp: dH = L cosθ_r cosθ_l dA / (π r²).
    m = 400
    g = (np.arange(m) + 0.5) / m - 0.5
    u, v = np.meshgrid(g, g)
    c = lamp.polygon
    ax, ay = (c[1] - c[0]), (c[3] - c[0])
    pts = c[0] + (u.ravel() + 0.5)[:, None] * ax + (v.ravel() + 0.5)[:, None] * ay
    d = pts[None] - p[:, None]
    r2 = (d ** 2).sum(-1)
    cos_r = np.maximum((d * n[:, None]).sum(-1), 0) / np.sqrt(r2)
    cos_l = np.maximum(-(d @ lamp.direction), 0) / np.sqrt(r2)
    L = 5.0 / (math.pi * 1.0)
    ref = L * (cos_r * cos_l / (math.pi * r2)).sum(1) / (m * m)
    assert np.allclose(h, ref, rtol=3e-3, atol=1e-6)
    assert (ref > 0).sum() >= 15
    s = (c[None] - p[:, None]) @ np.eye(3)
    heights = np.einsum("nvc,nc->nv", s, n)
    clipped = (heights.max(1) > 0) & (heights.min(1) < 0)
    assert clipped.sum() >= 5  # the clipping path is exercised


def test_world_ambient():
    world = bpy.data.worlds.new("W")
    if world.node_tree is None:
        world.use_nodes = True
    bg = world.node_tree.nodes["Background"]
    bg.inputs["Color"].default_value = (0.2, 0.4, 0.6, 1)
    bg.inputs["Strength"].default_value = 2.0
    bpy.context.scene.world = world
    floor = make_plane("Floor", material=diffuse_material("D", (ALBEDO,) * 3))
    job = pipeline.prepare(bpy.context.evaluated_depsgraph_get(), [floor],
                           pipeline.Settings(density=16, lamps=False, world_ambient=True))
    assert job.direct is None  # direct light is run's first phase
    pipeline.light(job)
    assert np.allclose(job.direct, ALBEDO * np.array([0.4, 0.8, 1.2]))


def _bake_incident(obj, samples=512):
    scene = bpy.context.scene
    scene.render.engine = "CYCLES"
    scene.cycles.device = "CPU"
    scene.cycles.samples = samples
    scene.world = None
    attr = obj.data.color_attributes.new("bake", "FLOAT_COLOR", "POINT")
    obj.data.color_attributes.active_color = attr
    for o in bpy.context.view_layer.objects:
        o.select_set(False)
    obj.select_set(True)
    bpy.context.view_layer.objects.active = obj
    bpy.ops.object.bake(type="DIFFUSE", pass_filter={"DIRECT", "INDIRECT"}, target="VERTEX_COLORS")
    out = np.empty(len(obj.data.vertices) * 4, np.float32)
    obj.data.color_attributes["bake"].data.foreach_get("color", out)
    return out.reshape(-1, 4)[:, :3]


@pytest.mark.slow
def test_all_lamp_types_against_cycles_bake():
    """Cycles bakes incident radiance at the 4 vertices of a tilted quad lit by one lamp of
    each type; lights.incident_radiance must agree (area light sampling noise: ~1%)."""
    obj = make_plane("Recv", size=1.0, material=diffuse_material("D", (0.8,) * 3))
    obj.rotation_euler = (math.radians(20), math.radians(-10), 0)
    add_lamp("POINT", location=(0.4, 0.3, 1.5), energy=60.0, shadow_soft_size=0.0, color=(1, 0.5, 0.2))
    add_lamp("SUN", rotation=(math.radians(35), math.radians(10), 0), energy=0.7)
    add_lamp("SPOT", location=(-1.0, 0.2, 1.2), rotation=(0, math.radians(-45), 0), energy=40.0,
             shadow_soft_size=0.0, spot_size=math.radians(70), spot_blend=0.3)
    add_lamp("AREA", location=(0.2, -0.8, 1.0), rotation=(math.radians(-30), 0, 0), energy=30.0,
             shape="RECTANGLE", size=0.6, size_y=0.3)
    bpy.context.view_layer.update()
    baked = _bake_incident(obj)
    me = obj.data
    co = np.array([obj.matrix_world @ v.co for v in me.vertices])
    nrm = np.array([(obj.matrix_world.to_3x3() @ v.normal).normalized() for v in me.vertices])
    lamp_list = lamps.read_lamps(bpy.context.evaluated_depsgraph_get(), [])
    assert sorted(lp.kind for lp in lamp_list) == ["AREA", "POINT", "SPOT", "SUN"]
    ours = lights.incident_radiance(lamp_list, co, nrm)
    assert np.allclose(ours, baked, rtol=0.02, atol=1e-3), (ours, baked)


def test_a_sized_spot_softens_its_cone_edge():
    """A spot lamp with a radius is seen over its disc and the cone applies to every point of
    it (as in Cycles): just outside the cone some of the disc still shines, and the factor
    tends to the point lamp's as the radius shrinks."""
    import numpy as np
    spot = lights.Lamp("S", "SPOT", np.ones(3), np.array([0.0, 0.0, 5.0]), np.array([0.0, 0.0, -1.0]),
                      radius=0.3, spot_size=np.radians(60.0), spot_blend=0.1)
    edge = 5.0 * np.tan(np.radians(30.0))
    p = np.array([[edge * 1.02, 0.0, 0.0], [0.0, 0.0, 0.0]])       # just outside; on the axis
    d = spot.position - p
    soft = lights._spot_attenuation(spot, p, d, np.einsum("ij,ij->i", d, d))
    assert 0.0 < soft[0] < 0.5 and soft[1] == 1.0
    sharp = lights._spot_attenuation(lights.Lamp(**{**spot.__dict__, "radius": 0.0}), p, d,
                                    np.einsum("ij,ij->i", d, d))
    assert sharp[0] == 0.0
    tiny = lights._spot_attenuation(lights.Lamp(**{**spot.__dict__, "radius": 1e-6}), p, d,
                                   np.einsum("ij,ij->i", d, d))
    np.testing.assert_allclose(tiny, sharp, atol=1e-9)


def test_a_sized_spot_samples_only_near_its_cone_edge():
    """Points whose whole view of the spot's disc lies inside the full cone, or outside it,
    get exactly 1 or 0 without sampling, the same numbers as sampling every point."""
    import numpy as np
    rng = np.random.default_rng(3)
    for blend in (0.0, 0.3):
        spot = lights.Lamp("S", "SPOT", np.ones(3), np.array([0.2, -0.1, 3.0]),
                          np.array([0.0, 0.0, -1.0]), radius=0.25,
                          spot_size=np.radians(70.0), spot_blend=blend)
        p = np.column_stack([rng.uniform(-4, 4, 4000), rng.uniform(-4, 4, 4000), np.zeros(4000)])
        d = spot.position - p
        d2 = np.einsum("ij,ij->i", d, d)
        got = lights._spot_attenuation(spot, p, d, d2)
        edge = (got > 0) & (got < 1)
        assert edge.any() and (got == 1).any() and (got == 0).any()
        everywhere = np.array([lights._spot_attenuation(spot, p[i:i + 1], d[i:i + 1], d2[i:i + 1])[0]
                               if e else got[i] for i, e in enumerate(edge)])
        np.testing.assert_array_equal(got, everywhere)
        # The points given 0 or 1 outright: sampling them gives the same.
        k = np.flatnonzero(~edge)[::97]
        disc = spot.radius * lights._disc(np.column_stack([(np.arange(32) + 0.5) / 32,
                                                          np.mod(np.arange(32) * 0.6180339887498949, 1)]))
        for i in k:
            u, v = lights._basis(d[i:i + 1] / np.sqrt(d2[i]))
            q = spot.position + disc[:, :1] * u + disc[:, 1:] * v
            t = -((q - p[i]) @ spot.direction) / np.linalg.norm(q - p[i], axis=1)
            t0 = np.cos(spot.spot_size / 2)
            inside = t > t0 + (1 - t0) * blend if blend > 0 else t > t0
            assert inside.all() if got[i] == 1 else not (t > t0).any()


def test_shadow_samples_follow_each_points_id():
    """A subset of points given their ids casts the same shadow samples as among all."""
    import numpy as np
    area = lights.Lamp("A", "AREA", np.ones(3), np.array([0.0, 0.0, 2.0]), np.array([0.0, 0.0, -1.0]),
                      polygon=np.array([[-.5, -.5, 2], [.5, -.5, 2], [.5, .5, 2], [-.5, .5, 2]], float),
                      area=1.0, shape="SQUARE", axes=np.array([[0.5, 0, 0], [0, 0.5, 0]]))

    def half_blocked(origins, targets, skip, progress=None):    # a wall at x = 0.1 up to z = 1
        t = (0.1 - origins[:, 0]) / np.where(targets[:, 0] != origins[:, 0],
                                             targets[:, 0] - origins[:, 0], np.inf)
        z = origins[:, 2] + t * (targets[:, 2] - origins[:, 2])
        return ~((t > 0) & (t < 1) & (z < 1.0))

    p = np.column_stack([np.linspace(-1, 0, 50), np.zeros(50), np.zeros(50)])
    n = np.tile([0.0, 0.0, 1.0], (50, 1))
    everyone = lights.incident_radiance([area], p, n, shadows=lights.Shadows(half_blocked, samples=8))
    some = np.arange(5, 50, 7)
    alone = lights.incident_radiance([area], p[some], n[some],
                                    shadows=lights.Shadows(half_blocked, samples=8, ids=some))
    np.testing.assert_array_equal(alone, everyone[some])
    shuffled = lights.incident_radiance([area], p[some], n[some],
                                       shadows=lights.Shadows(half_blocked, samples=8))
    assert not np.array_equal(shuffled, everyone[some])


def test_a_probe_settles_the_points_that_see_all_or_none_of_a_lamp():
    """With many shadow rays per point, PROBE_SAMPLES rays first: points whose probe rays all
    agree keep that answer (exactly 1 or 0); the penumbra's points cast the full count and get
    the same value as without the probe."""
    import numpy as np
    area = lights.Lamp("A", "AREA", np.ones(3), np.array([1.0, 0.0, 2.0]), np.array([0.0, 0.0, -1.0]),
                      polygon=np.array([[.5, -.5, 2], [1.5, -.5, 2], [1.5, .5, 2], [.5, .5, 2]], float),
                      area=1.0, shape="SQUARE", axes=np.array([[0.5, 0, 0], [0, 0.5, 0]]))

    def wall(origins, targets, skip, progress=None):              # x = 0 up to z = 1.5
        dx = targets[:, 0] - origins[:, 0]
        t = -origins[:, 0] / np.where(dx != 0, dx, np.inf)
        z = origins[:, 2] + t * (targets[:, 2] - origins[:, 2])
        return ~((t > 0) & (t < 1) & (z < 1.5))

    p = np.column_stack([np.linspace(-3, 3, 61), np.zeros(61), np.zeros(61)])
    n = np.tile([0.0, 0.0, 1.0], (61, 1))
    k = 128
    probed = lights.Shadows(wall, samples=k)
    got = lights.lamp_visibility(area, p, n, np.arange(61), probed)
    lamps_probe, lights.PROBE_SAMPLES = lights.PROBE_SAMPLES, 10 ** 9
    try:
        full = lights.Shadows(wall, samples=k)
        want = lights.lamp_visibility(area, p, n, np.arange(61), full)
    finally:
        lights.PROBE_SAMPLES = lamps_probe
    penumbra = (want > 0) & (want < 1)
    assert penumbra.sum() >= 5 and (want == 0).any() and (want == 1).any()
    np.testing.assert_array_equal(got[penumbra], want[penumbra])
    np.testing.assert_array_equal(got[~penumbra], want[~penumbra])
    assert full.rays == 61 * k
    assert probed.rays == 61 * lights.PROBE_SAMPLES + penumbra.sum() * k


def test_the_sky_through_a_window_is_never_probed_away():
    """The world is never probed (PROBE_SAMPLES): from inside a room its light comes through a
    window of a few percent of the sky, which every probe ray misses at many points; those
    had been given no sky at all. With 128 rays per point, the points of a floor under a
    square opening see, on average, the cosine-weighted share of the sky that the opening
    holds (the form factor of a parallel rectangle), where the probe had left two thirds of
    it."""
    import numpy as np
    sky = lights.Lamp("World", "WORLD", np.ones(3), np.zeros(3), np.array([0.0, 0.0, -1.0]))
    half, height = 0.15, 1.0                 # the opening: |x|, |y| < half in the plane z = 1

    def ceiling(origins, targets, skip, progress=None):
        t = (height - origins[:, 2]) / (targets[:, 2] - origins[:, 2])
        x = origins[:, 0] + t * (targets[:, 0] - origins[:, 0])
        y = origins[:, 1] + t * (targets[:, 1] - origins[:, 1])
        return (t > 0) & (np.abs(x) < half) & (np.abs(y) < half)

    def form_factor(px, py):                 # point on z = 0 facing up, parallel rectangle
        def corner(a, b):
            ra, rb = np.hypot(a, height), np.hypot(b, height)
            return (a / ra * np.arctan(b / ra) + b / rb * np.arctan(a / rb)) / (2 * np.pi)
        x0, x1, y0, y1 = -half - px, half - px, -half - py, half - py
        return corner(x1, y1) - corner(x0, y1) - corner(x1, y0) + corner(x0, y0)

    g = np.linspace(-0.5, 0.5, 25)
    px, py = (a.ravel() for a in np.meshgrid(g, g))
    p = np.column_stack([px, py, np.zeros_like(px)])
    n = np.tile([0.0, 0.0, 1.0], (len(p), 1))
    shadows = lights.Shadows(ceiling, samples=128, extent=2.0)
    assert lights.rays_per_surfel(sky, shadows) >= 2 * lights.PROBE_SAMPLES   # probing range
    got = lights.lamp_visibility(sky, p, n, np.arange(len(p)), shadows)
    want = form_factor(px, py)
    assert 0.005 < want.min() and want.max() < 0.1, (want.min(), want.max())
    assert abs(got.mean() / want.mean() - 1.0) < 0.1, (got.mean(), want.mean())
    assert shadows.rays == len(p) * lights.rays_per_surfel(sky, shadows)     # no probe


def _sample_lamps():
    rng = np.random.default_rng(5)
    tri = rng.uniform(-1, 1, (7, 3, 3)) + [0.0, 0.0, 3.0]
    down = np.array([0.0, 0.0, -1.0])
    axes = np.array([[0.6, 0.0, 0.0], [0.0, 0.3, 0.1]])
    yield lights.Lamp("P", "POINT", np.ones(3), np.array([0.5, -0.2, 2.0]), down, radius=0.25)
    yield lights.Lamp("Spot", "SPOT", np.ones(3), np.array([0.1, 0.2, 2.5]), down, radius=0.1)
    yield lights.Lamp("Sun", "SUN", np.ones(3), np.zeros(3), np.array([0.3, 0.2, -0.93]),
                     angle=0.3)
    yield lights.Lamp("World", "WORLD", np.ones(3), np.zeros(3), down)
    for shape in ("RECTANGLE", "DISK"):
        yield lights.Lamp(shape, "AREA", np.ones(3), np.array([0.0, 0.0, 2.0]), down,
                         shape=shape, axes=axes)
    for both in (False, True):
        yield lights.Lamp(f"Mesh{both}", "MESH", np.ones(3), np.zeros(3), down, triangles=tri,
                         radiance=rng.uniform(0.1, 2.0, (7, 3)), two_sided=both)


@pytest.mark.parametrize("lamp", list(_sample_lamps()), ids=lambda lamp: lamp.name)
def test_the_native_lamp_samples_are_the_numpy_formulation(lamp):
    """lights._lamp_samples runs natively; the whole-array numpy formulation it replaced
    (numpy_lamp_samples) gives the same targets and weights, for every lamp kind."""
    from numpy_lamp_samples import lamp_samples
    rng = np.random.default_rng(11)
    p = rng.uniform(-2, 2, (500, 3)) * [1, 1, 0.3]
    n = rng.normal(size=(500, 3))
    n /= np.linalg.norm(n, axis=1, keepdims=True)
    shifts = lights.row_shifts(3, 77, np.arange(500))
    for k in (1, 7, 32):
        got = lights._lamp_samples(lamp, p, n, k, shifts, 40.0)
        want = lamp_samples(lamp, p, n, k, shifts, 40.0)
        np.testing.assert_allclose(got[0], want[0], rtol=1e-12, atol=1e-12)
        np.testing.assert_allclose(got[1], want[1], rtol=1e-9, atol=1e-300)
        assert got[1].max() > 0
