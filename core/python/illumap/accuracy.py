"""Automatic accuracy: the user asks for an error, Illumap chooses how to get it cheaply.

``choose_settings(scene, target_error)`` turns a target error (relative RMS per surfel, emitters
excluded, against a converged reference with exact visibility, as in bench/accuracy_speed.py)
into settings: surfel count (density), method (direct or FMM), expansion order p, opening angle
theta, leaf size, visibility mode (``none``, ``seed`` or ``exact``) and solver tolerance.

The error models are calibrated on the benchmarks (bench/accuracy_speed.py, fitted by
bench/calibrate.py into :data:`CALIBRATION`): for each scene kind ("grid": meshes sampled on
grids, the Cornell box; "random": randomly sampled meshes, the room with occluders;
"point_cloud": scans, the bunny) and each benchmarked setting (method, p, θ, visibility), the
measured error against N, as a non-increasing upper envelope, and the measured wall time
against N, both interpolated log-log. Beyond the measured sizes time follows its fitted slope;
an error only in its discretization part, which falls as the kind's direct curve does, while
what the setting adds there is held (a node-pair visibility model converges far slower).
An error curve holds everything the setting does: density, expansion, visibility model
(the FMM classifies node pairs as visible / hidden / partial from sampled rays, which blurs
shadows at large θ) and the solver at its tolerance. For each candidate setting the model gives
the N that meets ``SAFETY`` × target and the time it takes there; the cheapest wins.

Leaf size: each FMM setting was swept with leaves of 32 surfels; bench/leaf_size.py solves the
same surfels with leaves of 16 and 64 right after, and each setting's ``leaf_variants`` keep the
worst paired error ratio (``error_factor``, credited below 1 only at the sizes measured) and the
paired time ratios against N. A variant is a candidate like any setting: smaller leaves move
node pairs from the near field (per-pair visibility) to the classified far field, larger ones
the other way, so the leaf size trades error against time differently per scene and size.

Sampling: the curves are of the calibration's samplings; another sampling of the same scene
at the same N and settings lands elsewhere (up to 1.25× on a mesh, more on random surfels).
Each kind's ``sampling`` factor (bench/sampling_spread.py: errors of a near-exact setting on six
further samplings over the model, fitted by bench/calibrate.py to exp(mean + SAMPLING_Z·sd) of
their log ratios per size, never below 1) scales the discretization part of its predictions
(what moves between samplings; expansion and visibility-model errors stay), so that a target
holds for the user's sampling, not just for ours. Grids are deterministic and have none.

Visibility: settings without occlusion (``visibility="none"``) are modelled as
``sqrt(e_exact(N)² + e_fmm(p, θ)² + e_occlusion²)``, where ``e_exact`` is the direct exact-
visibility fit of the scene kind, ``e_fmm`` the expansion error table :data:`FMM_ERROR` and
``e_occlusion`` a probe of the scene: the direct solution on a few hundred of its surfels with
and without exact visibility (:func:`occlusion_probe`, tens of milliseconds). A convex or
open scene has ``e_occlusion`` ≈ 0 and gets the cheap ``none``; a scene with occluders gets
``exact`` (or ``seed`` where its fit says so). The probe runs only where a setting without
visibility could win and the saving could exceed its cost (``probe="auto"``); without
surfels (a summary dict) no probe runs and ``none`` is not chosen.

Density here is a surfel count over the scene's area, sampled uniformly by the caller; denser
sampling where the illumination varies is the add-on's second pass (``illumap.sampling``).

``estimate_error(solution, surfels)`` is the a-posteriori estimate: the solver part from the
final residual, the FMM part (expansion and visibility classification) from one FMM
application against the exact per-pair sum on a random subset of receivers (``apply_rows``,
which applies visibility per pair), the discretization part from the calibrated model at the
solution's N (or, with ``coarse=True``, measured on a spatially even half of the surfels).

``solve(surfels, target_error)`` does both and puts the chosen settings and the estimate in
``Solution.stats["accuracy"]``.
"""

from __future__ import annotations

import bisect
import copy
import json
import math
import time
from importlib import resources

import numpy as np

from .operator import DEFAULT_LEAF_SIZE, VISIBILITY_DEFAULTS, TransportOperator
from .solver import MAX_BOUND_ALBEDO
from .surfels import InputError, Surfels

__all__ = ["choose_settings", "choose_mesh_settings", "solve_keywords", "estimate_error", "solve",
           "solve_triangles", "scene_summary", "occlusion_probe", "visibility_keywords",
           "adaptive_time_ratio",
           "CALIBRATION", "FMM_ERROR", "EXACT_KEYWORDS", "PRESETS", "KINDS"]

KINDS = ("grid", "mesh", "random", "point_cloud")

#: Worst relative RMS difference (FMM solution − direct solution, same surfels, no visibility,
#: residual 1e-9) over the benchmark scenes, by theta then order p: the expansion error alone.
#: (Measured with visibility "none" before the exact near field; settings at a smaller theta
#: use the 0.35 row, an upper bound.)
FMM_ERROR = {
    0.35: {0: 1.2e-01, 2: 4.6e-03, 3: 1.1e-03, 4: 2.5e-04, 6: 1.7e-05, 8: 1.3e-06},
    0.5: {0: 1.6e-01, 2: 1.9e-02, 3: 6.9e-03, 4: 2.8e-03, 6: 4.8e-04, 8: 9.0e-05},
    0.7: {0: 2.3e-01, 2: 4.7e-02, 3: 2.5e-02, 4: 1.1e-02, 6: 3.5e-03, 8: 1.3e-03},
}

