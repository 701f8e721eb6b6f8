"""The a-posteriori error estimate of a solution (:func:`estimate_error`): its solver part from
the final residual, its FMM part from one application against the exact per-pair sum on a
random subset of receivers, its discretization part from the calibrated model (or measured on
a spatially even half of the surfels)."""

from __future__ import annotations

import math
import time

import numpy as np

from ..operator import VISIBILITY_DEFAULTS, TransportOperator
from ..solver import MAX_BOUND_ALBEDO
from ..solver import solve as _solve
from ..surfels import Surfels
from . import calibration
from .calibration import EXACT_KEYWORDS, kind_table, visibility_keywords
from .inputs import scene_summary
from .models import discretization

#: The error a solve keeps over its estimate, at most, where the estimate is large: a closed
#: box lit by four surfels, the first two or three steps of CG or GMRES, whose iterates' bounce
#: gain is still growing (1.30-1.54; tests/core/test_solver.py). Below 3% the estimate held
#: everywhere measured. The a-posteriori estimate's solver part is the estimate times this,
#: at most the bound.
SOLVER_ESTIMATE_MARGIN = 1.6


def _rms(x) -> float:
    return float(math.sqrt(np.mean(np.square(x)))) if x.size else 0.0


def _morton_keys(points, bits=20):
    lo = points.min(axis=0)
    span = float((points.max(axis=0) - lo).max()) or 1.0
    q = np.minimum(((points - lo) / span * (2 ** bits - 1)).astype(np.uint64), 2 ** bits - 1)
    key = np.zeros(len(points), dtype=np.uint64)
    for b in range(bits):
        for axis in range(3):
            key |= ((q[:, axis] >> np.uint64(b)) & np.uint64(1)) << np.uint64(3 * b + axis)
    return key


def _even_half(surfels: Surfels):
    """Every other surfel along a Morton curve, per orientation class and emitter flag (so that
    each surface and each light keeps about half of its surfels): a spatially even half."""
    order = np.argsort(_morton_keys(surfels.positions), kind="stable")
    axis = np.argmax(np.abs(surfels.normals), axis=1)
    dominant = (axis * 2 + (surfels.normals[np.arange(surfels.n), axis] > 0)) * 2 + (
        surfels.emission.max(axis=1) > 0)
    keep, areas = [], []
    for g in np.unique(dominant):
        members = order[dominant[order] == g]
        kept = members[::2]
        keep.append(kept)   # each class keeps its total area (and each light its power)
        areas.append(surfels.areas[kept] * (surfels.areas[members].sum()
                                            / surfels.areas[kept].sum()))
    keep = np.concatenate(keep)
    areas = np.concatenate(areas)
    order = np.argsort(keep)
    return keep[order], areas[order]


_OPERATOR_STATS = ("method", "order", "theta", "leaf_size", "near_field", "visibility")


def _neumann_bound(surfels: Surfels) -> float:
    """1/(1 − ρ_max): how much any error can grow over the bounces (ρ_max at most
    MAX_BOUND_ALBEDO)."""
    return 1.0 / (1.0 - min(float(surfels.albedo.max()), MAX_BOUND_ALBEDO))


def bounce_gain(radiosity, surfels: Surfels, operator: TransportOperator | None,
                first_bounce: np.ndarray | None = None) -> float:
    """How much an error made in one bounce grows over all of them, as the scene's own light
    did: ‖B − E‖ / ‖ρ K E‖ (all indirect light over its first bounce, RMS over the surfels),
    within [1, 1/(1 − ρ_max)]. One application of ``operator``. The bound 1/(1 − ρ_max) holds
    for any error; this gain is that of an error spread like the light (measured 1.4 on the
    Cornell box against 3.6 for the bound). ``first_bounce``: ρ∘K(E) where the solve has it
    (``Solution.products``), else one application of ``operator``."""
    bound = _neumann_bound(surfels)
    if first_bounce is None:
        first_bounce = surfels.albedo * operator.apply(surfels.emission)
    first = _rms(first_bounce)
    if first <= 0.0:
        return bound
    indirect = _rms(np.asarray(radiosity) - surfels.emission)
    return float(min(max(indirect / first, 1.0), bound))


