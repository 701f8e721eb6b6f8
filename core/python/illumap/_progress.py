"""Progress reporting and cancellation shared by the operator and the solvers.

A user's ``progress(fraction, phase)`` may return False or raise to cancel. Either way the
caller sees :class:`Cancelled` (chained ``from`` the callback's exception when it raised);
``KeyboardInterrupt`` and other non-``Exception`` errors propagate unchanged. Results are only
returned on success, so a cancelled computation leaves nothing half-written.
"""

from __future__ import annotations

try:
    from ._core import Cancelled  # the native module raises this one
except ImportError:  # pragma: no cover - native module not built
    class Cancelled(Exception):
        """The computation was cancelled through its progress callback."""

__all__ = ["Cancelled", "ProgressGuard"]


class ProgressGuard:
    """Wraps a user progress callable.

    ``fraction_range`` maps the reporter's own 0..1 onto a sub-range of the user's 0..1;
    ``phase`` (when given) replaces the reporter's phase names. Fractions reach the user
    clipped to [0, 1] and never decreasing.
    """

    def __init__(self, callback, *, phase=None, fraction_range=(0.0, 1.0),
                 start=0.0):
        self.callback = callback
        self.phase = phase
        self.low, self.high = fraction_range
        self.last = float(start)
        self.error = None        # the exception the callback raised, if any
        self.cancelled = False   # the callback returned False or raised

    # -- reporting -----------------------------------------------------------------------------
    def _emit(self, fraction, phase):
        """Call the user; record a cancellation instead of raising."""
        if self.callback is None or self.cancelled:
            return not self.cancelled
        try:
            f = float(fraction)
        except (TypeError, ValueError):
            f = 0.0
        f = min(max(f, 0.0), 1.0) if f == f else 0.0
        f = self.low + (self.high - self.low) * f
        f = min(max(f, self.last), 1.0)
        self.last = f
        try:
            answer = self.callback(f, self.phase if self.phase is not None else phase)
        except Exception as exc:  # noqa: BLE001 - any error of the callback cancels
            self.error = exc
            self.cancelled = True
            return False
        if answer is False:
            self.cancelled = True
            return False
        return True

    def native_callback(self):
        """A callable for native code (returns False to cancel), or None without a callback."""
        if self.callback is None:
            return None

        def report(fraction, phase):
            return self._emit(fraction, phase)

        return report

    def check(self, fraction, phase=None):
        """Report from Python code; raise Cancelled if the user cancels."""
        if not self._emit(fraction, phase):
            self._raise()

    def _raise(self):
        if self.error is not None:
            raise Cancelled(f"cancelled: the progress callback raised {self.error!r}") \
                from self.error
        raise Cancelled("cancelled: the progress callback returned False")

    # -- context: turn the native outcome into one exception ----------------------------------
    def __enter__(self):
        return self

    def __exit__(self, exc_type, exc, tb):
        if self.cancelled:
            if exc_type is not None and not issubclass(exc_type, Exception):
                return False  # KeyboardInterrupt etc. go through
            self._raise()
        return False
