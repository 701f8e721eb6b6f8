"""Batch jobs: the command line as users type it (scripts/blender -b ... --python
scripts/illumap_batch.py -- ...), frame ranges with one result per frame, idempotent re-runs,
exit codes."""

import os
import subprocess

import bpy
import numpy as np
import pytest

from illumap_bpy_testing import (diffuse_material, emission_material, make_plane,
                                 requires_core, top_camera)

from addon import batch

pytestmark = requires_core
REPO = os.path.dirname(os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__)))))


def animated_scene(path):
    """Floor + emitter that rises from z=1 (frame 1) to z=2 (frame 3); a camera; saved."""
    floor = make_plane("Floor", size=2.0, material=diffuse_material("F", (0.5,) * 3))
    em = make_plane("Emitter", size=0.5, location=(0, 0, 1), flip=True,
                    material=emission_material("E", (1, 1, 1), 1.0))
    em.keyframe_insert("location", frame=1)
    em.location.z = 2.0
    em.keyframe_insert("location", frame=3)
    top_camera(ortho_scale=2.5)
    bpy.context.scene.frame_set(1)
    bpy.ops.wm.save_as_mainfile(filepath=str(path))
    return floor, em


def run_cli(blend, *args):
    cmd = [os.path.join(REPO, "scripts", "blender"), "-b", str(blend), "--python",
           os.path.join(REPO, "scripts", "illumap_batch.py"), "--", *args]
    return subprocess.run(cmd, capture_output=True, text=True, timeout=300)


def job(*argv):
    """``batch.main`` with an output (a job without one is a usage error): an .npz in the
    temporary folder, overwritten by each job."""
    import tempfile
    return batch.main([*argv, "--export-npz",
                       os.path.join(tempfile.gettempdir(), f"illumap-test-{os.getpid()}.npz")])


def floor_centre_value(blend_path):
    bpy.ops.wm.open_mainfile(filepath=str(blend_path))
    obj = bpy.data.objects["Illumap Surfels"]
    n = len(obj.data.points)
    pos = np.empty(n * 3)
    obj.data.attributes["position"].data.foreach_get("vector", pos)
    ill = np.empty(n * 4)
    obj.data.attributes["illumination"].data.foreach_get("color", ill)
    pos, ill = pos.reshape(n, 3), ill.reshape(n, 4)
    near = (pos[:, 2] < 0.1) & (np.hypot(pos[:, 0], pos[:, 1]) < 0.1)
    return ill[near, 0].mean()


def test_cli_frame_range_outputs_and_idempotence(tmp_path):
    scene = tmp_path / "scene.blend"
    animated_scene(scene)
    out = tmp_path / "out" / "lit_####.blend"
    png = tmp_path / "out" / "lit_####.png"
    args = ("--objects", "Floor,Emitter", "--frames", "1-3", "--density", "200", "--method",
            "direct", "--output", str(out), "--render", str(png), "--resolution", "32",
            "--samples", "2")
    proc = run_cli(scene, *args)
    assert proc.returncode == 0, proc.stdout + proc.stderr
    for f in (1, 2, 3):
        assert (tmp_path / "out" / f"lit_{f:04d}.blend").exists()
        assert (tmp_path / "out" / f"lit_{f:04d}.png").exists()
        assert f"Illumap frame {f}:" in proc.stdout
    assert "surfels" in proc.stdout and "iterations" in proc.stdout and "residual" in proc.stdout
    # One result per frame: the emitter rises, so the floor centre gets darker.
    values = [floor_centre_value(tmp_path / "out" / f"lit_{f:04d}.blend") for f in (1, 2, 3)]
    # The saved file opens as the UI shows a result: the lit meshes through the Object
    # Preview, the surfels (a diagnostic) hidden in the viewport and in renders.
    lit = [o for o in bpy.data.objects if "Illumap Mesh Preview" in o.modifiers]
    assert lit and all("illumination" in o.data.attributes for o in lit)
    surfels = bpy.data.objects["Illumap Surfels"]
    assert surfels.hide_render and surfels.hide_viewport
    assert values[0] > values[1] > values[2] > 0
    # The rendered preview shows the illumination (not black).
    img = bpy.data.images.load(str(tmp_path / "out" / "lit_0001.png"))
    px = np.empty(img.size[0] * img.size[1] * 4, np.float32)
    img.pixels.foreach_get(px)
    assert img.size[0] == 32 and px.reshape(-1, 4)[:, :3].max() > 0.05
    # --skip-existing: a second run skips every frame whose outputs exist; delete one output
    # and only its frame is redone.
    mtime = os.path.getmtime(tmp_path / "out" / "lit_0001.blend")
    os.remove(tmp_path / "out" / "lit_0002.png")
    proc = run_cli(scene, *args, "--skip-existing")
    assert proc.returncode == 0, proc.stdout + proc.stderr
    assert proc.stdout.count("skipped") == 2 and "Illumap frame 2: " in proc.stdout
    assert os.path.getmtime(tmp_path / "out" / "lit_0001.blend") == mtime
    assert (tmp_path / "out" / "lit_0002.png").exists()
    # By default a re-run overwrites, as Blender does (the scene may have changed).
    proc = run_cli(scene, *args[:3], "1", *args[4:])
    assert proc.returncode == 0, proc.stdout + proc.stderr
    assert "skipped" not in proc.stdout
    assert os.path.getmtime(tmp_path / "out" / "lit_0001.blend") > mtime


