"""The bad-scene corpus of the add-on and the batch command (issue 35).

Every case builds a small scene that is wrong in one way, runs Illumap on it and asserts
* the clear message: a regex naming the object (or option) and the real cause;
* that the file is untouched: no new object, mesh, attribute, material, node group, image or
  modifier, and no change of the active colour attribute (``snapshot``);
* for the batch command, the documented exit code (``errors.ExitCode``) and that no output
  file was written.
"""

import math
import os

import bpy
import numpy as np
import pytest

from illumap_bpy_testing import (add_lamp, diffuse_material, emission_material, link,
                                 make_plane, requires_core, select_only, top_camera)

from addon import batch
from addon.errors import ExitCode, IllumapError, NoLightError

pytestmark = requires_core


# --- helpers -------------------------------------------------------------------------------

def snapshot():
    """What a failed run must leave as it was: the datablocks and their attributes."""
    def attrs(data):
        return tuple(sorted(a.name for a in data.attributes))
    return {
        "objects": sorted(o.name for o in bpy.data.objects),
        "meshes": sorted((m.name, attrs(m), m.color_attributes.active_color_name or "")
                         for m in bpy.data.meshes),
        "pointclouds": sorted((p.name, attrs(p)) for p in bpy.data.pointclouds),
        "materials": sorted(m.name for m in bpy.data.materials),
        "node_groups": sorted(g.name for g in bpy.data.node_groups),
        "images": sorted(i.name for i in bpy.data.images),
        "modifiers": sorted((o.name, tuple(m.name for m in o.modifiers))
                            for o in bpy.data.objects),
    }


def lit_floor(name="Floor", lamp=True):
    """A 2 m floor under a point lamp (the scene every case spoils in one way)."""
    floor = make_plane(name, size=2.0, material=diffuse_material("Grey", (0.5,) * 3))
    if lamp:
        add_lamp("POINT", location=(0, 0, 2), energy=100.0)
    return floor


def files_under(folder):
    return sorted(os.path.relpath(os.path.join(d, f), folder)
                  for d, _, names in os.walk(folder) for f in names)


# --- add-on cases: pipeline.compute raises IllumapError with the message -------------------

def _inf_vertex():
    floor = lit_floor("Spiky")
    floor.data.vertices[0].co.x = float("inf")   # Blender stores it as FLT_MAX
    return [floor]


def _huge_vertex():
    floor = lit_floor("Far")
    floor.data.vertices[2].co.z = 1e30
    return [floor]


def _nan_location():
    floor = lit_floor("Lost")
    floor.location.x = float("nan")
    return [floor]


def _nan_rotation():
    floor = lit_floor("Spun")
    floor.rotation_euler.z = float("nan")
    return [floor]


def _zero_scale():
    floor = lit_floor("Flat")
    floor.scale = (1.0, 1.0, 0.0)
    return [floor]


def _scale_1e100():
    floor = lit_floor("Giant")
    floor.scale = (1e100,) * 3
    return [floor]


def _zero_area_faces():
    mesh = bpy.data.meshes.new("Sliver")
    mesh.from_pydata([(0, 0, 0), (1, 0, 0), (2, 0, 0)], [], [(0, 1, 2)])
    obj = link(bpy.data.objects.new("Sliver", mesh))
    add_lamp("POINT", location=(0, 0, 2), energy=100.0)
    return [obj]


def _no_light():
    return [lit_floor("Dark", lamp=False)]


def _lamps_off():
    floor = lit_floor("Unlit")
    return [floor]


def _facing_away():
    floor = lit_floor("Floor", lamp=False)
    add_lamp("SUN", rotation=(math.pi, 0, 0), energy=3.0)   # shines upwards, from below
    return [floor]


def _zero_size_area_lamp():
    floor = lit_floor("Floor", lamp=False)
    add_lamp("AREA", location=(0, 0, 1), energy=100.0, size=0.0)
    return [floor]


