"""The core this test run uses is the portable Linux wheel (scripts/setup_env.sh installs it):
tagged manylinux_2_28_x86_64, confirmed by auditwheel, and its native module needs nothing newer
than glibc 2.28 and no library beyond libc/libm, so it loads on Blender's own Linux baseline
(Rocky/Alma 8, RHEL 8, Ubuntu 20.04+) and never clashes with the TBB that bpy loads."""

from __future__ import annotations

import importlib.metadata
import importlib.util
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
TAG = f"cp{sys.version_info[0]}{sys.version_info[1]}"
PLATFORM_TAG = "manylinux_2_28_x86_64"

pytestmark = pytest.mark.skipif(not sys.platform.startswith("linux"), reason="Linux wheel")


def _load(name: str):
    spec = importlib.util.spec_from_file_location(name, ROOT / "scripts" / f"{name}.py")
    module = importlib.util.module_from_spec(spec)
    sys.modules[name] = module
    spec.loader.exec_module(module)
    return module


wheel_abi = _load("wheel_abi")


def built_wheel() -> Path:
    """The wheel scripts/setup_env.sh built for this Python (build/wheels/linux-x64)."""
    found = sorted((ROOT / "build" / "wheels" / "linux-x64").glob(f"illumap-*-{TAG}-{TAG}-*.whl"))
    assert found, "no portable wheel built for this Python: run scripts/setup_env.sh --all"
    assert len(found) == 1, found
    return found[0]


def test_installed_core_is_the_portable_wheel() -> None:
    distribution = importlib.metadata.distribution("illumap")
    tags = [line.split(": ", 1)[1] for line in distribution.read_text("WHEEL").splitlines()
            if line.startswith("Tag: ")]
    assert tags == [f"{TAG}-{TAG}-{PLATFORM_TAG}"], tags
    import illumap._core
    module = Path(illumap._core.__file__)
    # Installed into site-packages, not a build tree or the checkout.
    assert not module.is_relative_to(ROOT / "core"), module
    assert built_wheel().name.endswith(f"-{TAG}-{TAG}-{PLATFORM_TAG}.whl")


def test_native_module_needs_only_libc_up_to_glibc_2_28() -> None:
    import illumap._core
    module = Path(illumap._core.__file__)
    needs = wheel_abi.elf_needs(module.name, module.read_bytes())
    # No Embree, TBB or C++ runtime: only the C library (and the loader) of any glibc system.
    assert set(needs.libraries) <= {"libc.so.6", "libm.so.6", "ld-linux-x86-64.so.2",
                                    "libpthread.so.0", "libdl.so.2", "librt.so.1"}, needs.libraries
    assert needs.max_version("GLIBC") <= (2, 28), needs.versions
    assert needs.max_version("GLIBCXX") is None and needs.max_version("CXXABI") is None, \
        needs.versions
    # The built wheel holds exactly this module and nothing else native.
    modules = wheel_abi.wheel_modules(built_wheel())
    assert list(modules) == [f"illumap/{module.name}"], list(modules)
    assert modules[f"illumap/{module.name}"] == module.read_bytes()
    assert wheel_abi.problems(built_wheel()) == []


def test_abi_check_refuses_a_tag_below_what_the_module_needs(tmp_path: Path) -> None:
    """The check can fail: the same wheel renamed to promise a glibc one minor version older
    than the newest symbol version its module needs is refused."""
    wheel = built_wheel()
    (data,) = wheel_abi.wheel_modules(wheel).values()
    major, minor = wheel_abi.elf_needs("_core", data).max_version("GLIBC")[:2]
    older = tmp_path / wheel.name.replace(PLATFORM_TAG, f"manylinux_{major}_{minor - 1}_x86_64")
    shutil.copy(wheel, older)
    found = wheel_abi.problems(older)
    assert any(f"GLIBC_{major}.{minor}" in p for p in found), found


def test_auditwheel_confirms_the_manylinux_2_28_tag() -> None:
    result = subprocess.run([sys.executable, "-m", "auditwheel", "show", str(built_wheel())],
                            text=True, capture_output=True, timeout=120)
    assert result.returncode == 0, result.stdout + result.stderr
    text = " ".join(result.stdout.split())
    # auditwheel names the most compatible tag the wheel is consistent with: 2.28 or older.
    import re
    match = re.search(r'consistent with the following platform tag: "manylinux_(\d+)_(\d+)_x86_64"',
                      text)
    assert match, text
    assert (int(match.group(1)), int(match.group(2))) <= (2, 28), text
    assert "system-provided shared libraries" in text or "external versioned symbols" in text, text


def test_native_module_carries_embree_kernels_for_every_x86_level() -> None:
    """Embree in the module has its SSE2, SSE4.2, AVX and AVX2 kernels (scripts/build_embree.py
    ISA_OPTIONS), so its runtime dispatch can pick AVX2's 8-wide BVHs where the CPU has them and
    still run on an SSE2-only CPU. Embree names each intersector by its ISA (``avx2::BVH8...``);
    those names are in the module's read-only data. AVX-512 is not built."""
    import illumap._core
    data = Path(illumap._core.__file__).read_bytes()
    for name in (b"sse2::BVH4", b"sse42::BVH4", b"avx::BVH8", b"avx2::BVH8"):
        assert name in data, f"no {name.decode()} intersectors in {illumap._core.__file__}"
    assert b"avx512::" not in data
