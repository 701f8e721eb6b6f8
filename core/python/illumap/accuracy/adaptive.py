"""Meshes sampled for a target error: one uniform pass or two (adaptive) passes, chosen by their
modelled time (:func:`choose_mesh_settings`), and the whole run on triangles
(:func:`solve_triangles`)."""

from __future__ import annotations

import copy
import math
import time

import numpy as np

from .. import refinement, sampling
from ..refinement import ADAPTIVE_MAX_RATIO  # noqa: F401 (ADAPTIVE_ERROR_RATIO's condition)
from ..solver import solve as _solve
from ..surfels import InputError, Surfels
from . import calibration
from .estimate import estimate_error
from .choice import SAFETY, choose_settings, solve_keywords
from .inputs import NO_SURFEL_LIMIT, check_target
from .models import interp_log_n, setting_time
#: Adaptive runs: pass 1 takes this share of the chosen count (its only use is to find where the
#: illumination varies); pass 2's density follows ``illumap.refinement`` (regions, neighbours
#: and the multipliers' bound ADAPTIVE_MAX_RATIO there).
ADAPTIVE_FIRST_SHARE = 0.5
#: Error of an adaptive run against a uniform one of the same count, as the count is chosen:
#: measured on the Cornell box's triangles against the 48k-surfel reference
#: (bench/micro/bench_adaptive.py, bench/results/adaptive.json: 1.5k, 3k and 6k surfels, exact
#: visibility): 0.69-0.73 for the direct method, 0.69-0.81 for FMM settings, whose expansion
#: and visibility error the second pass does not lower. It scales the discretization part of a
#: setting's error only, and is the upper end measured for any setting: with the direct method's
#: range (0.75, rounded up) the automatic mode at 10% chose 3152 surfels and measured 10.2% on
#: the benchmark's sampling.
ADAPTIVE_ERROR_RATIO = 0.8
#: Solve time of the second pass against a uniform pass of the same count and settings
#: (paired, bench/micro/bench_adaptive.py, bench/results/adaptive.json): the median over
#: five settings at each count, interpolated in log N and held beyond. A varying density packs
#: surfels into fewer octree cells, whose near field (per-pair visibility rays) grows:
#: 0.97-1.41 at 1.5k, 0.84-1.37 at 3k, 0.85-1.15 at 6k, 0.97-1.86 at 12k surfels.
ADAPTIVE_TIME_RATIO = [[1447, 1.18], [2873, 0.96], [5731, 1.02], [11422, 1.39]]
#: Two passes run (uncapped) only where predicted at most this share of one uniform pass's
#: time, exp(-rms) of the time models' own error: each setting's largest swept size predicted
#: from the smaller ones (bench/calibration/calibrate.py's ``time_holdout``, kept in the calibration: 0.42 rms
#: in log time; 0.66), or 0.7 when the calibration has no hold-out. Twice on the triangles at
#: 5%, two passes predicted at 0.78x one pass's time measured 1.28x and 1.35x, and missed the
#: target on one sampling (5.11%) where one pass met it.
ADAPTIVE_TIME_MARGIN = (round(math.exp(-calibration.CALIBRATION["time_holdout"]["rms"]), 2)
                        if "time_holdout" in calibration.CALIBRATION else 0.7)
#: Fewest surfels for which that ratio is assumed (measured from 2k up; at 1383 surfels, a first
#: pass of 690, the automatic mode's adaptive run got 0.83 of the uniform model's error).
ADAPTIVE_MIN_COUNT = 2000


