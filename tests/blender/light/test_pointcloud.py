"""Point-cloud input: PointCloud objects and vertex-only meshes, with and without
radius/normal attributes; colour from a colour attribute; clear errors."""

import math

import bpy
import numpy as np
import pytest

from illumap_bpy_testing import grid_positions, link, make_surfels

from addon import pipeline
from addon.read import pointcloud
from addon.errors import IllumapError


def vertex_mesh(name, positions, attrs=None):
    mesh = bpy.data.meshes.new(name)
    mesh.vertices.add(len(positions))
    mesh.vertices.foreach_set("co", np.asarray(positions, np.float32).ravel())
    for attr_name, (kind, values) in (attrs or {}).items():
        a = mesh.attributes.new(attr_name, kind, "POINT")
        key = {"FLOAT_COLOR": "color", "FLOAT_VECTOR": "vector", "FLOAT": "value"}[kind]
        a.data.foreach_set(key, np.asarray(values, np.float32).ravel())
    return link(bpy.data.objects.new(name, mesh))


def prepare(*objs):
    return pipeline.prepare(bpy.context.evaluated_depsgraph_get(), list(objs),
                            pipeline.Settings(lamps=False))


def test_pointcloud_with_radius_normals_and_colour():
    pos = grid_positions(10, size=1.0, z=0.5)
    n = len(pos)
    obj = make_surfels(pos, (0, 0, -1.0), 0.05, (0.2, 0.3, 0.4), pointcloud=True, name="PC")
    assert obj.type == "POINTCLOUD"
    col = obj.data.attributes.new("Col", "FLOAT_COLOR", "POINT")
    col.data.foreach_set("color", np.tile([0.1, 0.6, 0.3, 1.0], n).astype(np.float32))
    obj.location = (0, 0, 1)
    job = prepare(obj)
    assert job.count == n and not job.warnings
    assert np.allclose(job.positions[:, 2], 1.5, atol=1e-6)
    assert np.allclose(job.normals, (0, 0, -1), atol=1e-6)
    assert np.allclose(job.areas, math.pi * 0.05 ** 2, rtol=1e-5)
    assert np.allclose(job.albedo, (0.1, 0.6, 0.3), atol=1e-6)


def test_vertex_only_mesh_without_radius_or_normals_estimates_and_warns():
    # A 20×20 grid (spacing 0.05) on a tilted plane: areas ~ spacing², normals = plane normal.
    g = grid_positions(20, size=1.0)
    tilt = math.radians(30)
    rot = np.array([[1, 0, 0], [0, math.cos(tilt), -math.sin(tilt)], [0, math.sin(tilt), math.cos(tilt)]])
    obj = vertex_mesh("Verts", g @ rot.T)
    job = prepare(obj)
    # Normals of unknown orientation: every point is two-sided, a surfel facing each way.
    assert [(s.kind, s.stop - s.start) for s in job.sources] == [("POINTS", 400), ("BACK", 400)]
    assert np.array_equal(job.normals[400:], -job.normals[:400])
    assert any("radius" in w for w in job.warnings) and any("normal" in w for w in job.warnings)
    interior = np.all(np.abs(g[:, :2]) < 0.4, axis=1)
    assert np.allclose(job.areas[:400][interior], 0.05 ** 2, rtol=0.1)
    expected = rot @ np.array([0, 0, 1.0])
    cos = job.normals[:400] @ expected
    assert np.all(np.abs(cos) > 0.999)
    assert np.all(cos > 0) or np.all(cos < 0)   # consistently oriented
    assert np.all(cos > 0)                      # flat patch: the +Z heuristic


def test_estimated_normals_on_a_sphere_point_outwards():
    rng = np.random.default_rng(0)
    p = rng.normal(size=(800, 3))
    p /= np.linalg.norm(p, axis=1, keepdims=True)
    n = pointcloud.estimate_normals(p)
    assert np.all(np.einsum("ij,ij->i", n, p) > 0.9)
    areas = pointcloud.estimate_areas(p)
    assert abs(areas.sum() / (4 * math.pi) - 1) < 0.15


def test_a_torus_without_normals_faces_outwards_everywhere():
    # The inner side of a torus faces its centroid: a per-point rule would turn it inwards.
    rng = np.random.default_rng(5)
    u, v = rng.random(3000) * 2 * math.pi, rng.random(3000) * 2 * math.pi
    p = np.c_[(1 + 0.3 * np.cos(v)) * np.cos(u), (1 + 0.3 * np.cos(v)) * np.sin(u), 0.3 * np.sin(v)]
    truth = np.c_[np.cos(v) * np.cos(u), np.cos(v) * np.sin(u), np.sin(v)]
    job = prepare(vertex_mesh("Torus", p))
    assert any("both sides" in w for w in job.warnings)
    assert np.all(np.einsum("ij,ij->i", job.normals[:3000], truth) > 0.9)


