"""Checks that refuse a run before it does work that cannot give a useful result (no bpy):
settings outside what the core accepts (``check_settings``, before anything is read), raised
as an ``IllumapError`` that names the setting. A scene whose light reaches no surface is the
core's to refuse (``illumap.stages.light.check_light``, after the direct light, before the
solve).
"""

from __future__ import annotations

from illumap.limits import limit
from illumap.settings import SettingsError, check

from .errors import ExitCode, IllumapError

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
