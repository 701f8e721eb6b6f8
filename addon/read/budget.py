"""What a run may spend, planned from the settings before anything is sampled: the memory a
surfel count needs, the surfel density a target error asks for (the error models), the target
the surfels are solved to, the shadow rays, the occluders' shape. Numpy and the core's
``illumap.accuracy``; no bpy."""

from __future__ import annotations

import math
import os


from illumap.settings import Settings
# What a run spends is the core's (``illumap.stages.choices``); named here for the planning.
from illumap.stages.choices import (SURFEL_COVERAGE, occluder_shape,  # noqa: F401
                                    surfel_shadow_samples, surfel_target)

from ..errors import ExitCode, IllumapError


# Rough peak memory per surfel for sampling, solver vectors and the FMM tree (bytes). Used to
# refuse budgets that cannot fit before anything is allocated.
BYTES_PER_SURFEL = 2048


def memory_limit(settings: Settings) -> int:
    """The byte limit runs are checked against (settings, else half the physical memory)."""
    if settings.memory_limit:
        return int(settings.memory_limit)
    try:
        return os.sysconf("SC_PHYS_PAGES") * os.sysconf("SC_PAGE_SIZE") // 2
    except (ValueError, OSError, AttributeError):
        return 8 << 30


def _mesh_share(budget: int, mesh_area: float, point_area: float, meshes: int) -> int:
    """The meshes' part of the default budget beside point clouds: their share of the whole
    surface (m²), so that a lamp-sized emitter beside a scan is not given the whole budget."""
    if point_area <= 0:
        return budget
    return max(meshes, int(round(budget * mesh_area / (mesh_area + point_area))))


def check_memory(count: int, settings: Settings) -> None:
    """Refuse a surfel count whose estimated memory exceeds the limit, with the estimate."""
    need = int(count) * BYTES_PER_SURFEL
    limit = memory_limit(settings)
    if need > limit:
        raise IllumapError(
            f"{count:,} surfels would need about {need / 2**30:.1f} GiB "
            f"(~{BYTES_PER_SURFEL} bytes each), more than the {limit / 2**30:.1f} GiB allowed; "
            "lower the density or the surfel budget")


def adaptive_error_ratio_applies(settings: Settings) -> bool:
    """Whether this run's adaptive passes are those the core's ADAPTIVE_ERROR_RATIO was
    measured with (first pass share and density bound): then the error model may count on it."""
    from illumap import accuracy
    return (settings.adaptive
            and math.isclose(settings.adaptive_first_pass, accuracy.ADAPTIVE_FIRST_SHARE)
            and math.isclose(settings.adaptive_max_ratio, accuracy.ADAPTIVE_MAX_RATIO))


def target_density(settings: Settings, mesh_area: float, point_count: int, point_area: float,
                   stats: dict) -> tuple[float, dict] | None:
    """Surfels per m² for meshes that the error model says meet ``settings.target_error``,
    and the settings it chose for that count (``illumap.accuracy.choose_mesh_settings``: the
    "mesh" kind, calibrated on stratified triangle samples as ``sampling`` draws them, with the
    adaptive error ratio when two passes run; scans alone: ``choose_settings``, kind
    "point_cloud"). The budget, when set, caps the count. Fills ``stats['density']`` with the
    choice. None without a target error."""
    if settings.target_error is None:
        return None
    from illumap import accuracy
    total = mesh_area + point_area
    kind = "mesh" if mesh_area > 0 else "point_cloud"
    cap = settings.budget if settings.budget else None
    if kind == "point_cloud":
        cap = point_count
    # meshes are sampled at any count, a scan has its points
    summary = dict(n=accuracy.NO_SURFEL_LIMIT if kind == "mesh" else max(point_count, 1),
                   total_area=total, kind=kind)
    try:
        if kind == "mesh":
            chosen = accuracy.choose_mesh_settings(summary, surfel_target(settings), kind=kind,
                                                   adaptive=adaptive_error_ratio_applies(settings),
                                                   max_surfels=cap)
        else:
            chosen = accuracy.choose_settings(summary, surfel_target(settings), kind=kind,
                                              max_surfels=cap)
    except (ValueError, KeyError) as exc:  # InputError is a ValueError
        raise IllumapError(f"Cannot choose a surfel density for target error "
                           f"{settings.target_error:g}: {exc}", ExitCode.INPUT) from None
    density = chosen["n"] / total
    predicted = chosen.get("predicted") or {}
    disc = predicted.get("discretization")
    if disc is None:
        disc = predicted.get("total", float("nan"))
    stats["density"] = dict(target_error=float(settings.target_error), kind=kind,
                            density=float(density), surfels=int(chosen["n"]),
                            predicted_discretization=float(disc),
                            discretization_scale=float(chosen["discretization_scale"]),
                            surfel_target=float(surfel_target(settings)),
                            predicted=float(predicted.get("total", float("nan"))),
                            reached=bool(chosen.get("reached", True)), cap=cap,
                            notes=list(chosen.get("notes", [])))
    return density, chosen


def capped_target_warning(density: dict) -> str | None:
    """What to tell a user whose target error the surfel count cannot reach: the budget (or a
    scan's points) caps it below what the error model needs. None when the target is within
    reach. ``density`` is ``stats['density']`` from ``target_density``."""
    if density.get("reached", True):
        return None
    wanted = density["surfel_target"]
    where = ("above the target" if wanted == density["target_error"] else
             f"where the target leaves them {wanted:.1%} (they carry the indirect light)")
    predicted = f"the surfels are predicted at {density['predicted']:.1%} error {where}"
    head = f"Target error {density['target_error']:.2%} may not be met"
    cap = density.get("cap")
    if cap is None:
        return f"{head}: at the most surfels the error model covers, {predicted}; loosen the target"
    if density["kind"] == "point_cloud":
        limit, remedy = f"the scans' {cap:,} points cap", "a denser scan or a looser target"
    else:
        limit, remedy = f"the surfel budget of {cap:,} caps", "raise the budget or clear it"
    return f"{head}: {limit} the surfels, and {predicted}; {remedy}"
