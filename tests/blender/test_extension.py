"""Packaging and harness tests: the extension zip installs into a fresh Blender user directory,
and the test runner and batch launcher behave like Blender's command line."""

from __future__ import annotations

import os
import subprocess
import sys
import textwrap
import zipfile
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
LAUNCHER = ROOT / "scripts" / "blender"


def run_python(code: str, env: dict | None = None, timeout: float = 300) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-c", textwrap.dedent(code)], cwd=ROOT, text=True,
                          capture_output=True, env={**os.environ, **(env or {})}, timeout=timeout)


@pytest.fixture(scope="module")
def extension_zip() -> Path:
    result = subprocess.run([sys.executable, "scripts/build_extension.py"], cwd=ROOT, text=True,
                            capture_output=True, timeout=900)
    assert result.returncode == 0, result.stdout + result.stderr
    path = Path(result.stdout.strip().splitlines()[-1])
    assert path.is_file()
    return path


def test_zip_holds_the_addon_and_its_wheel_only(extension_zip: Path) -> None:
    names = zipfile.ZipFile(extension_zip).namelist()
    assert "blender_manifest.toml" in names and "__init__.py" in names
    assert any(n.startswith("addon/") for n in names)
    wheels = [n for n in names if n.startswith("wheels/") and n.endswith(".whl")]
    assert len(wheels) == 1 and "illumap-" in wheels[0]
    for excluded in ("core/", "tests/", "bench/", "scripts/", "sample_blends/", ".venv/", "docs/"):
        assert not any(n.startswith(excluded) for n in names), excluded


def test_extension_installs_and_registers(extension_zip: Path, tmp_path: Path) -> None:
    code = f"""
        import sys, pathlib
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
        installed = list(site.rglob("illumap/_core*.so"))
        assert installed, "the extension's wheel was not installed into the user site-packages"
        print("OK", illumap.__file__)
    """
    result = run_python(code, env={"BLENDER_USER_RESOURCES": str(tmp_path)})
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
    script.write_text("import sys\nprint('ARGS', sys.argv[sys.argv.index('--') + 1:])\n")
    result = subprocess.run([str(LAUNCHER), "-b", "--python", str(script), "--", "--x", "1"],
                            cwd=ROOT, text=True, capture_output=True, timeout=120)
    assert result.returncode == 0 and "ARGS ['--x', '1']" in result.stdout, result.stderr


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
        sys.argv = ["blender", "--python", {str(script)!r}, "--", "--quality", "draft",
                    "--output", {str(out)!r}]
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
