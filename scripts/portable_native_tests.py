"""Builds the native visibility tests (core/tests_native/test_visibility.cpp) with the Linux
wheel's toolchain and static Embree, and runs them once per Embree kernel set: the one Embree's
runtime dispatch picks on this CPU, then each forced ISA asked for (default: SSE2, which every
x86-64 CPU has), so a machine without AVX is covered on this one.

    .venv/bin/python scripts/portable_native_tests.py                  # dispatch + sse2
    .venv/bin/python scripts/portable_native_tests.py --isa sse2 --isa sse4.2 --isa avx
    .venv/bin/python scripts/portable_native_tests.py --dispatch-only  # which BVH/kernels, no tests

How an ISA is forced without touching the core: the program is linked with
``-Wl,--wrap=rtcNewDevice`` and scripts/embree_config_shim.cpp, which appends
``ILLUMAP_EMBREE_CONFIG`` (e.g. ``isa=sse2``) to the configuration of every Embree device the
visibility code makes. Before the tests, one test's scenes are built with ``verbose=2`` and
what Embree reports is printed: the BVH (``BVH8``: 8-wide, AVX/AVX2 kernels; ``BVH4``: SSE) and
the intersector of single rays, named by its ISA (``avx2::...``, ``sse2::...``).
Exit status 0 when every run passes. The Windows counterpart is scripts/windows_native_tests.py.
"""

from __future__ import annotations

import argparse
import os
import re
import subprocess
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from native_test_build import QUAD_TESTS, build_visibility_tests  # noqa: E402
from zig_toolchain import ROOT  # noqa: E402

OUT = ROOT / "build" / "native-tests" / "linux-x64"
SHIM = ROOT / "scripts" / "embree_config_shim.cpp"
# A quick test whose scenes show the dispatch (discs and triangles both).
DISPATCH_TEST = "occluder"


def build() -> Path:
    """Compile and link test_visibility for linux-x64; return its path."""
    return build_visibility_tests("linux-x64", OUT / "test_visibility", extra_sources=(SHIM,),
                                  extra_flags=("-Wl,--wrap=rtcNewDevice", "-pthread"))


def run(exe: Path, config: str, only: str = "", shape: str = "", capture: bool = False
        ) -> subprocess.CompletedProcess:
    """Run ``exe`` with ``config`` appended to every Embree device's configuration."""
    env = {**os.environ, "ILLUMAP_EMBREE_CONFIG": config}
    env.pop("ILLUMAP_VIS_SHAPE", None)
    if shape:
        env["ILLUMAP_VIS_SHAPE"] = shape
    return subprocess.run([str(exe), *([only] if only else [])], env=env, text=True,
                          capture_output=capture)


def dispatch(exe: Path, isa: str) -> list[str]:
    """What Embree reports for one quick test's scenes, discs and squares: the kernels compiled
    in, each distinct BVH with its builder (``BVH8`` from the AVX/AVX2 kernels, ``BVH4`` from
    the SSE ones) and the intersector that traces single rays (named by its ISA)."""
    config = "verbose=2" + (f",isa={isa}" if isa else "")
    found, targets = set(), set()
    for shape in ("disc", "quad"):
        result = run(exe, config, DISPATCH_TEST, shape, capture=True)
        if result.returncode != 0:
            sys.stderr.write(result.stdout[-4000:] + result.stderr[-4000:])
            raise SystemExit(f"the dispatch check failed ({isa or 'this CPU'}, {shape})")
        found |= {f"{bvh} using {builder}" for bvh, builder in
                  re.findall(r"^building (BVH\d+<[^>]*>) using (\S+)", result.stdout, re.M)}
        found |= {f"single rays traced by {name}" for name in
                  re.findall(r"^\s+intersector1\s+=\s+(\S+)", result.stdout, re.M)}
        targets |= set(re.findall(r"^\s+(\S.*?)\s+\(compile time enabled\)", result.stdout,
                                  re.M))
    return [f"kernels compiled in: {t}" for t in sorted(targets)] + sorted(found)


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--isa", action="append",
                        help="an ISA to force as well (Embree's names: sse2, sse4.2, avx, avx2; "
                             "repeatable; default sse2)")
    parser.add_argument("--dispatch-only", action="store_true",
                        help="print what each run's Embree builds, run no tests")
    args = parser.parse_args()
    exe = build()
    print(exe)
    status = 0
    for isa in ["", *(args.isa or ["sse2"])]:
        label = f"isa={isa}" if isa else "this CPU's dispatch"
        print(f"== {label}", flush=True)
        for line in dispatch(exe, isa):
            print(f"   {line}", flush=True)
        if args.dispatch_only:
            continue
        config = f"isa={isa}" if isa else ""
        status |= run(exe, config).returncode
        status |= run(exe, config, QUAD_TESTS, "quad").returncode
    return 1 if status else 0


if __name__ == "__main__":
    raise SystemExit(main())
