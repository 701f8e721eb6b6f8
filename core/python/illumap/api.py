"""The public ``illumap.solve``: a plain solve (``illumap.solver``) with the keywords given, or,
with ``target_error``, the automatic mode (``illumap.accuracy``), which chooses them.

It sits above both, so the solver never imports the automatic mode that calls it.
"""

from __future__ import annotations

from . import accuracy, solver
from .solver import Solution
from .surfels import InputError, Surfels

#: Keywords of a plain solve that the automatic mode chooses itself and so does not take.
_CHOSEN_BY_TARGET = ("tol", "restart", "error_tol")


def solve(surfels: Surfels, *, target_error: float | str | None = None, **keywords) -> Solution:
    """Solve ``B = E + ρ∘K(B)`` for the radiosity B of every surfel.

    Without ``target_error``: :func:`illumap.solver.solve` with ``keywords`` (method, solver,
    tol, error_tol, max_iterations, progress, operator, restart and the operator keywords; see
    there).

    target_error : float or preset name, optional
        Relative RMS error wanted per surfel (e.g. 0.03). Illumap then chooses the method, FMM
        order, θ, leaf size, visibility and tolerance itself
        (:func:`illumap.accuracy.choose_settings`) and reports them with an a-posteriori error
        estimate in ``stats["accuracy"]``; ``method``, ``solver`` (other than "auto"),
        ``max_iterations`` and operator keywords given explicitly override the chosen ones
        (``tol``, ``restart`` and ``error_tol`` are chosen, not taken); ``operator=`` is
        refused. Surfel density is the caller's: see
        ``stats["accuracy"]["settings"]["density"]`` for the density the target needs.
    """
    if target_error is None:
        return solver.solve(surfels, **keywords)
    if keywords.pop("operator", None) is not None:
        raise InputError("solve: target_error chooses the operator; do not pass operator=")
    progress = keywords.pop("progress", None)
    for key in _CHOSEN_BY_TARGET:
        keywords.pop(key, None)
    if keywords.get("solver", "auto") == "auto":
        keywords.pop("solver", None)
    if keywords.get("max_iterations", 0) is None:
        keywords.pop("max_iterations")
    return accuracy.solve(surfels, target_error, progress=progress, **keywords)