def estimate_error(solution, surfels: Surfels, *, operator: TransportOperator | None = None,
                   probe: int = 256, coarse: bool = False, settings: dict | None = None,
                   kind: str | None = None, seed: int = 0,
                   discretization_scale: float | None = None,
                   scored: np.ndarray | None = None) -> dict:
    """A-posteriori estimate of the relative RMS error (emitters excluded) of ``solution``.

    ``scored`` (N,) bool: the surfels whose error is estimated, relative to their own RMS
    radiosity (default: those that emit nothing). A caller that hands the solve light it
    computed itself as emission (direct lamp light at the surfels) scores the lit surfels too:
    relative to the dark ones alone, every part read several times what a receiver, which
    sees lit and dark surfels alike, is left with.

    * ``solver``: SOLVER_ESTIMATE_MARGIN × the solve's ``stats["solver_error_estimate"]``
      (the bounce gain times ‖r‖/‖B‖ for the final residual r = E − (B − ρ K B), RMS over the
      non-emitting surfels), at most its bound ``stats["solver_error_bound"]`` (1/(1 − ρ_max)
      in place of the gain); without them, the bound from ``final_residual``.
    * ``fmm``: the FMM applied to B against the exact per-pair sum (with the same visibility,
      applied per pair) on ``probe`` random receivers, times ρ, relative to B there, amplified
      by the scene's bounce gain (``gain``: all indirect light over its first bounce,
      ‖B − E‖ / ‖ρ K E‖, within [1, 1/(1 − ρ_max)]; an operator error spreads over the
      bounces as the light does, not as the worst case 1/(1 − ρ_max) bound): expansion error
      plus the visibility classification of node pairs. Zero for a direct solution.
    * ``occlusion``: for ``visibility="none"``, the probe's estimate from ``settings`` (the
      :func:`choose_settings` result), else 0.
    * ``discretization``: with ``coarse=True`` measured on a spatially even half of the surfels
      (e ≈ d/(√2 − 1)); otherwise the calibrated model of the scene kind at this N, times
      ``discretization_scale`` (the models are of uniform density: ADAPTIVE_ERROR_RATIO for an
      adaptive sampling; default: that of ``settings``, else 1), None when there is no
      calibration.
    ``total`` = sqrt of the sum of squares (independent sources); ``numerical`` = solver + fmm.
    """
    t0 = time.perf_counter()
    if discretization_scale is None:
        discretization_scale = (settings or {}).get("discretization_scale", 1.0)
    rng = np.random.default_rng(seed)
    B = np.asarray(solution.radiosity)
    stats = solution.stats
    non_emit = ~(surfels.emission.max(axis=1) > 0)
    if not non_emit.any():
        non_emit = np.ones(surfels.n, bool)
    e_solver = _solver_error(stats, surfels, B, non_emit)
    if scored is not None:
        scored = np.asarray(scored, dtype=bool).reshape(-1)
        if len(scored) != surfels.n:
            raise ValueError(f"scored must have {surfels.n} entries, got {len(scored)}")
        if scored.any():
            # The solve's own estimate is relative to its non-emitting surfels; the residual
            # is taken to be alike over the scored ones.
            e_solver *= _rms(B[non_emit]) / (_rms(B[scored]) or 1.0)
            non_emit = scored
    vis = stats.get("visibility", "none")
    vis_kw = _visibility_keywords_of(stats, settings, kind)
    e_fmm, gain, rows = 0.0, None, np.array([], dtype=np.int64)
    if stats.get("method", "direct") == "fmm":
        # What the solve applied its operator to stands for another application of the same.
        products = getattr(solution, "products", None) \
            if operator is None or operator is getattr(solution, "operator", None) else None
        e_fmm, gain, rows = _fmm_error(stats, surfels, B, non_emit, vis_kw, operator, probe, rng,
                                       products)
    e_occ = 0.0
    if vis == "none" and settings is not None and settings.get("predicted", {}).get("occlusion"):
        e_occ = float(settings["predicted"]["occlusion"])
    if coarse:
        e_disc, source = _coarse_discretization(stats, surfels, B, non_emit, vis_kw), "coarse"
    else:
        e_disc, source = _model_discretization(surfels, settings, kind, discretization_scale)
    total = math.sqrt(e_solver ** 2 + e_fmm ** 2 + e_occ ** 2 + (e_disc or 0.0) ** 2)
    return dict(solver=e_solver, fmm=e_fmm, occlusion=e_occ, discretization=e_disc,
                discretization_source=source, total=total, numerical=e_solver + e_fmm,
                gain=gain, probe_rows=int(rows.size), seconds=time.perf_counter() - t0)


