"""Cross-builds the ``illumap`` core wheel for Windows x64 on this Linux machine: Zig's clang for
``x86_64-windows-gnu`` (MinGW-w64 runtime, libc++ linked statically), a static Embree without
TBB (scripts/build_embree.py), and a "Python SDK" for the target made here from registry
packages:

* the headers of the interpreter the wheel is for (CPython's ``Include/`` is the same on every
  platform) with Windows' ``pyconfig.h`` from Debian's CPython source package;
* an import library for ``python3XY.dll``, made with ``zig dlltool`` from a .def that lists the
  C API symbols this interpreter exports (functions and data alike).

Then the module is built with CMake (core/CMakeLists.txt, cross branch) and packed with the
``illumap`` package files into a ``win_amd64`` wheel. Called by scripts/build_wheels.py
(``--platform windows-x64``). What this cannot verify here, and why: docs/development.md.
"""

from __future__ import annotations

import base64
import hashlib
import re
import shutil
import subprocess
import sys
import tarfile
import tomllib
import zipfile
from pathlib import Path

import build_embree
import build_wheels
from zig_toolchain import ROOT, Target, toolchain_file, zig_executable

SDK_DIR = ROOT / "build" / "python-sdk"
CORE = ROOT / "core"
# Debian source packages with each Python's Windows pyconfig.h (PC/ folder of the tarball).
PYTHON_SOURCES = {
    (3, 11): ("bookworm", "python3.11", "PC/pyconfig.h"),
    (3, 13): ("trixie", "python3.13", "PC/pyconfig.h.in"),  # 3.13 copies .in verbatim
}
DEB_SRC_SUITE = """
Types: deb-src
URIs: http://deb.debian.org/debian
Suites: {suite}
Components: main
Signed-By: /usr/share/keyrings/debian-archive-keyring.gpg
"""


def log(message: str) -> None:
    print(f"[cross] {message}", file=sys.stderr, flush=True)


def run(*cmd: str | Path, cwd: Path = ROOT, check: bool = True) -> str:
    env = None
    if Path(str(cmd[0])).name in ("cmake", "ninja"):
        import os
        env = {**os.environ,
               "PATH": f"{Path(sys.executable).parent}{os.pathsep}{os.environ['PATH']}"}
    result = subprocess.run([str(c) for c in cmd], cwd=cwd, text=True, capture_output=True,
                            env=env)
    if check and result.returncode != 0:
        sys.stderr.write(result.stdout + result.stderr)
        raise SystemExit(f"command failed ({result.returncode}): {' '.join(map(str, cmd))}")
    return result.stdout


def interpreter_facts(python: Path) -> dict:
    """Version, include folder and exporting library of ``python``."""
    code = ("import sys, sysconfig, json; v = sysconfig.get_config_vars(); print(json.dumps("
            "{'version': sys.version_info[:2], 'include': sysconfig.get_paths()['include'], "
            "'libdir': v.get('LIBDIR'), 'ldlibrary': v.get('LDLIBRARY'), "
            "'executable': sys.executable}))")
    import json
    return json.loads(run(python, "-c", code))


def windows_pyconfig(version: tuple[int, int]) -> Path:
    """Windows' pyconfig.h for ``version`` from Debian's CPython source (downloaded once)."""
    suite, package, member = PYTHON_SOURCES[version]
    folder = SDK_DIR / "debian" / package
    header = folder / "pyconfig.h"
    if header.is_file():
        return header
    folder.mkdir(parents=True, exist_ok=True)
    sources = build_embree.DEB_SRC_FILE
    if f"Suites: {suite}" not in (sources.read_text() if sources.is_file() else ""):
        log(f"adding Debian's {suite} source archive to {sources}")
        text = (sources.read_text() if sources.is_file() else build_embree.DEB_SRC)
        subprocess.run([*build_embree.sudo(), "tee", str(sources)],
                       input=text + DEB_SRC_SUITE.format(suite=suite), text=True,
                       stdout=subprocess.DEVNULL, check=True)
        run(*build_embree.sudo(), "apt-get", "update", "-qq")
    log(f"downloading Debian's source package {package} (for Windows' pyconfig.h)")
    run("apt-get", "source", "-qq", "--download-only", f"{package}/{suite}", cwd=folder,
        check=False)
    tarballs = sorted(folder.glob(f"{package}_*.orig.tar.*"))
    tarballs = [t for t in tarballs if not t.name.endswith(".asc")]
    if not tarballs:
        raise SystemExit(f"apt-get source {package} brought no source tarball")
    with tarfile.open(tarballs[-1]) as archive:
        (entry,) = [m for m in archive.getmembers() if m.name.endswith("/" + member)
                    and m.name.count("/") == member.count("/") + 1]
        header.write_bytes(archive.extractfile(entry).read())
    for path in folder.iterdir():  # keep only the header
        if path != header:
            path.unlink()
    return header


def exported_symbols(facts: dict) -> list[tuple[str, bool]]:
    """(name, is_data) of the C API symbols the interpreter exports (``Py*``, ``_Py*``)."""
    from elftools.elf.elffile import ELFFile
    library = Path(facts["libdir"] or "") / (facts["ldlibrary"] or "")
    path = library if library.suffix == ".so" or ".so." in library.name else \
        Path(facts["executable"])
    symbols = []
    with path.open("rb") as handle:
        dynsym = ELFFile(handle).get_section_by_name(".dynsym")
        for symbol in dynsym.iter_symbols():
            kind = symbol["st_info"]["type"]
            if symbol["st_shndx"] == "SHN_UNDEF" or kind not in ("STT_FUNC", "STT_OBJECT"):
                continue
            if re.match(r"_?Py", symbol.name):
                symbols.append((symbol.name, kind == "STT_OBJECT"))
    return sorted(set(symbols))


