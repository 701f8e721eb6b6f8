"""The code keeps a shape a reader can hold: no Python file in addon/ or core/python/illumap over
600 lines, and no function (or method) there over 120 lines, read with ``ast``; no C++ source
or header under core/src over 600 lines either.

A function's length is the lines from its ``def`` to its last line, docstring and nested
functions included. Failures name file:line and the size, so the offender is found at once.
"""

from __future__ import annotations

import ast
import os

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
FOLDERS = ("addon", os.path.join("core", "python", "illumap"))
MAX_FILE_LINES = 600
MAX_FUNCTION_LINES = 120

#: Known offenders, each at most its size when listed, so that none grows while it waits (a
#: stale entry fails below). Empty: every file and function is within the limits.
ALLOWED_FILES: dict[str, int] = {}
ALLOWED_FUNCTIONS: dict[tuple[str, str], int] = {}


def python_files() -> list[str]:
    """Every .py file under FOLDERS, relative to the repository root with '/' separators."""
    out = []
    for folder in FOLDERS:
        for base, dirs, files in os.walk(os.path.join(ROOT, folder)):
            dirs[:] = sorted(d for d in dirs if d != "__pycache__")
            out += [os.path.relpath(os.path.join(base, f), ROOT).replace(os.sep, "/")
                    for f in sorted(files) if f.endswith(".py")]
    return out


def native_files() -> list[str]:
    """Every .cpp/.hpp file under core/src, relative to the repository root with '/' separators."""
    out = []
    for base, dirs, files in os.walk(os.path.join(ROOT, "core", "src")):
        dirs.sort()
        out += [os.path.relpath(os.path.join(base, f), ROOT).replace(os.sep, "/")
                for f in sorted(files) if f.endswith((".cpp", ".hpp"))]
    return out


def file_lines(text: str) -> int:
    """Lines of a file as an editor counts them."""
    return len(text.splitlines())


def long_functions(text: str, path: str, limit: int) -> list[tuple[str, int, int]]:
    """(name, line, length) of every function or method of ``text`` longer than ``limit``."""
    found = []
    for node in ast.walk(ast.parse(text, path)):
        if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
            length = node.end_lineno - node.lineno + 1
            if length > limit:
                found.append((node.name, node.lineno, length))
    return found


def offences(limit_file: int = MAX_FILE_LINES, limit_function: int = MAX_FUNCTION_LINES,
             files: dict[str, str] | None = None) -> list[str]:
    """'file:line …' for every file and function past its limit that the allow-lists do not
    cover (or that outgrew its allowed size). ``files`` (path → text) replaces the tree."""
    if files is None:
        files = {}
        for path in python_files():
            with open(os.path.join(ROOT, path), encoding="utf-8") as f:
                files[path] = f.read()
    out = []
    for path, text in files.items():
        lines = file_lines(text)
        if lines > limit_file and lines > ALLOWED_FILES.get(path, 0):
            out.append(f"{path}:1 has {lines} lines (limit {limit_file})")
        for name, line, length in long_functions(text, path, limit_function):
            if length > ALLOWED_FUNCTIONS.get((path, name), 0):
                out.append(f"{path}:{line} {name}() has {length} lines (limit {limit_function})")
    return out


def test_no_file_or_function_past_its_limit():
    found = offences()
    assert not found, "past the size limits:\n" + "\n".join(found)


def test_no_native_file_past_its_limit():
    """One concept per file holds for the native core too (a merge once left gather.cpp at 611)."""
    long_files = []
    for path in native_files():
        with open(os.path.join(ROOT, path), encoding="utf-8") as f:
            lines = file_lines(f.read())
        if lines > MAX_FILE_LINES:
            long_files.append(f"{path}:1 has {lines} lines (limit {MAX_FILE_LINES})")
    assert native_files(), "no native sources found under core/src"
    assert not long_files, "past the size limits:\n" + "\n".join(long_files)


def test_allow_list_names_only_current_offenders():
    """An allowed offender that was fixed leaves the list, so the list cannot hide a new one."""
    texts = {}
    for path in {*ALLOWED_FILES, *(p for p, _ in ALLOWED_FUNCTIONS)}:
        full = os.path.join(ROOT, path)
        texts[path] = open(full, encoding="utf-8").read() if os.path.exists(full) else ""
    stale = [path for path in ALLOWED_FILES if file_lines(texts[path]) <= MAX_FILE_LINES]
    for path, name in ALLOWED_FUNCTIONS:
        if not any(n == name for n, _, _ in long_functions(texts[path], path,
                                                           MAX_FUNCTION_LINES)):
            stale.append(f"{path} {name}()")
    assert not stale, f"no longer past the limits, remove from the allow-list: {stale}"


def test_the_check_sees_a_long_file_and_a_long_function():
    """The check itself: a new 601-line file and a 121-line function are both reported, with
    their file:line."""
    body = "\n".join(f"    x{i} = {i}" for i in range(119))
    function = f"def long():\n    '''doc'''\n{body}\n"          # 121 lines
    text = function + "\n" * (601 - file_lines(function))
    found = offences(files={"addon/new_module.py": text})
    assert found == ["addon/new_module.py:1 has 601 lines (limit 600)",
                     "addon/new_module.py:1 long() has 121 lines (limit 120)"]
    assert offences(files={"addon/new_module.py": function[:function.rindex("    x118")]}) == []


def test_test_files_have_unique_names():
    """pytest imports test files by their base name (tests/ has no packages): two files of one
    name in different folders stop the whole suite at collection, though each runs alone."""
    seen: dict[str, str] = {}
    clashes = []
    for base, dirs, files in os.walk(os.path.join(ROOT, "tests")):
        dirs[:] = sorted(d for d in dirs if d != "__pycache__")
        for name in sorted(files):
            if name.startswith("test_") and name.endswith(".py"):
                path = os.path.relpath(os.path.join(base, name), ROOT)
                if name in seen:
                    clashes.append(f"{seen[name]} and {path}")
                seen.setdefault(name, path)
    assert not clashes, "test files that share a name:\n" + "\n".join(clashes)