def _solver_error(stats: dict, surfels: Surfels, B, non_emit) -> float:
    """The solver part: the solve's own estimate times SOLVER_ESTIMATE_MARGIN, at most its
    bound; without them, the bound from the final residual."""
    bound = stats.get("solver_error_bound")
    if bound is not None and math.isfinite(bound):   # the solve's own, over the same surfels
        e_solver = float(bound)
        if stats.get("solver_error_estimate") is not None:
            e_solver = min(e_solver, SOLVER_ESTIMATE_MARGIN * float(stats["solver_error_estimate"]))
        return e_solver
    b_rms = _rms(B[non_emit]) or 1.0
    e_norm = math.sqrt(float(np.sum(surfels.emission ** 2)))
    res = float(stats.get("final_residual", 0.0) or 0.0)
    return res * e_norm / math.sqrt(max(non_emit.sum(), 1)) * _neumann_bound(surfels) / b_rms


def _visibility_keywords_of(stats: dict, settings: dict | None, kind: str | None) -> dict:
    """The visibility keywords the solve used: its own (its stats), else the chosen ones,
    else the kind's."""
    vis = stats.get("visibility", "none")
    vis_kw = visibility_keywords(vis, kind if kind in EXACT_KEYWORDS else "random")
    if settings is not None:
        vis_kw = dict(settings.get("visibility_keywords", vis_kw))
    if vis != "none":
        vis_kw.update({k: stats[k] for k in VISIBILITY_DEFAULTS if k in stats})
    return vis_kw


def _fmm_error(stats: dict, surfels: Surfels, B, non_emit, vis_kw: dict, operator, probe: int,
               rng, products: dict | None = None) -> tuple:
    """(e_fmm, bounce gain, receiver rows): the FMM applied to B against the exact per-pair
    sum on ``probe`` random non-emitting receivers, times ρ, relative to B there, times the
    bounce gain. With the solve's ``products`` (``Solution.products``) the FMM's side is
    ρ∘K of its last iterate, which the solve applied already, and the first bounce its own."""
    kw = {k: stats[k] for k in _OPERATOR_STATS if k in stats}
    kw.pop("method", None)
    if stats.get("visibility", "none") != "none":
        kw.update(vis_kw)
    if operator is None:
        operator = TransportOperator(surfels, method="fmm", **kw)
    candidates = np.flatnonzero(non_emit)
    rows = np.sort(rng.choice(candidates, min(probe, len(candidates)), replace=False))
    if products is not None:   # the exact per-pair sums, with the same visibility
        exact_y = operator.apply_rows(products["iterate"], rows)
        diff = products["rho_k_iterate"][rows] - surfels.albedo[rows] * exact_y
        first_bounce = products["first_bounce"]
    else:
        exact_y = operator.apply_rows(B, rows)
        diff = surfels.albedo[rows] * (operator.apply(B)[rows] - exact_y)
        first_bounce = None
    gain = bounce_gain(B, surfels, operator, first_bounce)
    return _rms(diff) / (_rms(B[rows]) or 1.0) * gain, gain, rows


def _coarse_discretization(stats: dict, surfels: Surfels, B, non_emit, vis_kw: dict) -> float:
    """The discretization part measured: the same solve on a spatially even half of the
    surfels, d = its distance to B there, e ≈ d/(√2 − 1)."""
    half, half_areas = _even_half(surfels)
    sub = Surfels(surfels.positions[half], surfels.normals[half], half_areas,
                  surfels.albedo[half], surfels.emission[half])
    keys = {k: stats[k] for k in _OPERATOR_STATS if k in stats}
    if keys.get("method") == "direct":
        keys = {k: v for k, v in keys.items() if k in ("method", "near_field", "visibility")}
    if stats.get("visibility", "none") != "none":
        keys.update(vis_kw)
    coarse_sol = _solve(sub, tol=max(float(stats.get("tol", 1e-6)), 1e-10), **keys)
    m = non_emit[half]
    d = _rms(coarse_sol.radiosity[m] - B[half][m]) / (_rms(B[half][m]) or 1.0)
    return d / (math.sqrt(2.0) - 1.0)


def _model_discretization(surfels: Surfels, settings: dict | None, kind: str | None,
                          scale) -> tuple:
    """(e_disc, "model") from the kind's calibrated model at this N times ``scale``;
    (None, None) without a calibration."""
    if not calibration.CALIBRATION.get("kinds"):
        return None, None
    k = kind or (settings or {}).get("kind") or scene_summary(surfels)["kind"]
    e_disc = discretization(kind_table(k), surfels.n)
    if e_disc is None:
        return None, None
    return e_disc * float(scale), "model"