def test_normal_attribute_used():
    pos = grid_positions(4, size=1.0)
    obj = vertex_mesh("V", pos, {"N": ("FLOAT_VECTOR", np.tile([0, 1.0, 0], (16, 1))),
                                 "radius": ("FLOAT", np.full(16, 0.1))})
    job = prepare(obj)
    assert np.allclose(job.normals, (0, 1, 0), atol=1e-6)
    assert np.allclose(job.areas, math.pi * 0.01, rtol=1e-5)
    assert not job.warnings


def test_too_few_points_without_radius_is_an_error():
    obj = vertex_mesh("Few", [(0, 0, 0), (1, 0, 0), (0, 1, 0)])
    with pytest.raises(IllumapError, match="'Few'.*radius"):
        prepare(obj)


def room_scan(spacing=0.25):
    """Points on the six walls of a 4 × 4 × 3 m room, and each point's inward normal."""
    pos, nrm = [], []
    lo, hi = np.array([-2.0, -2.0, 0.0]), np.array([2.0, 2.0, 3.0])
    for axis in range(3):
        u, v = [a for a in range(3) if a != axis]
        gu = np.arange(lo[u] + spacing / 2, hi[u], spacing)
        gv = np.arange(lo[v] + spacing / 2, hi[v], spacing)
        uu, vv = (x.ravel() for x in np.meshgrid(gu, gv))
        for side, inward in ((lo[axis], 1.0), (hi[axis], -1.0)):
            p = np.zeros((len(uu), 3))
            p[:, u], p[:, v], p[:, axis] = uu, vv, side
            n = np.zeros_like(p)
            n[:, axis] = inward
            pos.append(p)
            nrm.append(n)
    return np.concatenate(pos), np.concatenate(nrm)


def scan_illumination(obj):
    attr = obj.data.attributes["illumination"]
    out = np.empty(len(attr.data) * 4, np.float32)
    attr.data.foreach_get("color", out)
    return out.reshape(-1, 4)[:, :3].astype(np.float64)


def test_interior_scan_without_normals_is_lit_inside_and_gets_its_result():
    """A room scanned as points without normals, a lamp inside. Estimated normals cannot know
    which side is inside (facing them away from the centroid turns every wall dark), so
    each point is two-sided and shows its brighter side. The light lands on the scan object
    itself, and matches the same scan given its true inward normals."""
    pos, inward = room_scan()
    grey = np.tile([0.6, 0.6, 0.6, 1.0], (len(pos), 1))
    blind = vertex_mesh("Scan", pos, {"Col": ("FLOAT_COLOR", grey)})
    lamp = bpy.data.lights.new("Bulb", "POINT")
    lamp.energy, lamp.shadow_soft_size = 800.0, 0.0
    link(bpy.data.objects.new("Bulb", lamp)).location = (0.3, -0.2, 1.6)
    bpy.context.view_layer.update()
    settings = pipeline.Settings(visibility="exact")
    result = pipeline.compute(bpy.context, [blind], settings)
    got = scan_illumination(blind)
    assert got.shape == (len(pos), 3)
    assert got.min() > 0.0                           # every wall lit from inside
    assert any("both sides" in w for w in result.warnings)
    bpy.data.objects.remove(blind)
    # The same points with the estimated normals turned inwards by hand, one-sided: the
    # two-sided scan shows exactly that light (the outward-facing surfels get none).
    est = pointcloud.estimate_normals(pos, 8)
    est *= np.sign(np.einsum("ij,ij->i", est, inward))[:, None]
    oriented = vertex_mesh("Oriented", pos, {"Col": ("FLOAT_COLOR", grey),
                                             "normal": ("FLOAT_VECTOR", est)})
    pipeline.compute(bpy.context, [oriented], settings)
    # The solves agree to 1e-8. At the points, the gather's rays meet the two scans' splats
    # from opposite faces (two-sided against one-sided splats), which moves a few by 0.1%;
    # and the scan without normals is lit about its points' PCA normals, which bend round
    # the room's edges (a crease shows the mean of its surfaces), where the given normals
    # do not: away from the edges both agree.
    lo, hi = np.array([-2.0, -2.0, 0.0]), np.array([2.0, 2.0, 3.0])
    to_edge = np.sort(np.minimum(pos - lo, hi - pos), axis=1)[:, 1]   # 2nd-nearest wall
    inner = to_edge > 0.3
    assert inner.sum() > len(pos) // 2
    np.testing.assert_allclose(got[inner], scan_illumination(oriented)[inner], rtol=3e-3)
    bpy.data.objects.remove(oriented)
    # With the true normals: PCA normals bend round the room's edges, the rest agrees.
    known = vertex_mesh("Known", pos, {"Col": ("FLOAT_COLOR", grey),
                                       "normal": ("FLOAT_VECTOR", inward)})
    pipeline.compute(bpy.context, [known], settings)
    truth = scan_illumination(known)
    rms = np.sqrt(np.mean((got - truth) ** 2) / np.mean(truth ** 2))
    print(f"\ninterior scan without normals against true normals: rel. RMS {rms:.4f}")
    assert rms < 0.1, rms
