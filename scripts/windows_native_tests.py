"""Cross-compiles the native visibility tests (core/tests_native/test_visibility.cpp: Embree's
oriented discs and squares, the seed method, cancellation, threads) for Windows x64 with the
toolchain and static Embree of the Windows wheel, and runs them under Wine.

    .venv/bin/python scripts/windows_native_tests.py            # exit 0 when every test passes
    .venv/bin/python scripts/windows_native_tests.py --build-only

This checks, on this Linux machine, that the Windows build of the visibility code and of Embree
(internal tasking, SSE2 kernels, MinGW-w64 runtime, static libc++) computes what the Linux
build computes. Wine comes from Debian's ``wine64`` package (``apt-get install wine64``; the test
set-up does not install it: the Windows build is not part of a test run).
"""

from __future__ import annotations

import argparse
import os
import shutil
import subprocess
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from native_test_build import QUAD_TESTS, build_visibility_tests  # noqa: E402
from zig_toolchain import ROOT  # noqa: E402

OUT = ROOT / "build" / "windows-native"
WINE_CANDIDATES = ("wine64", "/usr/lib/wine/wine64", "wine")


def wine() -> str | None:
    """The Wine launcher for 64-bit programs, or None when Wine is not installed."""
    for candidate in WINE_CANDIDATES:
        found = shutil.which(candidate) or (candidate if Path(candidate).is_file() else None)
        if found:
            return found
    return None


def build() -> Path:
    """Compile and link test_visibility.exe; return its path."""
    return build_visibility_tests("windows-x64", OUT / "test_visibility.exe")


def run(exe: Path, only: str = "", shape: str = "") -> int:
    """Run ``exe`` under Wine (a private prefix under build/); return its exit status."""
    launcher = wine()
    if launcher is None:
        raise SystemExit("Wine is not installed (Debian: apt-get install wine64)")
    env = {**os.environ, "WINEPREFIX": str(ROOT / "build" / "wine-prefix"), "WINEDEBUG": "-all",
           "WINEDLLOVERRIDES": "mscoree,mshtml="}
    if shape:
        env["ILLUMAP_VIS_SHAPE"] = shape
    return subprocess.run([launcher, str(exe), *([only] if only else [])], env=env).returncode


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--build-only", action="store_true")
    parser.add_argument("only", nargs="?", default="",
                        help="run only the tests whose names appear in this text")
    args = parser.parse_args()
    exe = build()
    print(exe)
    if args.build_only:
        return 0
    status = run(exe, args.only)
    # The exact-mode tests again with squares instead of discs.
    quad = run(exe, QUAD_TESTS, "quad")
    return status or quad


if __name__ == "__main__":
    raise SystemExit(main())
