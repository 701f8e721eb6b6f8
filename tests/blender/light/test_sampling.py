"""Surfel sampling from meshes: area sums, density, stratification, transforms, modifiers,
bad geometry. Runs through the bpy module (conftest resets the file before each test)."""

import bpy
import numpy as np
import pytest

from illumap_bpy_testing import link, make_plane

from addon import pipeline
from addon.read import sampling
from addon.errors import IllumapError


def depsgraph():
    return bpy.context.evaluated_depsgraph_get()


def sample(obj, n, seed=0):
    tm = sampling.read_mesh(obj, depsgraph())
    return tm, sampling.sample_mesh(tm, n, np.random.default_rng(seed))


def make_cube(name="Cube", size=2.0):
    bpy.ops.mesh.primitive_cube_add(size=size)
    obj = bpy.context.active_object
    obj.name = name
    return obj


def test_area_sum_equals_mesh_area_with_transform_and_modifier():
    obj = make_cube()
    obj.scale = (1.5, 0.5, 2.0)
    obj.rotation_euler = (0.3, 0.2, 0.1)
    obj.location = (3.0, -1.0, 2.0)
    mod = obj.modifiers.new("Sub", "SUBSURF")
    mod.levels = 2
    bpy.context.view_layer.update()
    tm, s = sample(obj, 5000)
    # Reference area from Blender's own evaluated polygons, in world space.
    ev = obj.evaluated_get(depsgraph())
    me = ev.to_mesh()
    me.transform(ev.matrix_world)
    me.calc_loop_triangles()
    ref = sum(t.area for t in me.loop_triangles)
    ev.to_mesh_clear()
    assert abs(tm.total_area - ref) < 1e-6 * ref
    assert abs(s.areas.sum() - ref) < 1e-6 * ref
    # Subdivision rounds the box: its area is well below the unsubdivided box's.
    box = 2 * (3 * 1 + 3 * 4 + 1 * 4)
    assert ref < 0.95 * box
    # Surfels lie on the transformed, subdivided surface: in its world bounding box, and their
    # local coordinates are inside the object's local bounding box.
    local = (s.positions - np.array(obj.location)) @ np.array(obj.matrix_world.to_3x3().inverted()).T
    box = np.array([v[:] for v in obj.bound_box])
    assert np.all(local >= box.min(0) - 1e-5) and np.all(local <= box.max(0) + 1e-5)
    # Subdivision pulls the faces in (level 2 reaches ~0.84 of the cage): the modifier applied.
    assert 0.8 < np.abs(local).max() < 0.9
    assert np.allclose(np.linalg.norm(s.normals, axis=1), 1.0)


def test_density_honoured_across_objects():
    a = make_plane("A", size=2.0)          # 4 m²
    b = make_plane("B", size=1.0, location=(0, 0, 1))  # 1 m²
    job = pipeline.prepare(depsgraph(), [a, b], pipeline.Settings(density=250.0, lamps=False))
    counts = {s.name: s.stop - s.start for s in job.sources if s.kind == "MESH"}
    assert counts == {"A": 1000, "B": 250}
    assert abs(job.areas[:1000].sum() - 4.0) < 1e-9
    assert abs(job.areas[1000:1250].sum() - 1.0) < 1e-9
    # Open planes reflect on both faces: the backs that see the other plane get surfels of
    # their own after the front faces (B's underside faces A; A's underside faces nothing).
    backs = {s.name: s.stop - s.start for s in job.sources if s.kind == "BACK"}
    assert backs == {"B": 250}
    assert np.allclose(job.normals[1250:], -job.normals[1000:1250])


def test_budget_shared_by_area():
    a = make_plane("A", size=2.0)
    b = make_plane("B", size=1.0, location=(0, 0, 1))
    job = pipeline.prepare(depsgraph(), [a, b], pipeline.Settings(budget=500, lamps=False))
    counts = {s.name: s.stop - s.start for s in job.sources if s.kind == "MESH"}
    assert counts == {"A": 400, "B": 100}       # the budget counts front faces


