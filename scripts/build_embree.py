"""Builds Embree 3.13.5 from Debian's source package as a static library for one target platform,
with the Zig toolchain (scripts/zig_toolchain.py), for the portable wheels.

    .venv/bin/python scripts/build_embree.py linux-x64     # -> build/embree/linux-x64/install

Why this Embree: a static library with Embree's own tasking system needs no TBB at all, so the
wheel cannot clash with the TBB that bpy loads (in either import order), and it bundles no shared
library. Only what Illumap uses is built (triangles and oriented-disc points, single rays, ray
streams and packets of 8), with the SSE2, SSE4.2, AVX and AVX2 kernels among which Embree picks
at run time (SSE2 on any x86-64 CPU, AVX2 where the CPU has it); the curve code that points
would drag in is left out (CURVE_FIXES), which keeps the one-off build to a few CPU-minutes.

The source comes from Debian's archive (``apt-get source embree``: a deb-src line for Debian's own
archive is added when missing). Idempotent: a stamp records the configuration; a second run with
the same one does nothing.
"""

from __future__ import annotations

import argparse
import hashlib
import os
import re
import shutil
import subprocess
import sys
import tarfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from zig_toolchain import ROOT, TARGETS, Target, toolchain_file  # noqa: E402

VERSION = "3.13.5"
DEBIAN_SOURCE = "embree"  # Debian bookworm: 3.13.5+dfsg-2
ORIG_TARBALL = f"embree_{VERSION}+dfsg.orig.tar.xz"
EMBREE_DIR = ROOT / "build" / "embree"
DEB_SRC_FILE = Path("/etc/apt/sources.list.d/illumap-debian-src.sources")
DEB_SRC = """Types: deb-src
URIs: http://deb.debian.org/debian
Suites: bookworm
Components: main
Signed-By: /usr/share/keyrings/debian-archive-keyring.gpg
"""

# Embree's CMake options. Geometry types Illumap does not use are off (issue 58 may need
# EMBREE_GEOMETRY_USER); the filter functions stay on (Embree's default).
OPTIONS = {
    "EMBREE_STATIC_LIB": "ON",
    "EMBREE_TASKING_SYSTEM": "INTERNAL",
    "EMBREE_ISPC_SUPPORT": "OFF",
    "EMBREE_TUTORIALS": "OFF",
    "EMBREE_GEOMETRY_TRIANGLE": "ON",
    "EMBREE_GEOMETRY_POINT": "ON",
    "EMBREE_GEOMETRY_QUAD": "OFF",
    "EMBREE_GEOMETRY_CURVE": "OFF",
    "EMBREE_GEOMETRY_SUBDIVISION": "OFF",
    "EMBREE_GEOMETRY_USER": "OFF",
    "EMBREE_GEOMETRY_INSTANCE": "OFF",
    "EMBREE_GEOMETRY_GRID": "OFF",
    "EMBREE_RAY_PACKETS": "ON",  # rtcOccluded8 (VisibilityOptions::packets)
    # Embree 3.13.5 predates CMake 4, which refuses its cmake_minimum_required(3.1).
    "CMAKE_POLICY_VERSION_MINIMUM": "3.5",
    "CMAKE_BUILD_TYPE": "Release",
}
# The kernels: SSE2, SSE4.2, AVX and AVX2, as Embree's own release builds (less AVX-512); Embree
# picks the best one the CPU has when a device is made (rtcNewDevice; "isa=sse2" in its config
# forces another). AVX2 needs the AVX set beside it: Embree compiles its 8-wide BVH builders for
# AVX only and selects them through AVX's slot (an SSE2+AVX2 build fails every BVH8 build with
# RTC_ERROR_UNSUPPORTED_CPU, "BVH build failed (error 5)"). Zig's clang does not imply POPCNT by
# SSE4.2 as GCC does, so each of these ISAs' flags names it (Embree's SSE4.2 level requires a
# CPU with POPCNT anyway).
X86_ISAS = {"EMBREE_MAX_ISA": "NONE", "EMBREE_ISA_SSE2": "ON", "EMBREE_ISA_SSE42": "ON",
            "EMBREE_ISA_AVX": "ON", "EMBREE_ISA_AVX2": "ON", "EMBREE_ISA_AVX512": "OFF",
            "FLAGS_SSE42": "-msse4.2 -mpopcnt", "FLAGS_AVX": "-mavx -mpopcnt",
            "FLAGS_AVX2": "-mf16c -mavx2 -mfma -mlzcnt -mbmi -mbmi2 -mpopcnt"}
