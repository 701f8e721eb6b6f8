"""The one exception type the add-on raises for problems a user can fix, and the batch exit
codes (``ExitCode``, the one table of them).

The operator reports ``str(error)`` through ``self.report({'ERROR'}, ...)`` and the batch
script maps ``IllumapError.exit_code`` to its process exit status.
"""

from __future__ import annotations

import enum


class ExitCode(enum.IntEnum):
    """Process exit codes of the batch command (addon/batch.py, docs/user_guide.md).

    Every failure exits non-zero, so a render farm can trust a 0."""

    OK = 0            #: every requested frame computed and every output written
    INTERNAL = 1      #: an unexpected error (a bug): the traceback is printed
    USAGE = 2         #: bad command-line arguments (unknown option, bad value, frame range)
    INPUT = 3         #: bad scene or input (nothing to compute, bad geometry, no light, memory)
    SOLVER = 4        #: the solve or the light evaluation failed
    OUTPUT = 5        #: an output (--output, --render, --export-*) cannot be or was not written
    CANCELLED = 130   #: cancelled (Ctrl+C, or a progress callback that returned False)


#: (code, meaning) rows for help texts and docs, in ExitCode order.
EXIT_CODE_TABLE = (
    (ExitCode.OK, "success"),
    (ExitCode.INTERNAL, "unexpected error (a bug; traceback printed)"),
    (ExitCode.USAGE, "bad arguments"),
    (ExitCode.INPUT, "bad scene or input (incl. no light in the scene)"),
    (ExitCode.SOLVER, "solver failure"),
    (ExitCode.OUTPUT, "an output cannot be written (checked before the solve where possible)"),
    (ExitCode.CANCELLED, "cancelled"),
)


def exit_code_help() -> str:
    """The exit codes as one line, for ``--help``."""
    return "Exit codes: " + ", ".join(f"{int(code)} {text}" for code, text in EXIT_CODE_TABLE) + "."


class IllumapError(Exception):
    """A user-facing error: the message says what is wrong and, where possible, how to fix it.

    ``exit_code`` is an ``ExitCode``: INPUT (default) for a bad scene or input, SOLVER for a
    solver failure, USAGE for bad settings, OUTPUT for an output that cannot be written.
    """

    exit_code = ExitCode.INPUT

    def __init__(self, message: str, exit_code: int | None = None) -> None:
        super().__init__(message)
        if exit_code is not None:
            self.exit_code = ExitCode(exit_code)


class IllumapCancelled(IllumapError):
    """The run was cancelled by the user (Esc, or a progress callback returning False)."""

    exit_code = ExitCode.CANCELLED


class NoLightError(IllumapError):
    """The scene has no light that reaches the surfaces: the solve is skipped (its result
    would be black) and nothing is written. Reported as a warning in the UI."""

    exit_code = ExitCode.INPUT


class OutputError(IllumapError):
    """An output path cannot be written (batch ``--output``, ``--render``, ``--export-*``)."""

    exit_code = ExitCode.OUTPUT


def core_cancelled(exc: BaseException) -> bool:
    """Whether ``exc`` is the core's ``Cancelled`` (from a progress callable that returned
    False)."""
    try:
        import illumap
    except ImportError:
        return False
    return isinstance(exc, getattr(illumap, "Cancelled", ()))
