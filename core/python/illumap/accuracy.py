"""Automatic accuracy: model no more than the scene needs.

``choose_settings(scene, target_error)`` turns a target error (relative RMS per surfel, emitters
excluded, as in bench/accuracy_speed.py) into settings: surfel density, method (direct or FMM),
expansion order p, opening angle theta, leaf size, visibility mode and solver tolerance. It
splits the target into budgets for the three error sources and picks, for each, the cheapest
setting that the calibrated error models say meets its budget:

* discretization (surfel density):  ``e_disc(N) = c_kind · N^(−a_kind)`` per scene kind (meshes
  sampled on grids, randomly sampled meshes, point clouds); the density is that of N surfels
  over the scene's area. A point cloud cannot be made denser than its points: the density is
  capped there and ``notes`` says so.
* FMM expansion (p, theta): the table :data:`FMM_ERROR` (worst relative RMS difference between
  the FMM and direct solutions over the benchmark scenes) and the cost table :data:`FMM_COST`
  (seconds per surfel per application) against the direct operator's :data:`DIRECT_COST`
  (seconds per surfel pair); at small N the direct operator is both exact and cheaper.
* solver: a relative residual ``tol`` bounds the error by about ``tol * ‖E‖ / ((1 − ρ_max)
  ‖B‖)``, so ``tol = budget * (1 − ρ_max) * ‖B‖/‖E‖`` with ‖B‖/‖E‖ estimated from the emitter
  fraction.

``estimate_error(solution, surfels)`` is the a-posteriori estimate: the solver part from the
final residual, the FMM part from a probe (the FMM applied to the solution against the exact
direct sum on a random subset of receivers, ``apply_rows``), and, optionally, the
discretization part by comparing with a solve on a random half of the surfels.

``solve(surfels, target_error)`` does both and puts the chosen settings and the estimate in
``Solution.stats["accuracy"]``.

The calibration tables below were produced by::

    .venv/bin/python bench/accuracy_speed.py --calibrate 3000 --out bench/results/calibration.json

(2026-11-22, 2 shared cores; cornell, bunny and interior scenes of bench/scenes.py at about
3000 surfels each) and, for the discretization constants, by the direct-solve points of
``bench/accuracy_speed.py --full`` (see :data:`DISCRETIZATION`).
"""

from __future__ import annotations

import math
import time

import numpy as np

from .operator import (DEFAULT_LEAF_SIZE, VISIBILITIES, TransportOperator)
from .surfels import InputError, Surfels

__all__ = ["choose_settings", "solve_keywords", "estimate_error", "solve", "scene_summary",
           "FMM_ERROR", "FMM_COST", "DIRECT_COST", "DISCRETIZATION", "BUDGET_SPLIT",
           "PRESETS"]

# --- calibration ---------------------------------------------------------------------------------
#: Worst relative RMS difference (FMM solution − direct solution, same surfels, residual 1e-9)
#: over the three benchmark scenes, by theta then order p.
FMM_ERROR = {
    0.35: {0: 1.2e-01, 2: 4.6e-03, 3: 1.1e-03, 4: 2.5e-04, 6: 1.7e-05, 8: 1.3e-06},
    0.5: {0: 1.6e-01, 2: 1.9e-02, 3: 6.9e-03, 4: 2.8e-03, 6: 4.8e-04, 8: 9.0e-05},
    0.7: {0: 2.3e-01, 2: 4.7e-02, 3: 2.5e-02, 4: 1.1e-02, 6: 3.5e-03, 8: 1.3e-03},
}
#: Median seconds per surfel for one FMM application (build included once per solve
#: separately; both 2 threads), by theta then order.
FMM_COST = {
    0.35: {0: 1.0e-06, 2: 3.0e-06, 3: 6.0e-06, 4: 1.4e-05, 6: 6.0e-05, 8: 2.0e-04},
    0.5: {0: 1.0e-06, 2: 1.5e-06, 3: 3.0e-06, 4: 6.0e-06, 6: 2.5e-05, 8: 1.0e-04},
    0.7: {0: 1.0e-06, 2: 1.5e-06, 3: 3.0e-06, 4: 5.0e-06, 6: 2.5e-05, 8: 6.0e-05},
}
#: Seconds per surfel pair for one direct application (2 threads).
DIRECT_COST = 2.5e-9
#: Discretization error model ``e_disc(N) = c · N^(−a)`` (relative RMS against a converged
#: reference), by scene kind: (c, a, n_min), an upper envelope of the direct-solve points of
#: ``bench/accuracy_speed.py --full`` (references of 24k surfels, 37k for the bunny).
#: Convergence is slow (a ≈ 0.27–0.65, often below 0.5): O(h) at edges and corners, random
#: sampling noise, PCA normals on the scan. Below ``n_min`` the model does not hold (small
#: lights are not resolved: the Cornell box has 24% error at 80 surfels, 1.8% at 245), so no
#: fewer are recommended.
DISCRETIZATION = {
    "grid": (0.068, 0.27, 250),        # Cornell box: 1.27% at 500, 0.95% at 2000, 0.60% at 8000
    "random": (1.68, 0.364, 1000),     # interior: 10.5% at 1003, 6.9% at 3999, 5.3% at 11998
    "point_cloud": (33.0, 0.65, 1000),  # bunny scan: 18% at 1641, 10.7% at 6225, 5.3% at 18457
}
#: Fractions of the target given to (discretization, FMM, solver).
BUDGET_SPLIT = (0.8, 0.12, 0.08)
#: Named presets of the add-on → target error.
PRESETS = {"draft": 0.10, "preview": 0.10, "medium": 0.03, "high": 0.01, "final": 0.01,
           "reference": 0.003}
