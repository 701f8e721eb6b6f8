"""Setting choice: the calibrated setting, surfel count and solver tolerance that meet a target
error at the least modelled time (:func:`choose_settings`), and the solve keywords of a choice
(:func:`solve_keywords`)."""

from __future__ import annotations

import math

from ..operator import DEFAULT_LEAF_SIZE
from ..solver import MAX_BOUND_ALBEDO
from ..surfels import InputError, Surfels
from .calibration import (DEFAULT_N_MIN, SETTING_VISIBILITY_KEYS, kind_table,
                          visibility_keywords)
from .inputs import NO_SURFEL_LIMIT, check_target, scene_summary
from .models import discretization, needed_n, predicted_error, predicted_time, settings_with_leaves
from .probe import occlusion_probe

#: When the occlusion probe runs (``probe="auto"``): a setting without visibility must be
#: predicted at most PROBE_GAIN times the time of the best one with visibility, were the scene
#: unoccluded, and that best time above PROBE_WORTH seconds (below it the probe costs about
#: what it could save). The probe stops early at PROBE_DECISIVE × the target
#: (``occlusion_probe``'s ``decisive``): no setting without visibility can then meet it.
PROBE_DECISIVE = 2.0
PROBE_WORTH = 0.25   # s
PROBE_GAIN = 0.67
#: The settings are chosen to meet SAFETY × target by the models (scenes that differ from the
#: calibration ones; the spread between samplings is the kinds' sampling factors).
SAFETY = 0.95

#: The solve stops once its own error estimate (``illumap.solve``'s ``error_tol``: the bounce
#: gain times the residual over the radiosity, RMS over the non-emitting surfels) is within
#: this share of the target, or at the calibrated ``tol``, whichever comes first. It spares
#: the iterations that a residual relative to the emission (a small bright light dominates
#: it) asks for beyond what the target needs. The result then keeps 0.13-0.86 of the estimate
#: (bench/micro/solver_estimate.py: the benchmark scenes at their targets and the Cornell box at
#: albedo 0.95, 1 to 6 CG steps, errors ≥ 5e-4; the solve closes with the Jacobi step its
#: last residual holds, which multiplies the error by ρ∘K), so at most 0.2 of the target.
#: The RMS is over the unlit surfels on purpose: with the lamps' and the sky's light folded
#: into the emission, one over every surfel that is not a light let the sky bench scene stop
#: after 2 iterations at 1%, its sphere's underside (lit by bounced light only) 0.92% off
#: against Cycles where 5 gave 0.44% (whole scene 0.51% against 0.35%).
SOLVER_ERROR_SHARE = 0.2
#: The solve's relative-residual tolerance: TOL_PER_TARGET × the target where 1 − ρ_max is
#: TOL_REFERENCE_GAP (ρ_max = 0.8), in proportion to 1 − ρ_max elsewhere (a residual grows
#: over the bounces by up to 1/(1 − ρ_max)), within [TOL_MIN, TOL_MAX]; TOL_MAX is the
#: calibration sweep's own tolerance (``solve_tol``), 1e-4 at a 1% target and ρ_max = 0.8.
TOL_PER_TARGET = 0.01
TOL_REFERENCE_GAP = 0.2
TOL_MIN = 1e-8
TOL_MAX = 1e-4


def _candidates(table, s, fixed, target, e_occ, n_min, cap, allow_direct, scale=1.0,
                unoccluded_only=False):
    """Every calibrated setting with its N, predicted error and time, and whether it meets
    ``target`` (at the scene's own N when ``fixed``); ``order``: its place among them. With
    ``unoccluded_only`` the settings without visibility alone (the only ones ``e_occ``
    changes)."""
    out = []
    for order, (label, entry) in enumerate(settings_with_leaves(table)):
        kw = entry["keywords"]
        if kw["method"] == "direct" and not allow_direct:
            continue
        if unoccluded_only and kw.get("visibility", "none") != "none":
            continue
        if fixed:   # the count the target needs is found for the chosen setting only
            n = s["n"]
            err = predicted_error(entry, table, n, e_occ, scale)
            if err is None:
                continue
            need = None
            ok = err <= target
        else:
            need = needed_n(entry, table, target, e_occ, n_min, cap, scale)
            n = need if need is not None else cap
            err = predicted_error(entry, table, n, e_occ, scale)
            if err is None:
                continue
            ok = need is not None
        out.append(dict(label=label, entry=entry, n=n, need=need, error=err, ok=ok,
                        time=predicted_time(entry, n), order=order))
    return out