#: Keywords of ``visibility="exact"`` that the automatic mode uses (and the benchmarks that
#: calibrate it), per scene kind: occluders within one disc radius of either end of a ray are
#: ignored (the default 0.05 lets neighbouring discs on a curved or scanned surface shadow a
#: surfel's grazing rays). Disc radius (``coverage``, in spacings): a grid is closed at the
#: default 1.3 (a square cell's corners lie at 1.25), and wider discs stick out past edges,
#: which doubles the Cornell box reference's refinement difference (0.84% → 1.67%); irregular
#: samples leave holes between 1.3-spacing discs that leak light through thin walls and scans,
#: so they get 1.7, the add-on's width.
EXACT_KEYWORDS = {"grid": {"endpoint_offset": 1.0},
                  "mesh": {"endpoint_offset": 1.0, "coverage": 1.7},
                  "random": {"endpoint_offset": 1.0, "coverage": 1.7},
                  "point_cloud": {"endpoint_offset": 1.0, "coverage": 1.7}}


def visibility_keywords(visibility: str, kind: str = "random") -> dict:
    """The operator keywords the automatic mode uses with ``visibility`` on a scene of
    ``kind`` (one of :data:`KINDS`): :data:`EXACT_KEYWORDS` for "exact", none otherwise."""
    if visibility != "exact":
        return {}
    if kind not in EXACT_KEYWORDS:
        raise InputError(f"kind: expected one of {KINDS}, got {kind!r}")
    return dict(EXACT_KEYWORDS[kind])


#: Visibility keywords a calibrated setting may fix itself (bench/calibrate.py keeps them):
#: "per_pair_all" leaf pairs and more samples per node pair take the FMM's visibility error
#: down to the direct method's.
SETTING_VISIBILITY_KEYS = ("visibility_leaf_mode", "visibility_samples")

#: Named presets of the add-on → target error.
PRESETS = {"draft": 0.10, "preview": 0.10, "medium": 0.03, "high": 0.01, "final": 0.01,
           "reference": 0.003}

#: Surfels of the occlusion probe, and when it runs (see choose_settings: ``probe``).
PROBE_SURFELS = 200
#: The automatic mode's probe first runs on this share of PROBE_SURFELS and stops there when it
#: measures visibility="none" at PROBE_DECISIVE x the target or more (no setting without
#: visibility can then meet it), at about half the cost. On 100 surfels it measured 0.11-1.66x
#: the 200-surfel value (five samplings each of the bunny, the Cornell box, its triangles and
#: the room): stopping wrongly would take an overestimate by more than 2x.
PROBE_FIRST_SHARE = 0.5
PROBE_DECISIVE = 2.0
PROBE_WORTH = 0.25   # s
PROBE_GAIN = 0.67
#: The settings are chosen to meet SAFETY × target by the models (scenes that differ from the
#: calibration ones; the spread between samplings is the kinds' sampling factors).
SAFETY = 0.95
#: The sampling factor's quantile: exp(mean + SAMPLING_Z·sd) of the log error ratios (about
#: the 98th percentile of a log-normal spread), fitted by bench/calibrate.py.
SAMPLING_Z = 2.0
#: The solve stops once its own error estimate (``illumap.solve``'s ``error_tol``: the bounce
#: gain times the residual over the radiosity, RMS over the non-emitting surfels) is within
#: this share of the target, or at the calibrated ``tol``, whichever comes first. It spares
#: the iterations that a residual relative to the emission (a small bright light dominates
#: it) asks for beyond what the target needs. The result then keeps 0.13-0.86 of the estimate
#: (bench/solver_estimate.py: the benchmark scenes at their targets and the Cornell box at
#: albedo 0.95, 1 to 6 CG steps, errors ≥ 5e-4; the solve closes with the Jacobi step its
#: last residual holds, which multiplies the error by ρ∘K), so at most 0.2 of the target.
SOLVER_ERROR_SHARE = 0.2
#: The error a solve keeps over its estimate, at most, where the estimate is large: a closed
#: box lit by four surfels, the first two or three steps of CG or GMRES, whose iterates' bounce
#: gain is still growing (1.30-1.54; tests/core/test_solver.py). Below 3% the estimate held
#: everywhere measured. The a-posteriori estimate's solver part is the estimate times this,
#: at most the bound.
SOLVER_ESTIMATE_MARGIN = 1.6
#: Fewest surfels recommended per kind when the calibration has none (small lights and
#: occluders are not resolved below it).
DEFAULT_N_MIN = 250


def _load_calibration() -> dict:
    """The calibration fitted by bench/calibrate.py (``--write``), from the package's
    data/calibration.json."""
    text = resources.files(__package__).joinpath("data", "calibration.json").read_text(
        encoding="utf-8")
    return json.loads(text)


#: The fitted error and time models per scene kind (see the module docstring), with the
#: sweeps they were fitted on: data/calibration.json, written by bench/calibrate.py.
CALIBRATION = _load_calibration()


# --- scene summary -------------------------------------------------------------------------------

def _grid_like(surfels: Surfels) -> bool:
    """True when most areas are equal (regular sampling)."""
    a = surfels.areas
    med = float(np.median(a))
    return bool(np.mean(np.abs(a - med) <= 1e-6 * med) > 0.5)


