"""What a run spends, chosen from its settings (no bpy): the occluders' size and shape, the
target error the surfels are solved to, and their shadow rays per lamp."""

from __future__ import annotations

from .. import lights
from ..gather.rays import target_shadow_samples
from ..settings import Settings, SettingsError
from ..settings import spec as setting_spec


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
    Raises SettingsError for an unknown shape."""
    shapes = setting_spec("occluder_shape").values
    shape = str(settings.occluder_shape).lower()
    if shape not in shapes:
        raise SettingsError(f"Unknown occluder shape '{settings.occluder_shape}' (choose "
                            f"{', '.join(shapes)})")
    return "disc" if settings.target_error is not None else shape


#: With the light evaluated at the meshes (``illumap.gather``), the surfels only carry the indirect
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
