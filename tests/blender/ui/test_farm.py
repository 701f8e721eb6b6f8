"""The batch command as a render farm uses it (issue 55): a job without an output is a usage
error, --render takes the scene's render settings and leaves nothing behind when it fails,
progress lines and --quiet/--verbose, Blender's thread count reaches the core (batch and
operator), and the exports need no Python module beyond bpy (EXR through Blender's image
writer; lightmaps from the light at the corners, grown across UV seams)."""

import os
import subprocess

import bpy
import numpy as np
import pytest

from illumap_bpy_testing import (diffuse_material, emission_material, make_plane,
                                 requires_core, top_camera)

from addon import batch, pipeline, threads
from addon.write import exports
from addon.errors import ExitCode
from illumap import lightmaps

pytestmark = requires_core
REPO = os.path.dirname(os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__)))))


def lit_scene(path=None):
    floor = make_plane("Floor", size=2.0, material=diffuse_material("F", (0.5,) * 3))
    make_plane("Emitter", size=0.5, location=(0, 0, 1), flip=True,
               material=emission_material("E", (1, 1, 1), 1.0))
    top_camera(ortho_scale=2.5)
    if path is not None:
        bpy.ops.wm.save_as_mainfile(filepath=str(path))
    return floor


def run_cli(blend, *args, before=(), env=None):
    cmd = [os.path.join(REPO, "scripts", "blender"), *before, "-b", str(blend), "--python",
           os.path.join(REPO, "scripts", "illumap_batch.py"), "--", *args]
    return subprocess.run(cmd, capture_output=True, text=True, timeout=300,
                          env={**os.environ, **(env or {})})


def files_under(path):
    return sorted(os.path.relpath(os.path.join(d, f), path)
                  for d, _, fs in os.walk(path) for f in fs)


# --- a job without an output ---------------------------------------------------------------

def test_a_job_without_an_output_is_a_usage_error_before_anything_is_read(monkeypatch, capsys):
    lit_scene()

    def must_not_run(*args, **kwargs):
        raise AssertionError("the scene was read")
    monkeypatch.setattr(batch, "select_objects", must_not_run)
    monkeypatch.setattr(pipeline, "compute", must_not_run)
    assert batch.main(["--quality", "draft"]) == ExitCode.USAGE
    err = capsys.readouterr().err
    assert "no output" in err and "--output" in err and "--render" in err
    assert "Illumap Surfels" not in bpy.data.objects


def test_cli_a_job_without_an_output_exits_2(tmp_path):
    scene = tmp_path / "scene.blend"
    lit_scene(scene)
    proc = run_cli(scene, "--quality", "draft")
    assert proc.returncode == 2, proc.stdout + proc.stderr
    assert "no output" in proc.stderr and "Illumap frame" not in proc.stdout


# --- --render --------------------------------------------------------------------------------

def _png_size(path):
    data = open(path, "rb").read(32)
    assert data[:8] == b"\x89PNG\r\n\x1a\n"
    return int.from_bytes(data[16:20], "big"), int.from_bytes(data[20:24], "big")


def test_cli_render_takes_the_scenes_settings_and_the_extensions_format(tmp_path):
    """No flags: the scene's resolution at its percentage and its samples; a .jpg is a JPEG
    (the issue's "Cycles wrote no image"), a name without a known extension takes the
    scene's format; flags override; the scene's settings are saved as they were."""
    lit_scene()
    r = bpy.context.scene.render
    r.resolution_x, r.resolution_y, r.resolution_percentage = 60, 40, 50
    r.image_settings.file_format = "PNG"
    bpy.context.scene.cycles.samples = 2
    scene = tmp_path / "scene.blend"
    bpy.ops.wm.save_as_mainfile(filepath=str(scene))
    out = tmp_path / "out"
    proc = run_cli(scene, "--quality", "draft", "--render", str(out / "a.jpg"),
                   "--output", str(out / "lit.blend"))
    assert proc.returncode == 0, proc.stdout + proc.stderr
    assert open(out / "a.jpg", "rb").read(3) == b"\xff\xd8\xff"       # a JPEG
    assert "(30×20, JPEG)" in proc.stdout
    proc = run_cli(scene, "--quality", "draft", "--render", str(out / "b.frame"))
    assert proc.returncode == 0, proc.stdout + proc.stderr
    assert _png_size(out / "b.frame") == (30, 20)                     # the scene's PNG
    proc = run_cli(scene, "--quality", "draft", "--render", str(out / "c.png"),
                   "--resolution", "24", "--samples", "1")
    assert proc.returncode == 0, proc.stdout + proc.stderr
    assert _png_size(out / "c.png") == (24, 16)
    assert sorted(files_under(out)) == ["a.jpg", "b.frame", "c.png", "lit.blend"]
    bpy.ops.wm.open_mainfile(filepath=str(out / "lit.blend"))
    r = bpy.context.scene.render
    assert (r.resolution_x, r.resolution_y, r.resolution_percentage) == (60, 40, 50)
    assert r.image_settings.file_format == "PNG" and bpy.context.scene.cycles.samples == 2


