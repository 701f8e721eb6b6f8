"""The one exception type the add-on raises for problems a user can fix.

The operator reports ``str(error)`` through ``self.report({'ERROR'}, ...)`` and the batch
script maps ``IllumapError.exit_code`` to its process exit status.
"""

from __future__ import annotations


class IllumapError(Exception):
    """A user-facing error: the message says what is wrong and, where possible, how to fix it.

    ``exit_code`` follows the batch conventions: 3 = bad scene or input, 4 = solver failure.
    """

    exit_code = 3

    def __init__(self, message: str, exit_code: int | None = None) -> None:
        super().__init__(message)
        if exit_code is not None:
            self.exit_code = exit_code


class IllumapCancelled(IllumapError):
    """The run was cancelled by the user (Esc, or a progress callback returning False)."""

    exit_code = 130
