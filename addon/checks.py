"""Checks that refuse a run before it does work that cannot give a useful result (numpy only,
no bpy): settings outside what the core accepts (``check_settings``, before anything is read)
and a scene whose light reaches no surface (``check_light``, after the direct light, before the
solve). Each raises an ``IllumapError`` whose message names the setting, lamp or object and the
real cause.
"""

from __future__ import annotations

import math
import numbers

import numpy as np

from .errors import ExitCode, IllumapError, NoLightError

#: The largest count the native core takes (a C ``int``): rays, samples, leaf sizes...
MAX_INT32 = 2 ** 31 - 1
#: The largest sampling seed (the core's ray seeds are unsigned 64-bit; numpy takes any).
MAX_SEED = 2 ** 63 - 1
#: The largest lightmap side in pixels (a 16k × 16k float RGBA lightmap is 4 GiB).
MAX_LIGHTMAP_SIZE = 16384


def max_order() -> int:
    """The highest FMM expansion order: the core's one constant (``illumap.operator``)."""
    from illumap.operator import MAX_ORDER
    return int(MAX_ORDER)


def _fail(message: str) -> None:
    raise IllumapError(f"Invalid setting {message}", ExitCode.USAGE)


def _integer(name: str, value, low: int, high: int = MAX_INT32, optional: bool = False) -> None:
    if value is None and optional:
        return
    if isinstance(value, bool) or not isinstance(value, numbers.Integral) \
            or not low <= int(value) <= high:
        _fail(f"{name}: expected an integer >= {low} and <= {high}, got {value!r}")


def _number(name: str, value, low: float, high: float | None, *, open_low=True,
            open_high=True, optional: bool = False) -> None:
    if value is None and optional:
        return
    ok = (not isinstance(value, bool) and isinstance(value, numbers.Real)
          and math.isfinite(float(value)))
    if ok:
        x = float(value)
        ok = (x > low if open_low else x >= low) and \
            (high is None or (x < high if open_high else x <= high))
    if not ok:
        lo = "(" if open_low else "["
        hi = "inf)" if high is None else (f"{high:g})" if open_high else f"{high:g}]")
        _fail(f"{name}: expected a number in {lo}{low:g}, {hi}, got {value!r}")


def _choice(name: str, value, choices) -> None:
    if not isinstance(value, str) or value.lower() not in choices:
        _fail(f"{name}: expected one of {', '.join(choices)}, got {value!r}")


def check_settings(settings) -> None:
    """Refuse settings (``pipeline.Settings``) that the core would reject deep in a run, or
    with a raw type error (integers of 2^31 or more, NaN tolerances, an FMM order above the
    native limit). Raises IllumapError (``ExitCode.USAGE``) naming the setting."""
    s = settings
    _number("density", s.density, 0.0, None, optional=True)
    _integer("budget", s.budget, 1, 2 ** 62, optional=True)
    _choice("method", s.method, ("fmm", "direct"))
    _integer("order", s.order, 0, max_order())
    _number("theta", s.theta, 0.0, 1.0)
    _integer("leaf_size", s.leaf_size, 1)
    _choice("near_field", s.near_field, ("disc", "point"))
    _choice("visibility", s.visibility, ("none", "seed", "exact"))
    _choice("solver", s.solver, ("auto", "cg", "gmres", "jacobi"))
    _number("tol", s.tol, 0.0, 1.0)
    _integer("max_iterations", s.max_iterations, 1)
    t = s.target_error
    if t is not None and (isinstance(t, bool) or not isinstance(t, numbers.Real)
                          or not 0.0 < float(t) < 1.0):   # NaN fails too
        raise IllumapError(f"Target error must lie in (0, 1), got {t!r}", ExitCode.USAGE)
    _number("adaptive_first_pass", s.adaptive_first_pass, 0.0, 1.0, open_high=False)
    _number("adaptive_max_ratio", s.adaptive_max_ratio, 1.0, None, open_low=False)
    _integer("shadow_samples", s.shadow_samples, 1)
    _integer("gather_rays", s.gather_rays, 1)
    _integer("receiver_shadow_samples", s.receiver_shadow_samples, 1)
    _choice("transfer_domain", s.transfer_domain, ("point", "corner"))
    _integer("seed", s.seed, 0, MAX_SEED)
    _integer("memory_limit", s.memory_limit, 1, 2 ** 62, optional=True)
    _integer("lightmap_size", s.lightmap_size, 1, MAX_LIGHTMAP_SIZE)


def _names(items, limit: int = 3) -> str:
    names = [f"'{n}'" for n in items]
    return ", ".join(names[:limit]) + (f" and {len(names) - limit} more" if len(names) > limit
                                       else "")


def check_light(job) -> None:
    """Refuse a job (``pipeline.Job`` after ``pipeline.light``) whose surfels receive no
    light and emit none: its map would be black. Says whether the scene has no light at all
    (no lamps, no emissive materials, no world light) or has lamps that light no surface
    (every surface faces away, lies in shadow or outside a spot's cone). Raises NoLightError;
    the pipeline skips the solve, and nothing is written."""
    emission = np.asarray(job.emission)
    direct = np.zeros(0) if job.direct is None else np.asarray(job.direct)
    if (emission > 0).any() or (direct > 0).any():
        return
    s = job.settings
    lamps = [lamp.name for lamp in list(job.lamps) + list(job.emitters)]
    lamp_notes = [w for w in job.warnings if w.startswith("Lamp '")]
    end = ("so the map would be black: solve skipped, nothing written.")
    if lamps:
        one = len(lamps) == 1
        raise NoLightError(
            f"The lamp{'' if one else 's'} {_names(lamps)} light{'s' if one else ''} none of "
            f"the surfaces (every surface of the {job.count} surfels faces away from "
            f"{'it' if one else 'them'}, lies in shadow or outside the cone), {end} Turn the "
            "lamp towards the objects, or check the objects' normals.")
    hints = []
    if not s.lamps:
        hints.append("the lamps are switched off (Lamps setting, batch --no-lamps)")
    if not s.world_ambient:
        hints.append("World Light is off (batch: without --no-world it is on)")
    elif job.world is None:
        hints.append("the world is black or absent")
    else:
        hints.append("the world's light reaches none of the surfaces")
    hints += lamp_notes
    raise NoLightError(
        "No light in the scene: no lamps, no emissive materials and no world light reach the "
        f"{job.count} surfels, {end} Add a lamp or an Emission material"
        + ("; " + "; ".join(hints) if hints else "") + ".")
