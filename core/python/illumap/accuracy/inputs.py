"""What the automatic mode is asked: a target error (a number or a named preset) and a scene
(Surfels, or a summary of one)."""

from __future__ import annotations

import numpy as np

from ..limits import limit
from ..surfels import InputError, Surfels

#: A surfel count that stands for "no limit": meshes can be sampled at any count (a scene
#: summary's ``n`` for meshes, the cap when nothing caps the count).
NO_SURFEL_LIMIT = 10 ** 9

#: Target error of each named preset (``target_error="medium"``).
TARGET_PRESETS = {"draft": 0.10, "preview": 0.10, "medium": 0.03, "high": 0.01, "final": 0.01,
                  "reference": 0.003}


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


def check_target(target_error) -> float:
    if isinstance(target_error, str):
        key = target_error.lower()
        if key not in TARGET_PRESETS:
            raise InputError(f"target_error: unknown preset {target_error!r}; "
                             f"expected a number or one of {sorted(TARGET_PRESETS)}")
        return TARGET_PRESETS[key]
    if isinstance(target_error, bool):
        raise InputError(f"target_error: expected a number, got {target_error!r}")
    try:
        t = float(target_error)
    except (TypeError, ValueError):
        raise InputError(f"target_error: expected a number, got {target_error!r}") from None
    lim = limit("target_error")
    if not lim.contains(t):
        raise InputError(f"target_error: expected a relative error in {lim.interval()}, "
                         f"got {target_error!r}")
    return t
