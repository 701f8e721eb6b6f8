"""Packaging and harness tests: the extension zip installs into a fresh Blender user directory,
and the test runner and batch launcher behave like Blender's command line."""

from __future__ import annotations

import importlib.util
import io
import os
import subprocess
import sys
import textwrap
import tomllib
import zipfile
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[3]
LAUNCHER = ROOT / "scripts" / "blender"


def run_python(code: str, env: dict | None = None, timeout: float = 300,
               cwd: Path = ROOT) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-c", textwrap.dedent(code)], cwd=cwd, text=True,
                          capture_output=True, env={**os.environ, **(env or {})}, timeout=timeout)


# The zips a test run builds: this machine's platform only. The Windows zip (a cross build of
# Embree and the module, about ten CPU-minutes more) is built by a plain
# scripts/build_extension.py; its wheels are checked by scripts/windows_native_tests.py.
TESTED_PLATFORMS = ["linux-x64"]


@pytest.fixture(scope="module")
def extension_zips() -> dict[str, Path]:
    """The zips scripts/build_extension.py writes, by platform."""
    command = [sys.executable, "scripts/build_extension.py"]
    for platform in TESTED_PLATFORMS:
        command += ["--platform", platform]
    result = subprocess.run(command, cwd=ROOT, text=True, capture_output=True, timeout=1800)
    assert result.returncode == 0, result.stdout + result.stderr
    paths = [Path(line) for line in result.stdout.strip().splitlines() if line.endswith(".zip")]
    # Named as Blender's build tool names split packages: <id>-<version>-<platform>.zip.
    expected = {p: f"illumap-0.1.0-{p.replace('-', '_')}.zip" for p in TESTED_PLATFORMS}
    assert sorted(path.name for path in paths) == sorted(expected.values()), paths
    assert all(path.is_file() for path in paths)
    return {p: next(path for path in paths if path.name == name) for p, name in expected.items()}


@pytest.fixture(scope="module")
def extension_zip(extension_zips: dict[str, Path]) -> Path:
    """The zip for this machine (Linux x64), which the installation tests install."""
    return extension_zips["linux-x64"]


# Blocks every ``illumap`` but the one the extension installed under BLENDER_USER_RESOURCES: the
# test venv has the core installed too, and it must not stand in for the zip's wheel.
EXTENSION_ONLY_CORE = """
    import importlib.abc, importlib.machinery, os, sys
    USER = os.environ["BLENDER_USER_RESOURCES"]
    class ExtensionOnlyCore(importlib.abc.MetaPathFinder):
        def find_spec(self, name, path, target=None):
            if name != "illumap":
                return None
            for entry in sys.path:
                if entry.startswith(USER):
                    spec = importlib.machinery.PathFinder.find_spec(name, [entry])
                    if spec is not None:
                        return spec
            raise ModuleNotFoundError("illumap outside the extension is hidden", name=name)
    sys.meta_path.insert(0, ExtensionOnlyCore())
"""