def _nan_lamp():
    floor = lit_floor("Floor", lamp=False)
    lamp = add_lamp("POINT", location=(0, 0, 2), energy=100.0)
    lamp.location.y = float("nan")
    return [floor]


def _coincident_points():
    mesh = bpy.data.meshes.new("Scan")
    mesh.from_pydata([(0.0, 0.0, 0.0)] * 12 + [(1.0, 0.0, 0.0)], [], [])
    obj = link(bpy.data.objects.new("Scan", mesh))
    add_lamp("POINT", location=(0, 0, 2), energy=100.0)
    return [obj]


def _nan_points():
    mesh = bpy.data.meshes.new("Cloud")
    mesh.from_pydata([(0.0, 0.0, 0.0), (1.0, 0.0, 0.0), (0.0, 1.0, 0.0), (1.0, 1.0, 0.0),
                      (0.5, 0.5, 0.0)], [], [])
    obj = link(bpy.data.objects.new("Cloud", mesh))
    obj.location.z = float("nan")
    add_lamp("POINT", location=(0, 0, 2), energy=100.0)
    return [obj]


def _nothing_usable():
    cam = link(bpy.data.objects.new("Cam", bpy.data.cameras.new("Cam")))
    return [cam]


ADDON_CASES = [
    # (id, build, settings overrides, error type, message regex)
    ("inf-vertex", _inf_vertex, {}, IllumapError,
     r"Object 'Spiky': vertex 0 lies at .*3\.4e\+38.* beyond .* infinite or absurd"),
    ("huge-vertex", _huge_vertex, {}, IllumapError,
     r"Object 'Far': vertex 2 lies at .*1e\+30.* beyond"),
    ("nan-location", _nan_location, {}, IllumapError,
     r"Object 'Lost' has a non-finite transform \(NaN or infinite location, rotation or scale"),
    ("nan-rotation", _nan_rotation, {}, IllumapError,
     r"Object 'Spun' has a non-finite transform"),
    ("zero-scale", _zero_scale, {}, IllumapError,
     r"Object 'Flat' has a degenerate \(zero-scale\) transform"),
    ("scale-1e100", _scale_1e100, {}, IllumapError,
     r"Object 'Giant': vertex 0 lies at \(-3\.4e\+38, .*beyond ±1e\+12 m: an infinite or absurd coordinate or scale"),
    ("zero-area-faces", _zero_area_faces, {}, IllumapError,
     r"Object 'Sliver': all 1 faces have zero area"),
    ("no-light", _no_light, {}, NoLightError,
     r"No light in the scene: no lamps, no emissive materials and no world light"),
    ("no-light-target-error", _no_light, {"target_error": 0.05}, NoLightError,
     r"No light in the scene.*solve skipped"),
    ("lamps-switched-off", _lamps_off, {"lamps": False}, NoLightError,
     r"No light in the scene.*lamps are switched off"),
    ("facing-away", _facing_away, {}, NoLightError,
     r"lamp 'LSUN' lights none of the surfaces.*faces away"),
    ("zero-size-area-lamp", _zero_size_area_lamp, {}, NoLightError,
     r"No light in the scene.*Lamp 'LAREA': area light of size 0"),
    ("nan-lamp", _nan_lamp, {}, IllumapError,
     r"Lamp 'LPOINT' has a non-finite transform"),
    ("coincident-points", _coincident_points, {}, IllumapError,
     r"Point cloud 'Scan': 1[23] points coincide with their .*nearest neighbours .*point 0 "
     r"at \(0, 0, 0\).*Merge by Distance"),
    ("nan-point-cloud", _nan_points, {}, IllumapError,
     r"Object 'Cloud' has a non-finite transform"),
    ("nothing-usable", _nothing_usable, {}, IllumapError,
     r"Nothing to compute: select mesh or point-cloud objects"),
    ("budget-absurd", lambda: [lit_floor()], {"budget": 10 ** 12}, IllumapError,
     r"1,000,000,000,000 surfels would need about [\d.]+ GiB"),
    ("density-absurd", lambda: [lit_floor()], {"density": 1e300, "budget": None}, IllumapError,
     r"Density 1e\+300/m² over 4 m² asks for .* surfels, far beyond any memory"),
    ("order-11", lambda: [lit_floor()], {"order": 11}, IllumapError,
     r"order: expected an integer >= 0 and <= 10, got 11"),
    ("tol-nan", lambda: [lit_floor()], {"tol": float("nan")}, IllumapError,
     r"tol: expected a number in \(0, 1\), got nan"),
    ("leaf-size-2^31", lambda: [lit_floor()], {"leaf_size": 2 ** 31}, IllumapError,
     r"leaf_size: expected an integer >= 1 and <= 2147483647, got 2147483648"),
    ("gather-rays-2^31", lambda: [lit_floor()], {"gather_rays": 2 ** 31}, IllumapError,
     r"Invalid setting gather_rays: expected an integer >= 1 and <= 2147483647, got 2147483648"),
    ("seed-negative", lambda: [lit_floor()], {"seed": -1}, IllumapError,
     r"seed: expected an integer >= 0 and <= \d+, got -1"),
    ("occluder-shape", lambda: [lit_floor()], {"occluder_shape": "hexagon"}, IllumapError,
     r"Invalid setting occluder_shape: expected one of disc, octagon, quad, got 'hexagon'"),
    ("target-error-range", lambda: [lit_floor()], {"target_error": 1.5}, IllumapError,
     r"Invalid setting target_error: expected a number in \(0, 1\), got 1\.5"),
]