def scene_summary(scene, kind: str | None = None) -> dict:
    """What :func:`choose_settings` needs: ``n``, ``total_area`` (m²), ``albedo_max``,
    ``albedo_mean``, ``emitter_area_fraction``, ``kind`` ("grid", "random" or
    "point_cloud"). ``scene`` is Surfels or such a dict (``n`` and ``total_area`` required)."""
    if isinstance(scene, Surfels):
        emitters = scene.emission.max(axis=1) > 0
        return dict(n=scene.n, total_area=scene.total_area,
                    albedo_max=float(scene.albedo.max()),
                    albedo_mean=float(np.average(scene.albedo.mean(axis=1), weights=scene.areas)),
                    emitter_area_fraction=float(scene.areas[emitters].sum() / scene.total_area),
                    kind=kind or ("grid" if _grid_like(scene) else "random"))
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


def _check_target(target_error) -> float:
    if isinstance(target_error, str):
        key = target_error.lower()
        if key not in PRESETS:
            raise InputError(f"target_error: unknown preset {target_error!r}; "
                             f"expected a number or one of {sorted(PRESETS)}")
        return PRESETS[key]
    if isinstance(target_error, bool):
        raise InputError(f"target_error: expected a number, got {target_error!r}")
    try:
        t = float(target_error)
    except (TypeError, ValueError):
        raise InputError(f"target_error: expected a number, got {target_error!r}") from None
    if not (math.isfinite(t) and 0 < t < 1):
        raise InputError(f"target_error: expected a relative error in (0, 1), got {target_error!r}")
    return t


# --- occlusion probe -----------------------------------------------------------------------------

def _probe_subset(surfels: Surfels, count: int, seed: int) -> Surfels:
    """About ``count`` surfels drawn at random, emitters and the rest apart, each group's areas
    scaled to keep its total (and so each light's power and each surface's disc coverage)."""
    rng = np.random.default_rng(seed)
    emit = surfels.emission.max(axis=1) > 0
    parts = []
    for group, share in ((np.flatnonzero(emit), 0.25), (np.flatnonzero(~emit), 0.75)):
        if group.size == 0:
            continue
        k = min(group.size, max(8, int(share * count)))
        pick = np.sort(rng.choice(group, k, replace=False))
        parts.append((pick, group.size / k))
    idx = np.concatenate([p for p, _ in parts])
    scale = np.concatenate([np.full(p.size, s) for p, s in parts])
    return Surfels(surfels.positions[idx], surfels.normals[idx], surfels.areas[idx] * scale,
                   surfels.albedo[idx], surfels.emission[idx])


def _probe_error(sub: Surfels, kind: str) -> float:
    """Relative RMS difference (non-emitters) between the direct solutions of ``sub`` without
    and with exact visibility."""
    from .solver import solve as _solve
    # a few per cent is all it needs; one thread: a second costs more than it saves on a few
    # hundred surfels (1.6 -> 1.1 ms and 3.4 -> 2.9 ms on the bunny)
    plain = _solve(sub, method="direct", tol=1e-3, threads=1)
    occluded = _solve(sub, method="direct", tol=1e-3, threads=1, visibility="exact",
                      **visibility_keywords("exact", kind))
    m = ~(sub.emission.max(axis=1) > 0)
    ref = occluded.radiosity[m]
    den = float(np.sqrt(np.mean(ref ** 2))) or 1.0
    return float(np.sqrt(np.mean((plain.radiosity[m] - ref) ** 2))) / den


def occlusion_probe(surfels: Surfels, count: int = PROBE_SURFELS, seed: int = 0,
                    kind: str = "random", decisive: float | None = None) -> dict:
    """How much occlusion changes this scene: relative RMS difference (non-emitters) between
    the direct solutions without and with exact visibility on about ``count`` of its surfels.

    decisive : an error of ``visibility="none"`` that settles the question (the caller's
        choice no longer depends on it beyond that). When given, the probe first runs on
        PROBE_FIRST_SHARE of ``count`` and stops there if it measures at least ``decisive``.

    Returns ``error_none`` (that difference, the error of ``visibility="none"``), ``surfels``
    (of the last stage) and ``seconds``."""
    t0 = time.perf_counter()
    stages = [count]
    first = int(PROBE_FIRST_SHARE * count)
    if decisive is not None and surfels.n > first:
        stages.insert(0, first)
    for size in stages:
        sub = surfels if surfels.n <= size else _probe_subset(surfels, size, seed)
        if not (sub.emission > 0).any():
            return dict(error_none=0.0, surfels=sub.n, seconds=time.perf_counter() - t0)
        err = _probe_error(sub, kind)
        if decisive is not None and err >= decisive:
            break
    return dict(error_none=err, surfels=sub.n, seconds=time.perf_counter() - t0)


# --- choosing ------------------------------------------------------------------------------------

def _kind_table(kind: str) -> dict:
    kinds = CALIBRATION.get("kinds", {})
    for k in (kind, "random", "grid", *kinds):   # the closest calibrated kind
        if k in kinds:
            return kinds[k]
    raise InputError("illumap.accuracy has no calibration (run bench/calibrate.py)")


#: Scene kinds whose error curves are steps between the measured sizes (the value at the
#: measured size below), not log-log interpolations: on grids the error is not monotone in N
#: (grid lines move across shadow and light edges: on the Cornell box 3.25% at 2437 surfels,
#: between 3.16% at 1927 and 2.22% at 4128), and the interpolation missed its 3% target there.
STEP_KINDS = ("grid",)


