"""What a built wheel's native modules ask of the system that loads them: the shared libraries
they link and the glibc/libstdc++ symbol versions they need. Used by scripts/build_wheels.py to
refuse a wheel that would not load on its platform tag's glibc, and by tests/core/test_wheel.py.

    .venv/bin/python scripts/wheel_abi.py wheels/illumap-*-manylinux_2_28_x86_64.whl
"""

from __future__ import annotations

import argparse
import io
import re
import sys
import zipfile
from dataclasses import dataclass, field
from pathlib import Path

# What every manylinux system provides (PEP 600's allowed libraries for the glibc family).
LINUX_SYSTEM_LIBRARIES = frozenset({
    "libc.so.6", "libm.so.6", "libpthread.so.0", "libdl.so.2", "librt.so.1",
    "ld-linux-x86-64.so.2", "libgcc_s.so.1", "libstdc++.so.6"})
# What a Windows Python extension may import: the C runtime (UCRT through the api-ms-win-crt
# forwarders, or msvcrt.dll for MinGW), the kernel and the Python DLL itself.
WINDOWS_SYSTEM_DLL = re.compile(
    r"^(kernel32|ucrtbase|msvcrt|advapi32|user32|ntdll|bcrypt|ws2_32|shell32|ole32|"
    r"api-ms-win-[a-z0-9-]+|python3\d*)\.dll$", re.IGNORECASE)


def _version_tuple(text: str) -> tuple[int, ...]:
    return tuple(int(part) for part in text.split("."))


@dataclass
class ElfNeeds:
    """One ELF module's needs."""
    name: str
    libraries: list[str] = field(default_factory=list)
    versions: dict[str, set[str]] = field(default_factory=dict)  # library -> {"GLIBC_2.14", ...}

    def max_version(self, prefix: str) -> tuple[int, ...] | None:
        """The highest ``prefix``_x.y version needed (e.g. prefix "GLIBC"), None when none."""
        found = [_version_tuple(v[len(prefix) + 1:]) for names in self.versions.values()
                 for v in names if re.fullmatch(rf"{prefix}_[\d.]+", v)]
        return max(found) if found else None


def elf_needs(name: str, data: bytes) -> ElfNeeds:
    """The DT_NEEDED libraries and versioned symbol needs of an ELF file's bytes."""
    from elftools.elf.dynamic import DynamicSection
    from elftools.elf.elffile import ELFFile
    from elftools.elf.gnuversions import GNUVerNeedSection

    needs = ElfNeeds(name)
    elf = ELFFile(io.BytesIO(data))
    for section in elf.iter_sections():
        if isinstance(section, DynamicSection):
            needs.libraries += [tag.needed for tag in section.iter_tags("DT_NEEDED")]
        elif isinstance(section, GNUVerNeedSection):
            for verneed, auxiliaries in section.iter_versions():
                needs.versions.setdefault(verneed.name, set()).update(a.name for a in auxiliaries)
    return needs


def pe_imports(data: bytes) -> list[str]:
    """The DLL names a PE (Windows) module imports, read from its import directory."""
    import struct

    pe = struct.unpack_from("<I", data, 0x3C)[0]
    if data[pe:pe + 4] != b"PE\0\0":
        raise ValueError("not a PE file")
    sections_count = struct.unpack_from("<H", data, pe + 6)[0]
    optional_size = struct.unpack_from("<H", data, pe + 20)[0]
    optional = pe + 24
    if struct.unpack_from("<H", data, optional)[0] != 0x20B:
        raise ValueError("not a PE32+ (64-bit) module")
    import_rva = struct.unpack_from("<I", data, optional + 120)[0]
    sections = []
    for i in range(sections_count):
        base = optional + optional_size + 40 * i
        size, rva, raw_size, raw = struct.unpack_from("<IIII", data, base + 8)
        sections.append((rva, max(size, raw_size), raw))

    def offset(rva_value: int) -> int:
        for start, size, raw in sections:
            if start <= rva_value < start + size:
                return raw + rva_value - start
        raise ValueError(f"RVA {rva_value:#x} is in no section")

    names, entry = [], offset(import_rva)
    while True:
        name_rva = struct.unpack_from("<I", data, entry + 12)[0]
        if name_rva == 0:
            return names
        start = offset(name_rva)
        names.append(data[start:data.index(b"\0", start)].decode())
        entry += 20


