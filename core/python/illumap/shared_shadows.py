"""Lamp shadows shared between the close points of a dense scan (no bpy).

A sized lamp is first probed with a few shadow rays per receiver (``lights.PROBE_SAMPLES``);
where they all agree, the lamp is wholly in view (1) or wholly hidden (0), and only the rest,
the penumbrae, take the full count. On a scan of millions of points most of the surface is
wholly lit or wholly shadowed, and the probe there repeats the same answer at every point.
So the probe is first cast at sentinels, about one point per cell of ``SENTINEL_SPACING``
point spacings; a point whose ``SENTINEL_NEIGHBOURS`` nearest sentinels (within
``SENTINEL_REACH`` cells) all found the lamp wholly in view, or all found it wholly hidden,
takes that answer; every other point probes itself, as without sharing. A point's value is
therefore the one its own probe would give wherever its own probe agrees with the sentinels
around it; a shadow or a gap of light narrower than the sentinels' spacing (about four
points), lying between them, can be missed, as one narrower than about 1/PROBE_SAMPLES of
the lamp can be missed by the probe itself.
"""

from __future__ import annotations

from typing import Callable

import numpy as np

from . import _core
from .grid_cells import first_in_each_cell

#: Sentinels lie about this many of the points' spacings apart (one per cell of that side).
SENTINEL_SPACING = 4.0
#: A point takes the sentinels' answer when its nearest this many all agree ...
SENTINEL_NEIGHBOURS = 8
#: ... and lie within this many cells of it (farther: a point off the rest probes itself).
SENTINEL_REACH = 2.0
#: A group of fewer points probes every point itself.
MIN_SHARED_POINTS = 4096
#: Points whose nearest neighbour measures the spacing (a sample of the group's).
_SPACING_SAMPLE = 4096


def shared_probe(probe: Callable[[np.ndarray], np.ndarray], points: np.ndarray,
                 groups: np.ndarray, rows: np.ndarray) -> np.ndarray:
    """The probe's visible fractions (len(rows),) at the receivers ``rows`` (int, rows of
    ``points`` (M, 3), m), shared within each group of ``groups`` (M,) int (≥ 0; −1: the
    receiver probes itself) as the module docstring says. ``probe(r)`` casts the probe at
    receivers ``r`` and returns their fractions in [0, 1]."""
    rows = np.asarray(rows, dtype=np.int64)
    out = np.empty(len(rows))
    own = np.zeros(len(rows), dtype=bool)
    g = groups[rows]
    own[g < 0] = True
    for group in np.unique(g[g >= 0]):
        mine = np.flatnonzero(g == group)
        decided, value = _from_sentinels(probe, points, rows[mine])
        out[mine[decided]] = value[decided]
        own[mine[~decided]] = True
    if own.any():
        out[own] = probe(rows[own])
    return out


def _from_sentinels(probe, points: np.ndarray, rows: np.ndarray) -> tuple:
    """For the receivers ``rows`` of one group: which the sentinels decide (bool) and their
    value there (the sentinels' own probes where they are sentinels)."""
    decided = np.zeros(len(rows), dtype=bool)
    value = np.zeros(len(rows))
    if len(rows) < MIN_SHARED_POINTS:
        return decided, value
    q = np.ascontiguousarray(points[rows], dtype=np.float64)
    cell = SENTINEL_SPACING * _spacing(q)
    if not (np.isfinite(cell) and cell > 0):
        return decided, value
    sentinels = first_in_each_cell(np.floor((q - q.min(axis=0)) / cell).astype(np.int64))
    seen = probe(rows[sentinels])
    near, dist = _core.knn(np.ascontiguousarray(q[sentinels]), q,
                           min(SENTINEL_NEIGHBOURS, len(sentinels)))
    near, dist = np.asarray(near), np.asarray(dist)
    around = seen[near]
    lo, hi = around.min(axis=1), around.max(axis=1)
    decided = (lo == hi) & ((lo == 0.0) | (lo == 1.0)) & (dist[:, -1] <= SENTINEL_REACH * cell)
    value = np.where(decided, lo, 0.0)
    decided[sentinels] = True
    value[sentinels] = seen
    return decided, value


def _spacing(q: np.ndarray) -> float:
    """The typical distance (m) from a point to its nearest other (median over a sample)."""
    step = max(1, len(q) // _SPACING_SAMPLE)
    sample = np.ascontiguousarray(q[::step])
    _, dist = _core.knn(q, sample, 2)
    d = np.asarray(dist)[:, 1]
    d = d[d > 0]
    return float(np.median(d)) if len(d) else np.inf