def choose_mesh_settings(scene: dict, target_error, *, kind: str = "mesh", adaptive: bool = True,
                         max_surfels: int | None = None) -> dict:
    """:func:`choose_settings` for meshes to be sampled (``scene``: a summary dict, ``n``
    any large number and ``total_area`` in m²), as :func:`solve_triangles` and the add-on
    sample them. With ``adaptive`` (two passes: ADAPTIVE_FIRST_SHARE of the count uniformly,
    then the count denser where that solution varies) the models' discretization part is
    scaled by ADAPTIVE_ERROR_RATIO where the count is at least ADAPTIVE_MIN_COUNT (below it a
    first pass is too coarse to find where the illumination varies, so the count is raised to
    it). The two passes' modelled time (pass 1 with the same settings at its share of the
    count, pass 2 scaled by ADAPTIVE_TIME_RATIO as its density varies) must be at most
    ADAPTIVE_TIME_MARGIN times one uniform pass's (within the time models' error one pass is
    the simpler and surer choice); two passes also run where ``max_surfels`` caps the count
    below what one uniform pass needs (they lower the error at that count). The result's
    ``adaptive`` says which (False: one uniform pass), ``discretization_scale`` what the
    models were scaled by (``estimate_error`` and the second pass's :func:`solve` take it
    from there), ``predicted_time`` the total (``predicted_time_passes``: each pass's)."""
    uniform = choose_settings(scene, target_error, kind=kind, max_surfels=max_surfels)
    uniform["adaptive"] = False
    if not adaptive:
        return uniform
    two = choose_settings(scene, target_error, kind=kind, max_surfels=max_surfels,
                          discretization_scale=ADAPTIVE_ERROR_RATIO,
                          min_surfels=ADAPTIVE_MIN_COUNT)
    if two["n"] < ADAPTIVE_MIN_COUNT:   # capped below where the ratio was measured
        two = copy.deepcopy(uniform)
    first = setting_time(two, ADAPTIVE_FIRST_SHARE * two["n"])   # same settings, its share
    time_ratio = adaptive_time_ratio(two["n"])
    second = time_ratio * two["predicted_time"]
    two["predicted_time_passes"] = [first, second]
    two["predicted_time"] = first + second
    reached = uniform["predicted"]["total"] <= SAFETY * uniform["target_error"] + 1e-12
    if reached and two["predicted_time"] > ADAPTIVE_TIME_MARGIN * uniform["predicted_time"]:
        uniform["notes"].append(
            f"adaptive: one uniform pass ({uniform['predicted_time']:.3g} s) is chosen: two "
            f"passes are predicted at {two['predicted_time']:.3g} s, more than "
            f"{ADAPTIVE_TIME_MARGIN} of it (the adaptive error ratio {ADAPTIVE_ERROR_RATIO} "
            f"from {ADAPTIVE_MIN_COUNT} surfels, pass 2's time ratio {time_ratio:.3g})")
        return uniform
    two["adaptive"] = True
    why = (f"predicted at most {ADAPTIVE_TIME_MARGIN} of one uniform pass's time "
           f"({uniform['predicted_time']:.3g} s)"
           if reached else "one uniform pass of the capped count is predicted to miss the target")
    two["notes"].append(f"adaptive: two passes, the models' discretization error scaled by "
                        f"{two['discretization_scale']:g} (adaptive error ratio "
                        f"{ADAPTIVE_ERROR_RATIO} from {ADAPTIVE_MIN_COUNT} surfels), {why}")
    return two


def adaptive_time_ratio(n: float) -> float:
    """Modelled solve time of an adaptive second pass of ``n`` surfels over a uniform pass's
    (ADAPTIVE_TIME_RATIO at ``n``)."""
    return interp_log_n(ADAPTIVE_TIME_RATIO, n)


def _mesh_surfels(samples, albedo, emission, keep):
    mask = np.ones(len(samples.positions), bool) if keep is None else \
        np.asarray(keep(samples.positions), bool)
    tri = samples.triangle[mask]
    return Surfels(samples.positions[mask], samples.normals[mask], samples.areas[mask],
                   albedo[tri], emission[tri]), mask