def addon_files() -> list[str]:
    """The add-on files the extension must carry, as the build script lists them."""
    import importlib.util
    spec = importlib.util.spec_from_file_location("build_extension",
                                                  ROOT / "scripts" / "build_extension.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module.addon_files()


def test_manifest_paths_list_every_addon_file() -> None:
    """The zip is built from an include list, so a new module under addon/ must be added to it."""
    build = tomllib.loads((ROOT / "blender_manifest.toml").read_text())["build"]
    assert "paths_exclude_pattern" not in build, "the extension is an include list ([build] paths)"
    listed, expected = build["paths"], addon_files()
    missing = sorted(set(expected) - set(listed))
    assert not missing, f"add {missing} to [build] paths in blender_manifest.toml"
    extra = sorted(set(listed) - set(expected))
    assert not extra, f"remove {extra} from [build] paths in blender_manifest.toml: no such file"
    assert "addon/compat.py" in listed and "addon/__init__.py" in listed, listed


WHEEL_PLATFORMS = {"linux-x64": "manylinux_2_28_x86_64", "windows-x64": "win_amd64"}
MODULE_SUFFIXES = {"linux-x64": "-x86_64-linux-gnu.so", "windows-x64": "-win_amd64.pyd"}


MANIFEST_PLATFORMS = tomllib.loads((ROOT / "blender_manifest.toml").read_text())["platforms"]


def test_manifest_platforms_are_known() -> None:
    assert MANIFEST_PLATFORMS and set(MANIFEST_PLATFORMS) <= set(WHEEL_PLATFORMS), \
        MANIFEST_PLATFORMS


def test_tested_platforms_are_in_the_manifest() -> None:
    assert set(TESTED_PLATFORMS) <= set(MANIFEST_PLATFORMS), (TESTED_PLATFORMS, MANIFEST_PLATFORMS)


@pytest.mark.parametrize("platform", TESTED_PLATFORMS)
def test_zip_holds_exactly_the_addon_and_a_wheel_per_python_abi(extension_zips: dict[str, Path],
                                                                 platform: str) -> None:
    archive = zipfile.ZipFile(extension_zips[platform])
    names = archive.namelist()
    wheels = sorted(n for n in names if n.startswith("wheels/") and n.endswith(".whl"))
    # Blender 4.2-5.0 run Python 3.11, Blender 5.1+ Python 3.13: one wheel each, this
    # platform's only.
    assert [w.split("-")[2] for w in wheels] == ["cp311", "cp313"], wheels
    assert all(w.endswith(f"-{WHEEL_PLATFORMS[platform]}.whl") for w in wheels), wheels
    # The manifest, the add-on's files and the wheels, and nothing else: no tests, bench, docs,
    # scripts, caches or new top-level folders.
    assert sorted(names) == sorted(["blender_manifest.toml", *addon_files(), *wheels]), names
    manifest = tomllib.loads(archive.read("blender_manifest.toml").decode())
    # Blender's split build records the zip's own platform and wheels.
    assert manifest["build"]["generated"]["platforms"] == [platform], manifest["build"]
    assert sorted(Path(w).name for w in manifest["build"]["generated"]["wheels"]) == \
        [Path(w).name for w in wheels]
    # The range the tests cover: bpy 5.0.1 (cp311) and 5.2.3 (cp313); 5.3 is not tested.
    assert manifest["blender_version_min"] == "4.2.0"
    assert manifest["blender_version_max"] == "5.3.0"
    for wheel in wheels:
        inner = zipfile.ZipFile(io.BytesIO(archive.read(wheel))).namelist()
        # One native module and nothing bundled beside it: Embree is linked statically,
        # without TBB, so nothing can clash with the libraries Blender loads.
        native = [n for n in inner if n.endswith((".so", ".pyd", ".dll")) or ".so." in n]
        abi = wheel.split("-")[2]
        assert native == [f"illumap/_core.{'cpython-' + abi[2:] if platform == 'linux-x64' else abi}"
                          f"{MODULE_SUFFIXES[platform]}"], (wheel, native)
        assert "illumap/__init__.py" in inner, inner


def test_extension_installs_and_registers(extension_zip: Path, tmp_path: Path) -> None:
    code = EXTENSION_ONLY_CORE + f"""
    import pathlib
    import bpy
    bpy.ops.extensions.package_install_files(repo="user_default", filepath={str(extension_zip)!r},
                                             enable_on_install=True)
    import addon_utils
    enabled = [m.__name__ for m in addon_utils.modules() if addon_utils.check(m.__name__)[1]]
    assert "bl_ext.user_default.illumap" in enabled, enabled
    assert bpy.ops.illumap.compute_illumination_map.idname() == "ILLUMAP_OT_compute_illumination_map"
    panels = [c for c in bpy.types.Panel.__subclasses__() if getattr(c, "bl_category", "") == "Illumap"]
    assert panels, "no Illumap panel registered"
    import illumap, illumap._core
    site = pathlib.Path({str(tmp_path)!r}) / "extensions" / ".local" / "lib"
    assert pathlib.Path(illumap._core.__file__).is_relative_to(site), illumap._core.__file__
    # The wheel of this Python's ABI: one module, Embree linked in, nothing bundled beside it.
    abi = f"cpython-{{sys.version_info.major}}{{sys.version_info.minor}}"
    assert abi in pathlib.Path(illumap._core.__file__).name, (abi, illumap._core.__file__)
    assert not list(site.rglob("illumap.libs")), list(site.rglob("illumap.libs/*"))
    print("OK", illumap.__file__)
    """
    result = run_python(code, env={"BLENDER_USER_RESOURCES": str(tmp_path)}, cwd=tmp_path)
    assert result.returncode == 0 and "OK" in result.stdout, result.stdout + result.stderr


def test_installed_extension_runs_the_operator_with_defaults(extension_zip: Path,
                                                            tmp_path: Path) -> None:
    """What a user does first: install the zip into a fresh Blender, enable it, select a small
    scene and press Compute with every setting at its default, the preview step included (on
    Blender 5.2 Geometry Nodes modifier inputs are not ID properties: addon/compat.py)."""
    user = tmp_path / "user"
    code = EXTENSION_ONLY_CORE + f"""
    import pathlib
    import numpy as np
    import bpy
    bpy.ops.wm.read_factory_settings(use_empty=True)
    bpy.ops.extensions.package_install_files(repo="user_default", filepath={str(extension_zip)!r},
                                             enable_on_install=True)
    bpy.ops.mesh.primitive_plane_add(size=2.0)
    floor = bpy.context.active_object
    bpy.ops.mesh.primitive_plane_add(size=0.5, location=(0, 0, 1), rotation=(3.14159, 0, 0))
    light = bpy.data.lights.new("Lamp", "POINT")
    light.energy = 50.0
    lamp = bpy.data.objects.new("Lamp", light)
    bpy.context.scene.collection.objects.link(lamp)
    lamp.location = (0.3, 0.0, 2.0)
    floor.select_set(True)
    props = bpy.context.scene.illumap
    assert props.build_preview, "the preview is on by default"
    assert bpy.ops.illumap.compute_illumination_map() == {{"FINISHED"}}
    surfels = bpy.data.objects["Illumap Surfels"]
    n = len(surfels.data.attributes["illumination"].data)
    illum = np.empty(4 * n, dtype=np.float32)
    surfels.data.attributes["illumination"].data.foreach_get("color", illum)
    illum = illum.reshape(n, 4)[:, :3]
    assert n > 50 and np.isfinite(illum).all() and illum.max() > 0.0, (n, illum.max())
    # What the user meets: the floor shows its light through the Object Preview; the surfels
    # are a diagnostic, hidden until asked for.
    assert "Illumap Mesh Preview" in floor.modifiers, list(floor.modifiers)
    assert surfels.hide_render and surfels.hide_viewport and not surfels.modifiers
    # Asked for: one Geometry Nodes modifier that instances a disc per surfel.
    assert bpy.ops.illumap.build_preview() == {{"FINISHED"}}
    (mod,) = surfels.modifiers
    assert mod.type == "NODES" and mod.node_group is not None, mod
    depsgraph = bpy.context.evaluated_depsgraph_get()
    discs = [i for i in depsgraph.object_instances
             if i.is_instance and i.parent and i.parent.original == surfels]
    assert len(discs) == n, (len(discs), n)
    import illumap
    assert illumap.__file__.startswith({str(user)!r}), illumap.__file__
    print("OK", bpy.app.version_string, n)
    """
    result = run_python(code, env={"BLENDER_USER_RESOURCES": str(user)}, cwd=tmp_path)
    assert result.returncode == 0 and "OK" in result.stdout, result.stdout + result.stderr


def test_runner_exits_with_pytest_status(tmp_path: Path) -> None:
    passing = tmp_path / "test_pass.py"
    passing.write_text("import bpy\n\ndef test_ok():\n    assert bpy.app.version >= (4, 2, 0)\n")
    failing = tmp_path / "test_fail.py"
    failing.write_text("def test_bad():\n    assert 1 == 2\n")
    for path, expected in ((passing, 0), (failing, 1)):
        result = subprocess.run([str(LAUNCHER), "-b", "--python", "tests/run_in_blender.py", "--",
                                 str(path), "-q", "-p", "no:cacheprovider"],
                                cwd=ROOT, text=True, capture_output=True, timeout=300)
        assert result.returncode == expected, result.stdout + result.stderr


def test_launcher_follows_blender_exit_codes() -> None:
    cases = [
        (["-b", "--python-expr", "import sys; sys.exit(5)"], 5),
        (["-b", "--python-expr", "raise RuntimeError('x')"], 0),  # Blender only prints it
        (["-b", "--python-exit-code", "7", "--python-expr", "raise RuntimeError('x')"], 7),
        (["-b", "--no-such-option"], 2),
        (["-b", "missing_file.blend"], 2),
    ]
    for args, expected in cases:
        result = subprocess.run([str(LAUNCHER), *args], cwd=ROOT, text=True, capture_output=True,
                                timeout=120)
        assert result.returncode == expected, (args, result.stdout + result.stderr)


def test_launcher_passes_script_arguments(tmp_path: Path) -> None:
    script = tmp_path / "echo_args.py"
    script.write_text("import sys, bpy\nprint('ARGS', sys.argv[sys.argv.index('--') + 1:])\n"
                      "print('VERSION', tuple(bpy.app.version))\n")
    result = subprocess.run([str(LAUNCHER), "-b", "--python", str(script), "--", "--x", "1"],
                            cwd=ROOT, text=True, capture_output=True, timeout=120)
    assert result.returncode == 0 and "ARGS ['--x', '1']" in result.stdout, result.stderr
    # The launcher runs on this test run's bpy (5.2 on .venv, 5.0 on .venv-blender50).
    import bpy
    assert f"VERSION {tuple(bpy.app.version)}" in result.stdout, result.stdout


def test_batch_script_runs_the_installed_extension(extension_zip: Path, tmp_path: Path) -> None:
    """scripts/illumap_batch.py away from a checkout (copied into a bare folder) finds the
    installed extension's add-on, computes a small scene and saves the result."""
    script_dir = tmp_path / "scripts"
    script_dir.mkdir()
    script = script_dir / "illumap_batch.py"
    script.write_text((ROOT / "scripts" / "illumap_batch.py").read_text())
    out = tmp_path / "lit.blend"
    code = f"""
        import runpy, sys
        import bpy
        bpy.ops.extensions.package_install_files(repo="user_default", filepath={str(extension_zip)!r},
                                                 enable_on_install=True)
        bpy.ops.mesh.primitive_plane_add(size=2.0)
        bpy.ops.mesh.primitive_plane_add(size=0.5, location=(0, 0, 1), rotation=(3.14159, 0, 0))
        light = bpy.data.lights.new("Lamp", "POINT")
        light.energy = 50.0
        lamp = bpy.data.objects.new("Lamp", light)
        bpy.context.scene.collection.objects.link(lamp)
        lamp.location = (0.3, 0.0, 2.0)
        # Both planes: the plate alone faces away from the lamps, a black map that is refused.
        sys.argv = ["blender", "--python", {str(script)!r}, "--", "--quality", "draft",
                    "--objects", "Plane,Plane.001", "--output", {str(out)!r}]
        try:
            runpy.run_path({str(script)!r}, run_name="__main__")
        except SystemExit as exc:
            code = exc.code
        else:
            code = None
        used = sorted(m for m in sys.modules if m.endswith("addon.batch"))
        print("EXIT", code, "MODULES", used)
    """
    result = subprocess.run([sys.executable, "-c", textwrap.dedent(code)], cwd=tmp_path, text=True,
                            capture_output=True, timeout=600,
                            env={**os.environ, "BLENDER_USER_RESOURCES": str(tmp_path / "user")})
    log = result.stdout + result.stderr
    assert "EXIT 0 MODULES ['bl_ext.user_default.illumap.addon.batch']" in result.stdout, log
    assert "Illumap frame 1:" in result.stdout and out.is_file(), log
    assert "shadow rays" in result.stdout and "unshadowed" not in result.stdout, log


def test_one_platform_build_narrows_the_manifest_to_its_wheels() -> None:
    """``build_extension.py --platform P`` hands Blender's tool a manifest naming P alone and only
    P's wheels, so the tool neither asks for another platform's wheels nor lists them."""
    spec = importlib.util.spec_from_file_location("build_extension_narrow",
                                                  ROOT / "scripts" / "build_extension.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    full = tomllib.loads((ROOT / "blender_manifest.toml").read_text())
    for platform in MANIFEST_PLATFORMS:
        suffix = f"-{WHEEL_PLATFORMS[platform]}.whl"
        narrowed = tomllib.loads(module.manifest_for([platform], (suffix,)))
        assert narrowed["platforms"] == [platform]
        assert narrowed["wheels"] == [w for w in full["wheels"] if w.endswith(suffix)]
        assert len(narrowed["wheels"]) == 2, narrowed["wheels"]  # cp311 and cp313
        assert {k: v for k, v in narrowed.items() if k not in ("platforms", "wheels")} == \
            {k: v for k, v in full.items() if k not in ("platforms", "wheels")}
    # All platforms: the manifest as written.
    suffixes = tuple(f"-{WHEEL_PLATFORMS[p]}.whl" for p in MANIFEST_PLATFORMS)
    assert module.manifest_for(MANIFEST_PLATFORMS, suffixes) == \
        (ROOT / "blender_manifest.toml").read_text()