def _steps(table: dict) -> bool:
    kinds = CALIBRATION.get("kinds", {})
    return any(table is kinds.get(k) for k in STEP_KINDS)


#: Curves as sorted lists with their logarithms, by id (checked against the object itself, so a
#: curve rebuilt at the same address is read afresh): the choice evaluates a few thousand of
#: them per call, and rebuilding the lists each time was most of its cost.
_CURVE_CACHE: dict = {}


def _curve(points) -> tuple:
    """(points, ns, values, log ns, log values) of ``[[n, value], …]``."""
    hit = _CURVE_CACHE.get(id(points))
    if hit is None or hit[0] is not points:
        ns = [float(p[0]) for p in points]
        vs = [float(p[1]) for p in points]
        hit = (points, ns, vs, [math.log(n) for n in ns],
               [math.log(v) if v > 0 else -math.inf for v in vs])
        if len(_CURVE_CACHE) > 4096:
            _CURVE_CACHE.clear()
        _CURVE_CACHE[id(points)] = hit
    return hit


def _loglog(model: dict, n: float, *, error: bool, steps: bool = False) -> float:
    """A calibrated curve at ``n``: log-log interpolation between the measured points (with
    ``steps``, for an error: the value at the largest measured size ≤ n); beyond them the
    model's slope (error ∝ N^-slope, time ∝ N^slope), and below the first point, for time,
    proportional to N."""
    _, ns, vs, lns, lvs = _curve(model["points"])
    if n <= ns[0]:
        return vs[0] * (ns[0] / n) ** model["slope"] if error else vs[0] * n / ns[0]
    if n >= ns[-1]:
        k = -model["slope"] if error else model["slope"]
        return vs[-1] * (n / ns[-1]) ** k
    i = bisect.bisect_right(ns, n) - 1
    if error and steps:
        return vs[i]
    w = (math.log(n) - lns[i]) / (lns[i + 1] - lns[i])
    return math.exp((1 - w) * lvs[i] + w * lvs[i + 1])


def _leaf_factor(entry: dict, n: float) -> float:
    """A leaf variant's error factor against its setting's leaf-32 error at ``n`` (1 for the
    calibrated setting itself): the paired ratio measured at sizes around ``n``; beyond the
    measured sizes never below 1 (a smaller error is credited only where it was seen)."""
    f = float(entry.get("error_factor", 1.0))
    lo, hi = entry.get("factor_range", (0, math.inf))
    return f if lo / 1.5 <= n <= 1.5 * hi else max(f, 1.0)


def _interp_log_n(points, n: float) -> float:
    """``[[n, value], …]`` at ``n``: interpolated in log N, held beyond the ends; 1 if empty."""
    if not points:
        return 1.0
    _, ns, vs, lns, _ = _curve(points)
    if n <= ns[0]:
        return vs[0]
    if n >= ns[-1]:
        return vs[-1]
    i = bisect.bisect_right(ns, n) - 1
    w = (math.log(n) - lns[i]) / (lns[i + 1] - lns[i])
    return (1 - w) * vs[i] + w * vs[i + 1]


def _leaf_time_ratio(entry: dict, n: float) -> float:
    """A leaf variant's time against its setting's leaf-32 time at ``n`` (paired, one run)."""
    return _interp_log_n(entry.get("time_ratio"), n)


def _settings_with_leaves(table: dict):
    """(label, entry) of every calibrated setting and of each of its leaf variants
    (``leaf_variants``, from bench/leaf_size.py): the setting's keywords with that
    ``leaf_size``, its error and cost curves, the variant's ``error_factor`` and
    ``time_ratio``."""
    for label, entry in table["settings"].items():
        yield label, entry
        for leaf, variant in entry.get("leaf_variants", {}).items():
            yield f"{label} leaf={leaf}", dict(
                entry, keywords=dict(entry["keywords"], leaf_size=int(leaf)),
                error_factor=variant["error_factor"], factor_range=variant["n_range"],
                time_ratio=variant["time_ratio"])


def _predicted_time(entry: dict, n: float) -> float:
    return _loglog(entry["cost"], n, error=False) * _leaf_time_ratio(entry, n)


def _predicted_error(entry: dict, table: dict, n: float, e_occlusion,
                     scale: float = 1.0, sampling: bool = True) -> float | None:
    """The model's error of one calibrated setting at ``n`` surfels (None: not usable), its
    discretization part (the direct exact-visibility model) times ``scale`` (an adaptive
    sampling's ratio): what the setting adds to it (expansion, visibility model) stays. A leaf
    variant scales what its setting's error is measured against (the whole error with
    visibility, the expansion error without) by its factor. With ``sampling`` the kind's
    sampling factor scales the discretization part too (what moves from one sampling to
    the next), not what the setting adds."""
    kw = entry["keywords"]
    vis = kw.get("visibility", "none")
    factor = _leaf_factor(entry, n)
    spread = _sampling_factor(table, n) if sampling else 1.0
    if vis != "none":
        e = factor * _setting_error(entry, table, n)
        e_disc = (_discretization(table, n, sampling=False)
                  if scale != 1.0 or spread != 1.0 else None)
        if e_disc is None:
            return e
        e_rest2 = max(0.0, e * e - e_disc * e_disc)
        return math.sqrt((spread * scale * min(e_disc, e)) ** 2 + e_rest2)
    if e_occlusion is None:
        return None
    base = table["settings"].get(table.get("discretization", ""))
    if base is None:
        return None
    e_fmm = 0.0
    if kw["method"] == "fmm":
        row = min((t for t in FMM_ERROR if t >= kw["theta"]), default=max(FMM_ERROR))
        e_fmm = factor * FMM_ERROR[row].get(kw["order"], FMM_ERROR[row][0])
    e_disc = spread * scale * _loglog(base["error"], n, error=True, steps=_steps(table))
    return math.sqrt(e_disc ** 2 + e_fmm ** 2 + e_occlusion ** 2)