#: Operator applications a solve needs (CG at ρ ≤ 0.9 in the benchmarks: 5–15) + build ≈ 2.
APPLICATIONS_ESTIMATE = 12


# --- scene summary -------------------------------------------------------------------------------

def _grid_like(surfels: Surfels) -> bool:
    """True when areas are (nearly) all equal and positions sit on a lattice-like spacing."""
    a = surfels.areas
    return bool(np.std(a) <= 1e-6 * np.mean(a))


def scene_summary(scene, kind=None) -> dict:
    """What :func:`choose_settings` needs: n, total_area, albedo_max, emitter_area_fraction,
    kind ("grid", "random" or "point_cloud"). ``scene`` is Surfels or such a dict."""
    if isinstance(scene, Surfels):
        emitters = scene.emission.max(axis=1) > 0
        out = dict(n=scene.n, total_area=scene.total_area,
                   albedo_max=float(scene.albedo.max()),
                   albedo_mean=float(np.average(scene.albedo.mean(axis=1), weights=scene.areas)),
                   emitter_area_fraction=float(scene.areas[emitters].sum() / scene.total_area),
                   kind=kind or ("grid" if _grid_like(scene) else "random"))
        return out
    if isinstance(scene, dict):
        missing = {"n", "total_area"} - set(scene)
        if missing:
            raise InputError(f"scene summary: missing {sorted(missing)}")
        out = dict(albedo_max=0.8, albedo_mean=0.6, emitter_area_fraction=0.02, kind="random")
        out.update(scene)
        if kind:
            out["kind"] = kind
        return out
    raise InputError(f"scene: expected Surfels or a summary dict, got {type(scene).__name__}")


def available_visibilities():
    return [m for m, (ok, _) in VISIBILITIES.items() if ok]


# --- choosing ------------------------------------------------------------------------------------

def _check_target(target_error):
    if isinstance(target_error, str):
        target_error = target_error.lower()
        if target_error not in PRESETS:
            raise InputError(f"target_error: unknown preset {target_error!r}; "
                             f"expected a number or one of {sorted(PRESETS)}")
        return PRESETS[target_error]
    try:
        t = float(target_error)
    except (TypeError, ValueError):
        raise InputError(f"target_error: expected a number, got {target_error!r}") from None
    if not (math.isfinite(t) and 0 < t < 1):
        raise InputError(f"target_error: expected a relative error in (0, 1), got {target_error!r}")
    return t