# SSE2 only: every x86-64 CPU, Embree's 4-wide BVH.
SSE2_ONLY = {"EMBREE_MAX_ISA": "NONE", "EMBREE_ISA_SSE2": "ON", "EMBREE_ISA_SSE42": "OFF",
             "EMBREE_ISA_AVX": "OFF", "EMBREE_ISA_AVX2": "OFF", "EMBREE_ISA_AVX512": "OFF"}
ISA_OPTIONS = {
    "linux-x64": X86_ISAS,
    # Windows: still SSE2 only. X86_ISAS should build there as well (the same clang), but that
    # build and its run under Wine (scripts/windows_native_tests.py) have not been done yet;
    # switch to X86_ISAS once they pass. MinGW's math.h hides M_PI unless _USE_MATH_DEFINES
    # comes before its first include.
    "windows-x64": {**SSE2_ONLY, "EMBREE_IGNORE_CMAKE_CXX_FLAGS": "OFF",
                    "CMAKE_CXX_FLAGS": "-D_USE_MATH_DEFINES"},
    # Apple silicon: Embree maps its SSE code onto NEON.
    "macos-arm64": {"EMBREE_MAX_ISA": "NONE", "EMBREE_ISA_NEON": "ON", "EMBREE_ISA_NEON2X": "OFF"},
}
# Debug printers that newer clang rejects (members that do not exist in a template); they are
# never called. (file, text, replacement)
SOURCE_FIXES = (
    ("kernels/subdiv/bezier_curve.h",
     'return cout << "QuadraticBezierCurve ( (" << a.u.lower << ", " << a.u.upper << "), " << a.v0',
     'return cout << "QuadraticBezierCurve ( " << a.v0'),
    ("kernels/geometry/pointi.h",
     '<< "i {" << line.v0 << ", " << line.geomID()',
     '<< "i {" << line.geomID()'),
)
# Embree's virtual curve intersectors (six files, compiled again for every ISA: the heaviest part
# of the build) instantiate every curve basis even when EMBREE_GEOMETRY_CURVE is off; only their
# point entries (spheres, discs, oriented discs) can be reached then, so the curve entries are
# compiled only with curves on (each 4-wide file: 153 s to compile before, 11-19 s after, on
# this machine under load).
CURVE_FIXES = tuple(
    (f"kernels/geometry/curve_intersector_virtual_{variant}.cpp", old, new)
    for variant in ("4v", "4i", "4i_mb", "8v", "8i", "8i_mb")
    for old, new in (
        ("        intersector.vtbl[Geometry::GTY_CONE_LINEAR_CURVE ]",
         "#if defined(EMBREE_GEOMETRY_CURVE)\n"
         "        intersector.vtbl[Geometry::GTY_CONE_LINEAR_CURVE ]"),
        ("        return intersector;", "#endif\n        return intersector;"),
    )) + (
    # Likewise the curve geometries (one per basis) that rtcNewGeometry makes for curve types
    # only, and only when EMBREE_GEOMETRY_CURVE is on.
    ("kernels/common/scene_curves.cpp",
     "    CurveGeometry* createCurves(Device* device, Geometry::GType gtype)\n    {\n",
     "    CurveGeometry* createCurves(Device* device, Geometry::GType gtype)\n    {\n"
     "#if !defined(EMBREE_GEOMETRY_CURVE)\n"
     '      throw_RTCError(RTC_ERROR_INVALID_OPERATION,"invalid geometry type");\n#else\n'),
    ("kernels/common/scene_curves.cpp",
     '      default: throw_RTCError(RTC_ERROR_INVALID_OPERATION,"invalid geometry type");\n'
     "      }\n",
     '      default: throw_RTCError(RTC_ERROR_INVALID_OPERATION,"invalid geometry type");\n'
     "      }\n#endif\n"),
)
# The version resource of Embree's DLL: a static library has no use for it, and the file is
# UTF-16, which Zig's resource compiler rejects. Applied for every target (other platforms ignore
# .rc files), but only the Windows build's stamp depends on it.
WINDOWS_FIXES = (
    ("kernels/CMakeLists.txt", "SET(EMBREE_LIBRARY_FILES\n \n  embree.rc\n",
     "SET(EMBREE_LIBRARY_FILES\n"),
)