def _setting_error(entry: dict, table: dict, n: float) -> float:
    """A setting's calibrated error at ``n``. Beyond its largest measured size only the
    discretization part keeps falling, as the kind's direct curve does; what the setting adds
    there (its expansion and visibility model: sqrt(e² − e_disc²) at that size) is held, as a
    node-pair visibility model at fixed θ and leaf size converges far slower, if at all
    (bench/fmm_against_direct.py, Cornell box at 1927 / 4128 / 8295 surfels: the distance to
    the direct solution of the same surfels is 1.62 / 1.44 / 1.19% with all-pairs s = 16,
    θ = 0.3, and 11.3 / 7.1 / 7.0% in the default leaf mode, while the direct solution's own
    error falls from 3.4 to 1.2%)."""
    curve = entry["error"]
    steps = _steps(table)
    n_max = curve["points"][-1][0]
    base = table["settings"].get(table.get("discretization", ""))
    if n <= n_max or base is None or base["error"] is curve:   # the direct curve itself
        return _loglog(curve, n, error=True, steps=steps)
    e_max = _loglog(curve, n_max, error=True, steps=steps)
    d_max = _loglog(base["error"], n_max, error=True, steps=steps)
    d0 = min(d_max, e_max)   # continuous at n_max (the direct curve may be extrapolated there)
    rest2 = e_max * e_max - d0 * d0
    d = d0 * _loglog(base["error"], n, error=True, steps=steps) / d_max
    return math.sqrt(d * d + rest2)


def _sampling_factor(table: dict, n: float) -> float:
    """The kind's sampling factor at ``n`` (1 without one)."""
    return _interp_log_n(table.get("sampling", {}).get("points"), n)


def _discretization(table: dict, n: float, sampling: bool = True) -> float | None:
    """The kind's discretization model at ``n`` (the direct exact-visibility curve), with its
    sampling factor unless ``sampling`` is False."""
    base = table["settings"].get(table.get("discretization", ""))
    if base is None:
        return None
    e = _loglog(base["error"], n, error=True, steps=_steps(table))
    return e * _sampling_factor(table, n) if sampling else e


def _needed_n(entry, table, target, e_occlusion, n_min, cap, scale=1.0):
    """Smallest N in [n_min, cap] with predicted error <= target (None when none is)."""
    lo = max(n_min, 2)
    if _predicted_error(entry, table, lo, e_occlusion, scale) is None:
        return None
    if _predicted_error(entry, table, lo, e_occlusion, scale) <= target:
        return lo
    if _predicted_error(entry, table, cap, e_occlusion, scale) > target:
        return None
    if _steps(table):   # a step curve first meets the target at a measured size
        for n in sorted({p[0] for p in entry["error"]["points"]}):
            if lo < n <= cap and _predicted_error(entry, table, n, e_occlusion, scale) <= target:
                return int(n)
    hi = cap
    for _ in range(60):   # bisection on log N (the error decreases with N)
        mid = math.sqrt(lo * hi)
        if _predicted_error(entry, table, mid, e_occlusion, scale) <= target:
            hi = mid
        else:
            lo = mid
        if hi / lo < 1.01:
            break
    return int(math.ceil(hi))


def _candidates(table, s, fixed, target, e_occ, n_min, cap, allow_direct, scale=1.0,
                unoccluded_only=False):
    """Every calibrated setting with its N, predicted error and time, and whether it meets
    ``target`` (at the scene's own N when ``fixed``); ``order``: its place among them. With
    ``unoccluded_only`` the settings without visibility alone (the only ones ``e_occ``
    changes)."""
    out = []
    for order, (label, entry) in enumerate(_settings_with_leaves(table)):
        kw = entry["keywords"]
        if kw["method"] == "direct" and not allow_direct:
            continue
        if unoccluded_only and kw.get("visibility", "none") != "none":
            continue
        if fixed:   # the count the target needs is found for the chosen setting only
            n = s["n"]
            err = _predicted_error(entry, table, n, e_occ, scale)
            if err is None:
                continue
            need = None
            ok = err <= target
        else:
            need = _needed_n(entry, table, target, e_occ, n_min, cap, scale)
            n = need if need is not None else cap
            err = _predicted_error(entry, table, n, e_occ, scale)
            if err is None:
                continue
            ok = need is not None
        out.append(dict(label=label, entry=entry, n=n, need=need, error=err, ok=ok,
                        time=_predicted_time(entry, n), order=order))
    return out