def test_a_failed_render_leaves_nothing_behind(tmp_path, monkeypatch, capsys):
    """Blender writes part of an image and fails: exit 5, no image, no hidden temporary file,
    and the frame's .blend is not saved either (the render comes first)."""
    scene = tmp_path / "scene.blend"
    lit_scene(scene)
    out = tmp_path / "out"

    def failing_render():
        path = bpy.context.scene.render.filepath
        with open(path + ".png", "wb") as f:    # as Blender adds an extension
            f.write(b"half")
        with open(path, "wb") as f:
            f.write(b"half")
        raise RuntimeError("Error: out of memory")
    monkeypatch.setattr(batch, "render_still", failing_render)
    code = batch.main(["--quality", "draft", "--render", str(out / "x.jpg"),
                       "--output", str(out / "x.blend")])
    assert code == ExitCode.OUTPUT
    assert "out of memory" in capsys.readouterr().err
    assert files_under(out) == []


# --- progress, --quiet, --verbose ----------------------------------------------------------

def test_progress_lines_quiet_and_verbose(tmp_path, capsys):
    lit_scene()
    npz = str(tmp_path / "x.npz")
    assert batch.main(["--quality", "draft", "--export-npz", npz]) == 0
    lines = capsys.readouterr().out.splitlines()
    phases = [ln for ln in lines if ln.startswith("Illumap frame 1: ") and "surfels" not in ln]
    assert "Illumap frame 1: solve" in phases and "Illumap frame 1: gather" in phases
    # The phases are printed before the frame's report.
    report = next(i for i, ln in enumerate(lines) if "surfels," in ln)
    assert lines.index("Illumap frame 1: solve") < report
    assert batch.main(["--quality", "draft", "--export-npz", npz, "--verbose"]) == 0
    out = capsys.readouterr().out
    assert "worker thread" in out
    assert any(ln.startswith("Illumap frame 1: ") and ln.endswith("%") for ln in out.splitlines())
    # --quiet: no progress and no report, but the warnings (here: no UV map, no lightmap)
    assert batch.main(["--quality", "draft", "--export-lightmaps", str(tmp_path / "{object}.exr"),
                       "--quiet"]) == 0
    out = capsys.readouterr().out
    assert "Illumap frame" not in out and "Warning:" in out
    assert batch.main(["--quiet", "--verbose", "--export-npz", npz]) == ExitCode.USAGE


# --- threads -------------------------------------------------------------------------------

class _Render:
    def __init__(self, mode, n):
        self.threads_mode, self.threads = mode, n


class _Scene:
    def __init__(self, mode, n):
        self.render = _Render(mode, n)


@pytest.mark.parametrize("mode, blender, startup, hardware, expected", [
    ("FIXED", 3, "", 64, 3),          # the scene's Fixed count, or -t in Blender
    ("AUTO", 4, "", 64, 4),           # Auto with -t 4 (Blender reports 4 of 64)
    ("AUTO", 64, "", 64, None),       # Auto, no -t: the core counts affinity and cgroup
    ("FIXED", 3, "6", 64, 6),         # ILLUMAP_THREADS in the environment wins
    ("AUTO", 64, "junk", 64, None),   # a value that is not a count is ignored
])
def test_worker_threads_follow_blender(mode, blender, startup, hardware, expected):
    count, source = threads.worker_threads(_Scene(mode, blender), startup_value=startup,
                                           cpu_count=hardware)
    assert count == expected, source


def test_the_operator_passes_blenders_thread_count_to_the_core(monkeypatch, registered_addon):
    """Render Properties > Performance > Threads: Fixed 1 reaches the core as
    ILLUMAP_THREADS=1 while it solves; back on Auto the variable is cleared again."""
    if threads._STARTUP_VALUE:
        pytest.fail("ILLUMAP_THREADS is set in the test environment")
    floor = lit_scene()
    for o in bpy.data.objects:
        o.select_set(o.type == "MESH")
    seen = []
    real_run = pipeline.run_passes

    def run(job, progress=None, **kwargs):
        seen.append(os.environ.get("ILLUMAP_THREADS"))
        return real_run(job, progress, **kwargs)
    monkeypatch.setattr(pipeline, "run_passes", run)
    scene = bpy.context.scene
    scene.illumap.preset = "DRAFT"
    scene.render.threads_mode, scene.render.threads = "FIXED", 1
    assert bpy.ops.illumap.compute_illumination_map() == {"FINISHED"}
    scene.render.threads_mode = "AUTO"
    assert bpy.ops.illumap.compute_illumination_map() == {"FINISHED"}
    assert seen[0] == "1"
    assert seen[-1] is None or int(seen[-1]) < os.cpu_count()
    assert "illumination" in floor.data.attributes