def choose_settings(scene, target_error, *, kind: str | None = None, allow_direct: bool = True,
                    max_surfels: int | None = None, min_surfels: int | None = None,
                    probe="auto", discretization_scale: float = 1.0) -> dict:
    """Settings meeting ``target_error`` (relative RMS per surfel) at the least modelled time.

    scene : Surfels (its N is then fixed: the setting is chosen for it, and ``n`` reports the
        count the target needs), or a summary dict with at least ``n`` (surfels available:
        the points of a scan; any large number for meshes) and ``total_area`` (m²).
    target_error : float in (0, 1), or a preset name from :data:`TARGET_PRESETS`.
    kind : "grid" | "random" | "point_cloud"; default guessed (equal areas → "grid").
    allow_direct : when False, only FMM settings are considered.
    max_surfels : cap on the recommended surfel count (e.g. the points of a scan).
    min_surfels : floor on the recommended surfel count (default: the calibration's n_min).
    discretization_scale : the sampling's discretization error against the uniform one the
        models were fitted on (ADAPTIVE_ERROR_RATIO for an adaptive sampling); it scales the
        discretization part of each setting's error, not what its expansion and visibility
        model add.
    probe : "auto" (default): run :func:`occlusion_probe` on Surfels when a setting without
        visibility would be at least 1/PROBE_GAIN times faster were the scene unoccluded and
        the best setting with visibility is predicted above PROBE_WORTH seconds (below, the
        probe costs about what it could save); True: whenever such a setting could win;
        False: never (``visibility="none"`` is then not chosen); or a probe result to reuse.

    Returns a dict: ``target_error``, ``kind``, ``density`` (surfels per m²), ``n``
    (recommended count), ``method``, ``order``, ``theta``, ``leaf_size``, ``visibility``,
    ``visibility_keywords``, ``solver``, ``tol``, ``label`` (the calibrated setting),
    ``predicted`` (``total`` error and ``discretization``, the setting's error at N),
    ``predicted_time`` (s, calibration machine), ``discretization_scale`` (as given),
    ``reached`` (False where no setting meets the target within the counts allowed: the most
    accurate one is returned, with a note), ``probe`` and ``notes``. Pass it to
    :func:`solve_keywords` for ``illumap.solve``.
    """
    target = check_target(target_error)
    s = scene_summary(scene, kind)
    table = kind_table(s["kind"])
    fixed = isinstance(scene, Surfels)
    cap, n_min = _count_range(s, table, fixed, max_surfels, min_surfels)
    scale = float(discretization_scale)

    def rank(e_occ, unoccluded_only=False):
        # aim a little below the target: the fits are of a few sampled scenes
        return _candidates(table, s, fixed, SAFETY * target, e_occ, n_min, cap, allow_direct,
                           scale, unoccluded_only=unoccluded_only)
    candidates, probe_info = _ranked_with_probe(rank, scene, s["kind"], target, probe, fixed)
    e_occ = None if probe_info is None else float(probe_info["error_none"])
    notes = []
    best = _cheapest_meeting(candidates, target, cap, notes)
    kw = best["entry"]["keywords"]
    vis = kw.get("visibility", "none")
    if e_occ is None:
        notes.append("visibility: no occlusion probe (a summary, probe=False, or too small a "
                     "scene for it to pay off): visibility='none' not considered")
    else:
        notes.append(f"visibility: the probe puts the error of visibility='none' at "
                     f"{e_occ:.3g}")
    if fixed:
        need = needed_n(best["entry"], table, SAFETY * target, e_occ, n_min, NO_SURFEL_LIMIT,
                        scale)
        n_out = need or s["n"]
    else:
        n_out = best["n"]
    e_disc = discretization(table, n_out)
    if e_disc is not None:
        e_disc *= scale
    return dict(
        target_error=target,
        kind=s["kind"],
        density=n_out / s["total_area"],
        n=int(n_out),
        method=kw["method"],
        order=int(kw.get("order", 0)),
        theta=float(kw.get("theta", 0.5)),
        leaf_size=int(kw.get("leaf_size", DEFAULT_LEAF_SIZE)),
        visibility=vis,
        visibility_keywords={**visibility_keywords(vis, s["kind"]),
                             **{k: kw[k] for k in SETTING_VISIBILITY_KEYS if k in kw}},
        solver="auto",
        tol=solver_tolerance(target, s["albedo_max"]),
        error_tol=float(f"{SOLVER_ERROR_SHARE * target:.6g}"),
        label=best["label"],
        predicted=dict(total=float(best["error"]), discretization=e_disc,
                       occlusion=e_occ if vis == "none" else None),
        predicted_time=float(best["time"]),
        discretization_scale=scale,
        reached=bool(best["ok"]),
        probe=probe_info,
        notes=notes,
    )


