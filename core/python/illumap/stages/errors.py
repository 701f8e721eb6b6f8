"""Why a run stops (no bpy): ``RunError`` says what is wrong and whether the input or the
solve is at fault (``kind``); ``NoLight`` is a scene whose light reaches no surface. A
cancelled run raises the core's ``illumap.Cancelled``."""

from __future__ import annotations


class RunError(Exception):
    """A run that cannot give a result: ``kind`` is "input" (a bad scene) or "solver" (the
    solve or the light evaluation failed)."""

    def __init__(self, message: str, kind: str = "input") -> None:
        super().__init__(message)
        self.kind = kind


class NoLight(RunError):
    """The scene has no light that reaches the surfaces: the solve is skipped (its result
    would be black)."""