def test_cli_threads_follow_dash_t_the_scene_and_the_affinity(tmp_path):
    scene = tmp_path / "scene.blend"
    lit_scene(scene)
    npz = str(tmp_path / "x.npz")
    env = {"ILLUMAP_THREADS": ""}
    proc = run_cli(scene, "--quality", "draft", "--export-npz", npz, "--verbose",
                   before=("-t", "1"), env=env)
    assert proc.returncode == 0, proc.stdout + proc.stderr
    assert "Illumap: 1 worker thread (" in proc.stdout
    bpy.context.scene.render.threads_mode = "FIXED"
    bpy.context.scene.render.threads = 1
    bpy.ops.wm.save_as_mainfile(filepath=str(scene))
    proc = run_cli(scene, "--quality", "draft", "--export-npz", npz, "--verbose", env=env)
    assert "Illumap: 1 worker thread (Blender's thread setting" in proc.stdout, proc.stdout
    # An affinity mask of one CPU: one worker thread (the core counts the mask too).
    lit_scene(scene)
    bpy.context.scene.render.threads_mode = "AUTO"
    bpy.ops.wm.save_as_mainfile(filepath=str(scene))
    cmd = ["taskset", "-c", "0", os.path.join(REPO, "scripts", "blender"), "-b", str(scene),
           "--python", os.path.join(REPO, "scripts", "illumap_batch.py"), "--",
           "--quality", "draft", "--export-npz", npz, "--verbose"]
    proc = subprocess.run(cmd, capture_output=True, text=True, timeout=300,
                          env={**os.environ, **env})
    assert proc.returncode == 0, proc.stdout + proc.stderr
    assert "Illumap: 1 worker thread (" in proc.stdout, proc.stdout


# --- exports without OpenImageIO -----------------------------------------------------------

NO_OIIO = ("--python-expr", "import sys; sys.modules['OpenImageIO'] = None")