def test_stratified_not_clumped():
    obj = make_plane("P", size=1.0)
    n = 1024
    _, s = sample(obj, n)
    xy = s.positions[:, :2]
    d = np.linalg.norm(xy[:, None] - xy[None], axis=2)
    np.fill_diagonal(d, np.inf)
    nearest = d.min(axis=1)
    rng = np.random.default_rng(1)
    r = rng.random((n, 2)) - 0.5
    dr = np.linalg.norm(r[:, None] - r[None], axis=2)
    np.fill_diagonal(dr, np.inf)
    spacing = 1 / np.sqrt(n)
    # Uniform random points have min distances ~0.03 × spacing and many near-coincident pairs;
    # the stratified set keeps every pair apart and its nearest distances tightly spread.
    assert nearest.min() > 0.2 * spacing
    assert dr.min() < 0.05 * spacing
    assert nearest.std() / nearest.mean() < 0.5 * (dr.min(1).std() / dr.min(1).mean())
    # Coverage: every cell of a 16×16 grid (4 expected surfels each) holds at least one.
    cells = np.floor((xy + 0.5) * 16).clip(0, 15).astype(int)
    occupied = np.zeros((16, 16), bool)
    occupied[cells[:, 0], cells[:, 1]] = True
    assert occupied.all()


def test_smooth_and_flat_normals():
    bpy.ops.mesh.primitive_uv_sphere_add(radius=1.0, segments=16, ring_count=8)
    obj = bpy.context.active_object
    _, s = sample(obj, 400)
    radial = s.positions / np.linalg.norm(s.positions, axis=1, keepdims=True)
    flat_cos = np.einsum("ij,ij->i", s.normals, radial)
    bpy.ops.object.shade_smooth()
    _, s2 = sample(obj, 400)
    radial2 = s2.positions / np.linalg.norm(s2.positions, axis=1, keepdims=True)
    smooth_cos = np.einsum("ij,ij->i", s2.normals, radial2)
    assert flat_cos.min() > 0.9 and smooth_cos.min() > 0.98
    # Interpolated normals follow the sphere better than face normals do.
    assert np.mean(1 - smooth_cos) < 0.5 * np.mean(1 - flat_cos)


def test_zero_area_faces_skipped_with_warning():
    mesh = bpy.data.meshes.new("Z")
    mesh.from_pydata([(0, 0, 0), (1, 0, 0), (1, 1, 0), (0, 1, 0), (2, 0, 0), (3, 0, 0), (4, 0, 0)],
                     [], [(0, 1, 2, 3), (4, 5, 6)])
    obj = link(bpy.data.objects.new("Z", mesh))
    job = pipeline.prepare(depsgraph(), [obj], pipeline.Settings(density=100, lamps=False))
    assert abs(job.areas.sum() - 1.0) < 1e-9
    assert any("zero-area" in w and "'Z'" in w for w in job.warnings)


def test_all_zero_area_is_an_error():
    mesh = bpy.data.meshes.new("Z")
    mesh.from_pydata([(0, 0, 0), (1, 0, 0), (2, 0, 0)], [], [(0, 1, 2)])
    obj = link(bpy.data.objects.new("Z", mesh))
    with pytest.raises(IllumapError, match="zero area"):
        pipeline.prepare(depsgraph(), [obj], pipeline.Settings(density=100, lamps=False))


def test_nan_vertices_error_names_object():
    obj = make_plane("Broken")
    co = np.zeros(12, dtype=np.float32)
    obj.data.vertices.foreach_get("co", co)
    co[4] = np.nan
    obj.data.vertices.foreach_set("co", co)
    obj.data.update()
    with pytest.raises(IllumapError, match="'Broken'.*NaN"):
        pipeline.prepare(depsgraph(), [obj], pipeline.Settings(density=100, lamps=False))


def test_nothing_selected_is_an_error():
    with pytest.raises(IllumapError, match="select"):
        pipeline.prepare(depsgraph(), [], pipeline.Settings())


def test_non_manifold_mesh_works():
    # Three quads sharing one edge (non-manifold) plus a loose edge: samples, no crash.
    mesh = bpy.data.meshes.new("NM")
    mesh.from_pydata([(0, 0, 0), (0, 1, 0), (1, 0, 0), (1, 1, 0), (-1, 0, 0), (-1, 1, 0),
                      (0, 0, 1), (0, 1, 1), (5, 5, 5), (6, 5, 5)],
                     [(8, 9)], [(0, 2, 3, 1), (0, 1, 5, 4), (0, 1, 7, 6)])
    obj = link(bpy.data.objects.new("NM", mesh))
    job = pipeline.prepare(depsgraph(), [obj], pipeline.Settings(density=100, lamps=False))
    front = sum(s.stop - s.start for s in job.sources if s.kind == "MESH")
    assert abs(job.areas[:front].sum() - 3.0) < 1e-9