def solve_triangles(corners, albedo, emission, target_error, *, kind: str = "mesh",
                    adaptive: bool = True, seed: int = 0, keep=None, count: int | None = None,
                    estimate: bool = True, progress=None, **overrides):
    """Sample a triangle mesh for ``target_error`` and solve it, denser where the
    illumination varies.

    corners : (T, 3, 3) triangle corners, m (normal = (b − a) × (c − a)).
    albedo, emission : (T, 3) per triangle (reflectance in [0, 1), radiance W/(m²·sr)).
    target_error : relative RMS per surfel, or a preset name (:data:`TARGET_PRESETS`).
    kind : the calibrated scene kind whose error model sets the count ("mesh": stratified
        samples of triangles, uniform density, as in bench/scenes/surfels.py ``cornell_mesh``; the
        second pass only lowers the error).
    adaptive : two passes where :func:`choose_mesh_settings` predicts them faster than one
        uniform pass (the uniform-density models' discretization part scaled by
        ADAPTIVE_ERROR_RATIO from ADAPTIVE_MIN_COUNT surfels up); pass 1 solves
        ADAPTIVE_FIRST_SHARE of the count, uniformly; pass 2
        resamples the full count with a density multiplier per region that grows with how
        much pass 1's luminance varies there (``illumap.refinement``), and solves again. Without
        it: one uniform pass of the count chosen for the target.
    keep : optional callable, positions (N, 3) → bool (N,): which samples become surfels
        (e.g. not those inside a closed solid).
    count : samples of the (final) pass instead of the chosen count (a budget: the settings
        and the number of passes are chosen for at most that many surfels).
    overrides : replace chosen solve keywords.

    Returns ``(Solution, Surfels)``; ``stats["accuracy"]`` holds the chosen settings, the solve
    keywords, ``passes`` (surfels, iterations and seconds of each) and, with ``estimate``, the
    a-posteriori estimate of the final pass.
    """
    c = np.asarray(corners, dtype=np.float64)
    rho = np.asarray(albedo, dtype=np.float64)
    emit = np.asarray(emission, dtype=np.float64)
    if rho.shape != (len(c), 3) or emit.shape != (len(c), 3):
        raise InputError(f"albedo and emission: expected shape (T, 3) = ({len(c)}, 3), got "
                         f"{rho.shape} and {emit.shape}")
    areas = sampling.triangle_areas(c)
    target = check_target(target_error)
    chosen = choose_mesh_settings(
        dict(n=NO_SURFEL_LIMIT, total_area=float(areas.sum()), kind=kind,
             albedo_max=float(rho.max()),
             albedo_mean=float(np.average(rho.mean(axis=1), weights=areas))),
        target, kind=kind, adaptive=adaptive,
        max_surfels=None if count is None else max(int(count), 1))
    adaptive = bool(chosen["adaptive"])
    scale = chosen["discretization_scale"]
    kw = solve_keywords(chosen)
    kw.update(overrides)
    if count is None:
        count = int(chosen["n"])
    elif int(count) < 1:
        raise InputError(f"count: expected at least 1 sample, got {count}")
    count = int(count)
    rng = np.random.default_rng(seed)
    passes = []

    def run(samples):
        surfels, mask = _mesh_surfels(samples, rho, emit, keep)
        t0 = time.perf_counter()
        sol = _solve(surfels, progress=progress, **kw)
        passes.append(dict(surfels=surfels.n, iterations=int(sol.iterations),
                           seconds=time.perf_counter() - t0))
        return sol, surfels, mask

    if not adaptive:
        sol, surfels, _ = run(sampling.sample_triangles(c, count, rng))
    else:
        first_count = max(int(ADAPTIVE_FIRST_SHARE * count), 1)
        first = sampling.sample_triangles(c, first_count, rng)
        sol1, s1, mask = run(first)
        t0 = time.perf_counter()
        refined = refinement.refine(s1.positions, sol1.radiosity,
                                    [(c, first.triangle[mask], first.bary[mask], areas.sum())])
        regions = refined.regions[0]
        second = sampling.sample_triangles(regions.corners, count, rng,
                                           weights=refined.multipliers)
        second.triangle, second.bary = regions.to_parent(second.triangle, second.bary)
        refine_seconds = time.perf_counter() - t0
        sol, surfels, _ = run(second)
        passes[-1]["refinement_seconds"] = refine_seconds
    info = dict(settings=chosen, solve_keywords=kw, adaptive=bool(adaptive), passes=passes,
                discretization_scale=scale)
    if estimate:
        info["estimate"] = estimate_error(sol, surfels, settings=chosen, kind=kind)
    sol.stats["accuracy"] = info
    return sol, surfels