def choose_settings(scene, target_error, *, kind: str | None = None, allow_direct: bool = True,
                    max_surfels: int | None = None, min_surfels: int | None = None,
                    probe="auto", discretization_scale: float = 1.0) -> dict:
    """Settings meeting ``target_error`` (relative RMS per surfel) at the least modelled time.

    scene : Surfels (its N is then fixed: the setting is chosen for it, and ``n`` reports the
        count the target needs), or a summary dict with at least ``n`` (surfels available:
        the points of a scan; any large number for meshes) and ``total_area`` (m²).
    target_error : float in (0, 1), or a preset name from :data:`PRESETS`.
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
    ``probe`` and ``notes``. Pass it to
    :func:`solve_keywords` for ``illumap.solve``.
    """
    target = _check_target(target_error)
    s = scene_summary(scene, kind)
    table = _kind_table(s["kind"])
    notes = []
    fixed = isinstance(scene, Surfels)
    cap = s["n"] if (fixed or s["kind"] == "point_cloud") else 10 ** 9
    if max_surfels is not None:
        cap = min(cap, int(max_surfels))
    n_min = min(max(int(table.get("n_min", DEFAULT_N_MIN)), int(min_surfels or 0)), cap)
    probe_info = probe if isinstance(probe, dict) else None

    def rank(e_occ, unoccluded_only=False):
        # aim a little below the target: the fits are of a few sampled scenes
        return _candidates(table, s, fixed, SAFETY * target, e_occ, n_min, cap, allow_direct,
                           float(discretization_scale), unoccluded_only=unoccluded_only)
    candidates = rank(None if probe_info is None else float(probe_info["error_none"]))
    if fixed and (probe is True or probe == "auto"):
        # probe when a setting without visibility could win were the scene unoccluded, and
        # ("auto") when that would save more than the probe costs
        meeting = [c for c in candidates if c["ok"]]
        best_time = min((c["time"] for c in meeting), default=math.inf)
        worth = probe is True or best_time > PROBE_WORTH
        if worth and any(c["ok"] and c["time"] < PROBE_GAIN * best_time
                         for c in rank(0.0, unoccluded_only=True)):
            probe_info = occlusion_probe(scene, kind=s["kind"],
                                         decisive=PROBE_DECISIVE * target)
            # without a probe the settings without visibility were left out; only they change
            candidates = sorted(candidates + rank(float(probe_info["error_none"]),
                                                  unoccluded_only=True),
                                key=lambda c: c["order"])
    e_occ = None if probe_info is None else float(probe_info["error_none"])
    if not candidates:
        raise InputError("illumap.accuracy: no calibrated setting applies")
    meeting = [c for c in candidates if c["ok"]]
    if meeting:
        best = min(meeting, key=lambda c: c["time"])
    else:
        best = min(candidates, key=lambda c: (c["error"], c["time"]))
        notes.append(f"no calibrated setting reaches {target:.3g} with {cap} surfels; "
                     f"the most accurate one is predicted at {best['error']:.3g}")
    kw = best["entry"]["keywords"]
    vis = kw.get("visibility", "none")
    if e_occ is None:
        notes.append("visibility: no occlusion probe (a summary, probe=False, or too small a "
                     "scene for it to pay off): visibility='none' not considered")
    else:
        notes.append(f"visibility: the probe puts the error of visibility='none' at "
                     f"{e_occ:.3g}")
    rho = min(s["albedo_max"], MAX_BOUND_ALBEDO)
    tol = float(min(1e-4, max(1e-8, 0.01 * target * (1 - rho) / 0.2)))
    if fixed:
        need = _needed_n(best["entry"], table, SAFETY * target, e_occ, n_min, 10 ** 9,
                         float(discretization_scale))
        n_out = need or s["n"]
    else:
        n_out = best["n"]
    e_disc = _discretization(table, n_out)
    if e_disc is not None:
        e_disc *= float(discretization_scale)
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
        tol=tol,
        error_tol=float(f"{SOLVER_ERROR_SHARE * target:.6g}"),
        label=best["label"],
        predicted=dict(total=float(best["error"]), discretization=e_disc,
                       occlusion=e_occ if vis == "none" else None),
        predicted_time=float(best["time"]),
        discretization_scale=float(discretization_scale),
        probe=probe_info,
        notes=notes,
    )


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


# --- a-posteriori estimate -------------------------------------------------------------------------

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


def bounce_gain(radiosity, surfels: Surfels, operator: TransportOperator) -> float:
    """How much an error made in one bounce grows over all of them, as the scene's own light
    did: ‖B − E‖ / ‖ρ K E‖ (all indirect light over its first bounce, RMS over the surfels),
    within [1, 1/(1 − ρ_max)]. One application of ``operator``. The bound 1/(1 − ρ_max) holds
    for any error; this gain is that of an error spread like the light (measured 1.4 on the
    Cornell box against 3.6 for the bound)."""
    bound = _neumann_bound(surfels)
    first = _rms(surfels.albedo * operator.apply(surfels.emission))
    if first <= 0.0:
        return bound
    indirect = _rms(np.asarray(radiosity) - surfels.emission)
    return float(min(max(indirect / first, 1.0), bound))