def test_budget_too_large_refused_with_estimate():
    obj = make_plane("P")
    with pytest.raises(IllumapError, match=r"GiB"):
        pipeline.prepare(depsgraph(), [obj], pipeline.Settings(budget=10**12, lamps=False))


def test_collection_instance_sampled_in_world_space():
    src = bpy.data.collections.new("Src")  # not linked to the scene: only the instance shows
    plane = make_plane("Tile", size=1.0)
    bpy.context.scene.collection.objects.unlink(plane)
    src.objects.link(plane)
    empty = link(bpy.data.objects.new("Inst", None))
    empty.instance_type = "COLLECTION"
    empty.instance_collection = src
    empty.location = (5.0, 0.0, 2.0)
    empty.scale = (2.0, 2.0, 2.0)
    bpy.context.view_layer.update()
    job = pipeline.prepare(depsgraph(), [empty], pipeline.Settings(density=100, lamps=False))
    assert abs(job.areas.sum() - 4.0) < 1e-9          # 1 m² scaled by 2 × 2
    assert np.allclose(job.positions[:, 2], 2.0)
    assert np.all(np.abs(job.positions[:, 0] - 5.0) <= 1.0 + 1e-6)
    assert [s.name for s in job.sources] == ["Inst/Tile#1"]


def test_density_too_large_refused():
    obj = make_plane("P")
    with pytest.raises(IllumapError, match="GiB"):
        pipeline.prepare(depsgraph(), [obj], pipeline.Settings(density=1e9, lamps=False))
    with pytest.raises(IllumapError, match="beyond any memory"):
        pipeline.prepare(depsgraph(), [obj], pipeline.Settings(density=1e30, lamps=False))


@pytest.mark.parametrize("cuts", [15, 63])
def test_stratified_on_fine_meshes(cuts):
    """More triangles than (or about as many as) surfels: allocation along the cumulative area
    still spreads them. Uniform random points: coefficient of variation of nearest distances
    ≈ 0.52 and a minimum ≈ 0.02 spacing; the bounds below are well clear of that."""
    bpy.ops.mesh.primitive_grid_add(x_subdivisions=cuts + 2, y_subdivisions=cuts + 2, size=1.0)
    obj = bpy.context.active_object
    _, s = sample(obj, 1024)
    xy = s.positions[:, :2]
    d = np.linalg.norm(xy[:, None] - xy[None], axis=2)
    np.fill_diagonal(d, np.inf)
    nearest = d.min(axis=1) * 32  # in units of the mean spacing 1/√1024
    assert nearest.min() > 0.05
    assert nearest.std() / nearest.mean() < 0.4


def test_geometry_nodes_instances_sampled():
    """A mesh whose Geometry Nodes output is only instances (a tile on each of 4 points)."""
    tile = make_plane("Tile", size=0.5)
    tile.hide_render = tile.hide_viewport = True
    base = make_plane("Scatter", size=4.0)
    ng = bpy.data.node_groups.new("Scatter", "GeometryNodeTree")
    ng.interface.new_socket("Geometry", in_out="INPUT", socket_type="NodeSocketGeometry")
    ng.interface.new_socket("Geometry", in_out="OUTPUT", socket_type="NodeSocketGeometry")
    nodes, links = ng.nodes, ng.links
    gin, gout = nodes.new("NodeGroupInput"), nodes.new("NodeGroupOutput")
    inst = nodes.new("GeometryNodeInstanceOnPoints")
    info = nodes.new("GeometryNodeObjectInfo")
    info.inputs["Object"].default_value = tile
    links.new(gin.outputs[0], inst.inputs["Points"])
    links.new(info.outputs["Geometry"], inst.inputs["Instance"])
    links.new(inst.outputs["Instances"], gout.inputs[0])
    base.modifiers.new("GN", "NODES").node_group = ng
    bpy.context.view_layer.update()
    job = pipeline.prepare(depsgraph(), [base], pipeline.Settings(density=400, lamps=False))
    assert len(job.sources) == 4
    assert abs(job.areas.sum() - 4 * 0.25) < 1e-9
    # Each tile sits on one corner of the 4 m plane.
    corners = np.round(np.array([job.positions[s.start:s.stop].mean(0) for s in job.sources]), 1)
    assert {tuple(c[:2]) for c in corners} == {(-2, -2), (2, -2), (2, 2), (-2, 2)}