def choose_settings(scene, target_error, *, kind=None, allow_direct=True,
                    max_surfels=None) -> dict:
    """Settings meeting ``target_error`` (relative RMS per surfel) at the least modelled cost.

    scene : Surfels, or a summary dict with at least ``n`` and ``total_area`` (optionally
        ``albedo_max``, ``emitter_area_fraction``, ``kind``).
    target_error : float in (0, 1), or a preset name from :data:`PRESETS`.
    kind : "grid" | "random" | "point_cloud"; default guessed (equal areas → "grid").
    allow_direct : when False, only FMM settings are considered.
    max_surfels : cap on the recommended surfel count (e.g. the points of a scan).

    Returns a dict: ``target_error``, ``density`` (surfels per m²), ``n`` (recommended count),
    ``method``, ``order``, ``theta``, ``leaf_size``, ``visibility``, ``solver``, ``tol``,
    ``budget`` and ``predicted`` (per error source), ``predicted_time`` (s) and ``notes``.
    Pass it to :func:`solve_keywords` for ``illumap.solve``.
    """
    target = _check_target(target_error)
    s = scene_summary(scene, kind)
    notes = []
    b_disc, b_fmm, b_solve = (f * target for f in BUDGET_SPLIT)
    c, a, n_min = DISCRETIZATION.get(s["kind"], DISCRETIZATION["random"])
    n_needed = max(int(math.ceil(min((c / b_disc) ** (1.0 / a), 1e12))), n_min)
    if s["kind"] == "point_cloud":
        cap = s["n"] if max_surfels is None else min(max_surfels, s["n"])
        if n_needed > cap:
            notes.append(f"point cloud: {n_needed} surfels would be needed for a discretization "
                         f"error of {b_disc:.3g}; the scan has {cap}, so its error is bounded "
                         f"below by about {c * cap ** -a:.3g}")
        n_needed = min(n_needed, cap)
    elif max_surfels is not None and n_needed > max_surfels:
        notes.append(f"surfel budget {max_surfels} below the {n_needed} the target needs")
        n_needed = max_surfels
    n_used = s["n"] if isinstance(scene, Surfels) else n_needed
    e_disc = c * max(n_needed, 1) ** -a

    # method, p, theta: cheapest meeting the FMM budget
    candidates = []
    if allow_direct:
        candidates.append((DIRECT_COST * n_used * n_used, "direct", None, None, 0.0))
    for theta, row in FMM_ERROR.items():
        for p, err in row.items():
            if err <= b_fmm:
                candidates.append((FMM_COST[theta][p] * n_used, "fmm", p, theta, err))
    if not candidates:   # nothing meets it: the most accurate FMM setting
        theta = min(FMM_ERROR)
        p = max(FMM_ERROR[theta])
        candidates.append((FMM_COST[theta][p] * n_used, "fmm", p, theta, FMM_ERROR[theta][p]))
        notes.append(f"no calibrated FMM setting reaches {b_fmm:.2g}; using p={p}, θ={theta}")
    cost, method, p, theta, e_fmm = min(candidates, key=lambda c_: c_[0])

    # solver tolerance: ‖δB‖/‖B‖ ≲ tol ‖E‖ / ((1 − ρmax) ‖B‖); ‖B_ne‖/‖E‖ ~ sqrt(f_emit)·ρ_mean
    rho = min(s["albedo_max"], 0.995)
    f_emit = max(s["emitter_area_fraction"], 1e-6)
    b_over_e = max(min(math.sqrt(f_emit) * max(s.get("albedo_mean", 0.6), 0.05), 1.0), 1e-3)
    tol = float(min(1e-2, max(1e-10, b_solve * (1 - rho) * b_over_e)))

    # The calibrated budgets cover expansion and solver error only; the sampled visibility
    # classification adds its own per-surfel error (tests/core/test_visibility.py), so
    # occlusion is not switched on here: pass visibility= explicitly to solve().
    visibility = "none"
    notes.append("visibility: 'none' (occlusion is not in the error model; "
                  f"available: {available_visibilities()})")
    total_area = s["total_area"]
    return dict(
        target_error=target,
        kind=s["kind"],
        density=n_needed / total_area,
        n=n_needed,
        method=method,
        order=p if p is not None else 0,
        theta=theta if theta is not None else 0.5,
        leaf_size=DEFAULT_LEAF_SIZE,
        visibility=visibility,
        solver="auto",
        tol=tol,
        budget=dict(discretization=b_disc, fmm=b_fmm, solver=b_solve),
        predicted=dict(discretization=e_disc, fmm=e_fmm, solver=b_solve,
                       total=e_disc + e_fmm + b_solve),
        predicted_time=cost * APPLICATIONS_ESTIMATE,
        notes=notes,
    )


def solve_keywords(settings: dict) -> dict:
    """The ``illumap.solve`` keywords of a :func:`choose_settings` result."""
    kw = dict(method=settings["method"], solver=settings.get("solver", "auto"),
              tol=settings["tol"])
    if settings["method"] == "fmm":
        kw.update(order=settings["order"], theta=settings["theta"],
                  leaf_size=settings["leaf_size"])
    if settings.get("visibility", "none") != "none":
        kw["visibility"] = settings["visibility"]
    return kw


# --- a-posteriori estimate -------------------------------------------------------------------------

def _rms(x):
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


def _even_half(surfels: Surfels) -> np.ndarray:
    """Every other surfel along a Morton curve, per orientation class and emitter flag (so
    that each surface and each light keeps about half of its surfels): a spatially even half, unlike a random one."""
    order = np.argsort(_morton_keys(surfels.positions), kind="stable")
    # group by the dominant normal direction so that two touching walls alternate separately
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


