"""What a run may spend, planned from the settings before anything is sampled: the memory a
surfel count needs, the surfel density a target error asks for (the error models), the target
the surfels are solved to, the shadow rays, the occluders' shape. Numpy and the core's
``illumap.accuracy``; no bpy."""

from __future__ import annotations

import math
import os


from illumap import lights
from illumap.settings import Settings
from illumap.settings import spec as setting_spec

from .errors import ExitCode, IllumapError
from .receive import target_shadow_samples


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


#: Disc radius of the surfels as occluders, in units of each surfel's own radius sqrt(A/π):
#: for lamp shadows (``make_segment_query``) and for exact visibility between surfels
#: (``TransportOperator``'s ``coverage``), so both see the same walls. Holes in a stratified
#: surfel set reach 1.7 of that radius inside a surface and 2.2 at its outline. Too small leaks
#: light, too large darkens: discs overhang outlines and block pairs that see each other.
#: Measured for 1.3 (the core's default) / 1.5 / 1.7 / 2.0:
#: * lamp shadows, a 1 m plate over a floor (100 and 400 surfels/m², four lamp types, 16 rays
#:   per surfel): the worst umbra surfel keeps 31–50% / 19% / 6% (one ray in 16) / 0%.
#: * interreflection through a one-sided thin wall between two rooms (High preset, 400/m²;
#:   tests/blender/light/test_thin_wall.py): the dark room gets 1.4–1.5% / 0.10–0.17% / 0.04–0.06% /
#:   0.03–0.04% of the lit room's level (0.08–0.09% / 0.02% / 0.01% / 0.01% at 1600/m²; a
#:   two-sided wall leaks ten times less).
#: * over-occlusion, a closed box holding a block, where every row of F·V sums to 1: mean
#:   |row sum − 1| 0.041 / 0.049 / 0.058 / 0.074 at 400/m² (0.020 / 0.024 / 0.029 / 0.037 at
#:   1600/m²; 0.024 and 0.012 without the block or visibility, the operator's own error).
#: * against a Cycles bake of a box with a lamp-shadowing block (tests/blender/
#:   test_bake_compare.py, this value for both uses): relative RMS 0.065 / 0.074 / 0.084 / 0.103,
#:   mean ratio 0.988 / 0.975 / 0.962 / 0.942.
#: 1.7 keeps speckles out of lamp shadows and light out of closed rooms; the price is a few
#: per cent less light in enclosed scenes, shrinking with density.
SURFEL_COVERAGE = 1.7


def occluder_shape(settings: Settings) -> str:
    """The occluder shape this run uses for lamp shadows and exact visibility alike: the
    settings' own, except with a target error, whose models are calibrated on discs.
    Raises IllumapError (exit code 2) for an unknown shape."""
    shapes = setting_spec("occluder_shape").values
    shape = str(settings.occluder_shape).lower()
    if shape not in shapes:
        raise IllumapError(f"Unknown occluder shape '{settings.occluder_shape}' (choose "
                           f"{', '.join(shapes)})", ExitCode.USAGE)
    return "disc" if settings.target_error is not None else shape


def adaptive_error_ratio_applies(settings: Settings) -> bool:
    """Whether this run's adaptive passes are those the core's ADAPTIVE_ERROR_RATIO was
    measured with (first pass share and density bound): then the error model may count on it."""
    from illumap import accuracy
    return (settings.adaptive
            and math.isclose(settings.adaptive_first_pass, accuracy.ADAPTIVE_FIRST_SHARE)
            and math.isclose(settings.adaptive_max_ratio, accuracy.ADAPTIVE_MAX_RATIO))


#: With the light evaluated at the meshes (``receive``), the surfels only carry the indirect
#: light, a fraction of what a receiver sees, and the final gather averages their error over
#: its rays: the surfels are solved to this multiple of the target error, at most
#: MAX_SURFEL_TARGET. bench/reference, every scene against its Cycles bake (one run,
#: 2026-12-06): at 5 each target was met with room to spare (10%: 1.4-4.6%, 3%: 0.8-2.0%,
#: 1%: 0.39-0.75%) in about half the time it took at 3 (3%: 0.35-0.62 s instead of 0.73-1.25 s).
RECEIVER_TARGET_RATIO = 5.0


MAX_SURFEL_TARGET = 0.3


def surfel_target(settings: Settings) -> float | None:
    """The target error the surfel solve is held to: the settings' own, or a multiple of it
    when the light is evaluated at the meshes (RECEIVER_TARGET_RATIO)."""
    t = settings.target_error
    if t is None or not settings.transfer:
        return t
    return min(MAX_SURFEL_TARGET, RECEIVER_TARGET_RATIO * t)


def surfel_shadow_samples(settings: Settings) -> int:
    """Shadow rays per surfel and sized lamp (the world's too, up to ``lights.WORLD_SAMPLES``):
    the settings' own, or with a target error at least what a receiver casts for the surfels'
    target (``surfel_target``), at most ``lights.WORLD_SAMPLES``. Each surfel's direct light is
    a sample whose noise every receiver that gathers it takes in: in a room lit through a
    window (the bench's ``window``, Target 1%) the sky seen through it with 16 rays per surfel
    moved the walls by about 1% from one sampling to the next; 32 rays took the scene from
    1.38% to 1.24% against Cycles (64: 1.21%, for twice the rays), the other bench scenes as
    before."""
    own = int(settings.shadow_samples)
    target = surfel_target(settings)
    if target is None:
        return own
    return max(own, min(target_shadow_samples(target), lights.WORLD_SAMPLES))


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
