"""Builds the Illumap extension: one zip per platform, each with a core wheel per Python ABI.

Usage (from the repository root, after ``scripts/setup_env.sh --all``)::

    .venv/bin/python scripts/build_extension.py
    # -> dist/illumap-<version>-linux_x64.zip, dist/illumap-<version>-windows_x64.zip

The platforms are the manifest's ``platforms``; for each, the wheels of both Python ABIs are built
(scripts/build_wheels.py: cp313 for Blender 5.1+, cp311 for Blender 4.2-5.0, from the
interpreters of ``.venv`` and ``.venv-blender50``; ``--python`` picks others). Linux wheels are
``manylinux_2_28_x86_64`` (Blender's own baseline), Windows wheels ``win_amd64``, cross-built
with Zig (scripts/cross_wheel.py). Blender's build tool then writes one zip per platform
(``--split-platforms``), named ``<id>-<version>-<platform>.zip`` as Blender's tooling expects,
each with only that platform's wheels; Blender installs the wheel that matches its Python.

What goes into the zip is an include list: ``[build] paths`` in ``blender_manifest.toml`` names
every file (the root ``__init__.py`` and each file under ``addon/``); Blender's build tool adds the
manifest and the wheels. The build stops when a file under ``addon/`` is missing from that list,
so a new module cannot be left out of the zip, and nothing outside the list can get in. It also
stops when the manifest's ``wheels`` or ``platforms`` differ from what was built.

``--platform linux-x64`` builds that platform's zip only (the tests do, so that a test run does
not cross-build Windows): Blender's tool then works on a copy of the manifest whose ``platforms``
and ``wheels`` name that platform alone. The files go through build/extension either way.
"""

from __future__ import annotations

import argparse
import re
import shutil
import subprocess
import sys
import sysconfig
import tomllib
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
import build_wheels  # noqa: E402

ROOT = Path(__file__).resolve().parent.parent
# The folder of the add-on's modules: every file in it must be listed in the manifest's paths.
ADDON_DIR = "addon"
# The interpreters whose ABIs the zip carries: Python 3.13 (Blender 5.1+), 3.11 (4.2-5.0).
DEFAULT_PYTHONS = (ROOT / ".venv" / "bin" / "python", ROOT / ".venv-blender50" / "bin" / "python")


def blender_ext_tool() -> Path:
    """Path of ``blender_ext.py`` inside the installed bpy wheel."""
    base = Path(sysconfig.get_paths()["purelib"]) / "bpy"
    tools = sorted(base.glob("*/scripts/addons_core/bl_pkg/cli/blender_ext.py"))
    if not tools:
        raise SystemExit(f"blender_ext.py not found under {base}")
    return tools[-1]


def run(*cmd: str | Path) -> str:
    """Run ``cmd`` in the repository root and return its stdout; exit with its output on
    failure."""
    result = subprocess.run([str(c) for c in cmd], cwd=ROOT, text=True, capture_output=True)
    if result.returncode != 0:
        sys.stderr.write(result.stdout + result.stderr)
        raise SystemExit(f"command failed ({result.returncode}): {' '.join(map(str, cmd))}")
    return result.stdout


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


def check_manifest(manifest: dict, wheels: dict[str, list[Path]]) -> None:
    """Check that the manifest's ``wheels`` are exactly the ones built for its ``platforms``."""
    platforms = sorted(manifest.get("platforms", []))
    built = sorted(p for p, w in wheels.items() if w)
    if platforms != built:
        raise SystemExit(f"blender_manifest.toml lists platforms {platforms}, but wheels were "
                         f"built for {built}")
    listed = sorted(Path(w).name for w in manifest.get("wheels", []))
    made = sorted(w.name for platform_wheels in wheels.values() for w in platform_wheels)
    if listed != made:
        raise SystemExit(f"blender_manifest.toml lists wheels {listed}, but the build produced "
                         f"{made}: update the manifest's wheels entry")