def estimate_error(solution, surfels: Surfels, *, operator: TransportOperator | None = None,
                   probe: int = 256, coarse: bool = False, seed: int = 0) -> dict:
    """A-posteriori estimate of the relative RMS error (emitters excluded) of ``solution``.

    * ``solver``: ‖r‖/((1 − ρ_max)‖B‖) from the final true residual (r = E − (B − ρ K B)).
    * ``fmm``: the FMM applied to B against the exact direct sum on ``probe`` random receivers
      (``apply_rows`` of a direct operator), times ρ, relative to B there, amplified by
      1/(1 − ρ_max) for the propagation through the solve. Zero for a direct solution.
    * ``discretization`` (``coarse=True``): the same solve on a spatially even half of the
      surfels (every other one along a Morton curve, areas scaled to keep each surface's
      total); the difference d at the common surfels gives e ≈ d/(√2 − 1) for error
      O(N^-1/2). None when not asked.
    ``total`` is their sum. Costs: one FMM application, probe × N kernel evaluations, and with
    ``coarse`` one solve at N/2.
    """
    t0 = time.perf_counter()
    rng = np.random.default_rng(seed)
    B = np.asarray(solution.radiosity)
    stats = solution.stats
    rho_max = min(float(surfels.albedo.max()), 0.995)
    amplification = 1.0 / (1.0 - rho_max)
    non_emit = ~(surfels.emission.max(axis=1) > 0)
    if not non_emit.any():
        non_emit = np.ones(surfels.n, bool)
    b_rms = _rms(B[non_emit]) or 1.0
    # solver part: relative residual in the norm of E → relative to B over non-emitters
    e_norm = math.sqrt(float(np.sum(surfels.emission ** 2)))
    res = float(stats.get("final_residual", 0.0) or 0.0)
    e_solver = res * e_norm / math.sqrt(max(non_emit.sum(), 1)) * amplification / b_rms
    # FMM part
    method = stats.get("method", "direct")
    e_fmm = 0.0
    rows = np.array([], dtype=np.int64)
    if method == "fmm":
        if operator is None:
            operator = TransportOperator(surfels, method="fmm", order=stats.get("order", 4),
                                         theta=stats.get("theta", 0.5),
                                         leaf_size=stats.get("leaf_size", DEFAULT_LEAF_SIZE),
                                         near_field=stats.get("near_field", "disc"))
        candidates = np.flatnonzero(non_emit)
        rows = np.sort(rng.choice(candidates, min(probe, len(candidates)), replace=False))
        fmm_y = operator.apply(B)[rows]
        direct = TransportOperator(surfels, method="direct",
                                   near_field=stats.get("near_field", "disc"))
        exact_y = direct.apply_rows(B, rows)
        diff = surfels.albedo[rows] * (fmm_y - exact_y)
        e_fmm = _rms(diff) / (_rms(B[rows]) or 1.0) * amplification
    e_disc = None
    if coarse:
        from .solver import solve as _solve
        half, half_areas = _even_half(surfels)
        sub = Surfels(surfels.positions[half], surfels.normals[half], half_areas,
                      surfels.albedo[half], surfels.emission[half])
        keys = {k: stats[k] for k in ("method", "order", "theta", "leaf_size", "near_field")
                if k in stats}
        if keys.get("method") == "direct":
            keys = {k: v for k, v in keys.items() if k in ("method", "near_field")}
        coarse_sol = _solve(sub, tol=max(float(stats.get("tol", 1e-6)), 1e-10), **keys)
        m = non_emit[half]
        d = _rms(coarse_sol.radiosity[m] - B[half][m]) / (_rms(B[half][m]) or 1.0)
        e_disc = d / (math.sqrt(2.0) - 1.0)
    total = e_solver + e_fmm + (e_disc or 0.0)
    return dict(solver=e_solver, fmm=e_fmm, discretization=e_disc, total=total,
                numerical=e_solver + e_fmm, probe_rows=int(rows.size),
                seconds=time.perf_counter() - t0)


# --- one call ----------------------------------------------------------------------------------------

def solve(surfels: Surfels, target_error, *, kind=None, allow_direct=True, estimate=True,
          coarse=False, progress=None, **overrides):
    """Choose settings for ``target_error`` and solve; ``stats["accuracy"]`` holds the chosen
    settings and (``estimate=True``) the a-posteriori estimate. ``overrides`` replace chosen
    solve keywords (e.g. ``solver="jacobi"``)."""
    from .solver import solve as _solve
    chosen = choose_settings(surfels, target_error, kind=kind, allow_direct=allow_direct)
    kw = solve_keywords(chosen)
    kw.update(overrides)
    sol = _solve(surfels, progress=progress, **kw)
    info = dict(settings=chosen, solve_keywords=kw)
    if estimate:
        info["estimate"] = estimate_error(sol, surfels, coarse=coarse)
    sol.stats["accuracy"] = info
    return sol