def test_cli_bad_arguments_exit_2(tmp_path):
    scene = tmp_path / "scene.blend"
    animated_scene(scene)
    proc = run_cli(scene, "--quality", "ultra")
    assert proc.returncode == 2 and "quality" in proc.stderr


def test_exit_codes_in_process(tmp_path):
    make_plane("Floor")
    assert job(*["--frames", "3-1"]) == 2
    assert job(*["--density", "-5"]) == 2
    assert job(*["--objects", "Nope"]) == 3
    bpy.data.collections.new("Empty")
    bpy.context.scene.collection.children.link(bpy.data.collections["Empty"])
    assert job(*["--collection", "Empty"]) == 3


def test_empty_scene_exit_3(capsys):
    assert job(*["--method", "direct"]) == 3
    assert "select" in capsys.readouterr().err


def test_collection_and_default_selection(tmp_path):
    floor = make_plane("Floor", material=diffuse_material("F", (0.5,) * 3))
    em = make_plane("Emitter", size=0.5, location=(0, 0, 1), flip=True,
                    material=emission_material("E", (1, 1, 1), 1.0))
    coll = bpy.data.collections.new("Lit")
    bpy.context.scene.collection.children.link(coll)
    coll.objects.link(floor)
    coll.objects.link(em)
    objs = batch.select_objects(bpy.context.scene, bpy.context.view_layer, None, "Lit")
    assert {o.name for o in objs} == {"Floor", "Emitter"}
    assert batch.main(["--collection", "Lit", "--density", "50", "--method", "direct",
                       "--output", str(tmp_path / "a.blend")]) == 0
    assert (tmp_path / "a.blend").exists()
    assert "Illumap Surfels" in bpy.data.objects


def test_frame_paths():
    assert batch.parse_frames("1-3,7", 5) == [1, 2, 3, 7]
    assert batch.parse_frames(None, 5) == [5]
    assert batch.frame_path("/x/a_##.png", 7, False) == "/x/a_07.png"
    assert batch.frame_path("/x/a.png", 7, True) == "/x/a_0007.png"
    assert batch.frame_path("/x/a.png", 7, False) == "/x/a.png"


def test_solver_failure_and_cancel_exit_codes(monkeypatch, capsys):
    import illumap
    make_plane("Floor", material=diffuse_material("F", (0.5,) * 3))
    make_plane("Emitter", size=0.5, location=(0, 0, 1), flip=True,
               material=emission_material("E", (1, 1, 1), 1.0))

    def broken(*args, **kwargs):
        raise RuntimeError("matrix exploded")

    def cancelled(*args, **kwargs):
        raise illumap.Cancelled()

    monkeypatch.setattr(illumap, "solve", broken)
    assert job(*["--density", "20"]) == 4
    assert "matrix exploded" in capsys.readouterr().err
    monkeypatch.setattr(illumap, "solve", cancelled)
    assert job(*["--density", "20"]) == 130
    assert "Illumap Surfels" not in bpy.data.objects  # nothing written on failure/cancel


def test_budget_too_large_exit_3_with_estimate(capsys):
    make_plane("Floor")
    assert job(*["--budget", str(10 ** 12)]) == 3
    assert "GiB" in capsys.readouterr().err


