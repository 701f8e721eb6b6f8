"""How many worker threads the native core uses: Blender's own thread setting, passed through.

The core reads ``ILLUMAP_THREADS`` on every call, and without it uses every CPU the process may
use (its CPU affinity and its cgroup's CPU limit; ``core/src/parallel.hpp``). The add-on and
the batch command set that variable from Blender's thread setting before each run
(``apply``):

1. ``ILLUMAP_THREADS`` set in the environment Blender started with wins: a farm slot's own
   setting, the most specific to Illumap.
2. Otherwise Blender's count, ``scene.render.threads``: Blender's ``-t``/``--threads`` when
   given (it overrides the scene in Blender too), else the scene's Fixed thread count
   (Render Properties > Performance > Threads).
3. Otherwise (Auto-detect, no ``-t``) the variable is left unset and the core counts the CPUs
   it may use, which, unlike a plain hardware count, honours a container's CPU limit. An
   Auto-detect count below ``os.cpu_count()`` (Blender already counted an affinity mask) is
   passed through too.

``scripts/blender`` (the stand-in for Blender on machines with only the ``bpy`` module) cannot
set Blender's internal ``-t`` override, so it passes ``-t N`` on as ``ILLUMAP_THREADS=N``.
The result does not depend on the thread count (docs/user_guide.md).
"""

from __future__ import annotations

import os

ENV = "ILLUMAP_THREADS"
#: ``ILLUMAP_THREADS`` as the process started with it (None: unset): a user's or a farm's
#: own value, which ``apply`` never replaces.
_STARTUP_VALUE = os.environ.get(ENV)


def _positive(text) -> int | None:
    try:
        n = int(str(text).strip())
    except (TypeError, ValueError):
        return None
    return n if 0 < n <= 4096 else None


def available_cpus() -> int:
    """The CPUs this process may use, as far as Python sees them (its affinity mask); the
    core also applies the cgroup's CPU limit."""
    try:
        return len(os.sched_getaffinity(0)) or 1
    except (AttributeError, OSError):
        return os.cpu_count() or 1


def worker_threads(scene, startup_value: str | None = None,
                   cpu_count: int | None = None) -> tuple[int | None, str]:
    """(threads to ask the core for or None for its own default, where that came from).

    ``startup_value``: ``ILLUMAP_THREADS`` as the process started (default: as read when this
    module was imported); ``cpu_count``: the hardware's count (default ``os.cpu_count()``)."""
    startup = _STARTUP_VALUE if startup_value is None else startup_value
    own = _positive(startup) if startup else None
    if own is not None:
        return own, f"{ENV} in the environment"
    render = getattr(scene, "render", None)
    if render is not None:
        blender = _positive(getattr(render, "threads", 0))
        mode = getattr(render, "threads_mode", "AUTO")
        if blender is not None and mode == "FIXED":
            return blender, "Blender's thread setting (Fixed, or -t)"
        hardware = cpu_count if cpu_count is not None else (os.cpu_count() or 1)
        if blender is not None and blender < hardware:
            return blender, "Blender's thread count (-t, or the CPUs it may use)"
    return None, "the CPUs this process may use: its affinity and cgroup limit"


def apply(scene) -> tuple[int, str]:
    """Set (or clear) ``ILLUMAP_THREADS`` for the core from Blender's setting before a run;
    returns (the worker threads the core will use, where that count came from)."""
    count, source = worker_threads(scene)
    if _positive(_STARTUP_VALUE or "") is None:
        if count is None:
            os.environ.pop(ENV, None)
        else:
            os.environ[ENV] = str(count)
    return (count if count is not None else available_cpus()), source
