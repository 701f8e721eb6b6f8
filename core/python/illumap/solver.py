r"""Solvers for the radiosity system ``B = E + ρ∘K(B)``.

``K`` is the transport operator ``K(x)_i = Σ_j F_ij V_ij x_j`` (:class:`TransportOperator`),
``ρ`` the per-surfel, per-channel albedo and ``E`` the emission. Each colour channel is an
independent linear system ``(I − D K) b = e`` with ``D = diag(ρ[:, c])``; the three channels are
iterated together as an N×3 block (one operator application serves all three), but every scalar
of the iteration (step lengths, Givens rotations, convergence) is per channel.

Stopping rule (all solvers)
---------------------------
The relative residual in the ORIGINAL variables,

    rel_c = ‖E_c − (B_c − ρ_c ∘ K B_c)‖₂ / ‖E_c‖₂          (per channel c)

must satisfy ``max_c rel_c ≤ tol``. Channels with ``E_c = 0`` have the exact solution ``B_c = 0``
and count as converged. With ``error_tol`` the solve also stops, earlier, once what it leaves
undone is within that share of the result. An iterate's error is ``(I − ρK)⁻¹ r``, which the
Neumann series bounds by ``‖r‖ / (1 − ρ_max)`` (in the max norm, K's row sums being ≤ 1:
``stats["solver_error_bound"]``); the residual of an iterate, though, is spread like the light
it still misses, which the scene amplifies as it does its own light, by the bounce gain
``‖B − E‖ / ‖ρ∘K(E)‖`` (within [1, 1/(1 − ρ_max)]; ``K(E)`` is CG's and GMRES's first
application). ``error_tol`` tests that estimate, gain × ‖r‖ / ‖B‖, RMS over the non-emitting
surfels (``stats["solver_error_estimate"]``). Jacobi's residual is the next bounce, which the
rest of the series amplifies as the least damped mode, so its estimate is the bound.

Closing step: every solver returns ``B + r = E + ρ∘K(B)`` for its last iterate B, the Jacobi
step that the residual r already holds (no application). Its error is ρ∘K of B's, at most
ρ_max times it; on the bunny after two CG steps 0.58% against 1.58%. The reported residual,
bound and estimate are those of B, so they hold for the result with room to spare: on the
benchmark scenes and the Cornell box at albedo 0.95 (1 to 6 CG steps, errors ≥ 5e-4;
``bench/micro/solver_estimate.py``) the result kept 0.13–0.86 of the estimate and 0.03–0.24 of the
bound. The estimate can be low while it is large: the first two or three iterates of a closed
box lit by four surfels kept up to 1.54 times it, above 3% (tests/core/test_solver.py).

Iterations monitor the residual their recurrence gives. CG's recurrence residual is the true
one up to rounding (``r = b − (I − M) z`` holds for any linear operator), so CG recomputes it
from one more application only when it stops below ``iterations.CONFIRM_BELOW``, where the
two could have drifted apart; Jacobi and GMRES compute it from K(B). It is reported in
``Solution.stats["final_residual"]`` and used for ``Solution.converged``; the result's own
residual, ``ρ∘K(r)`` after the closing step, is smaller. ``E = 0`` everywhere returns zeros at
once, without building an operator.

Solvers
-------
``"jacobi"``
    The talk's "iterate till convergence": ``B ← E + ρ∘K(B)``, starting from ``B = E``. Converges
    when the spectral radius of ``D K`` is below 1; at ρ → 1 it needs ~log(tol)/log(ρ) steps.
    Divergence (a non-finite or steadily growing residual) stops it with ``converged=False`` and
    a warning in ``stats["warning"]``; no exception, the caller decides.

``"cg"``
    Conjugate gradients on a symmetric positive-definite form. Reciprocity ``A_i K_ij = A_j K_ji``
    makes ``W K`` symmetric (``W = diag(A)``). Substitute ``B = E + D^{1/2} y``::

        D^{1/2} y = D K E + D K D^{1/2} y
        ⇒ (I − D^{1/2} K D^{1/2}) y = D^{1/2} K E        (rows with ρ = 0 give y = 0 exactly)

    and ``y = W^{-1/2} z``, multiplying by ``W^{1/2}``::

        (I − M) z = W^{1/2} D^{1/2} K E,    M = D^{1/2} S D^{1/2},   S = W^{1/2} K W^{-1/2}.

    ``S = W^{-1/2} (W K) W^{-1/2}`` is symmetric, hence so is ``M``. ``S`` is similar to ``K``, so
    ``‖S‖₂ = ρ(K) ≤ max row sum of K ≤ 1`` (K ≥ 0), and ``‖M‖₂ ≤ max ρ · ρ(K) < 1`` when every
    albedo is below 1: ``I − M`` is symmetric positive definite (it suffices that
    ``max ρ · ρ(K) < 1``, weaker than row sums ≤ 1). It is the textbook symmetrized matrix
    ``diag(A/ρ) − diag(A) K`` scaled on both sides by ``P = diag(ρ/A)^{1/2}``, but no ``1/ρ``
    appears, so black (ρ = 0) surfels and channels are safe. The CG residual maps back exactly:
    ``r_orig = D^{1/2} W^{-1/2} r_z``, so the stopping rule above is monitored at no extra cost.
    If ``pᵀ(I − M)p ≤ 0`` the matrix is not SPD (row sums of K well above 1, e.g. the bare point
    near field in a closed box): CG stops with ``converged=False`` and a warning.

``"gmres"``
    Restarted GMRES(``restart``, default 30) on ``(I − D K) B = E`` from ``B = E``; needs no
    symmetry (for visibility that is not reciprocal). Modified Gram–Schmidt, Givens rotations.

``"auto"``
    CG when ``operator.symmetric`` (diag(A)·F·V symmetric), GMRES otherwise.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field

import numpy as np

from ._progress import Cancelled, ProgressGuard  # noqa: F401 (Cancelled: documented here)
from .limits import limit as _limit
from .operator import DEFAULT_METHOD, OPERATOR_KEYWORDS, TransportOperator, validate_keywords
from .iterations import _cg, _gmres, _jacobi, _Monitor, _norms
from .surfels import InputError, Surfels

__all__ = ["solve", "Solution", "SOLVERS", "DEFAULT_TOL", "DEFAULT_MAX_ITERATIONS",
           "DEFAULT_RESTART"]

SOLVERS = ("auto", "cg", "gmres", "jacobi")
DEFAULT_TOL = 1e-6
#: Per solver when ``max_iterations`` is None (operator applications, roughly).
DEFAULT_MAX_ITERATIONS = {"jacobi": 10000, "cg": 1000, "gmres": 1000}
DEFAULT_RESTART = 30
#: Fraction of the progress bar given to building the operator when ``solve`` builds it.
BUILD_FRACTION = 0.1
#: The error bound's 1/(1 − ρ_max) is taken with ρ_max at most this (albedo 1 has no bound).
MAX_BOUND_ALBEDO = 0.995


@dataclass
class Solution:
    """Result of :func:`solve`.

    radiosity : (N, 3) outgoing radiance B.
    iterations : iterations performed (Jacobi sweeps, CG steps, GMRES inner steps).
    residuals : max-over-channels relative residual per iteration; ``residuals[0]`` is the
        initial one (at B = E), so ``len(residuals) == iterations + 1`` (recurrence values;
        GMRES restarts and CG refreshes use the true residual).
    converged : True when the last iterate's relative residual is ≤ tol (or, with
        ``error_tol``, the solver's error estimate is within it); the radiosity is that
        iterate after the closing step (module docstring), whose residual is smaller
    timings : seconds per phase: "build" (0 with a prebuilt operator), "solve", "total".
    stats : operator stats plus "solver", "tol", "final_residual" (the last iterate's, max
        over channels; the result's own is smaller),
        "final_residuals" (per channel), "solver_error_bound" (RMS(r) / ((1 − ρ_max) RMS(B))
        over the non-emitting surfels: what the solver's stopping point adds to the error, at
        most), "solver_error_estimate" (the bounce gain instead of 1/(1 − ρ_max): what
        ``error_tol`` tests), "error_tol", "operator_applications" and, when something went
        wrong, "warning".
    """

    radiosity: np.ndarray
    iterations: int
    residuals: np.ndarray
    converged: bool
    timings: dict = field(default_factory=dict)
    stats: dict = field(default_factory=dict)
    #: The operator the solve applied, with ``keep_operator=True`` (else None): to estimate
    #: its error afterwards without building it again.
    operator: object = field(default=None, repr=False, compare=False)
    #: With ``keep_operator=True``, what the solve already applied it to, (N, 3) each, so that
    #: the estimate need not apply it again: "first_bounce" ρ∘K(E), "iterate" the last iterate
    #: B (before the closing step) and "rho_k_iterate" ρ∘K(B) (= r + B − E); else None.
    products: dict | None = field(default=None, repr=False, compare=False)

    @property
    def residual(self) -> float:
        """The last iterate's true relative residual (max over channels; the radiosity's own,
        after the closing step, is smaller)."""
        return float(self.stats.get("final_residual", np.nan))

    @property
    def solver(self) -> str:
        return self.stats.get("solver", "")


# ------------------------------------------------------------------------------------------------
# helpers


# ------------------------------------------------------------------------------------------------
def _make_apply(op, guard, monitor_ref):
    """K(x) for N×3 float64 x, with cancellation inside long native applications."""
    if isinstance(op, TransportOperator):

        def keep_alive(fraction, phase):  # native progress while one apply runs
            monitor = monitor_ref[0]
            return guard._emit(monitor.fraction if monitor else 0.0, "solve")

        callback = keep_alive if guard.callback is not None else None

        def apply(x):
            if monitor_ref[0] is not None:
                monitor_ref[0].applications += 1
            if not np.all(np.isfinite(x)):     # never hand NaN/inf to native code
                raise FloatingPointError("solver iterate became non-finite")
            return op.apply_native(np.ascontiguousarray(x, dtype=np.float64), callback)
    else:
        def apply(x):
            if monitor_ref[0] is not None:
                monitor_ref[0].applications += 1
            y = np.asarray(op.apply(np.ascontiguousarray(x, dtype=np.float64)), dtype=np.float64)
            if y.shape != x.shape:
                raise InputError(f"operator.apply returned shape {y.shape}, expected {x.shape}")
            return y
    return apply


def row_sum_cause(operator) -> str:
    """Why the operator's rows may sum above 1, and the setting that would change it, for
    the solvers' warnings: only what differs from the settings ``operator`` was built with
    (its ``near_field``, ``visibility`` and ``balance``, where it has them), as text that
    starts with ": "."""
    near_field = getattr(operator, "near_field", None)
    if near_field == "point":
        return (": the bare point kernel near_field='point' overshoots for close pairs; "
                "near_field='disc' bounds them")
    visibility = getattr(operator, "visibility", None)
    if visibility == "none":
        return (": without visibility every surfel sees through the others, so surfaces "
                "behind each other add up; visibility='exact' hides them")
    if hasattr(operator, "balance") and getattr(operator, "balance") is None:
        return (": surfaces that overlap, touch or cross each other see more than their "
                "hemisphere; hemisphere_hits (illumap.conservation.hemisphere_hits) bounds "
                "every row by the share of it that is lit")
    return (": surfaces that overlap, touch or cross each other (coincident faces, "
            "interpenetrating or very thin parts) see more than their hemisphere; separate "
            "them, or sample them more densely")


# the three solvers; each returns (B, true residual N×3, warning or None)


# ------------------------------------------------------------------------------------------------

_UNSET = object()


def solve(surfels: Surfels, *, method=_UNSET, solver: str = "auto", tol: float = DEFAULT_TOL,
          max_iterations=None, progress=None, operator=None, restart: int = DEFAULT_RESTART,
          error_tol: float | None = None, keep_operator: bool = False,
          **operator_keywords) -> Solution:
    """Solve ``B = E + ρ∘K(B)`` for the radiosity B of every surfel.

    Parameters
    ----------
    surfels : Surfels
    method, order, theta, leaf_size, near_field, visibility, threads
        Passed on to :class:`TransportOperator` (defaults there), as are the visibility
        keywords (visibility_leaf_mode, visibility_samples, coverage, visibility_shape,
        endpoint_offset, seed_delta, seed_k, seed_t1, seed_t2, seed_t3, seed_leaf_points,
        seed_binary_pairs; meanings and units in TransportOperator's docstring).
    solver : "auto" | "cg" | "gmres" | "jacobi"
        See the module docstring. "auto" = CG when the operator is symmetric, else GMRES.
    tol : float
        Stop when ``max_c ‖E_c − (B_c − ρ_c∘K B_c)‖₂ / ‖E_c‖₂ ≤ tol`` (relative residual in the
        original variables, per channel, max over channels).
    error_tol : float, optional
        Also stop, even above ``tol``, once the solver's own error estimate relative to the
        radiosity is at most this: ``g · RMS(r) / RMS(B)`` over the non-emitting surfels (r
        the residual of B, g the bounce gain ``RMS(B − E) / RMS(ρ∘K(E))`` within
        [1, 1/(1 − ρ_max)]; dimensionless, e.g. 0.01 for 1%; see the module docstring). The
        residual is relative to the emission, which a small bright light dominates, so a fixed
        ``tol`` over-solves scenes lit that way; this asks for what the result's error needs.
        CG and Jacobi test it every iteration, GMRES at its restarts. Reported as
        ``stats["solver_error_estimate"]``, next to the bound with 1/(1 − ρ_max) in place of g
        (``stats["solver_error_bound"]``).
    max_iterations : int, optional
        Defaults per solver: :data:`DEFAULT_MAX_ITERATIONS`.
    progress : callable(fraction, phase) -> bool | None
        Fractions in [0, 1], non-decreasing; phases "build" and "solve". Returning False or
        raising cancels with :class:`Cancelled`; nothing is returned or written then.
    operator : TransportOperator, optional
        A prebuilt operator over the same geometry (positions, normals, areas), reused across
        solves (e.g. for new albedo or emission). Operator keywords may not be given with it.
    restart : int
        GMRES restart length.
    keep_operator : bool
        Return the operator applied as ``Solution.operator`` (it holds its memory until
        dropped), e.g. to estimate the solution's error with it.

    Returns
    -------
    Solution
    """
    t_total = time.perf_counter()
    tol, max_iterations, error_tol = _checked(surfels, method, solver, tol, max_iterations,
                                              progress, operator, restart, error_tol,
                                              operator_keywords)

    guard = ProgressGuard(progress)
    E = surfels.emission
    rho = surfels.albedo
    n = surfels.n
    timings = {"build": 0.0, "solve": 0.0}
    stats = {"tol": tol, "n": n}

    with guard:
        if not np.any(E):
            guard.check(1.0, "solve")
            timings["total"] = time.perf_counter() - t_total
            stats.update(solver="none (E = 0)", final_residual=0.0, solver_error_bound=0.0,
                         solver_error_estimate=0.0, error_tol=error_tol,
                         final_residuals=[0.0, 0.0, 0.0], operator_applications=0)
            return Solution(np.zeros((n, 3)), 0, np.zeros(1), True, timings, stats)

        start_fraction = 0.0
        if operator is None:
            t = time.perf_counter()
            guard.check(0.0, "build")
            build_guard = ProgressGuard(progress, phase="build",
                                        fraction_range=(0.0, BUILD_FRACTION))
            with build_guard:
                operator = TransportOperator(surfels, progress=build_guard.native_callback(),
                                             **operator_keywords)
            timings["build"] = time.perf_counter() - t
            start_fraction = BUILD_FRACTION
            guard.last = max(guard.last, build_guard.last)
        guard.check(start_fraction, "solve")

        symmetric = bool(getattr(operator, "symmetric", False))
        chosen = solver
        if solver == "auto":
            chosen = "cg" if symmetric else "gmres"
        elif solver == "cg" and not symmetric:
            raise InputError("solver='cg' needs a symmetric operator (diag(A)·F·V symmetric, "
                             "i.e. reciprocal visibility); use solver='gmres' or 'auto'")
        limit = int(max_iterations) if max_iterations is not None \
            else DEFAULT_MAX_ITERATIONS[chosen]

        monitor_ref = [None]
        K = _make_apply(operator, guard, monitor_ref)
        non_emitting = ~(E.max(axis=1) > 0)
        if not non_emitting.any():
            non_emitting = np.ones(n, bool)
        amplification = 1.0 / (1.0 - min(float(rho.max()), MAX_BOUND_ALBEDO))
        mon = _Monitor(_norms(E), tol, limit, guard, start_fraction, error_tol=error_tol,
                       non_emitting=non_emitting, amplification=amplification, emission=E)
        mon.row_sum_cause = row_sum_cause(operator)
        monitor_ref[0] = mon

        t = time.perf_counter()
        if chosen == "jacobi":
            B, r, warning = _jacobi(K, E, rho, mon)
        elif chosen == "cg":
            B, r, warning = _cg(K, E, rho, surfels.areas, mon)
        else:
            B, r, warning = _gmres(K, E, rho, mon, int(restart))
        timings["solve"] = time.perf_counter() - t

        return _solution(B, r, warning, mon, operator, chosen, symmetric, limit, restart,
                         tol, error_tol, keep_operator, guard, timings, stats, t_total, E)


def _checked(surfels, method, solver, tol, max_iterations, progress, operator, restart,
             error_tol, operator_keywords: dict):
    """``solve``'s arguments checked (InputError or TypeError naming the argument); returns
    (tol, max_iterations, error_tol) as the limits take them. Sets the operator's method in
    ``operator_keywords`` when no prebuilt operator is given."""
    if not isinstance(surfels, Surfels):
        raise InputError(f"surfels: expected an illumap.Surfels, got {type(surfels).__name__}")
    unknown = set(operator_keywords) - set(OPERATOR_KEYWORDS)
    if unknown:
        raise TypeError(f"solve() got unexpected keyword(s) {sorted(unknown)}; operator "
                        f"keywords are {list(OPERATOR_KEYWORDS)}")
    if not isinstance(solver, str) or solver not in SOLVERS:
        raise InputError(f"solver: expected one of {list(SOLVERS)}, got {solver!r}")
    tol = _limit("tol").check(tol, InputError)
    if max_iterations is not None:
        max_iterations = _limit("max_iterations").check(max_iterations, InputError)
    if error_tol is not None:
        error_tol = _limit("error_tol").check(error_tol, InputError)
    _limit("restart").check(restart, InputError)
    if progress is not None and not callable(progress):
        raise InputError(f"progress: expected a callable or None, got {progress!r}")
    if operator is not None:
        given = sorted(operator_keywords) + ([] if method is _UNSET else ["method"])
        if given:
            raise InputError(f"operator keywords {given} cannot be combined with operator=; "
                             "the prebuilt operator already fixes them")
        if not hasattr(operator, "apply"):
            raise InputError(f"operator: expected a TransportOperator, got {operator!r}")
        op_surfels = getattr(operator, "surfels", None)
        if isinstance(op_surfels, Surfels):
            if not op_surfels.same_geometry(surfels):
                raise InputError("operator: it was built for other surfel geometry "
                                 "(positions, normals or areas differ)")
        elif getattr(operator, "n", surfels.n) != surfels.n:
            raise InputError(f"operator: built for N = {operator.n}, surfels have N = "
                             f"{surfels.n}")
    else:
        operator_keywords["method"] = DEFAULT_METHOD if method is _UNSET else method
        validate_keywords(**operator_keywords)
    return tol, max_iterations, error_tol


def _solution(B, r, warning, mon, operator, chosen, symmetric, limit, restart, tol, error_tol,
              keep_operator, guard, timings, stats, t_total, E) -> "Solution":
    """The solver's iterate made the result: the closing Jacobi step, convergence, the
    statistics and timings."""
    # The solvers return the residual of B (Jacobi and GMRES compute it from K(B); CG
    # maps its recurrence's back, and recomputes it only near rounding: CONFIRM_BELOW).
    final = mon.relative(_norms(r))
    final_value = float(np.max(final))
    bound = mon.error_bound(B, r)
    estimate = mon.error_estimate(B, r)
    # Closing step: B + r = E + ρ∘K(B) is one more Jacobi step, which the residual already
    # holds (no application). Its error is ρ∘K of B's, at most ρ_max times it (K's row
    # sums ≤ 1), so the bound and estimate of B hold for it with room to spare.
    products = None
    if warning is None and np.all(np.isfinite(r)):
        if keep_operator:
            products = dict(first_bounce=mon.first_bounce_values, iterate=B,
                            rho_k_iterate=r + B - E)
        B = B + r
    B = np.where(mon.active[None, :], B, 0.0)
    reached = final_value <= tol or (error_tol is not None and estimate <= error_tol)
    converged = bool(np.isfinite(final_value) and reached and warning is None)
    if not converged and warning is None:
        warning = (f"{chosen} did not reach tol={tol:g}"
                   + ("" if error_tol is None else f" or error_tol={error_tol:g}")
                   + f" in {mon.iterations} iterations (relative residual "
                   f"{final_value:.3g})")
    try:
        op_stats = dict(operator.stats)
    except Exception:  # noqa: BLE001 - duck-typed operators may lack stats
        op_stats = {}
    stats = {**op_stats, **stats}
    stats.update(solver=chosen, symmetric=symmetric, final_residual=final_value,
                 final_residuals=final.tolist(), operator_applications=mon.applications,
                 max_iterations=limit, solver_error_bound=bound,
                 solver_error_estimate=estimate, error_tol=error_tol)
    if chosen == "gmres":
        stats["restart"] = int(restart)
    if warning is not None:
        stats["warning"] = warning
    guard.check(1.0, "solve")
    timings["total"] = time.perf_counter() - t_total
    return Solution(B, mon.iterations, np.asarray(mon.history), converged, timings, stats,
                    operator if keep_operator else None, products)