def test_target_error_option_reports_chosen_settings(tmp_path, capfd):
    make_plane("Floor", size=2.0, material=diffuse_material("F", (0.5,) * 3))
    make_plane("Emitter", size=0.5, location=(0, 0, 1), flip=True,
               material=emission_material("E", (1, 1, 1), 1.0))
    assert batch.main(["--target-error", "0.05", "--budget", "600", "--no-transfer",
                       "--output", str(tmp_path / "t.blend")]) == 0
    assert (tmp_path / "t.blend").exists()
    printed = capfd.readouterr().out
    assert "target error 0.05" in printed and "estimated error" in printed
    assert "or solver error ≤ 0.01" in printed   # the solve's own share of the target
    # The density the target asks for (capped by the budget) and both adaptive passes.
    assert "surfels/m² (600 surfels, predicted discretization error" in printed
    assert "adaptive: pass 1 300 surfels" in printed and "pass 2 600 surfels" in printed
    assert job(*["--target-error", "1.5", "--budget", "100"]) == 2
    assert job(*["--target-error", "0.05", "--density", "100"]) == 2
    assert "exclude each other" in capfd.readouterr().err
    assert job(*["--target-error", "0.05", "--budget", "300", "--no-adaptive"]) == 0
    printed = capfd.readouterr().out
    assert "adaptive:" not in printed and "Illumap frame 1: 300 surfels" in printed


def test_a_target_error_chooses_the_count_unless_a_budget_caps_it():
    """--target-error alone: no preset budget caps the count the target asks for; with
    --budget the budget is a cap, and --quality's budget applies again without a target."""
    parse = batch.build_parser().parse_args
    settings = batch.make_settings(parse(["--target-error", "0.01"]))
    assert settings.target_error == pytest.approx(0.01)
    assert settings.budget is None and settings.density is None
    assert batch.make_settings(parse(["--target-error", "0.01", "--budget", "500"])).budget == 500
    assert batch.make_settings(parse([])).budget is not None


def test_lamp_shadow_options():
    args = batch.build_parser().parse_args(["--no-lamp-shadows", "--shadow-samples", "4"])
    settings = batch.make_settings(args)
    assert settings.lamp_shadows is False and settings.shadow_samples == 4
    settings = batch.make_settings(batch.build_parser().parse_args([]))
    assert settings.lamp_shadows is True and settings.shadow_samples == 16 and settings.adaptive
    assert job(*["--shadow-samples", "0"]) == 2


def test_occluder_shape_option(capsys):
    """--occluder-shape reaches the settings (default disc), an unknown shape is a usage error,
    and a run with lamp shadows names the shape it cast them against."""
    parse = batch.build_parser().parse_args
    assert batch.make_settings(parse([])).occluder_shape == "disc"
    assert batch.make_settings(parse(["--occluder-shape", "Octagon"])).occluder_shape == "octagon"
    with pytest.raises(batch.UsageError, match="hexagon"):
        parse(["--occluder-shape", "hexagon"])
    assert job(*["--occluder-shape", "hexagon"]) == 2
    capsys.readouterr()
    make_plane("Floor", size=2.0)
    make_plane("Plate", size=0.5, location=(0, 0, 0.5))
    bpy.ops.object.light_add(type="POINT", location=(0, 0, 2))
    bpy.context.object.data.energy = 100.0
    assert job(*["--quality", "draft", "--occluder-shape", "octagon"]) == 0
    out = capsys.readouterr().out
    # Meshes occlude with their own triangles, between surfels and for lamp shadows alike:
    # the shape matters for point clouds only.
    assert "visibility       exact, triangles" in out and "(triangles)" in out, out
    assert job(*["--quality", "high", "--density", "100", "--occluder-shape", "quad"]) == 0
    out = capsys.readouterr().out
    assert "visibility       exact, triangles" in out and "(triangles)" in out, out


@pytest.mark.parametrize("kind", ["random bytes", "truncated"])
def test_cli_an_unreadable_blend_is_one_line_and_exit_3(tmp_path, kind):
    """A corrupt .blend (random bytes, or a real scene cut short) stops the command line where
    it is read, as Blender does: one line on stderr naming the file, no traceback, the batch's
    "bad scene or input" exit code, and nothing written."""
    bad = tmp_path / "scene.blend"
    if kind == "random bytes":
        bad.write_bytes(np.random.default_rng(0).integers(0, 256, 5000, dtype=np.uint8).tobytes())
    else:
        good = tmp_path / "good.blend"
        animated_scene(good)
        bad.write_bytes(good.read_bytes()[:20000])
    out = tmp_path / "out" / "lit.blend"
    proc = run_cli(bad, "--quality", "draft", "--output", str(out))
    assert proc.returncode == int(batch.ExitCode.INPUT), proc.stdout + proc.stderr
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1 and str(bad) in lines[0] and "cannot read" in lines[0], proc.stderr
    assert "Traceback" not in proc.stdout + proc.stderr
    assert not (tmp_path / "out").exists()
