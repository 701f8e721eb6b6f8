"""Compiles the native visibility tests (core/tests_native/test_visibility.cpp) with a wheel's
Zig toolchain against that wheel's static Embree: shared by scripts/portable_native_tests.py
(Linux x64) and scripts/windows_native_tests.py (Windows x64 under Wine)."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
import build_embree  # noqa: E402
from zig_toolchain import ROOT, TARGETS, toolchain_file  # noqa: E402

SRC = ROOT / "core" / "src"
TESTS = ROOT / "core" / "tests_native"
SOURCES = ("visibility/visibility.cpp", "visibility/visibility_factory.cpp", "visibility/raycast.cpp",
           "visibility/seed_visibility.cpp", "geometry/octree.cpp")
# Embree's static libraries, the kernels first (they use the others).
EMBREE_LIBRARIES = ("embree3", "embree_avx2", "embree_sse42", "embree_avx", "lexers", "tasking",
                    "sys", "math", "simd")
# The exact-mode tests that run again with squares instead of discs, as core/tests_native/run.sh does.
QUAD_TESTS = "degenerate occluder half rooms scale reciprocity furnace coverage"


def build_visibility_tests(target_name: str, exe: Path, extra_sources: tuple[Path, ...] = (),
                           extra_flags: tuple[str, ...] = ()) -> Path:
    """Compile and link test_visibility for ``target_name`` (a key of zig_toolchain.TARGETS)
    into ``exe``, building that target's Embree first when it is missing; return ``exe``."""
    target = TARGETS[target_name]
    install = build_embree.build(target).parents[2]  # <install>/lib/cmake/embree-x.y.z
    compiler = toolchain_file(target).parent / "c++"
    exe.parent.mkdir(parents=True, exist_ok=True)
    libraries = [f"-l{name}" for name in EMBREE_LIBRARIES
                 if (install / "lib" / f"lib{name}.a").is_file()]
    command = [str(compiler), "-std=c++17", "-O2", "-Wall", "-I", str(SRC),
               "-I", str(install / "include"), str(TESTS / "test_visibility.cpp"),
               *(str(path) for path in extra_sources), *(str(SRC / name) for name in SOURCES),
               "-L", str(install / "lib"), *extra_flags,
               "-Wl,--start-group", *libraries, "-Wl,--end-group", "-o", str(exe)]
    result = subprocess.run(command, text=True, capture_output=True)
    if result.returncode != 0:
        sys.stderr.write(result.stdout + result.stderr)
        raise SystemExit(f"{exe.name} did not build")
    return exe
