"""The message when the native module cannot load names the cause a user can act on: another
platform than the zip's, another Python than its wheels', or a glibc older than the wheel needs
(addon/core_status.py; the panel and the preferences show it)."""

from __future__ import annotations

import importlib.util
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[3]
_spec = importlib.util.spec_from_file_location("illumap_core_status",
                                               ROOT / "addon" / "core_status.py")
core_status = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(core_status)

HERE_TAG = f"cp{sys.version_info[0]}{sys.version_info[1]}"
LINUX_ZIP = {"platforms": ["linux-x64"],
             "wheels": [f"illumap-0.1.0-{t}-{t}-manylinux_2_28_x86_64.whl"
                        for t in ("cp311", "cp313")]}
MISSING = ModuleNotFoundError("No module named 'illumap'", name="illumap")


def test_another_platform_is_named() -> None:
    text = core_status._explain(MISSING, manifest=LINUX_ZIP, here="windows-x64")
    lines = text.splitlines()
    assert lines[0] == "The native module 'illumap' is not installed."
    assert "built for linux-x64, not for windows-x64" in lines[1], text
    assert "Illumap zip made for windows-x64" in lines[1], text


def test_another_python_is_named() -> None:
    manifest = {"platforms": ["linux-x64"],
                "wheels": ["illumap-0.1.0-cp310-cp310-manylinux_2_28_x86_64.whl"]}
    text = core_status._explain(MISSING, manifest=manifest, here="linux-x64")
    assert "for Python 3.10" in text and "another Python version" in text, text
    assert "%d.%d" % sys.version_info[:2] in text.splitlines()[-1], text


def test_a_matching_wheel_blames_nothing_it_cannot_see() -> None:
    manifest = {"platforms": ["linux-x64"],
                "wheels": [f"illumap-0.1.0-{HERE_TAG}-{HERE_TAG}-manylinux_2_28_x86_64.whl"]}
    text = core_status._explain(MISSING, manifest=manifest, here="linux-x64")
    assert len(text.splitlines()) == 2, text  # the failure and Blender's Python, no guess


def test_an_old_glibc_is_named() -> None:
    error = ImportError("/lib64/libc.so.6: version `GLIBC_2.28' not found (required by "
                        "_core.cpython-311-x86_64-linux-gnu.so)")
    text = core_status._explain(error, here="linux-x64", glibc=(2, 17))
    assert text.startswith("The native module could not be loaded: ")
    assert "glibc 2.17" in text and "glibc 2.28" in text, text


def test_other_load_errors_keep_the_loader_message() -> None:
    error = ImportError("DLL load failed while importing _core")
    text = core_status._explain(error, here="windows-x64", glibc=None)
    assert "DLL load failed" in text and "glibc" not in text, text


def test_this_machine_is_named_as_blender_names_platforms() -> None:
    assert core_status.blender_platform() in ("linux-x64", "linux-arm64", "windows-x64",
                                              "windows-arm64", "macos-x64", "macos-arm64")
    if sys.platform.startswith("linux"):
        major, minor = core_status.glibc_version()
        assert (major, minor) >= (2, 28)


def test_the_split_zip_manifest_names_its_own_platform(tmp_path: Path) -> None:
    """In an installed split zip the manifest's top-level lists hold every platform; the
    generated table Blender's build tool appends holds the zip's own."""
    manifest = tmp_path / "blender_manifest.toml"
    manifest.write_text('platforms = ["linux-x64", "windows-x64"]\n'
                        'wheels = ["./wheels/a-0.1.0-cp313-cp313-win_amd64.whl"]\n'
                        '[build]\npaths = []\n[build.generated]\nplatforms = ["windows-x64"]\n'
                        'wheels = ["./wheels/a-0.1.0-cp313-cp313-win_amd64.whl"]\n')
    assert core_status._read_manifest(manifest) == {
        "platforms": ["windows-x64"], "wheels": ["a-0.1.0-cp313-cp313-win_amd64.whl"]}