def test_cli_every_export_works_without_openimageio(tmp_path):
    """The OpenImageIO module made unimportable (as on a Blender that lacks it): npz, EXR and
    lightmaps are written, and the EXR holds the surfels' illumination exactly."""
    floor = lit_scene()
    floor.data.uv_layers.new(name="UV")
    scene = tmp_path / "scene.blend"
    bpy.ops.wm.save_as_mainfile(filepath=str(scene))
    out = tmp_path / "out"
    cmd = [os.path.join(REPO, "scripts", "blender"), "-b", str(scene), "--python-exit-code",
           "9", *NO_OIIO, "--python", os.path.join(REPO, "scripts", "illumap_batch.py"), "--",
           "--quality", "draft", "--export-npz", str(out / "s.npz"), "--export-exr",
           str(out / "s.exr"), "--export-lightmaps", str(out / "{object}.exr"),
           "--lightmap-size", "16"]
    proc = subprocess.run(cmd, capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0, proc.stdout + proc.stderr
    assert sorted(files_under(out)) == ["Floor.exr", "s.exr", "s.npz"]   # Emitter: no UV map
    assert "Object 'Emitter' has no UV map: no lightmap written" in proc.stdout
    data = np.load(out / "s.npz")
    exr = exports.read_exr(str(out / "s.exr"))
    n = len(data["illumination"])
    np.testing.assert_array_equal(exr.reshape(-1, 4)[:n, :3], data["illumination"].astype(np.float32))
    lightmap = exports.read_exr(str(out / "Floor.exr"))
    assert lightmap.shape == (16, 16, 4) and (lightmap[:, :, 3] == 1).all()
    assert lightmap[:, :, :3].max() > 0


def test_the_exr_writer_needs_no_openimageio(tmp_path, monkeypatch):
    import sys
    monkeypatch.setitem(sys.modules, "OpenImageIO", None)
    px = np.random.default_rng(1).random((5, 7, 3)).astype(np.float32) * 40
    exports.write_exr(str(tmp_path / "a.exr"), px)
    back = exports.read_exr(str(tmp_path / "a.exr"))
    np.testing.assert_array_equal(back[:, :, :3], px)
    assert len(bpy.data.scenes) == 1 and not [i for i in bpy.data.images
                                              if i.name.startswith(".illumap")]


# --- lightmaps from the corners ------------------------------------------------------------

def test_corner_lightmap_interpolates_the_corners_and_grows_across_seams():
    """Two islands of one triangle pair each with different light: inside, each texel is the
    corners' values blended as Blender blends them over a face (here linear in u, exact);
    the margin beside an island takes that island's light, not black; texels beyond the
    margin are empty (alpha 0)."""
    size = 32
    # island A: u in [0.1, 0.4], v in [0.1, 0.9]; island B: u in [0.6, 0.9]
    uv, tris, values = [], [], []
    for u0, u1, level in ((0.1, 0.4, 1.0), (0.6, 0.9, 5.0)):
        base = len(uv)
        quad = [(u0, 0.1), (u1, 0.1), (u1, 0.9), (u0, 0.9)]
        uv += quad
        values += [(level + 2 * u, 0.5, 0.0) for u, _ in quad]
        tris += [(base, base + 1, base + 2), (base, base + 2, base + 3)]
    img = lightmaps.corner_lightmap(np.array(uv), np.array(tris), np.array(values), size,
                                 margin=2)
    centres = (np.arange(size) + 0.5) / size
    row = size // 2                            # v = 0.5
    for x, u in enumerate(centres):
        r, a = img[row, x, 0], img[row, x, 3]
        if 0.1 < u < 0.4:
            assert r == pytest.approx(1.0 + 2 * u, abs=1e-5) and a == 1
        elif 0.6 < u < 0.9:
            assert r == pytest.approx(5.0 + 2 * u, abs=1e-5) and a == 1
    # the margin: 1 and 2 texels outside each island's right edge take its own light
    right_a = max(x for x, u in enumerate(centres) if u < 0.4)
    assert img[row, right_a + 1, 3] == 1 and img[row, right_a + 1, 0] == pytest.approx(
        img[row, right_a, 0], rel=0.05)
    assert img[row, right_a + 2, 3] == 1 and img[row, right_a + 2, 0] < 3.0
    assert img[row, right_a + 3, 3] == 0 and img[row, right_a + 3, 0] == 0
    # v runs up the image: row 0 is v = 1 (outside both islands)
    assert img[0, :, 3].max() == 0 and img[size - 1, :, 3].max() == 0


def test_lightmaps_come_from_the_corner_result(tmp_path):
    """The batch's lightmap of a floor lit unevenly equals its per-corner result rasterized:
    the texel at a corner's UV carries that corner's light."""
    floor = lit_scene()
    floor.data.uv_layers.new(name="UV")
    out = tmp_path / "maps"
    assert batch.main(["--quality", "draft", "--export-lightmaps", str(out / "{object}.exr"),
                       "--lightmap-size", "8"]) == 0
    img = exports.read_exr(str(out / "Floor.exr"))
    attr = floor.data.attributes["illumination"]
    corner = np.empty(len(attr.data) * 4, np.float32)
    attr.data.foreach_get("color", corner)
    corner = corner.reshape(-1, 4)[:, :3]
    uv, tris = exports.mesh_uv_triangles(floor.data)
    expected = lightmaps.corner_lightmap(uv, tris, corner, 8)
    np.testing.assert_allclose(img, expected, rtol=1e-5, atol=1e-6)
    assert img[:, :, 3].min() == 1


def test_the_ui_exports_the_same_lightmaps_as_the_batch(tmp_path, registered_addon):
    """Export Lightmaps (the panel's button) writes each selected mesh's lightmap from its
    'illumination' attribute: the same pixels as the batch's from the run's corner result;
    without an attribute it refuses and writes nothing."""
    floor = lit_scene()
    floor.data.uv_layers.new(name="UV")
    out = tmp_path / "batch"
    assert batch.main(["--quality", "draft", "--export-lightmaps", str(out / "{object}.exr"),
                       "--lightmap-size", "16"]) == 0
    ui = tmp_path / "ui"
    ui.mkdir()
    for obj in bpy.context.view_layer.objects:
        obj.select_set(obj == floor)
    assert bpy.ops.illumap.export_lightmaps(directory=str(ui), size=16) == {"FINISHED"}
    # the attribute holds the run's float64 corner values in float32
    np.testing.assert_allclose(exports.read_exr(str(ui / "Floor.exr")),
                               exports.read_exr(str(out / "Floor.exr")), rtol=1e-6, atol=1e-9)
    floor.data.color_attributes.remove(floor.data.color_attributes["illumination"])
    empty = tmp_path / "none"
    empty.mkdir()
    with pytest.raises(RuntimeError, match="illumination"):
        bpy.ops.illumap.export_lightmaps(directory=str(empty), size=16)
    assert not list(empty.iterdir())
