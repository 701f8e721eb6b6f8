"""Where a result file comes from and how it is written: the commit, the native module's
build time, the UTC time, JSON (shared by every script that writes ``bench/results/``)."""

from __future__ import annotations

import os

#: The repository root (bench/scenes/ is two levels below it).
ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))


def provenance() -> dict:
    """Where the results come from: the repository's HEAD commit (short hash and subject), the
    last commit that changed core/src, whether core/src has uncommitted changes, and the native
    module's file time (UTC)."""
    import subprocess
    import time as _time
    from illumap import _core
    root = ROOT

    def git(*args):
        try:
            return subprocess.run(["git", "-C", root, *args], capture_output=True, text=True,
                                  timeout=20).stdout.strip()
        except (OSError, subprocess.SubprocessError):
            return ""
    path = getattr(_core, "__file__", "") or ""
    built = (_time.strftime("%Y-%m-%d %H:%M UTC", _time.gmtime(os.path.getmtime(path)))
             if path and os.path.exists(path) else None)
    return dict(commit=git("rev-parse", "--short", "HEAD"),
                subject=git("log", "-1", "--format=%s"),
                core_src_commit=git("log", "-1", "--format=%h", "--", "core/src"),
                core_src_modified=bool(git("status", "--porcelain", "--", "core/src")),
                core_module_built=built)


def utc_now() -> str:
    """The current time as the results files record it ("YYYY-MM-DD HH:MM UTC")."""
    import time as _time
    return _time.strftime("%Y-%m-%d %H:%M UTC", _time.gmtime())


def write_json(path: str, doc: dict, quiet: bool = False) -> None:
    """Write a results document to ``path`` (its folder made if needed; numpy scalars as
    floats) and, unless ``quiet``, say so."""
    import json
    os.makedirs(os.path.dirname(os.path.abspath(path)), exist_ok=True)
    with open(path, "w") as f:
        json.dump(doc, f, indent=1, default=float)
    if not quiet:
        print(f"wrote {path}")
