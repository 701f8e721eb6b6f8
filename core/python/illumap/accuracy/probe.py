"""The occlusion probe: how much occlusion changes a scene, from the direct solutions with and
without exact visibility on a few hundred of its surfels (tens of milliseconds)."""

from __future__ import annotations

import time

import numpy as np

from ..solver import solve as _solve
from ..surfels import Surfels
from .calibration import visibility_keywords

#: Surfels of the occlusion probe, and when it runs (see choose_settings: ``probe``).
PROBE_SURFELS = 200

#: The automatic mode's probe first runs on this share of PROBE_SURFELS and stops there when it
#: measures visibility="none" at PROBE_DECISIVE x the target or more (no setting without
#: visibility can then meet it), at about half the cost. On 100 surfels it measured 0.11-1.66x
#: the 200-surfel value (five samplings each of the bunny, the Cornell box, its triangles and
#: the room): stopping wrongly would take an overestimate by more than 2x.
PROBE_FIRST_SHARE = 0.5


def _probe_subset(surfels: Surfels, count: int, seed: int) -> Surfels:
    """About ``count`` surfels drawn at random, emitters and the rest apart, each group's areas
    scaled to keep its total (and so each light's power and each surface's disc coverage)."""
    rng = np.random.default_rng(seed)
    emit = surfels.emission.max(axis=1) > 0
    parts = []
    for group, share in ((np.flatnonzero(emit), 0.25), (np.flatnonzero(~emit), 0.75)):
        if group.size == 0:
            continue
        k = min(group.size, max(8, int(share * count)))
        pick = np.sort(rng.choice(group, k, replace=False))
        parts.append((pick, group.size / k))
    idx = np.concatenate([p for p, _ in parts])
    scale = np.concatenate([np.full(p.size, s) for p, s in parts])
    return Surfels(surfels.positions[idx], surfels.normals[idx], surfels.areas[idx] * scale,
                   surfels.albedo[idx], surfels.emission[idx])


def _probe_error(sub: Surfels, kind: str) -> float:
    """Relative RMS difference (non-emitters) between the direct solutions of ``sub`` without
    and with exact visibility."""
    # a few per cent is all it needs; one thread: a second costs more than it saves on a few
    # hundred surfels (1.6 -> 1.1 ms and 3.4 -> 2.9 ms on the bunny)
    plain = _solve(sub, method="direct", tol=1e-3, threads=1)
    occluded = _solve(sub, method="direct", tol=1e-3, threads=1, visibility="exact",
                      **visibility_keywords("exact", kind))
    m = ~(sub.emission.max(axis=1) > 0)
    ref = occluded.radiosity[m]
    den = float(np.sqrt(np.mean(ref ** 2))) or 1.0
    return float(np.sqrt(np.mean((plain.radiosity[m] - ref) ** 2))) / den


def occlusion_probe(surfels: Surfels, count: int = PROBE_SURFELS, seed: int = 0,
                    kind: str = "random", decisive: float | None = None) -> dict:
    """How much occlusion changes this scene: relative RMS difference (non-emitters) between
    the direct solutions without and with exact visibility on about ``count`` of its surfels.

    decisive : an error of ``visibility="none"`` that settles the question (the caller's
        choice no longer depends on it beyond that). When given, the probe first runs on
        PROBE_FIRST_SHARE of ``count`` and stops there if it measures at least ``decisive``.

    Returns ``error_none`` (that difference, the error of ``visibility="none"``), ``surfels``
    (of the last stage) and ``seconds``."""
    t0 = time.perf_counter()
    stages = [count]
    first = int(PROBE_FIRST_SHARE * count)
    if decisive is not None and surfels.n > first:
        stages.insert(0, first)
    for size in stages:
        sub = surfels if surfels.n <= size else _probe_subset(surfels, size, seed)
        if not (sub.emission > 0).any():
            return dict(error_none=0.0, surfels=sub.n, seconds=time.perf_counter() - t0)
        err = _probe_error(sub, kind)
        if decisive is not None and err >= decisive:
            break
    return dict(error_none=err, surfels=sub.n, seconds=time.perf_counter() - t0)