def log(message: str) -> None:
    print(f"[embree] {message}", file=sys.stderr, flush=True)


def run(*cmd: str | Path, cwd: Path | None = None, check: bool = True) -> int:
    """Run ``cmd``; cmake and ninja are the ones installed beside this interpreter."""
    env = {**os.environ, "PATH": f"{Path(sys.executable).parent}{os.pathsep}{os.environ['PATH']}"}
    result = subprocess.run([str(c) for c in cmd], cwd=cwd, env=env)
    if check and result.returncode != 0:
        raise SystemExit(f"command failed ({result.returncode}): {' '.join(map(str, cmd))}")
    return result.returncode


def sudo() -> list[str]:
    return [] if os.geteuid() == 0 else ["sudo"]


def expected_sha256(dsc: Path) -> str:
    """The orig tarball's SHA-256 as Debian's signed .dsc lists it."""
    match = re.search(rf"^ ([0-9a-f]{{64}}) \d+ {re.escape(ORIG_TARBALL)}$", dsc.read_text(), re.M)
    if not match:
        raise SystemExit(f"{dsc} lists no SHA-256 for {ORIG_TARBALL}")
    return match.group(1)


def fetch_source() -> Path:
    """Debian's Embree source tarball under build/embree/debian (downloaded once)."""
    folder = EMBREE_DIR / "debian"
    tarball = folder / ORIG_TARBALL
    if tarball.is_file():
        return tarball
    folder.mkdir(parents=True, exist_ok=True)
    if not DEB_SRC_FILE.is_file():
        log(f"adding Debian's source archive ({DEB_SRC_FILE})")
        subprocess.run([*sudo(), "tee", str(DEB_SRC_FILE)], input=DEB_SRC, text=True,
                       stdout=subprocess.DEVNULL, check=True)
        run(*sudo(), "apt-get", "update", "-qq")
    log(f"downloading Debian's source package {DEBIAN_SOURCE}")
    # Only the upstream tarball is used; the Debian packaging tarball may be gone from the
    # archive's pool, which makes apt-get fail after it has the two files we need.
    # Its messages are shown only when the two files did not come (the packaging tarball's 404
    # would otherwise read as a failure in every fresh set-up's log).
    fetched = subprocess.run(["apt-get", "source", "-qq", "--download-only",
                              f"{DEBIAN_SOURCE}/bookworm"], cwd=folder, text=True,
                             capture_output=True)
    dscs = sorted(folder.glob(f"embree_{VERSION}*.dsc"))
    if not tarball.is_file() or not dscs:
        sys.stderr.write(fetched.stdout + fetched.stderr)
        raise SystemExit(f"apt-get source {DEBIAN_SOURCE} did not bring {ORIG_TARBALL}")
    digest = hashlib.sha256(tarball.read_bytes()).hexdigest()
    if digest != expected_sha256(dscs[-1]):
        tarball.unlink()
        raise SystemExit(f"{ORIG_TARBALL}: SHA-256 does not match Debian's .dsc")
    return tarball