@pytest.mark.parametrize("build, overrides, error, pattern",
                         [c[1:] for c in ADDON_CASES], ids=[c[0] for c in ADDON_CASES])
def test_addon_bad_scene(build, overrides, error, pattern):
    from addon import pipeline
    objects = build()
    before = snapshot()
    settings = pipeline.settings_from_preset("draft", **overrides)
    if "budget" in overrides and overrides["budget"] is None:
        settings.budget = None
    with pytest.raises(error, match=pattern):
        pipeline.compute(bpy.context, objects, settings)
    assert snapshot() == before


def test_no_light_at_target_error_skips_the_solve(monkeypatch):
    """No light and a target error: refused before the solve, which would otherwise ramp up
    surfels for a black map."""
    import illumap
    from addon import pipeline

    def no_solve(*args, **kwargs):
        raise AssertionError("the solve ran on a scene without light")
    monkeypatch.setattr(illumap, "solve", no_solve)
    monkeypatch.setattr(illumap.accuracy, "solve", no_solve)
    objects = _no_light()
    with pytest.raises(NoLightError):
        pipeline.compute(bpy.context, objects,
                         pipeline.settings_from_preset("draft", target_error=0.02))


def test_world_light_alone_is_light():
    """World light counts as light: no warning, and the floor is lit."""
    from addon import pipeline
    floor = lit_floor(lamp=False)
    world = bpy.data.worlds.new("Grey")
    world.color = (0.5, 0.5, 0.5)
    bpy.context.scene.world = world
    result = pipeline.compute(bpy.context, [floor],
                              pipeline.settings_from_preset("draft", world_ambient=True))
    assert result.radiosity.max() > 0


def test_emitter_alone_is_light():
    from addon import pipeline
    em = make_plane("Glow", size=0.5, material=emission_material("E", (1, 1, 1), 1.0))
    result = pipeline.compute(bpy.context, [em], pipeline.settings_from_preset("draft"))
    assert result.radiosity.max() > 0


# --- add-on cases through the operator (what the UI reports) -------------------------------

def test_operator_empty_selection_untouched():
    lit_floor()
    select_only()
    before = snapshot()
    with pytest.raises(RuntimeError, match="Nothing selected: select the mesh or point-cloud"):
        bpy.ops.illumap.compute_illumination_map()
    assert snapshot() == before


def test_operator_bad_geometry_names_object():
    obj = _nan_location()[0]
    select_only(obj)
    before = snapshot()
    with pytest.raises(RuntimeError, match=r"Illumap failed: Object 'Lost' has a non-finite "
                                           r"transform"):
        bpy.ops.illumap.compute_illumination_map()
    assert snapshot() == before