def wheel_modules(wheel: Path) -> dict[str, bytes]:
    """The native files (.so, .pyd, .dll) inside a wheel, by archive name."""
    with zipfile.ZipFile(wheel) as archive:
        return {n: archive.read(n) for n in archive.namelist()
                if n.endswith((".so", ".pyd", ".dll")) or ".so." in n}


def glibc_from_tag(wheel: Path) -> tuple[int, int] | None:
    """The glibc version a manylinux wheel's file name promises, e.g. (2, 28)."""
    match = re.search(r"manylinux_(\d+)_(\d+)_", wheel.name)
    return (int(match.group(1)), int(match.group(2))) if match else None


def problems(wheel: Path) -> list[str]:
    """Why ``wheel`` would not load on every system its tag admits (empty when it would)."""
    found = []
    modules = wheel_modules(wheel)
    if not modules:
        return [f"{wheel.name}: no native module"]
    glibc = glibc_from_tag(wheel)
    for name, data in modules.items():
        if data[:4] == b"\x7fELF":
            needs = elf_needs(name, data)
            if glibc is None:
                found.append(f"{name}: an ELF module in a wheel without a manylinux tag")
                continue
            bundled = {Path(n).name for n in modules}
            for library in needs.libraries:
                if library not in LINUX_SYSTEM_LIBRARIES and library not in bundled:
                    found.append(f"{name}: links {library}, which is neither bundled nor a "
                                 "manylinux system library")
            highest = needs.max_version("GLIBC")
            if highest is not None and highest > glibc:
                found.append(f"{name}: needs GLIBC_{'.'.join(map(str, highest))}, above the "
                             f"tag's glibc {glibc[0]}.{glibc[1]}")
            # manylinux_2_28 (RHEL 8's GCC 8) ships libstdc++ up to GLIBCXX_3.4.25.
            cxx = needs.max_version("GLIBCXX")
            if cxx is not None and glibc <= (2, 28) and cxx > (3, 4, 25):
                found.append(f"{name}: needs GLIBCXX_{'.'.join(map(str, cxx))}, above what "
                             "glibc 2.28 systems ship (3.4.25)")
        elif data[:2] == b"MZ":
            for dll in pe_imports(data):
                if not WINDOWS_SYSTEM_DLL.match(dll) and Path(dll).name not in modules:
                    found.append(f"{name}: imports {dll}, which is neither bundled nor part "
                                 "of Windows or Python")
        else:
            found.append(f"{name}: neither ELF nor PE")
    return found


def describe(wheel: Path) -> str:
    """A short report of each native module's needs."""
    lines = [wheel.name]
    for name, data in wheel_modules(wheel).items():
        if data[:4] == b"\x7fELF":
            needs = elf_needs(name, data)
            lines.append(f"  {name}: links {', '.join(needs.libraries)}")
            for library, versions in sorted(needs.versions.items()):
                top = sorted(versions, key=lambda v: _version_tuple(re.sub(r"^[A-Z_]+_", "", v))
                             if re.search(r"_[\d.]+$", v) else (0,))
                lines.append(f"    {library}: {len(versions)} versions, highest {top[-1]}")
        elif data[:2] == b"MZ":
            lines.append(f"  {name}: imports {', '.join(pe_imports(data))}")
    return "\n".join(lines)


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("wheels", nargs="+", type=Path)
    args = parser.parse_args()
    status = 0
    for wheel in args.wheels:
        print(describe(wheel))
        for problem in problems(wheel):
            print(f"  PROBLEM {problem}")
            status = 1
    return status


if __name__ == "__main__":
    sys.exit(main())
