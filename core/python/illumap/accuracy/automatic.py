"""The automatic mode in one call: choose settings for a target error, solve, estimate."""

from __future__ import annotations

from ..solver import solve as _solve
from ..surfels import Surfels
from .choice import choose_settings, solve_keywords
from .estimate import estimate_error


def solve(surfels: Surfels, target_error, *, kind: str | None = None, allow_direct: bool = True,
          estimate: bool = True, coarse: bool = False, settings: dict | None = None,
          discretization_scale: float = 1.0, probe="auto", progress=None, scored=None,
          **overrides):
    """Choose settings for ``target_error`` (or use ``settings``, a :func:`choose_settings`
    result) and solve ``surfels``; ``stats["accuracy"]`` holds the chosen settings, the solve
    keywords and (``estimate=True``) the a-posteriori estimate. ``discretization_scale``: as
    in :func:`choose_settings` (ADAPTIVE_ERROR_RATIO for the second pass of an adaptive
    sampling). ``probe``: as in :func:`choose_settings` (False: never ``visibility="none"``).
    ``scored``: the surfels whose error the estimate scores (:func:`estimate_error`).
    ``overrides`` replace chosen solve keywords (e.g. ``solver="jacobi"``)."""
    chosen = settings if settings is not None else choose_settings(
        surfels, target_error, kind=kind, allow_direct=allow_direct,
        discretization_scale=discretization_scale, probe=probe)
    kw = solve_keywords(chosen)
    kw.update(overrides)
    sol = _solve(surfels, progress=progress, keep_operator=estimate, **kw)
    info = dict(settings=chosen, solve_keywords=kw)
    if estimate:
        # The FMM part against the operator the solve applied (its occluders included), not a
        # second one built for the purpose (at 48k surfels with exact visibility that took
        # three times the solve), and with what the solve already applied it to.
        info["estimate"] = estimate_error(sol, surfels, settings=chosen, coarse=coarse,
                                          kind=kind, operator=sol.operator, scored=scored)
    sol.operator = sol.products = None
    sol.stats["accuracy"] = info
    return sol
