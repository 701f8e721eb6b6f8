"""Whether the native core imports, and why not: the state the package sets at registration
and the panel and preferences read. No bpy.

When the import fails, the message names the cause a user can act on: no build for this
platform, no wheel for this Blender's Python version, a Linux system whose glibc is older than
the wheel needs, or else the loader's own error."""

import os
import platform
import re
import sys
from pathlib import Path

_native_error_message = None
# The glibc the Linux wheels are built for (manylinux_2_28: Blender's own baseline).
MIN_GLIBC = (2, 28)
# The extension's root folder (the manifest lies there in the installed extension).
_EXTENSION_ROOT = Path(__file__).resolve().parent.parent


def _import_native():
    """Import the native core and the pipeline; raise whatever the import raises."""
    import illumap  # the core package, installed from the bundled wheel
    load_native = getattr(illumap, "load_native", None)
    if load_native is not None:
        load_native()     # raises the ImportError that says why
    from . import pipeline  # noqa: F401


def blender_platform():
    """This machine as Blender's extension platforms name it (e.g. "linux-x64")."""
    system = {"linux": "linux", "win32": "windows", "darwin": "macos"}.get(sys.platform,
                                                                          sys.platform)
    machine = platform.machine().lower()
    arch = {"x86_64": "x64", "amd64": "x64", "arm64": "arm64", "aarch64": "arm64"}.get(machine,
                                                                                      machine)
    return f"{system}-{arch}"


def glibc_version():
    """The running glibc as (major, minor), or None off glibc (Windows, macOS, musl)."""
    try:
        text = os.confstr("CS_GNU_LIBC_VERSION")  # e.g. "glibc 2.28"
    except (AttributeError, ValueError, OSError):
        return None
    match = re.fullmatch(r"glibc (\d+)\.(\d+).*", text or "")
    return (int(match.group(1)), int(match.group(2))) if match else None


def _read_manifest(path):
    """The platforms and wheel names of the manifest at ``path`` (a split zip's own, from the
    ``[build.generated]`` table Blender's build tool appends), or None when unreadable."""
    try:
        import tomllib
        data = tomllib.loads(Path(path).read_text(encoding="utf-8"))
    except (OSError, ValueError, ImportError):
        return None
    data = data.get("build", {}).get("generated", data)
    return {"platforms": list(data.get("platforms", [])),
            "wheels": [Path(w).name for w in data.get("wheels", [])]}


def _manifest():
    """The installed extension's manifest (None outside an extension)."""
    return _read_manifest(_EXTENSION_ROOT / "blender_manifest.toml")


def _missing_cause(manifest, here, python_tag):
    """Why no wheel installed, from the manifest: another platform or another Python."""
    if manifest is None:
        return None
    if manifest["platforms"] and here not in manifest["platforms"]:
        return (f"This Illumap package is built for {', '.join(manifest['platforms'])}, not "
                f"for {here}: install the Illumap zip made for {here}.")
    tags = sorted({w.split("-")[2] for w in manifest["wheels"] if w.count("-") >= 4})
    if tags and python_tag not in tags:
        versions = ", ".join(f"{t[2]}.{t[3:]}" for t in tags)
        return (f"This Illumap package carries the core for Python {versions}; this Blender "
                "runs another Python version: install an Illumap build for this Blender.")
    return None


def _glibc_cause(error, glibc):
    """The glibc explanation when the loader refused a symbol version, else None."""
    if "GLIBC" not in str(error):
        return None
    have = f"{glibc[0]}.{glibc[1]}" if glibc else "an unknown version"
    need = re.search(r"GLIBC_(\d+\.\d+)", str(error))
    return (f"This system's C library (glibc {have}) is older than the native module needs"
            f" ({'glibc ' + need.group(1) if need else 'a newer glibc'}; Illumap's Linux "
            f"builds need glibc {MIN_GLIBC[0]}.{MIN_GLIBC[1]} or newer, like Blender itself).")


def _explain(error, manifest=None, here=None, glibc=None):
    """The message for an import failure ``error``; the other arguments default to this
    machine and the installed extension (tests pass their own)."""
    version = ".".join(map(str, sys.version_info[:3]))
    here = here or blender_platform()
    python_tag = f"cp{sys.version_info[0]}{sys.version_info[1]}"
    cause = None
    if isinstance(error, ModuleNotFoundError) and error.name == "illumap":
        first = "The native module 'illumap' is not installed."
        cause = _missing_cause(manifest if manifest is not None else _manifest(), here,
                               python_tag)
    elif isinstance(error, ImportError):
        first = f"The native module could not be loaded: {error}"
        cause = _glibc_cause(error, glibc if glibc is not None else glibc_version())
    else:
        first = f"The native module failed to initialise: {type(error).__name__}: {error}"
    return "\n".join([first, *([cause] if cause else []),
                      f"Blender's Python is {version} on {here}; the Illumap wheel must match "
                      f"it."])


def check_native():
    """Try the import again and return the problem as text (None when the core works)."""
    global _native_error_message
    try:
        _import_native()
    except Exception as error:  # any failure means the reduced UI
        _native_error_message = _explain(error)
    else:
        _native_error_message = None
    return _native_error_message


def core_error():
    """Why the native module is unavailable, or None when it works."""
    return _native_error_message
