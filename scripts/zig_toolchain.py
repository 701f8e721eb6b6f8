"""The portable C/C++ toolchain: Zig's bundled clang (the ``ziglang`` PyPI package) aimed at one
target platform, as compiler wrappers plus a CMake toolchain file.

Why Zig: it links against a chosen glibc version (2.28, Blender's own Linux baseline) and carries
the C/C++ runtimes of Windows (MinGW-w64) and macOS, so every platform's wheel is built on this
Linux machine from registry packages. Zig links its LLVM libc++ statically, so a module built with
it needs no libstdc++ (no ``GLIBCXX_`` symbol versions).

Usage from the other build scripts::

    from zig_toolchain import TARGETS, toolchain_file
    cmake_toolchain = toolchain_file(TARGETS["linux-x64"])   # build/toolchain/linux-x64/...
"""

from __future__ import annotations

import re
import stat
import subprocess
from dataclasses import dataclass
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
TOOLCHAIN_DIR = ROOT / "build" / "toolchain"
CACHE_DIR = ROOT / "build" / "zig-cache"


@dataclass(frozen=True)
class Target:
    """One platform a wheel is built for."""
    name: str            # Blender's platform name (manifest ``platforms``)
    zig_triple: str      # zig's -target
    cmake_system: str    # CMAKE_SYSTEM_NAME
    cmake_processor: str  # CMAKE_SYSTEM_PROCESSOR
    wheel_platform: str  # the wheel's platform tag
    module_suffix: str   # the extension module's file suffix after ``_core.<abi>``


TARGETS = {
    "linux-x64": Target("linux-x64", "x86_64-linux-gnu.2.28", "Linux", "x86_64",
                        "manylinux_2_28_x86_64", "x86_64-linux-gnu.so"),
    "windows-x64": Target("windows-x64", "x86_64-windows-gnu", "Windows", "AMD64",
                          "win_amd64", "win_amd64.pyd"),
    "macos-arm64": Target("macos-arm64", "aarch64-macos.11.0-none", "Darwin", "arm64",
                          "macosx_11_0_arm64", "darwin.so"),
}


def zig_executable() -> Path:
    """The zig compiler shipped in the ``ziglang`` wheel of this interpreter."""
    try:
        import ziglang
    except ImportError as error:
        raise SystemExit("the 'ziglang' package is missing: pip install -r "
                         "scripts/requirements-build.txt (scripts/setup_env.sh does it)") from error
    zig = Path(ziglang.__file__).parent / "zig"
    if not zig.is_file():
        raise SystemExit(f"no zig executable at {zig}")
    return zig


def _shared_zig(folder: Path, zig: Path) -> Path:
    """The zig the existing wrappers in ``folder`` run, when it is still there and the same
    version as ``zig``; else ``zig``. Each environment installs its own ``ziglang``, and Zig's
    cache keys its entries by the paths of its own headers and runtime sources: one zig for
    every build keeps one cache, so the second Python version's wheel reuses the first one's
    objects of the core (everything but the bindings) and Zig's C++ runtime."""
    wrapper = folder / "c++"
    match = re.search(r'^exec "([^"]+)"', wrapper.read_text(), re.M) if wrapper.is_file() else None
    if not match or Path(match.group(1)) == zig or not Path(match.group(1)).is_file():
        return zig

    def version(executable: Path | str) -> str:
        return subprocess.run([str(executable), "version"], text=True, capture_output=True
                              ).stdout.strip()
    return Path(match.group(1)) if version(match.group(1)) == version(zig) else zig


def _write_executable(path: Path, text: str) -> None:
    if not path.is_file() or path.read_text() != text:
        path.write_text(text)
    path.chmod(path.stat().st_mode | stat.S_IXUSR | stat.S_IXGRP | stat.S_IXOTH)


def toolchain_file(target: Target) -> Path:
    """Write (idempotently) the compiler wrappers and CMake toolchain file for ``target``; return
    the toolchain file's path."""
    folder = TOOLCHAIN_DIR / target.name
    folder.mkdir(parents=True, exist_ok=True)
    zig = _shared_zig(folder, zig_executable())
    tools = {}
    for tool, command in (("cc", f"cc -target {target.zig_triple}"),
                          ("c++", f"c++ -target {target.zig_triple}"),
                          ("ar", "ar"), ("ranlib", "ranlib"), ("rc", "rc")):
        wrapper = folder / tool
        # exec keeps the exit status; "$@" passes CMake's arguments untouched.
        _write_executable(wrapper, "#!/bin/sh\n"
                          # zig's cache under build/, kept between runs: libc++ once per target.
                          f'export ZIG_GLOBAL_CACHE_DIR="${{ZIG_GLOBAL_CACHE_DIR:-{CACHE_DIR}}}"\n'
                          f'exec "{zig}" {command} "$@"\n')
        tools[tool] = wrapper
    lines = [f"# Written by scripts/zig_toolchain.py for {target.name}; do not edit."]
    if target.cmake_system != "Linux":
        # Another OS: a cross build. (Linux x86-64 is this machine's OS, only an older glibc,
        # so CMake and FindPython treat it as a native build.)
        lines += [f"set(CMAKE_SYSTEM_NAME {target.cmake_system})",
                  f"set(CMAKE_SYSTEM_PROCESSOR {target.cmake_processor})"]
    lines += [
        f'set(CMAKE_C_COMPILER "{tools["cc"]}")',
        f'set(CMAKE_CXX_COMPILER "{tools["c++"]}")',
        f'set(CMAKE_AR "{tools["ar"]}" CACHE FILEPATH "")',
        f'set(CMAKE_RANLIB "{tools["ranlib"]}" CACHE FILEPATH "")',
        f'set(ILLUMAP_TARGET_PLATFORM "{target.name}")',
    ]
    if target.cmake_system == "Windows":
        lines.append(f'set(CMAKE_RC_COMPILER "{tools["rc"]}")')
    if target.cmake_system == "Darwin":
        lines.append("set(CMAKE_OSX_ARCHITECTURES arm64)")
    toolchain = folder / "toolchain.cmake"
    text = "\n".join(lines) + "\n"
    if not toolchain.is_file() or toolchain.read_text() != text:
        toolchain.write_text(text)
    return toolchain
