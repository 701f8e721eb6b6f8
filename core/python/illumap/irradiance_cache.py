"""The final gather shared between close receivers: an irradiance cache (Ward, Rubinstein and
Clear, "A ray tracing solution for diffuse interreflection", 1988) for dense receivers such as
a scan's points.

A dense scan has far more points than its indirect light has detail: away from other
surfaces that light changes over the distance to them, not over the points' spacing. Records
are gathered in full at some of the points; every other point takes the plane fitted by
weighted least squares to the records valid for it (at least ``MIN_RECORDS``), at its place. Record i (point x_i, unit normal n_i, reach R_i: the harmonic mean
distance of its rays' hits, ``GatherResult.reach``) is valid at (x, n) when

    ε_i = |x − x_i| / R_i + sqrt(1 − n·n_i) < a          (a: ``accuracy``)

and x does not lie behind x_i's tangent plane; its weight 1/ε_i − 1/a falls to zero at the
edge of its domain, so no seam shows where the records change. Beside a wall, in a crease or
under a box the hits are near, R_i is small and records crowd there: contact shadows keep
their edge. A record's reach says nothing of what lies near x, though: a ceiling's record
beside an emitter hung 1 mm under it would light the ceiling behind the emitter. So every
receiver first measures its own reach R_x with a few rays (``PROBE_RAYS``; with a floor
on the reach, receivers amid sentinels that all reach far take the least of theirs:
``PROBE_SENTINEL_SPACING``), and ε_i uses min(R_i, R_x). Records are placed coarse to fine, one per cell of a grid of side a·R_max
(R_max: the scene's size or the receivers' own, the smaller; a receiver far from the rest
gathers itself), then half that, and so on; each level places records only among the points
that the records so far leave uncovered (valid records fewer than ``MIN_RECORDS``), and at the receivers' own spacing every point still uncovered gathers
itself. The records depend on the points alone and each gathers with its own id (the rays it
would cast uncached), so results do not depend on threads or timing.

No reach counts as nearer than a floor (``min_reach``; the pipeline's is ``MIN_REACH_SHARE``
× the solved surfels' spacing, ``SurfelField.reach``). Without it, a record's domain beside a
crease or a contact shrinks with the distance to it, which only the points' spacing bounds,
and the records there multiply as a scan gets denser (a 990k-point Cornell box scan: 89k
records, 45M of its 136M rays; with the floor 35k). The light the gather looks up is the
surfels' field, which has no detail finer than their spacing. A receiver whose own
surroundings lie nearer than the floor and a record whose surroundings lie beyond
``NEAR_RECORD_FLOORS`` floors (or the other way round) see different light, and do not share.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

import numpy as np

from . import _core
from ._progress import ProgressGuard
from .receivers import GatherResult
from .grid_cells import first_in_each_cell
from .surfels import InputError

#: Ward's a: the largest ε at which a record still counts. Its domain reaches a·R_i across a
#: flat surface and acos(1 − a²) in normal direction (about 9° at 0.15). Chosen by a unit
#: comparison with Illumap's own gather, not against the light: on the Cornell box scanned
#: at 2 cm (123k points), the indirect light at 4000 points differed from 8192-ray gathers
#: by 1.00% at 0.2 (22k records), 0.87% at 0.15 (24k), 0.78% at 0.1 (37k), 0.84% at 0.05
#: (73k), and by 1.06% with every point's own 512-ray gather. The fitted planes average the
#: records' noise.
DEFAULT_ACCURACY = 0.15
#: A point is covered once this many records are valid for it: enough to fit the plane the
#: light slopes along (``_fitted``); with one, a record's value would stand for its whole
#: domain and a slope across it would show as a step.
MIN_RECORDS = 3
#: Nearest records looked at for each point.
RECORD_NEIGHBOURS = 16
#: A record counts only where x is above its tangent plane, to within this share of |x − x_i|.
BEHIND_SLACK = 0.05
#: A receiver whose ISOLATED_NEIGHBOUR-th nearest neighbour in its group lies more than
#: ISOLATED_SPACING times as far as the group's median gathers itself (``_isolated``).
ISOLATED_NEIGHBOUR = 4
ISOLATED_SPACING = 10.0
#: The floor of every reach (a record's and a receiver's own) as a share of the solved
#: surfels' spacing (``SurfelField.reach``, the median distance to the 8th nearest surfel;
#: see the module docstring). On the Cornell box scanned at 7 mm (990k points, default
#: settings): 89k records without a floor, 82k at 1, 35k at 4, and 4.39%, 4.39%, 4.42% from
#: the Cycles bake (bench/scaling_scans.py); the bench scans read 4.63% and 4.11% with it
#: (bench/results/reference_scans.json had 4.6% and 4.1%).
MIN_REACH_SHARE = 4.0
#: A receiver whose own reach (not floored) lies below the floor takes no record whose own
#: reach lies beyond this many floors, nor the other way round: beside a crease both are
#: near and the records serve it; under an emitter hung 1 mm below a ceiling the ceiling's
#: lit records beside it reach metres and do not, nor do the dark ones under it serve the
#: lit ceiling.
NEAR_RECORD_FLOORS = 2.0
#: The phase name the cache's progress reports.
PHASE = "gather"
#: Rays each receiver measures its own reach with: one in 8 that meets a surface nearby
#: brings its reach down to that distance × 8. (16 before: on a 990k-point Cornell box scan
#: the probe cast 16M of 87M rays; with 8 the bench scans' error stayed 4.00% and 4.26%.)
PROBE_RAYS = 8


@dataclass
class CachedGather:
    """The gather at every receiver through the cache (``GatherResult``'s fields), and what
    the cache saved."""

    radiance: np.ndarray      # (M, 3) incident radiance from the gather (irradiance/π)
    stderr: np.ndarray        # (M,) standard error of its luminance (records': their mean's)
    rays: int                 # rays cast
    records: np.ndarray       # (M,) bool: receivers that gathered themselves
    open: np.ndarray | None = None   # (M,) share of rays that hit nothing (records': their mean)
    halves: np.ndarray | None = None  # (M,) GatherResult.halves (records': their weighted mean)


def cached_gather(gather_rows: Callable[..., GatherResult], points, normals, *,
                  max_reach: float, groups=None, accuracy: float = DEFAULT_ACCURACY,
                  min_reach: float = 0.0, progress=None) -> CachedGather:
    """The final gather at receivers ``points`` with unit ``normals`` (M, 3; m), gathering in
    full only at records: ``gather_rows(rows, rays=None)`` gathers at the receivers ``rows``
    (int64) with the gather's own ray count or ``rays``, and returns their ``GatherResult``
    with its ``reach``. ``max_reach`` (m) bounds a record's
    reach (what a record that hits nothing gets; the scene's size is a safe value), as does
    the largest side of the box of the receivers that share records.
    ``groups`` (M,) int: a record serves only receivers of its own group (an object, a side);
    -1: the receiver always gathers itself, as does one far from the rest of its group
    (``_isolated``). ``accuracy``: Ward's a (0 < a ≤ 1; smaller is more records).
    ``min_reach`` (m, ≥ 0): no reach, a record's or a receiver's own, counts as nearer than
    this (``MIN_REACH_SHARE``): the records then cover any surface with a number of them
    that its area and shape set, whatever the receivers' density.
    ``progress(fraction, phase)`` is called between the gathers and between chunks of the
    receivers weighed (phase ``PHASE``, the fraction of the records' levels done); returning
    False or raising cancels with ``illumap.Cancelled``."""
    guard = ProgressGuard(progress)
    p = np.ascontiguousarray(points, dtype=np.float64)
    n = np.ascontiguousarray(normals, dtype=np.float64)
    if p.ndim != 2 or p.shape[1] != 3 or n.shape != p.shape:
        raise InputError(f"points and normals must have shape (M, 3), got {p.shape} and {n.shape}")
    if not 0.0 < accuracy <= 1.0:
        raise InputError(f"accuracy must be in (0, 1], got {accuracy}")
    if not (np.isfinite(max_reach) and max_reach > 0):
        raise InputError(f"max_reach must be a finite length > 0, got {max_reach}")
    if not (np.isfinite(min_reach) and min_reach >= 0):
        raise InputError(f"min_reach must be a finite length >= 0, got {min_reach}")
    m = len(p)
    group = (np.zeros(m, dtype=np.int64) if groups is None
             else np.ascontiguousarray(groups, dtype=np.int64).reshape(-1))
    if len(group) != m:
        raise InputError(f"groups must have {m} entries, got {len(group)}")
    # A receiver far from the rest of its group (a scan's stray point) gathers itself, and
    # the records' grid and reach follow from the others alone: else that one point would
    # move the grid's origin and coarsen its cells, and every other receiver's light with
    # them (by 1.4% on a scan beside two walls, for a point 1 km off).
    isolated, nearest = _isolated(p, group)
    group = np.where(isolated, -1, group)
    radiance, stderr, sky, halves = np.zeros((m, 3)), np.zeros(m), np.zeros(m), np.zeros(m)
    record = group < 0
    covered = np.zeros(m, dtype=bool)
    rays = 0
    spacing = _spacing(p, group, isolated, nearest)
    shared = np.flatnonzero(~record)
    # No record reaches farther than the receivers that share records extend: the grid
    # starts at that size, and a record whose rays meet nothing (an open sky) is valid as
    # far across them as it would be with the scene's size, which a far object changes.
    span = float(np.ptp(p[shared], axis=0).max()) if len(shared) > 1 else 0.0
    if span > 0:
        max_reach = min(max_reach, span)
    min_reach = min(float(min_reach), max_reach)
    origin = p[shared].min(axis=0) if len(shared) else np.zeros(3)
    reach = np.full(m, max_reach)
    raw = np.full(m, max_reach)           # reaches before the floor
    guard.check(0.0, PHASE)
    if len(shared):
        raw[shared], cast = _probed_reach(gather_rows, p, group, shared, max_reach, spacing,
                                          min_reach)
        rays += cast
    reach = np.maximum(raw, min_reach)
    own = reach.copy()
    cell = accuracy * max_reach
    # Levels halve the cell down to the receivers' spacing: their count, for the fraction.
    levels = max(1.0, np.log2(max(cell / (2.0 * spacing), 1.0)) + 2.0) if np.isfinite(spacing) else 1.0
    level = 0
    pending = np.flatnonzero(record)      # receivers that gather themselves: with level 0
    while True:
        open_ = np.flatnonzero(~record & ~covered)
        finest = cell <= 2.0 * spacing
        guard.check(min(level / levels, 1.0), PHASE)
        rows = np.concatenate([pending, open_ if finest else
                               _one_per_cell(p, open_, group, cell, origin)])
        pending = pending[:0]
        if len(rows):
            g = gather_rows(rows)
            radiance[rows], stderr[rows], halves[rows] = g.radiance, g.stderr, _halves(g)
            sky[rows] = _open(g)
            raw[rows] = _bounded(g.reach, max_reach)
            reach[rows] = own[rows] = np.maximum(raw[rows], min_reach)
            rays += int(g.rays)
            record[rows] = True
        if finest or not (~record & ~covered).any():
            break
        for rest in _chunks(np.flatnonzero(~record & ~covered)):
            guard.check(min(level / levels, 1.0), PHASE)
            covered[rest] = _weights(p, n, group, reach, own, record, rest, accuracy,
                                     raw, min_reach, counts_only=True)[2] >= MIN_RECORDS
        cell *= 0.5
        level += 1
    # The rest take their records' values, a chunk at a time (bounded memory); the records
    # are final here, but for the lost ones, which no valid weight names.
    lost = []
    for rest in _chunks(np.flatnonzero(~record)):
        guard.check(min(level / levels, 1.0), PHASE)
        idx, w, _ = _weights(p, n, group, reach, own, record, rest, accuracy, raw, min_reach)
        total = w.sum(axis=1)
        # A valid record pushed out of the nearest ones by later records: gather there too.
        alone = total <= 0
        lost.append(rest[alone])
        keep = ~alone
        rest, idx, w, total = rest[keep], idx[keep], w[keep], total[keep]
        radiance[rest] = _fitted(p, n, radiance, rest, idx, w)
        stderr[rest] = np.sqrt(np.einsum("rk,rk->r", w * w, stderr[idx] ** 2)) / total
        sky[rest] = np.einsum("rk,rk->r", w, sky[idx]) / total
        halves[rest] = np.einsum("rk,rk->r", w, halves[idx]) / total
    lost = np.concatenate(lost) if lost else np.zeros(0, dtype=np.int64)
    if len(lost):
        g = gather_rows(lost)
        radiance[lost], stderr[lost], halves[lost] = g.radiance, g.stderr, _halves(g)
        sky[lost] = _open(g)
        rays += int(g.rays)
        record[lost] = True
    return CachedGather(radiance=radiance, stderr=stderr, rays=rays, records=record, open=sky,
                        halves=halves)


#: With a floor on the reach, the probe is first cast at sentinels about this many of the
#: receivers' spacings apart (one per cell of that side, per group); a receiver whose
#: PROBE_SENTINEL_NEIGHBOURS nearest sentinels of its group lie within 2 cells and all reach
#: the floor or farther takes the least of their reaches (nearer than its own, mostly: its
#: records' domains shrink rather than grow) and casts no probe; every other receiver probes
#: itself. Surroundings nearer than the floor (a panel under a ceiling, the foot of a wall,
#: where the reach falls towards the crease and the sentinels on that side read less) then
#: probe themselves, but for a patch narrower than the sentinels' spacing that lies between
#: them. Groups of fewer receivers than PROBE_SENTINEL_MIN probe every receiver. (990k-point
#: Cornell box scan: 990k probes of 8 rays before, 8 CPU-s.)
PROBE_SENTINEL_SPACING = 4.0
PROBE_SENTINEL_NEIGHBOURS = 8
PROBE_SENTINEL_MIN = 4096


def _probed_reach(gather_rows, p: np.ndarray, group: np.ndarray, rows: np.ndarray,
                  max_reach: float, spacing: float, far: float) -> tuple[np.ndarray, int]:
    """Each receiver ``rows``' own reach (m, before the floor) from the probe, shared
    through sentinels where all reach the floor ``far`` > 0 (see ``PROBE_SENTINEL_SPACING``),
    and the rays cast."""
    raw = np.full(len(rows), np.nan)
    cast = 0
    if far > 0 and np.isfinite(spacing) and spacing > 0 and len(rows) >= PROBE_SENTINEL_MIN:
        cell = PROBE_SENTINEL_SPACING * spacing
        g = group[rows]
        q = p[rows]
        # groups are ≥ 0 here (the receivers that share records)
        sentinels = first_in_each_cell(
            np.column_stack([g, np.floor((q - q.min(axis=0)) / cell).astype(np.int64)]))
        probe = gather_rows(rows[sentinels], rays=PROBE_RAYS)
        cast += int(probe.rays)
        raw[sentinels] = _bounded(probe.reach, max_reach)
        for gv in np.unique(g):
            mine = np.flatnonzero(g == gv)
            theirs = sentinels[g[sentinels] == gv]
            if len(mine) < PROBE_SENTINEL_MIN or len(theirs) < PROBE_SENTINEL_NEIGHBOURS:
                continue
            near, dist = _core.knn(np.ascontiguousarray(q[theirs]), np.ascontiguousarray(q[mine]),
                                   PROBE_SENTINEL_NEIGHBOURS)
            around = raw[theirs][np.asarray(near)]
            least = around.min(axis=1)
            ok = (least >= far) & (np.asarray(dist)[:, -1] <= 2.0 * cell) & np.isnan(raw[mine])
            raw[mine[ok]] = least[ok]
    left = np.flatnonzero(np.isnan(raw))
    if len(left):
        probe = gather_rows(rows[left], rays=PROBE_RAYS)
        cast += int(probe.rays)
        raw[left] = _bounded(probe.reach, max_reach)
    return raw, cast


#: Receivers whose records are weighed at once (about 600 bytes each).
_CHUNK = 262144


def _chunks(rows: np.ndarray):
    """``rows`` in pieces of at most ``_CHUNK``."""
    for lo in range(0, len(rows), _CHUNK):
        yield rows[lo:lo + _CHUNK]


def _halves(g: GatherResult) -> np.ndarray | float:
    return 0.0 if g.halves is None else g.halves


def _open(g: GatherResult) -> np.ndarray | float:
    """A gather's share of rays that hit nothing (0 where it does not say)."""
    return 0.0 if g.open is None else g.open


def _fitted(p: np.ndarray, n: np.ndarray, values: np.ndarray, rows: np.ndarray,
            idx: np.ndarray, w: np.ndarray) -> np.ndarray:
    """The value at each receiver ``rows`` (R,) of the plane fitted, by weighted least squares
    ``w`` (R, K), to its records' ``values[idx]`` (idx: (R, K) rows of ``p``) over their
    offsets in the receiver's tangent plane: first order where the light slopes across the
    records' domains, which their weighted mean smooths to a bias. Where the records do not
    span the plane (fewer than three, or on a line) it is their weighted mean; it never leaves
    the range of the valid records' values (native: ``_core.fitted_values``)."""
    return _core.fitted_values(p, n, np.ascontiguousarray(values, dtype=np.float64),
                               np.ascontiguousarray(rows, dtype=np.int64),
                               np.ascontiguousarray(idx, dtype=np.int64),
                               np.ascontiguousarray(w, dtype=np.float64))


def _bounded(reach: np.ndarray, max_reach: float, min_reach: float = 0.0) -> np.ndarray:
    """A gather's reach (m) within [min_reach, max_reach] (and > 0); no hit (inf) is
    max_reach."""
    return np.clip(np.nan_to_num(reach, posinf=max_reach), max(min_reach, 1e-300), max_reach)


def _spacing(p: np.ndarray, group: np.ndarray, isolated: np.ndarray,
             nearest: np.ndarray) -> float:
    """The typical spacing (m) of the receivers that share records (``group`` ≥ 0): the median
    distance to the nearest other one of them. ``isolated`` and ``nearest``: ``_isolated``'s
    answer; where all of them are one group of which it set none apart, its search gave each
    one's nearest (a scan alone), else they are searched again."""
    shared = np.flatnonzero(group >= 0)
    if len(shared) < 2:
        return np.inf
    if not (isolated & ~np.isnan(nearest)).any() and (group[shared] == group[shared[0]]).all():
        return _median_positive(nearest[shared])
    q = np.ascontiguousarray(p[shared])
    _, dist = _core.knn(q, q, 2)
    return _median_positive(np.asarray(dist)[:, 1])


def _median_positive(distances: np.ndarray) -> float:
    """The median of the positive ``distances`` (m); inf when there are none."""
    d = distances[distances > 0]
    return float(np.median(d)) if len(d) else np.inf


def _isolated(p: np.ndarray, group: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(M,) bool: receivers of a group (≥ 0) whose ``ISOLATED_NEIGHBOUR``-th nearest other
    receiver of that group lies more than ``ISOLATED_SPACING`` times farther than is typical
    for the group (the median): points, and clusters of fewer than that many, far from the
    rest; and every receiver of a group too small to tell (2·ISOLATED_NEIGHBOUR or fewer),
    which would share a record or two at most. And (M,) the distance (m) from each receiver
    to the nearest other of its group, from the same search (nan where none was made)."""
    out = np.zeros(len(p), dtype=bool)
    nearest = np.full(len(p), np.nan)
    for g in np.unique(group[group >= 0]):
        rows = np.flatnonzero(group == g)
        if len(rows) <= 2 * ISOLATED_NEIGHBOUR:
            out[rows] = True
            continue
        q = np.ascontiguousarray(p[rows])
        _, dist = _core.knn(q, q, ISOLATED_NEIGHBOUR + 1)
        dist = np.asarray(dist)
        nearest[rows] = dist[:, 1]
        d = dist[:, ISOLATED_NEIGHBOUR]
        typical = float(np.median(d))
        if typical > 0:
            out[rows] = d > ISOLATED_SPACING * typical
    return out, nearest


def _one_per_cell(p: np.ndarray, rows: np.ndarray, group: np.ndarray, cell: float,
                  origin: np.ndarray) -> np.ndarray:
    """Of ``rows``, the one nearest the centre of each cell that holds any, per group, of
    the grid of side ``cell`` (m) with a corner at ``origin``."""
    if len(rows) == 0:
        return rows
    scaled = (p[rows] - origin) / cell
    key = np.floor(scaled).astype(np.int64)
    off = np.linalg.norm(scaled - key - 0.5, axis=1)
    k = np.column_stack([group[rows], key])
    span = k.max(axis=0) + 1
    if k.min() >= 0 and float(np.prod(span.astype(np.float64))) < 2.0 ** 62:
        # The cell and group packed into one integer (mixed radix: the same order as the
        # columns'), three sort keys instead of six.
        code = k[:, 0].copy()
        for d in range(1, 4):
            code = code * span[d] + k[:, d]
        order = np.lexsort((rows, off, code))
        code = code[order]
        first = np.ones(len(order), dtype=bool)
        first[1:] = code[1:] != code[:-1]
    else:
        order = np.lexsort((rows, off, key[:, 2], key[:, 1], key[:, 0], group[rows]))
        k = k[order]
        first = np.ones(len(order), dtype=bool)
        first[1:] = (k[1:] != k[:-1]).any(axis=1)
    return np.sort(rows[order[first]])


def _weights(p, n, group, reach, own, record, rows, accuracy, raw=None, min_reach=0.0,
             counts_only=False):
    """For receivers ``rows``: their nearest records (R, K) as rows of p, the records' weights
    (R, K) (zero where not valid) and how many are valid (R,) (native:
    ``_core.record_lookup``, the search and the weights in one pass). ``raw`` (M,): each
    receiver's and record's reach before the floor ``min_reach``: a receiver below it takes
    only records below NEAR_RECORD_FLOORS floors. ``counts_only``: (None, None, counts)."""
    k = RECORD_NEIGHBOURS
    idx = None if counts_only else np.zeros((len(rows), k), dtype=np.int64)
    w = None if counts_only else np.zeros((len(rows), k))
    counts = np.zeros(len(rows), dtype=np.int64)
    recs = np.flatnonzero(record & (group >= 0))
    present = np.unique(group[rows])
    floor = raw is not None and min_reach > 0
    raw = np.ascontiguousarray(raw if floor else reach, dtype=np.float64)
    for g in present:
        # One group (a scan's points): its rows are all of them, copied as slices.
        mine = slice(None) if len(present) == 1 else np.flatnonzero(group[rows] == g)
        theirs = recs[group[recs] == g]
        if len(theirs) == 0:
            continue
        kk = min(k, len(theirs))
        found = _core.record_lookup(
            p, n, reach, own, raw, theirs, np.ascontiguousarray(rows[mine]), kk,
            accuracy=float(accuracy), behind_slack=BEHIND_SLACK,
            min_reach=float(min_reach) if floor else 0.0,
            far_reach=NEAR_RECORD_FLOORS * float(min_reach), counts_only=counts_only)
        counts[mine] = found[-1]
        if not counts_only:
            idx[mine, :kk] = found[0]
            w[mine, :kk] = found[1]
    return idx, w, counts