def _count_range(s: dict, table: dict, fixed: bool, max_surfels, min_surfels) -> tuple:
    """(cap, n_min): the surfel counts the choice may recommend. A scene given as Surfels and
    a scan have their count; meshes can be sampled at any."""
    cap = s["n"] if (fixed or s["kind"] == "point_cloud") else NO_SURFEL_LIMIT
    if max_surfels is not None:
        cap = min(cap, int(max_surfels))
    n_min = min(max(int(table.get("n_min", DEFAULT_N_MIN)), int(min_surfels or 0)), cap)
    return cap, n_min


def _ranked_with_probe(rank, scene, kind: str, target: float, probe, fixed: bool) -> tuple:
    """(candidates, probe result or None). Without a probe result the settings without
    visibility are left out; on Surfels the probe runs (``probe`` True or "auto") when one
    of them could win were the scene unoccluded, and ("auto") when that would save more than
    the probe costs; then they are ranked with the probe's error."""
    probe_info = probe if isinstance(probe, dict) else None
    candidates = rank(None if probe_info is None else float(probe_info["error_none"]))
    if fixed and (probe is True or probe == "auto"):
        meeting = [c for c in candidates if c["ok"]]
        best_time = min((c["time"] for c in meeting), default=math.inf)
        worth = probe is True or best_time > PROBE_WORTH
        if worth and any(c["ok"] and c["time"] < PROBE_GAIN * best_time
                         for c in rank(0.0, unoccluded_only=True)):
            probe_info = occlusion_probe(scene, kind=kind, decisive=PROBE_DECISIVE * target)
            candidates = sorted(candidates + rank(float(probe_info["error_none"]),
                                                  unoccluded_only=True),
                                key=lambda c: c["order"])
    return candidates, probe_info


def _cheapest_meeting(candidates: list, target: float, cap, notes: list) -> dict:
    """The fastest candidate that meets the target, else the most accurate one (with a note)."""
    if not candidates:
        raise InputError("illumap.accuracy: no calibrated setting applies")
    meeting = [c for c in candidates if c["ok"]]
    if meeting:
        return min(meeting, key=lambda c: c["time"])
    best = min(candidates, key=lambda c: (c["error"], c["time"]))
    notes.append(f"no calibrated setting reaches {target:.3g} with {cap} surfels; "
                 f"the most accurate one is predicted at {best['error']:.3g}")
    return best


def solver_tolerance(target: float, albedo_max: float) -> float:
    """The relative-residual tolerance of a solve for ``target`` on a scene whose largest
    albedo is ``albedo_max`` (see TOL_PER_TARGET)."""
    rho = min(albedo_max, MAX_BOUND_ALBEDO)
    return float(min(TOL_MAX, max(TOL_MIN, TOL_PER_TARGET * target * (1 - rho)
                                  / TOL_REFERENCE_GAP)))


def solve_keywords(settings: dict) -> dict:
    """The ``illumap.solve`` keywords of a :func:`choose_settings` result."""
    kw = dict(method=settings["method"], solver=settings.get("solver", "auto"),
              tol=settings["tol"])
    if settings.get("error_tol") is not None:
        kw["error_tol"] = settings["error_tol"]
    if settings["method"] == "fmm":
        kw.update(order=settings["order"], theta=settings["theta"],
                  leaf_size=settings["leaf_size"])
    if settings.get("visibility", "none") != "none":
        kw["visibility"] = settings["visibility"]
        kw.update(settings.get("visibility_keywords", {}))
    return kw