def unpack(tarball: Path) -> Path:
    """The patched source tree under build/embree/src (unpacked once)."""
    source = EMBREE_DIR / "src" / f"embree-{VERSION}"
    stamp = source / ".illumap-unpacked"
    fixes = hashlib.sha256(repr(SOURCE_FIXES + CURVE_FIXES + WINDOWS_FIXES).encode()
                           ).hexdigest()
    if stamp.is_file() and stamp.read_text() == fixes:
        return source
    shutil.rmtree(source.parent, ignore_errors=True)
    source.parent.mkdir(parents=True)
    with tarfile.open(tarball) as archive:
        archive.extractall(source.parent, filter="data")
    for relative, old, new in SOURCE_FIXES + CURVE_FIXES + WINDOWS_FIXES:
        path = source / relative
        text = path.read_text()
        if text.count(old) != 1:
            raise SystemExit(f"{relative}: the text to fix is not there once")
        path.write_text(text.replace(old, new))
    stamp.write_text(fixes)
    return source


def _children_cpu() -> float:
    """CPU seconds used so far by the finished child processes (the compilers included)."""
    times = os.times()
    return times.children_user + times.children_system


def cmake_dir(target: Target) -> Path:
    """Where the installed Embree's CMake config lives for ``target``."""
    return EMBREE_DIR / target.name / "install" / "lib" / "cmake" / f"embree-{VERSION}"


def configuration(target: Target) -> tuple[dict[str, str], str]:
    """Embree's CMake options for ``target`` and a key that changes when they or the toolchain
    change (the stamp of a finished build)."""
    options = {**OPTIONS, **ISA_OPTIONS[target.name]}
    fixes = SOURCE_FIXES + CURVE_FIXES + \
        (WINDOWS_FIXES if target.cmake_system == "Windows" else ())
    key = hashlib.sha256(repr((sorted(options.items()), toolchain_file(target).read_text(),
                               fixes)).encode()).hexdigest()
    return options, key


def build(target: Target) -> Path:
    """Build and install Embree for ``target``; return its CMake config folder."""
    toolchain = toolchain_file(target)
    options, key = configuration(target)
    stamp = EMBREE_DIR / target.name / "stamp"
    config = cmake_dir(target)
    if stamp.is_file() and stamp.read_text() == key and config.is_dir():
        log(f"{target.name}: up to date ({config})")
        return config
    source = unpack(fetch_source())
    work = EMBREE_DIR / target.name / "build"
    install = EMBREE_DIR / target.name / "install"
    shutil.rmtree(install, ignore_errors=True)
    started, cpu_before = time.monotonic(), _children_cpu()
    log(f"{target.name}: configuring and building (once; several minutes on two cores)")
    run("cmake", "-G", "Ninja", "-Wno-dev", "-Wno-deprecated", "-S", source, "-B", work,
        f"-DCMAKE_TOOLCHAIN_FILE={toolchain}",
        f"-DCMAKE_INSTALL_PREFIX={install}", *(f"-D{k}={v}" for k, v in options.items()))
    run("cmake", "--build", work)
    # Headers, static libraries and CMake config ("devel"); the "lib" component would also
    # install documents that Debian's repacked source does not carry.
    run("cmake", "--install", work, "--component", "devel")
    if not config.is_dir():
        raise SystemExit(f"Embree installed no CMake config at {config}")
    stamp.write_text(key)
    log(f"{target.name}: built in {time.monotonic() - started:.0f} s "
        f"({_children_cpu() - cpu_before:.0f} CPU-seconds)")
    return config


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("targets", nargs="*", default=["linux-x64"], choices=sorted(TARGETS))
    args = parser.parse_args()
    for name in args.targets:
        print(build(TARGETS[name]))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