def estimate_error(solution, surfels: Surfels, *, operator: TransportOperator | None = None,
                   probe: int = 256, coarse: bool = False, settings: dict | None = None,
                   kind: str | None = None, seed: int = 0,
                   discretization_scale: float | None = None) -> dict:
    """A-posteriori estimate of the relative RMS error (emitters excluded) of ``solution``.

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
    amplification = _neumann_bound(surfels)
    non_emit = ~(surfels.emission.max(axis=1) > 0)
    if not non_emit.any():
        non_emit = np.ones(surfels.n, bool)
    b_rms = _rms(B[non_emit]) or 1.0
    e_norm = math.sqrt(float(np.sum(surfels.emission ** 2)))
    bound = stats.get("solver_error_bound")
    if bound is not None and math.isfinite(bound):   # the solve's own, over the same surfels
        e_solver = float(bound)
        if stats.get("solver_error_estimate") is not None:
            e_solver = min(e_solver, SOLVER_ESTIMATE_MARGIN * float(stats["solver_error_estimate"]))
    else:
        res = float(stats.get("final_residual", 0.0) or 0.0)
        e_solver = res * e_norm / math.sqrt(max(non_emit.sum(), 1)) * amplification / b_rms
    vis = stats.get("visibility", "none")
    # The solve's own visibility keywords (its stats), else the chosen ones, else the kind's.
    vis_kw = visibility_keywords(vis, kind if kind in EXACT_KEYWORDS else "random")
    if settings is not None:
        vis_kw = dict(settings.get("visibility_keywords", vis_kw))
    if vis != "none":
        vis_kw.update({k: stats[k] for k in VISIBILITY_DEFAULTS if k in stats})
    method = stats.get("method", "direct")
    e_fmm = 0.0
    gain = None
    rows = np.array([], dtype=np.int64)
    if method == "fmm":
        kw = {k: stats[k] for k in _OPERATOR_STATS if k in stats}
        kw.pop("method", None)
        if vis != "none":
            kw.update(vis_kw)
        if operator is None:
            operator = TransportOperator(surfels, method="fmm", **kw)
        candidates = np.flatnonzero(non_emit)
        rows = np.sort(rng.choice(candidates, min(probe, len(candidates)), replace=False))
        fmm_y = operator.apply(B)[rows]
        exact_y = operator.apply_rows(B, rows)   # exact per pair, same visibility
        diff = surfels.albedo[rows] * (fmm_y - exact_y)
        gain = bounce_gain(B, surfels, operator)
        e_fmm = _rms(diff) / (_rms(B[rows]) or 1.0) * gain
    e_occ = 0.0
    if vis == "none" and settings is not None and settings.get("predicted", {}).get("occlusion"):
        e_occ = float(settings["predicted"]["occlusion"])
    e_disc = None
    source = None
    if coarse:
        from .solver import solve as _solve
        half, half_areas = _even_half(surfels)
        sub = Surfels(surfels.positions[half], surfels.normals[half], half_areas,
                      surfels.albedo[half], surfels.emission[half])
        keys = {k: stats[k] for k in _OPERATOR_STATS if k in stats}
        if keys.get("method") == "direct":
            keys = {k: v for k, v in keys.items() if k in ("method", "near_field", "visibility")}
        if vis != "none":
            keys.update(vis_kw)
        coarse_sol = _solve(sub, tol=max(float(stats.get("tol", 1e-6)), 1e-10), **keys)
        m = non_emit[half]
        d = _rms(coarse_sol.radiosity[m] - B[half][m]) / (_rms(B[half][m]) or 1.0)
        e_disc = d / (math.sqrt(2.0) - 1.0)
        source = "coarse"
    elif CALIBRATION.get("kinds"):
        k = kind or (settings or {}).get("kind") or scene_summary(surfels)["kind"]
        e_disc = _discretization(_kind_table(k), surfels.n)
        if e_disc is not None:
            e_disc *= float(discretization_scale)
            source = "model"
    total = math.sqrt(e_solver ** 2 + e_fmm ** 2 + e_occ ** 2 + (e_disc or 0.0) ** 2)
    return dict(solver=e_solver, fmm=e_fmm, occlusion=e_occ, discretization=e_disc,
                discretization_source=source, total=total, numerical=e_solver + e_fmm,
                gain=gain, probe_rows=int(rows.size), seconds=time.perf_counter() - t0)


# --- one call ----------------------------------------------------------------------------------------

def solve(surfels: Surfels, target_error, *, kind: str | None = None, allow_direct: bool = True,
          estimate: bool = True, coarse: bool = False, settings: dict | None = None,
          discretization_scale: float = 1.0, progress=None, **overrides):
    """Choose settings for ``target_error`` (or use ``settings``, a :func:`choose_settings`
    result) and solve ``surfels``; ``stats["accuracy"]`` holds the chosen settings, the solve
    keywords and (``estimate=True``) the a-posteriori estimate. ``discretization_scale``: as
    in :func:`choose_settings` (ADAPTIVE_ERROR_RATIO for the second pass of an adaptive
    sampling). ``overrides`` replace chosen solve keywords (e.g. ``solver="jacobi"``)."""
    from .solver import solve as _solve
    chosen = settings if settings is not None else choose_settings(
        surfels, target_error, kind=kind, allow_direct=allow_direct,
        discretization_scale=discretization_scale)
    kw = solve_keywords(chosen)
    kw.update(overrides)
    sol = _solve(surfels, progress=progress, **kw)
    info = dict(settings=chosen, solve_keywords=kw)
    if estimate:
        info["estimate"] = estimate_error(sol, surfels, settings=chosen, coarse=coarse, kind=kind)
    sol.stats["accuracy"] = info
    return sol


# --- meshes: automatic density, adaptive ---------------------------------------------------------

#: Adaptive runs: pass 1 takes this share of the chosen count (its only use is to find where the
#: illumination varies), regions hold about this many pass-1 surfels, variation is measured
#: against this many neighbours, and density multipliers stay within [1, ADAPTIVE_MAX_RATIO].
ADAPTIVE_FIRST_SHARE = 0.5
ADAPTIVE_SURFELS_PER_REGION = 6
ADAPTIVE_NEIGHBOURS = 8
ADAPTIVE_MAX_RATIO = 4.0
#: Error of an adaptive run against a uniform one of the same count, as the count is chosen:
#: measured on the Cornell box's triangles against the 48k-surfel reference
#: (bench/bench_adaptive.py, bench/results/adaptive.json: 1.5k, 3k and 6k surfels, exact
#: visibility): 0.69-0.73 for the direct method, 0.69-0.81 for FMM settings, whose expansion
#: and visibility error the second pass does not lower. It scales the discretization part of a
#: setting's error only; 0.75 there (the direct method's range, rounded up) was optimistic: the
#: automatic mode at 10% chose 3152 surfels and measured 10.2% on the benchmark's sampling
#: (2026-12-01), so it takes the upper end measured for any setting.
ADAPTIVE_ERROR_RATIO = 0.8
#: Solve time of the second pass against a uniform pass of the same count and settings
#: (paired, bench/bench_adaptive.py, bench/results/adaptive.json, 2026-12-02): the median over
#: five settings at each count, interpolated in log N and held beyond. A varying density packs
#: surfels into fewer octree cells, whose near field (per-pair visibility rays) grows:
#: 0.97-1.41 at 1.5k, 0.84-1.37 at 3k, 0.85-1.15 at 6k, 0.97-1.86 at 12k surfels.
ADAPTIVE_TIME_RATIO = [[1447, 1.18], [2873, 0.96], [5731, 1.02], [11422, 1.39]]
#: Two passes run (uncapped) only where predicted at most this share of one uniform pass's
#: time, exp(-rms) of the time models' own error: each setting's largest swept size predicted
#: from the smaller ones (bench/calibrate.py's ``time_holdout``, kept in CALIBRATION: 0.42 rms
#: in log time; 0.66). Twice on the triangles at 5%, two passes predicted at
#: 0.78x one pass's time measured 1.28x and 1.35x, and missed the target on one sampling
#: (5.11%) where one pass met it. 0.7 without a hold-out in the calibration.
ADAPTIVE_TIME_MARGIN = (round(math.exp(-CALIBRATION["time_holdout"]["rms"]), 2)
                        if "time_holdout" in CALIBRATION else 0.7)
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
    first = _setting_time(two, ADAPTIVE_FIRST_SHARE * two["n"])   # same settings, its share
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
    return _interp_log_n(ADAPTIVE_TIME_RATIO, n)


def _setting_time(chosen: dict, n: float) -> float:
    """The modelled time of the setting ``chosen`` (a choose_settings result) at ``n``."""
    entry = dict(_settings_with_leaves(_kind_table(chosen["kind"])))[chosen["label"]]
    return _predicted_time(entry, n)


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
    target_error : relative RMS per surfel, or a preset name (:data:`PRESETS`).
    kind : the calibrated scene kind whose error model sets the count ("mesh": stratified
        samples of triangles, uniform density, as in bench/scenes.py ``cornell_mesh``; the
        second pass only lowers the error).
    adaptive : two passes where :func:`choose_mesh_settings` predicts them faster than one
        uniform pass (the uniform-density models' discretization part scaled by
        ADAPTIVE_ERROR_RATIO from ADAPTIVE_MIN_COUNT surfels up); pass 1 solves
        ADAPTIVE_FIRST_SHARE of the count, uniformly; pass 2
        resamples the full count with a density multiplier per region that grows with how
        much pass 1's luminance varies there (``illumap.sampling``), and solves again. Without
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
    from . import sampling
    from . import _core
    from .solver import solve as _solve
    c = np.asarray(corners, dtype=np.float64)
    rho = np.asarray(albedo, dtype=np.float64)
    emit = np.asarray(emission, dtype=np.float64)
    if rho.shape != (len(c), 3) or emit.shape != (len(c), 3):
        raise InputError(f"albedo and emission: expected shape (T, 3) = ({len(c)}, 3), got "
                         f"{rho.shape} and {emit.shape}")
    areas = sampling.triangle_areas(c)
    target = _check_target(target_error)
    chosen = choose_mesh_settings(
        dict(n=10 ** 9, total_area=float(areas.sum()), kind=kind, albedo_max=float(rho.max()),
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
        pts = np.ascontiguousarray(s1.positions)
        luminance = sol1.radiosity @ np.array([0.2126, 0.7152, 0.0722])
        k = min(ADAPTIVE_NEIGHBOURS + 1, s1.n)
        idx, _ = _core.knn(pts, pts, k)
        variation = sampling.local_variation(luminance, np.asarray(idx)[:, 1:])
        regions = sampling.Regions.build(c, ADAPTIVE_SURFELS_PER_REGION * areas.sum() / s1.n)
        located = regions.locate(first.triangle[mask], first.bary[mask])
        # regions too small to hold a pass-1 surfel take the variation of the nearest one
        nearest, _ = _core.knn(pts, np.ascontiguousarray(regions.corners.mean(axis=1)), 1)
        weights = sampling.density_multipliers(located, variation, regions.count,
                                               max_ratio=ADAPTIVE_MAX_RATIO,
                                               fill=variation[np.asarray(nearest)[:, 0]])
        second = sampling.sample_triangles(regions.corners, count, rng, weights=weights)
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
