"""Checks that refuse a run before it does work that cannot give a useful result (numpy only,
no bpy): settings outside what the core accepts (``check_settings``, before anything is read)
and a scene whose light reaches no surface (``check_light``, after the direct light, before the
solve). Each raises an ``IllumapError`` whose message names the setting, lamp or object and the
real cause.
"""

from __future__ import annotations

import numpy as np
from illumap.limits import limit
from illumap.settings import SettingsError, check

from .errors import ExitCode, IllumapError, NoLightError

# The limits of the settings are illumap.limits' (one table for the UI, the core and here).
#: The largest sampling seed (the core's ray seeds are unsigned 64-bit; numpy takes any).
MAX_SEED = limit("seed").high
#: The largest lightmap side in pixels.
MAX_LIGHTMAP_SIZE = limit("lightmap_size").high


def max_order() -> int:
    """The highest FMM expansion order (``illumap.limits``)."""
    return int(limit("order").high)


def check_settings(settings) -> None:
    """Refuse settings (``illumap.settings.Settings``) that the core would reject deep in a
    run, or with a raw type error, by the one declaration of the settings and their limits
    (``illumap.settings.check``). Raises IllumapError (``ExitCode.USAGE``) naming the
    setting."""
    try:
        check(settings)
    except SettingsError as exc:
        raise IllumapError(str(exc), ExitCode.USAGE) from None


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