def manifest_for(platforms: list[str], wheel_suffixes: tuple[str, ...]) -> str:
    """The manifest's text with ``platforms`` and ``wheels`` narrowed to ``platforms`` (the
    wheels whose names end with one of ``wheel_suffixes``); unchanged when they are all."""
    text = (ROOT / "blender_manifest.toml").read_text()
    text, count = re.subn(r"^platforms = \[[^\]]*\]$",
                          "platforms = [" + ", ".join(f'"{p}"' for p in platforms) + "]",
                          text, count=1, flags=re.M)
    if count != 1:
        raise SystemExit("blender_manifest.toml: no one-line platforms = [...] entry")

    def narrow(match: re.Match) -> str:
        lines = [line for line in match.group(1).splitlines(keepends=True)
                 if not line.strip().startswith('"') or line.strip().rstrip(",").strip('"')
                 .endswith(wheel_suffixes)]
        return "wheels = [\n" + "".join(lines) + "]"

    return re.sub(r"^wheels = \[\n(.*?)^\]", narrow, text, count=1, flags=re.M | re.S)


def without_build_table(manifest_text: str) -> str:
    """The manifest's text without its final ``[build]`` table (``paths``)."""
    head, found, _ = manifest_text.partition("\n[build]\n")
    if not found:
        raise SystemExit("blender_manifest.toml: no [build] table")
    return head.rstrip("\n") + "\n"


def stage(manifest_text: str, files: list[str]) -> Path:
    """A source folder for Blender's build tool under build/extension: the add-on's files, an
    empty ``wheels/`` and the manifest (narrowed to the platforms being built) without its
    ``[build] paths``. The folder holds exactly what the zip must, so Blender's tool takes it
    all; with ``paths`` it would append the wheels after them, where its platform split (Blender
    5.2) looks for them first and fails."""
    folder = ROOT / "build" / "extension"
    shutil.rmtree(folder, ignore_errors=True)
    (folder / "wheels").mkdir(parents=True)
    (folder / "blender_manifest.toml").write_text(without_build_table(manifest_text))
    for relative in files:
        (folder / relative).parent.mkdir(parents=True, exist_ok=True)
        shutil.copy2(ROOT / relative, folder / relative)
    return folder


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--output-dir", type=Path, default=ROOT / "dist")
    parser.add_argument("--python", type=Path, action="append",
                        help="an interpreter to build a wheel with (repeatable; default: "
                             ".venv and .venv-blender50)")
    parser.add_argument("--platform", action="append", choices=sorted(build_wheels.TARGETS),
                        help="build only this platform's zip (repeatable; default: every "
                             "platform the manifest lists)")
    args = parser.parse_args()

    pythons = args.python or list(DEFAULT_PYTHONS)
    missing = [str(p) for p in pythons if not p.is_file()]
    if missing:
        raise SystemExit(f"no interpreter at {', '.join(missing)}: run scripts/setup_env.sh --all")
    manifest = read_manifest()
    check_paths(manifest)
    listed = manifest.get("platforms") or []
    unknown = sorted(set(listed) - set(build_wheels.TARGETS))
    if not listed or unknown:
        raise SystemExit(f"blender_manifest.toml platforms {listed}: each must be one of "
                         f"{sorted(build_wheels.TARGETS)}")
    platforms = [p for p in listed if p in (args.platform or listed)]
    if args.platform and sorted(set(args.platform)) != sorted(platforms):
        raise SystemExit(f"--platform {args.platform}: the manifest lists only {listed}")
    suffixes = tuple(f"-{build_wheels.TARGETS[p].wheel_platform}.whl" for p in platforms)
    source = stage(manifest_for(platforms, suffixes), manifest["build"]["paths"])
    wheels = {platform: [build_wheels.build(python, platform, source / "wheels")
                         for python in pythons] for platform in platforms}
    staged = tomllib.loads((source / "blender_manifest.toml").read_text())
    check_manifest(staged, wheels)
    tool = blender_ext_tool()
    run(sys.executable, tool, "validate", source)
    args.output_dir.mkdir(parents=True, exist_ok=True)
    stem = f"{manifest['id']}-{manifest['version']}"
    outputs = [args.output_dir / f"{stem}-{platform.replace('-', '_')}.zip"
               for platform in platforms]
    for output in outputs:
        output.unlink(missing_ok=True)
    run(sys.executable, tool, "build", "--source-dir", source, "--output-dir", args.output_dir,
        "--split-platforms")
    for output in outputs:
        if not output.is_file():
            raise SystemExit(f"Blender's build tool wrote no {output.name}")
        print(output)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
