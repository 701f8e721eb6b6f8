"""Same scene, same light: identical runs give identical bits, whatever the thread count, the
order Blender keeps faces in, the camera or the other objects (issue "Same scene, same light").

The open scene: a ground grid, two buildings, a table with a thin top and a UV sphere resting on
the ground, under a sun and a blue sky (the sky's path is where runs used to differ).
"""

import os
import subprocess
import sys

import bmesh
import bpy
import numpy as np
import pytest

from illumap_bpy_testing import add_lamp, link, requires_core, select_only, sky_world

import determinism_run as one_run

pytestmark = requires_core

#: tests/blender, where the helper scripts live.
HERE = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def _mesh(name, verts, faces, location=(0.0, 0.0, 0.0), smooth=False):
    mesh = bpy.data.meshes.new(name)
    mesh.from_pydata([tuple(v) for v in verts], [], [tuple(f) for f in faces])
    mesh.update()
    if smooth:
        mesh.shade_smooth()
    obj = link(bpy.data.objects.new(name, mesh))
    obj.location = location
    return obj


def _box(name, lo, hi):
    x0, y0, z0 = lo
    x1, y1, z1 = hi
    verts = [(x0, y0, z0), (x1, y0, z0), (x1, y1, z0), (x0, y1, z0),
             (x0, y0, z1), (x1, y0, z1), (x1, y1, z1), (x0, y1, z1)]
    faces = [(0, 3, 2, 1), (4, 5, 6, 7), (0, 1, 5, 4), (1, 2, 6, 5), (2, 3, 7, 6), (3, 0, 4, 7)]
    return _mesh(name, verts, faces)


def _grid(name, size, cells):
    xs = np.linspace(-size / 2, size / 2, cells + 1)
    x, y = np.meshgrid(xs, xs, indexing="ij")
    verts = np.column_stack([x.ravel(), y.ravel(), np.zeros(x.size)])
    k = lambda i, j: i * (cells + 1) + j  # noqa: E731
    faces = [(k(i, j), k(i + 1, j), k(i + 1, j + 1), k(i, j + 1))
             for i in range(cells) for j in range(cells)]
    return _mesh(name, verts, faces)


def _sphere_data(radius=0.6, segments=24, rings=12):
    bm = bmesh.new()
    bmesh.ops.create_uvsphere(bm, u_segments=segments, v_segments=rings, radius=radius)
    verts = [tuple(v.co) for v in bm.verts]
    faces = sorted(tuple(v.index for v in f.verts) for f in bm.faces)
    bm.free()
    return verts, faces


def open_scene(face_order=None, smooth=True, sphere_at=(1.5, -1.0, 0.6)):
    """The open scene; ``face_order`` (a seed) shuffles the sphere's faces, as Blender does
    from one session to the next. Returns the mesh objects."""
    ground = _grid("Ground", 10.0, 20)
    house = _box("House", (-3.0, 1.0, 0.0), (-1.0, 3.0, 2.0))
    tower = _box("Tower", (2.0, 1.5, 0.0), (3.0, 2.5, 3.0))
    table = _box("Table", (-0.75, -2.5, 0.78), (0.75, -1.5, 0.82))
    verts, faces = _sphere_data()
    if face_order is not None:
        rng = np.random.default_rng(face_order)
        faces = [faces[i] for i in rng.permutation(len(faces))]

    sphere = _mesh("Sphere", verts, faces, location=sphere_at, smooth=smooth)
    add_lamp("SUN", rotation=(0.6, 0.3, 0.5), energy=3.0)
    sky_world((0.3, 0.5, 1.0))
    objects = [ground, house, tower, table, sphere]
    select_only(*objects)
    return objects


def _assert_same_bits(a: dict, b: dict):
    assert a.keys() == b.keys()
    for name in a:
        assert a[name].shape == b[name].shape, name
        diff = np.abs(a[name] - b[name]).max(initial=0.0)
        assert np.array_equal(a[name], b[name]), f"{name}: differs by up to {diff:.3g}"


def _values(objects, target=None):
    job, result = one_run.solve(objects, target)
    return job, result, one_run.keyed_values(result)


@pytest.mark.parametrize("target", [None, 0.03], ids=["default", "target3"])
@pytest.mark.parametrize("world", [True, False], ids=["sky", "no_sky"])
def test_two_identical_runs_give_the_same_bits(target, world):
    objects = open_scene()
    if not world:
        bpy.context.scene.world = None
    job_a, result_a, a = _values(objects, target)
    job_b, result_b, b = _values(objects, target)
    assert np.array_equal(job_a.positions, job_b.positions)
    assert np.array_equal(result_a.radiosity, result_b.radiosity)
    assert result_a.residual == result_b.residual
    _assert_same_bits(a, b)
    assert all(np.all(np.isfinite(v)) and v.min() >= 0.0 for v in a.values())