def test_operator_no_light_is_a_warning_and_writes_nothing():
    obj = _no_light()[0]
    select_only(obj)
    before = snapshot()
    # A warning, not an error: bpy.ops does not raise; the run is cancelled.
    assert bpy.ops.illumap.compute_illumination_map() == {"CANCELLED"}
    assert snapshot() == before


def test_operator_fmm_order_limit_is_the_core_limit():
    """The UI's FMM order stops where the native core does (one constant)."""
    from illumap.operator import MAX_ORDER
    prop = bpy.types.Scene.bl_rna.properties["illumap"].fixed_type.properties["order"]
    assert prop.hard_max == MAX_ORDER == 10


def test_second_run_refused_while_one_is_in_flight():
    """A run started while an interactive one is in flight is refused with a clear message,
    and the older run's result cannot be written over a newer one."""
    import threading
    from addon.ui import operators
    obj = lit_floor()
    select_only(obj)
    release = threading.Event()
    task = operators.ComputeTask(None, lambda job, progress: release.wait(10) and None)
    operators._current["task"] = task.start()
    try:
        before = snapshot()
        with pytest.raises(RuntimeError, match="An Illumap computation is already running"):
            bpy.ops.illumap.compute_illumination_map()
        assert snapshot() == before
    finally:
        release.set()
        task.wait(10)
        operators._current["task"] = None
    # A finished task that is not the latest run is discarded, not written.
    stale = operators.ComputeTask(None, lambda job, progress: "result").start()
    stale.wait(10)
    newer = operators.begin_run()
    assert newer > stale.run_id
    reports = []
    assert operators.finish_task(bpy.context, stale, lambda kind, text: reports.append(
        (kind, text))) == {"CANCELLED"}
    assert any("newer run" in text for _, text in reports), reports
    assert snapshot() == before


# --- batch cases: exit code, message, nothing written --------------------------------------

def _saved_scene(tmp_path, camera=True):
    lit_floor()
    if camera:
        top_camera()
    path = tmp_path / "scene.blend"
    bpy.ops.wm.save_as_mainfile(filepath=str(path))
    return path


def _a_file(tmp_path):
    p = tmp_path / "a_file.txt"
    p.write_text("not a folder")
    return p


