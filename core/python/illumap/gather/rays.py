"""How many rays the final gather casts per receiver (no bpy): the settings' own, or with a
target error the fewest whose noise stays within its share of the target; and what to tell a
user whose target the gather's own noise already exceeds."""

from __future__ import annotations

from ..settings import Settings


#: With a target error, the gather's noise (relative RMS over the receivers, estimated from
#: the halves of each receiver's ray lattice: ``stats['receivers']['gather_noise']``) is held
#: to this share of the target; its rays, a power of two in [MIN_TARGET_RAYS,
#: MAX_TARGET_RAYS], follow from noise = NOISE_AT_512_RAYS × (512 / rays)^NOISE_EXPONENT. On
#: the bench scenes the estimate was 1.4-2.0% at 64 rays, 0.28-0.37% at 512 and 0.08-0.10% at
#: 2048 (the lattice converges as rays^-0.8, not ^-0.5), and 1.45-2.3x the noise measured
#: with a second seed (bench/reference/gather_noise.py).
GATHER_NOISE_SHARE = 0.5
NOISE_AT_512_RAYS = 0.004
NOISE_EXPONENT = 0.75
MIN_TARGET_RAYS = 64
MAX_TARGET_RAYS = 2048
#: The shadow samples per receiver for a target: ∝ 1/target², a power of two in
#: [MIN_TARGET_SHADOW_SAMPLES, MAX_TARGET_SHADOW_SAMPLES] (no estimate of their noise yet; the
#: counts the bench's targets were met with: bench/results/reference_targets.json).
SHADOW_SAMPLES_AT_2_PERCENT = 128
MIN_TARGET_SHADOW_SAMPLES = 16
MAX_TARGET_SHADOW_SAMPLES = 512


def _power_of_two(wanted: float, low: int, high: int) -> int:
    """The least power of two ≥ ``wanted`` within [low, high] (both powers of two)."""
    count = low
    while count < wanted * (1.0 - 1e-9) and count < high:
        count *= 2
    return count


def receiver_rays(settings: Settings) -> tuple[int, int]:
    """(gather rays, shadow samples) per receiver: the settings', or with a target error the
    fewest gather rays whose predicted noise stays within GATHER_NOISE_SHARE of it, and shadow
    samples ∝ 1/target² (target 10%: 64 / 16, 3%: 128 / 64, 2%: 256 / 128, 1%: 512 / 512)."""
    t = settings.target_error
    if t is None:
        return int(settings.gather_rays), int(settings.receiver_shadow_samples)
    wanted = 512.0 * (NOISE_AT_512_RAYS / (GATHER_NOISE_SHARE * t)) ** (1.0 / NOISE_EXPONENT)
    rays = _power_of_two(wanted, MIN_TARGET_RAYS, MAX_TARGET_RAYS)
    return rays, target_shadow_samples(t)


def target_shadow_samples(target: float) -> int:
    """Shadow rays per point and sized lamp for a relative error ``target`` (0.01 = 1%):
    ∝ 1/target², a power of two in [MIN_TARGET_SHADOW_SAMPLES, MAX_TARGET_SHADOW_SAMPLES]."""
    return _power_of_two(SHADOW_SAMPLES_AT_2_PERCENT * (0.02 / target) ** 2,
                         MIN_TARGET_SHADOW_SAMPLES, MAX_TARGET_SHADOW_SAMPLES)


def more_rays(settings: Settings, gather_noise: float, rays: int) -> int | None:
    """With a target error, the gather rays per receiver that the noise estimated at ``rays``
    asks for, where it exceeds GATHER_NOISE_SHARE of the target (the light at the receivers
    comes from a few bright patches, where the noise model's bench scenes had it spread): the
    noise model's slope from the noise found, a power of two up to MAX_TARGET_RAYS. None
    where the noise is within its share, without a target, or at MAX_TARGET_RAYS already."""
    t = settings.target_error
    if t is None or rays >= MAX_TARGET_RAYS:
        return None
    share = GATHER_NOISE_SHARE * t
    if not gather_noise > share:
        return None
    wanted = rays * (gather_noise / share) ** (1.0 / NOISE_EXPONENT)
    return _power_of_two(wanted, 2 * rays, MAX_TARGET_RAYS)


def gather_noise_warning(settings: Settings, gather_noise: float, rays: int) -> str | None:
    """What to tell a user whose target error the final gather's own noise (relative RMS at
    the receivers, estimated from its rays) already exceeds: the most rays a target casts
    (MAX_TARGET_RAYS) leave about 0.1% on the bench scenes. None otherwise."""
    t = settings.target_error
    if t is None or not gather_noise > t:
        return None
    most = ", the most a target casts" if rays >= MAX_TARGET_RAYS else ""
    return (f"Target error {t:.2%} not met at the objects: the final gather's noise alone is "
            f"estimated at {gather_noise:.2%} ({rays} rays per receiver{most}); loosen the "
            f"target, or turn it off and raise Gather Rays")