def python_sdk(python: Path) -> tuple[Path, Path, tuple[int, int]]:
    """(include folder, import library, version) of the target Python for ``python``."""
    facts = interpreter_facts(python)
    version = tuple(facts["version"])
    name = f"python{version[0]}{version[1]}"
    folder = SDK_DIR / "windows-x64" / name
    include = folder / "include"
    library = folder / f"lib{name}.a"
    if include.is_dir() and library.is_file():
        return include, library, version
    shutil.rmtree(folder, ignore_errors=True)
    shutil.copytree(facts["include"], include)
    shutil.copy(windows_pyconfig(version), include / "pyconfig.h")
    symbols = exported_symbols(facts)
    definition = folder / f"{name}.def"
    definition.write_text(f"LIBRARY {name}.dll\nEXPORTS\n" + "".join(
        f"  {symbol}{' DATA' if data else ''}\n" for symbol, data in symbols))
    run(zig_executable(), "dlltool", "-m", "i386:x86-64", "-d", definition, "-l", library)
    log(f"{name}: import library with {len(symbols)} symbols")
    return include, library, version


def build_module(python: Path, target: Target) -> tuple[Path, tuple[int, int]]:
    """Configure and build the native module for ``target``; return it and the Python
    version."""
    include, library, version = python_sdk(python)
    embree = build_embree.build(target)
    tag = f"cp{version[0]}{version[1]}"
    work = CORE / "build" / f"{target.name}-{tag}"
    run("cmake", "-G", "Ninja", "-S", CORE, "-B", work, "-DCMAKE_BUILD_TYPE=Release",
        f"-DCMAKE_TOOLCHAIN_FILE={toolchain_file(target)}", f"-DILLUMAP_EMBREE_DIR={embree}",
        f"-DPython_EXECUTABLE={python}", f"-DILLUMAP_CROSS_PYTHON_INCLUDE={include}",
        f"-DILLUMAP_CROSS_PYTHON_LIBRARY={library}",
        f"-DILLUMAP_CPU_MODEL_OBJECT={build_wheels.cpu_model_object(target)}",
        # The module's file name: Windows' CPython looks for _core.cp3XY-win_amd64.pyd (nanobind
        # would take the host interpreter's suffix, a Linux one).
        f"-DNB_SUFFIX=.{tag}-{target.wheel_platform}.pyd", "-DNB_SUFFIX_S=.pyd")
    run("cmake", "--build", work, "--target", "_core")
    (module,) = work.glob("_core.*.pyd")
    return module, version


def _record_line(name: str, data: bytes) -> str:
    digest = base64.urlsafe_b64encode(hashlib.sha256(data).digest()).rstrip(b"=").decode()
    return f"{name},sha256={digest},{len(data)}"


def pack_wheel(module: Path, version: tuple[int, int], target: Target, output_dir: Path) -> Path:
    """A wheel of the ``illumap`` package files plus ``module``, tagged for ``target``."""
    project = tomllib.loads((CORE / "pyproject.toml").read_text())["project"]
    name, release = project["name"], project["version"]
    tag = f"cp{version[0]}{version[1]}"
    wheel_tag = f"{tag}-{tag}-{target.wheel_platform}"
    files: dict[str, bytes] = {}
    package = CORE / "python" / "illumap"
    for path in sorted(package.rglob("*")):
        relative = path.relative_to(package.parent).as_posix()
        if path.is_file() and "__pycache__" not in relative and \
                path.suffix not in (".pyc", ".so", ".pyd"):
            files[relative] = path.read_bytes()
    files[f"illumap/{module.name}"] = module.read_bytes()
    info = f"{name}-{release}.dist-info"
    metadata = [f"Metadata-Version: 2.1", f"Name: {name}", f"Version: {release}",
                f"Summary: {project['description']}",
                f"Requires-Python: {project['requires-python']}",
                *(f"Requires-Dist: {d}" for d in project.get("dependencies", [])),
                f"License: {project['license']['text']}"]
    files[f"{info}/METADATA"] = ("\n".join(metadata) + "\n").encode()
    files[f"{info}/WHEEL"] = ("Wheel-Version: 1.0\nGenerator: illumap scripts/cross_wheel.py\n"
                              f"Root-Is-Purelib: false\nTag: {wheel_tag}\n").encode()
    record = [_record_line(n, d) for n, d in files.items()] + [f"{info}/RECORD,,"]
    files[f"{info}/RECORD"] = ("\n".join(record) + "\n").encode()
    wheel = output_dir / f"{name}-{release}-{wheel_tag}.whl"
    with zipfile.ZipFile(wheel, "w", zipfile.ZIP_DEFLATED) as archive:
        for file_name, data in files.items():
            entry = zipfile.ZipInfo(file_name, date_time=(2020, 1, 1, 0, 0, 0))
            entry.external_attr = 0o644 << 16
            archive.writestr(entry, data, compress_type=zipfile.ZIP_DEFLATED)
    return wheel


def build(python: Path, target: Target, output_dir: Path) -> Path:
    """Build the ``target`` wheel for ``python``'s version into ``output_dir``."""
    if target.cmake_system != "Windows":
        raise SystemExit(f"{target.name}: no cross build (docs/development.md says what blocks "
                         "it)")
    module, version = build_module(python, target)
    return pack_wheel(module, version, target, output_dir)