BATCH_CASES = [
    # (id, argv builder(tmp_path, out_dir), exit code, stderr regex)
    ("output-under-a-file", lambda t, o: ["--output", str(_a_file(t) / "lit.blend")],
     ExitCode.OUTPUT, r"--output '.*a_file\.txt/lit\.blend' cannot be written: .*is a file, not "
                      r"a folder"),
    ("render-under-a-file", lambda t, o: ["--render", str(_a_file(t) / "x" / "lit.png")],
     ExitCode.OUTPUT, r"--render .* cannot be written: .*is a file, not a folder"),
    ("npz-under-a-file", lambda t, o: ["--export-npz", str(_a_file(t) / "s.npz")],
     ExitCode.OUTPUT, r"--export-npz .* cannot be written: .*is a file"),
    ("exr-is-a-folder", lambda t, o: ["--export-exr", str(t)],
     ExitCode.OUTPUT, r"--export-exr .* is a folder: give a file name"),
    ("output-unwritable", lambda t, o: ["--output", "/sys/illumap/lit.blend"],
     ExitCode.OUTPUT, r"--output '/sys/illumap/lit\.blend' cannot be written: the folder "
                      r"'/sys' is not writable"),
    ("render-unwritable", lambda t, o: ["--render", "/sys/lit.png"],
     ExitCode.OUTPUT, r"--render '/sys/lit\.png' cannot be written: the folder '/sys' is not "
                      r"writable"),
    ("npz-unwritable", lambda t, o: ["--export-npz", "/proc/illumap.npz"],
     ExitCode.OUTPUT, r"--export-npz '/proc/illumap\.npz' cannot be written"),
    ("lightmaps-unwritable", lambda t, o: ["--export-lightmaps", "/sys/{object}.exr"],
     ExitCode.OUTPUT, r"--export-lightmaps .* cannot be written"),
    ("output-is-input", lambda t, o: ["--output", str(t / "scene.blend")],
     ExitCode.OUTPUT, r"--output '.*scene\.blend' is the input file itself: .*--overwrite-input"),
    ("two-options-one-file", lambda t, o: ["--output", str(o / "x.blend"),
                                           "--export-npz", str(o / "x.blend.npz"),
                                           "--export-exr", str(o / "x.blend")],
     ExitCode.OUTPUT, r"--output and --export-exr both name"),
    ("render-without-camera", lambda t, o: ["--render", str(o / "lit.png"), "--no-camera"],
     ExitCode.OUTPUT, r"--render .* cannot be rendered: the scene has no camera"),
    ("frames-unbounded", lambda t, o: ["--frames", "1-100000000", "--output", str(o / "x.blend")],
     ExitCode.USAGE, r"--frames '1-100000000' asks for more than 10,000 frames"),
    ("frames-beyond-blender", lambda t, o: ["--frames", "1048000-1048600"],
     ExitCode.USAGE, r"frame range '1048000-1048600' lies outside Blender's frames "
                     r"-1048574\.\.1048574"),
    ("frames-huge-integer", lambda t, o: ["--frames", "99999999999999999999999"],
     ExitCode.USAGE, r"bad frame range '99999999999999999999999'"),
    ("frames-garbage", lambda t, o: ["--frames", "1-3,x"],
     ExitCode.USAGE, r"bad frame range 'x' in --frames"),
    ("budget-zero", lambda t, o: ["--budget", "0"], ExitCode.USAGE,
     r"--budget must lie in 1\.\.\d+ surfels, got 0"),
    ("density-nan", lambda t, o: ["--density", "nan"], ExitCode.USAGE,
     r"--density must lie in \(0, inf\) surfels/m², got nan"),
    ("tol-garbage", lambda t, o: ["--tol", "2"], ExitCode.USAGE,
     r"--tol must lie in \(0, 1\)"),
    ("resolution-absurd", lambda t, o: ["--resolution", "1000000"], ExitCode.USAGE,
     r"--resolution must lie in 1\.\.65536"),
    ("lightmap-size-absurd", lambda t, o: ["--lightmap-size", "1000000"], ExitCode.USAGE,
     r"--lightmap-size must lie in 1\.\.16384"),
    ("gather-rays-2^31", lambda t, o: ["--gather-rays", str(2 ** 31)], ExitCode.USAGE,
     r"--gather-rays must lie in 1\.\."),
    ("mesh-preview-without-transfer", lambda t, o: ["--render-preview", "meshes",
                                                    "--no-transfer"],
     ExitCode.USAGE, r"--render-preview meshes .* --no-transfer"),
    ("no-such-object", lambda t, o: ["--objects", "Nope", "--output", str(o / "x.blend")],
     ExitCode.INPUT,
     r"No object named 'Nope'"),
    ("no-light", lambda t, o: ["--no-lamps", "--output", str(o / "x.blend")], ExitCode.INPUT,
     r"nothing computed: No light in the scene"),
]


@pytest.mark.parametrize("argv, code, pattern", [c[1:] for c in BATCH_CASES],
                         ids=[c[0] for c in BATCH_CASES])
def test_batch_bad_input(tmp_path, capsys, argv, code, pattern):
    out = tmp_path / "out"
    args = argv(tmp_path, out)
    camera = "--no-camera" not in args
    args = [a for a in args if a != "--no-camera"]
    _saved_scene(tmp_path, camera=camera)
    listed = files_under(tmp_path)
    before = snapshot()
    assert batch.main(["--quality", "draft", *args]) == code
    err = capsys.readouterr().err
    assert __import__("re").search(pattern, err), err
    assert snapshot() == before
    assert files_under(tmp_path) == listed   # no output, no temporary file left


