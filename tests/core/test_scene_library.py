"""The scene library (bench/scenes/): its data modules import without Blender, every declared
scene names its objects and materials once, and the Cornell box's two forms are one box."""

import os
import subprocess
import sys

import numpy as np
import pytest

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
if ROOT not in sys.path:
    sys.path.insert(0, ROOT)

from bench.scenes import cornell, meshes, spec  # noqa: E402

DATA_MODULES = ("cornell", "shapes", "spec", "meshes")


def test_the_data_modules_import_without_blender():
    code = ("import sys; sys.path.insert(0, sys.argv[1]); "
            + "; ".join(f"import bench.scenes.{m}" for m in DATA_MODULES)
            + "; bad = [m for m in ('bpy', 'bmesh', 'illumap') if m in sys.modules]; "
              "sys.exit(f'imported {bad}' if bad else 0)")
    done = subprocess.run([sys.executable, "-c", code, ROOT], capture_output=True, text=True,
                          timeout=120)
    assert done.returncode == 0, done.stderr[-2000:]


def _declared():
    """Every declared scene: the reference scenes and the preview scenes."""
    scenes = [make() for make in meshes.REFERENCE.values()]
    scenes += [meshes.cornell_scan(0.2), meshes.preview_room(0.1, 0.35),
               meshes.preview_bunny(0.2)]
    return scenes


@pytest.mark.parametrize("scene", _declared(), ids=lambda s: s.name)
def test_a_declared_scene_names_each_object_and_material_once(scene):
    names = [o.name for o in scene.objects]
    assert len(names) == len(set(names)), names
    materials = {}
    for m in scene.objects:
        if isinstance(m, spec.Mesh):
            assert materials.setdefault(m.material.name, m.material) == m.material, m.name
            for verts, faces, _ in m.parts:
                assert np.isfinite(verts).all() and faces.min() >= 0 and faces.max() < len(verts)
    assert {m.name for m in scene.meshes("scored")} | {m.name for m in scene.meshes("emitter")} \
        == {o.name for o in scene.objects if isinstance(o, spec.Mesh)}
    assert set(scene.scan) <= {m.name for m in scene.meshes("scored")}


def test_the_regular_cornell_box_is_the_published_one_made_regular():
    """The surfel benches' box stands its blocks on the published footprints at the published
    heights (each side on a published edge; each top the parallelogram on three published
    corners, whose fourth lies off the published one by as much as the published top is off
    a parallelogram: 2.8 mm), with the published light's size and the published width."""
    quads = {q["name"]: q for q in cornell.regular_quads()}
    for label, name in (("Short", "ShortBlock"), ("Tall", "TallBlock")):
        top = np.array(cornell.PUBLISHED_MM[name][0], float)          # mm, Y up
        published = np.column_stack([cornell.BOX - 1e-3 * top[:, 0], 1e-3 * top[:, 2]])
        edges = {tuple(np.round(np.r_[published[k], published[(k + 1) % 4]], 9))
                 for k in range(4)}
        for k in range(4):
            side = quads[f"{label}Side{k}"]
            base = np.r_[side["origin"][:2], side["origin"][:2] + side["u"][:2]]
            assert tuple(np.round(base, 9)) in edges or \
                tuple(np.round(np.r_[base[2:], base[:2]], 9)) in edges, (name, k)
            assert side["v"][2] == pytest.approx(1e-3 * top[0, 1])
        q = quads[f"{label}Top"]
        corners = q["origin"][:2] + np.array([[0, 0], [1, 0], [1, 1], [0, 1]]) @ np.array(
            [q["u"][:2], q["v"][:2]])
        assert q["origin"][2] == pytest.approx(1e-3 * top[0, 1])
        gap = np.linalg.norm(corners[:, None] - published[None], axis=2).min(axis=1)
        skew = np.linalg.norm(published[0] - published[1] + published[2] - published[3])
        assert np.sort(gap)[2] < 1e-12 and gap.max() <= skew + 1e-12, (gap, skew)
    light = np.array(cornell.PUBLISHED_MM["Light"][0], float)
    size = 1e-3 * np.ptp(light, axis=0)                               # x, (y), z extents
    assert np.allclose([np.linalg.norm(quads["Light"]["v"]), np.linalg.norm(quads["Light"]["u"])],
                       [size[0], size[2]])
    assert cornell.BOX == pytest.approx(1e-3 * max(p[0] for p in cornell.PUBLISHED_MM["Ceiling"][0]))
