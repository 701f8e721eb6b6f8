"""Error and time models: a calibrated setting's predicted error and wall time at N surfels.

Curves are interpolated log-log between the measured sizes (steps on grids) and extrapolated
with their fitted slopes; an error splits into a discretization part (the kind's direct
exact-visibility curve, scaled by the sampling factor and an adaptive sampling's ratio) and
what the setting adds (expansion, visibility model); leaf variants scale both by their paired
ratios. :func:`needed_n` inverts a model: the fewest surfels that meet a target.
"""

from __future__ import annotations

import bisect
import math

from . import calibration
from .calibration import FMM_ERROR, kind_table

#: Scene kinds whose error curves are steps between the measured sizes (the value at the
#: measured size below), not log-log interpolations: on grids the error is not monotone in N
#: (grid lines move across shadow and light edges: on the Cornell box 3.25% at 2437 surfels,
#: between 3.16% at 1927 and 2.22% at 4128), and the interpolation missed its 3% target there.
STEP_KINDS = ("grid",)


def _steps(table: dict) -> bool:
    kinds = calibration.CALIBRATION.get("kinds", {})
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


def loglog(model: dict, n: float, *, error: bool, steps: bool = False) -> float:
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


def interp_log_n(points, n: float) -> float:
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
    return interp_log_n(entry.get("time_ratio"), n)


def settings_with_leaves(table: dict):
    """(label, entry) of every calibrated setting and of each of its leaf variants
    (``leaf_variants``, from bench/calibration/leaf_size.py): the setting's keywords with that
    ``leaf_size``, its error and cost curves, the variant's ``error_factor`` and
    ``time_ratio``."""
    for label, entry in table["settings"].items():
        yield label, entry
        for leaf, variant in entry.get("leaf_variants", {}).items():
            yield f"{label} leaf={leaf}", dict(
                entry, keywords=dict(entry["keywords"], leaf_size=int(leaf)),
                error_factor=variant["error_factor"], factor_range=variant["n_range"],
                time_ratio=variant["time_ratio"])


def predicted_time(entry: dict, n: float) -> float:
    return loglog(entry["cost"], n, error=False) * _leaf_time_ratio(entry, n)


def predicted_error(entry: dict, table: dict, n: float, e_occlusion,
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
    spread = sampling_factor(table, n) if sampling else 1.0
    if vis != "none":
        e = factor * setting_error(entry, table, n)
        e_disc = (discretization(table, n, sampling=False)
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
    e_disc = spread * scale * loglog(base["error"], n, error=True, steps=_steps(table))
    return math.sqrt(e_disc ** 2 + e_fmm ** 2 + e_occlusion ** 2)


def setting_error(entry: dict, table: dict, n: float) -> float:
    """A setting's calibrated error at ``n``. Beyond its largest measured size only the
    discretization part keeps falling, as the kind's direct curve does; what the setting adds
    there (its expansion and visibility model: sqrt(e² − e_disc²) at that size) is held, as a
    node-pair visibility model at fixed θ and leaf size converges far slower, if at all
    (bench/micro/fmm_against_direct.py, Cornell box at 1927 / 4128 / 8295 surfels: the distance to
    the direct solution of the same surfels is 1.62 / 1.44 / 1.19% with all-pairs s = 16,
    θ = 0.3, and 11.3 / 7.1 / 7.0% in the default leaf mode, while the direct solution's own
    error falls from 3.4 to 1.2%)."""
    curve = entry["error"]
    steps = _steps(table)
    n_max = curve["points"][-1][0]
    base = table["settings"].get(table.get("discretization", ""))
    if n <= n_max or base is None or base["error"] is curve:   # the direct curve itself
        return loglog(curve, n, error=True, steps=steps)
    e_max = loglog(curve, n_max, error=True, steps=steps)
    d_max = loglog(base["error"], n_max, error=True, steps=steps)
    d0 = min(d_max, e_max)   # continuous at n_max (the direct curve may be extrapolated there)
    rest2 = e_max * e_max - d0 * d0
    d = d0 * loglog(base["error"], n, error=True, steps=steps) / d_max
    return math.sqrt(d * d + rest2)


def sampling_factor(table: dict, n: float) -> float:
    """The kind's sampling factor at ``n`` (1 without one)."""
    return interp_log_n(table.get("sampling", {}).get("points"), n)


def discretization(table: dict, n: float, sampling: bool = True) -> float | None:
    """The kind's discretization model at ``n`` (the direct exact-visibility curve), with its
    sampling factor unless ``sampling`` is False."""
    base = table["settings"].get(table.get("discretization", ""))
    if base is None:
        return None
    e = loglog(base["error"], n, error=True, steps=_steps(table))
    return e * sampling_factor(table, n) if sampling else e


def needed_n(entry, table, target, e_occlusion, n_min, cap, scale=1.0):
    """Smallest N in [n_min, cap] with predicted error <= target (None when none is)."""
    lo = max(n_min, 2)
    if predicted_error(entry, table, lo, e_occlusion, scale) is None:
        return None
    if predicted_error(entry, table, lo, e_occlusion, scale) <= target:
        return lo
    if predicted_error(entry, table, cap, e_occlusion, scale) > target:
        return None
    if _steps(table):   # a step curve first meets the target at a measured size
        for n in sorted({p[0] for p in entry["error"]["points"]}):
            if lo < n <= cap and predicted_error(entry, table, n, e_occlusion, scale) <= target:
                return int(n)
    hi = cap
    for _ in range(60):   # bisection on log N (the error decreases with N)
        mid = math.sqrt(lo * hi)
        if predicted_error(entry, table, mid, e_occlusion, scale) <= target:
            hi = mid
        else:
            lo = mid
        if hi / lo < 1.01:
            break
    return int(math.ceil(hi))


def setting_time(chosen: dict, n: float) -> float:
    """The modelled time of the setting ``chosen`` (a choose_settings result) at ``n``."""
    entry = dict(settings_with_leaves(kind_table(chosen["kind"])))[chosen["label"]]
    return predicted_time(entry, n)