def test_batch_overwrite_input_when_asked(tmp_path, capsys):
    path = _saved_scene(tmp_path)
    stamp = os.path.getmtime(path)
    assert batch.main(["--quality", "draft", "--output", str(path), "--overwrite-input"]) == 0
    assert os.path.getmtime(path) >= stamp
    assert [f for f in os.listdir(tmp_path) if f.startswith(".")] == []
    bpy.ops.wm.open_mainfile(filepath=str(path))
    assert "Illumap Surfels" in bpy.data.objects


def test_batch_outputs_are_atomic(tmp_path, monkeypatch, capsys):
    """A failure while the frame's outputs are written leaves neither the output nor a
    temporary file; the exit code is the output code."""
    _saved_scene(tmp_path)
    out = tmp_path / "out"

    def failing_save(path):
        with open(path, "wb") as f:
            f.write(b"half")
        raise RuntimeError("Error: disk full")
    monkeypatch.setattr(batch, "save_copy", failing_save)
    code = batch.main(["--quality", "draft", "--output", str(out / "lit.blend"),
                       "--export-npz", str(out / "lit.npz")])
    assert code == ExitCode.OUTPUT
    assert "could not be saved: Error: disk full" in capsys.readouterr().err
    assert not (out / "lit.blend").exists()
    assert [f for f in os.listdir(out) if f.startswith(".")] == []
    assert (out / "lit.npz").exists()   # written whole before the save failed


def test_batch_unexpected_error_is_not_success(tmp_path, monkeypatch, capsys):
    lit_floor()
    from addon import pipeline

    def bug(*args, **kwargs):
        raise KeyError("boom")
    monkeypatch.setattr(pipeline, "compute", bug)
    assert batch.main(["--quality", "draft", "--export-npz", str(tmp_path / "x.npz")]) \
        == ExitCode.INTERNAL
    err = capsys.readouterr().err
    assert "KeyError: 'boom'" in err and "internal error" in err


def test_batch_frames_are_parsed_without_listing():
    """The range is counted before any list of frames exists: a huge range costs nothing."""
    import tracemalloc
    tracemalloc.start()
    with pytest.raises(batch.UsageError, match="more than 10,000 frames"):
        batch.parse_frames("1-1000000", 1)
    _, peak = tracemalloc.get_traced_memory()
    tracemalloc.stop()
    assert peak < 1 << 20
    assert batch.parse_frames("1-9000,1-9000,8000-10000", 1) == list(range(1, 10001))
    # the limit is where the message puts it: its last frame passes, the next one does not
    assert len(batch.parse_frames(f"1-{batch.MAX_FRAMES}", 1)) == batch.MAX_FRAMES
    with pytest.raises(batch.UsageError, match=f"more than {batch.MAX_FRAMES:,} frames"):
        batch.parse_frames(f"0-{batch.MAX_FRAMES}", 1)


def test_batch_help_documents_exit_codes(capsys):
    with pytest.raises(SystemExit):
        batch.build_parser().parse_args(["--help"])
    text = capsys.readouterr().out
    for code in ExitCode:
        assert f"{int(code)} " in text
    assert "--overwrite-input" in text and "10,000" in text


def test_a_solve_stopped_early_says_why():
    """A solve cut short (here by its iteration limit) is written with a warning that gives
    the solver's reason and says the light is not the converged one."""
    from addon import pipeline
    floor = lit_floor()
    wall = make_plane("Wall", size=2.0, location=(0, 0, 1), material=diffuse_material("W", (0.8,) * 3))
    wall.rotation_euler = (1.5708, 0, 0)
    bpy.context.view_layer.update()
    result = pipeline.compute(bpy.context, [floor, wall],
                              pipeline.settings_from_preset("draft", tol=1e-12, max_iterations=1))
    assert not result.converged
    stop = [w for w in result.warnings if w.startswith("Solver did not converge")]
    assert len(stop) == 1 and "did not reach tol" in stop[0] and "not the converged light" in stop[0]