def test_the_order_blender_keeps_faces_in_changes_nothing():
    """The same flat-shaded sphere with its faces in another order (what one scene built by
    a script shows from one session to the next): the same surfels and the same light at
    every corner, bit for bit. Smooth normals are left out: Blender sums them in face order,
    so they differ in their last bit (a ~1e-8 change in the light)."""
    objects = open_scene(face_order=None, smooth=False)
    job_a, result_a, a = _values(objects)
    bpy.ops.wm.read_factory_settings(use_empty=True)
    objects = open_scene(face_order=7, smooth=False)
    job_b, result_b, b = _values(objects)
    assert np.array_equal(job_a.positions, job_b.positions)
    assert np.array_equal(result_a.radiosity, result_b.radiosity)
    _assert_same_bits(a, b)


def test_contact_corners_are_evaluated_in_their_own_faces():
    """The sphere's bottom pole touches the ground: its corners (each in its own face, flat
    shading) read the same in every face order and never more than the ring above them, whose
    faces see more of the sky."""
    values = []
    for order in (None, 3):
        bpy.ops.wm.read_factory_settings(use_empty=True)
        objects = open_scene(face_order=order, smooth=False)
        _, _, v = _values(objects)
        values.append(v["Sphere"])
    assert np.array_equal(values[0], values[1])
    mesh = bpy.data.objects["Sphere"].data
    z = np.array([v.co.z for v in mesh.vertices])
    keys = one_run.corner_keys(mesh)
    vertex = np.array([loop.vertex_index for loop in mesh.loops])[np.argsort(keys, kind="stable")]
    pole = vertex == int(np.argmin(z))
    ring = vertex == int(np.argsort(z)[1])
    lum = values[0] @ np.array([0.2126, 0.7152, 0.0722])
    assert pole.sum() == 24
    assert np.all(lum[pole] <= lum[ring].max() + 1e-12)


def test_other_objects_leave_an_objects_surfels_alone():
    """Each object's samples follow from it alone: moving the tower, selecting in another
    order, or (at a fixed density) adding an object leaves the sphere's surfels alone."""
    from addon import pipeline

    def sphere_surfels(job):
        src = next(s for s in job.sources if s.name == "Sphere" and s.kind == "MESH")
        return job.positions[src.start:src.stop]

    objects = open_scene()
    settings = pipeline.settings_from_preset("medium")
    first = pipeline.prepare(bpy.context.evaluated_depsgraph_get(), objects, settings)
    bpy.data.objects["Tower"].location.x += 0.5
    moved = pipeline.prepare(bpy.context.evaluated_depsgraph_get(), objects[::-1], settings)
    assert np.array_equal(sphere_surfels(first), sphere_surfels(moved))
    # With a density (a budget is shared by area, so a new object takes its share):
    dense = pipeline.settings_from_preset("medium", density=200.0)
    before = pipeline.prepare(bpy.context.evaluated_depsgraph_get(), objects, dense)
    extra = _box("Shed", (3.5, -3.5, 0.0), (4.5, -2.5, 1.0))
    after = pipeline.prepare(bpy.context.evaluated_depsgraph_get(), [extra] + objects, dense)
    assert np.array_equal(sphere_surfels(before), sphere_surfels(after))


def test_a_moving_camera_changes_nothing():
    """Static objects under a moving camera: the same light, bit for bit."""
    objects = open_scene()
    cam = link(bpy.data.objects.new("Camera", bpy.data.cameras.new("Camera")))
    bpy.context.scene.camera = cam
    cam.location = (8.0, -8.0, 5.0)
    _, _, a = _values(objects)
    cam.location = (-8.0, 6.0, 3.0)
    cam.rotation_euler = (1.1, 0.0, 2.5)
    _, _, b = _values(objects)
    _assert_same_bits(a, b)


def test_thread_counts_give_the_same_bits(tmp_path):
    """One saved scene run in fresh processes with 1 and 2 worker threads (and 2 again): the
    same bits, with the sky on, at default settings and at a target."""
    open_scene()
    blend = str(tmp_path / "open.blend")
    bpy.ops.wm.save_as_mainfile(filepath=blend, copy=True)
    script = os.path.join(HERE, "determinism_run.py")
    for target in ([], ["0.03"]):
        runs = []
        for threads in ("1", "2", "2"):
            out = str(tmp_path / f"run_{threads}_{len(runs)}_{len(target)}.npz")
            env = dict(os.environ, ILLUMAP_THREADS=threads)
            done = subprocess.run([sys.executable, script, blend, out, *target], env=env,
                                  capture_output=True, text=True, timeout=300)
            assert done.returncode == 0, done.stderr[-2000:]
            runs.append(dict(np.load(out)))
        for other in runs[1:]:
            _assert_same_bits(runs[0], other)
