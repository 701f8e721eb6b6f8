"""Evaluation at receivers: the light a user sees, computed at the point that shows it.

Surfels discretise the *sources*; the values a user looks at live at *receivers* (mesh
vertices and corners, scan points, preview points). Interpolating surfel values to a receiver
smears light across contact lines and ignores surfaces nearer than a surfel spacing, so each
receiver x is evaluated on its own (DESIGN.md §6, the final gather of two-pass radiosity):

    L(x) = E(x) + ρ(x) · [ H_direct(x) + G(x) ]

* ``H_direct`` — incident radiance from lamps and emissive triangles, with shadow rays cast
  from x against the true triangles (``MeshOccluders.segment_query``);
* ``G`` — indirect incident radiance: ``gather`` casts cosine-distributed rays from x against
  the triangles and looks up the solved reflected radiance B' of the surfels at each hit
  (``SurfelField``); rays that leave the scene see the background radiance. The field is
  tabulated on a lattice of each triangle; a part known exactly at its points (lamp light,
  cast there with shadow rays where it changes sharply: ``gather_lattices``, ``ExactPart``,
  ``sharpness``) keeps shadow edges as sharp as the lattice. Surfels whose disc reaches
  through another surface (``straddling_surfels``) have unreliable solved values; the
  caller evaluates them as receivers before building the field.

All radiance is in Blender's units (irradiance / π for incident light), positions in metres.
Rays start ``offset`` off the surface along the receiver's normal; the default,
``RAY_OFFSET`` × the scene's feature length (the size of the bulk of its triangles, which a
far outlier does not change), lies far below a 1 mm gap in a 10 m scene and far above
single-precision noise. The triangles are stored in float relative to the median of their
corners, so neither where the scene sits nor an outlier beside it changes the result.

Results are deterministic: every receiver draws its rays from its own id and the seed, so
threads, chunking and the order of receivers do not change them.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

import numpy as np

from . import _core
from .pointcloud import plane_through
from .refinement import LUMINANCE_WEIGHTS
from .surfels import InputError

#: Ray origins move off the surface by this fraction of the scene's feature length (see above).
RAY_OFFSET = 1e-5
#: The share of a point's distance from the scene's centre that its rays skip (2^-18, as
#: ``LocalFrame::noise`` in core/src/local_frame.hpp).
ROUNDING_SKIP = 2.0 ** -18
#: Surfels looked up around a gather hit; those facing away from the hit surface are ignored.
LOOKUP_NEIGHBOURS = 8
#: A surfel counts for a hit when its normal is within acos(this) of the hit triangle's.
LOOKUP_MIN_COS = 0.5

Progress = Callable[[float, str], "bool | None"]


def _corners(corners) -> np.ndarray:
    c = np.ascontiguousarray(corners, dtype=np.float64)
    if c.ndim != 3 or c.shape[1:] != (3, 3):
        raise InputError(f"corners must have shape (T, 3, 3), got {c.shape}")
    if not np.isfinite(c).all():
        bad = ~np.isfinite(c).all(axis=(1, 2))
        raise InputError(f"corners of triangle {int(np.flatnonzero(bad)[0])} are not finite")
    return c


def _rows3(name: str, value, m: int | None = None) -> np.ndarray:
    a = np.ascontiguousarray(value, dtype=np.float64)
    if a.ndim != 2 or a.shape[1] != 3:
        raise InputError(f"{name} must have shape (M, 3), got {a.shape}")
    if m is not None and len(a) != m:
        raise InputError(f"{name} must have {m} rows, got {len(a)}")
    bad = ~np.isfinite(a).all(axis=1)
    if bad.any():
        raise InputError(f"{name}[{int(np.flatnonzero(bad)[0])}] is not finite")
    return a


class MeshOccluders:
    """Triangles (T, 3, 3) in metres as a ray-casting scene, for receivers.

    ``threads`` 0 uses every hardware thread; ``progress(fraction, phase)`` returning False
    cancels (``illumap.Cancelled``). ``offset`` (m) defaults to ``RAY_OFFSET`` × the feature
    length. ``extent`` (m) is the largest side of the triangles' box, ``feature_length`` (m) the
    size of their bulk (the largest per-axis spread between the 1st and 99th percentiles).
    """

    def __init__(self, corners, *, offset: float | None = None, threads: int = 0,
                 progress: Progress | None = None) -> None:
        c = _corners(corners)
        if len(c) == 0:
            raise InputError("MeshOccluders needs at least one triangle")
        self.corners = c
        self._scene = _core.MeshScene(c.reshape(-1, 9), threads=threads, progress=progress)
        self.extent = float(self._scene.extent)
        self.feature_length = float(self._scene.feature_length)
        self.offset = (float(offset) if offset is not None
                       else RAY_OFFSET * max(self.feature_length, 1e-30))
        if not (self.offset > 0 and np.isfinite(self.offset)):
            raise InputError(f"offset must be a finite number > 0, got {offset}")

    @property
    def n(self) -> int:
        """Number of triangles."""
        return int(self._scene.n)

    def rounding(self, points) -> np.ndarray:
        """(M,) m: how close to ``points`` (M, 3) a hit goes unseen. Rays skip the first few
        dozen float ulps of their origin's distance from the scene's centre (the triangles
        are stored in float against it), so that a receiver far out does not hit its own
        surface; a point that a neighbouring surface is nearer than this sees past it."""
        p = _rows3("points", points)
        centre = np.asarray(self._scene.center, dtype=np.float64)
        return np.abs(p - centre).max(axis=1) * ROUNDING_SKIP

    def visible(self, origins, targets, *, end_trim: float = 0.0,
                progress: Progress | None = None) -> np.ndarray:
        """float32 (M,): 1 where no triangle meets origins[k] → targets[k] (its last
        ``end_trim`` metres left out), else 0. Origins are used as given."""
        o = _rows3("origins", origins)
        t = _rows3("targets", targets, len(o))
        return self._scene.visible(o, t, end_trim=float(end_trim), progress=progress)

    def intersect(self, origins, directions, *, tmax: float = np.inf,
                  progress: Progress | None = None) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Closest hits of rays with unit ``directions``: (triangle int64 (-1: none),
        distance in m, front bool: the ray meets the triangle's front face)."""
        o = _rows3("origins", origins)
        d = _rows3("directions", directions, len(o))
        tri, dist, front = self._scene.intersect(o, d, tmax=float(tmax), progress=progress)
        return tri, dist, front.astype(bool)

    def segment_query(self, normals: np.ndarray):
        """A lamp-shadow query ``visible(origins, targets, rows, progress=None)`` for receivers
        with ``normals`` (M, 3): each origin is moved ``offset`` along its receiver's normal
        (``rows`` name the receiver of each segment) and the last ``offset`` of the segment is
        left out, so a sample on an emitter's own face does not hide itself."""
        nrm = _rows3("normals", normals)

        def visible(origins, targets, rows, progress=None):
            o = np.asarray(origins, dtype=np.float64) + self.offset * nrm[np.asarray(rows)]
            return self._scene.visible(np.ascontiguousarray(o),
                                       np.ascontiguousarray(targets, dtype=np.float64),
                                       end_trim=self.offset, progress=progress)
        return visible


class SurfelField:
    """The solved reflected radiance of surfels, looked up at points on surfaces.

    ``at(points, surface_normals)`` averages the ``LOOKUP_NEIGHBOURS`` nearest surfels whose
    normal agrees with the surface's (within acos ``LOOKUP_MIN_COS``), by inverse squared
    distance softened by 5% of the typical neighbour distance, so that a hit on a floor next
    to a box takes the floor's light, not the box's. Where none agrees, the nearest surfel's
    value is used.
    """

    def __init__(self, positions, normals, values) -> None:
        p = _rows3("positions", positions)
        if len(p) == 0:
            raise InputError("SurfelField needs at least one surfel")
        n = _rows3("normals", normals, len(p))
        v = _rows3("values", values, len(p))
        self._field = _core.SurfelField(p, n, v, k=LOOKUP_NEIGHBOURS, min_cos=LOOKUP_MIN_COS)

    @property
    def n(self) -> int:
        """Number of surfels."""
        return int(self._field.n)

    @property
    def reach(self) -> float:
        """Median distance (m) from a surfel to its ``LOOKUP_NEIGHBOURS``-th nearest: the
        gather tabulates the field on a lattice at most this coarse."""
        return float(self._field.reach)

    def at(self, points, surface_normals, occluders: "MeshOccluders | None" = None) -> np.ndarray:
        """Values (M, 3) at ``points`` (M, 3) on surfaces with unit normals (M, 3). With
        ``occluders``, a surfel counts only where no triangle separates it from the point
        (both lifted ``occluders.offset`` off their surfaces), as in ``gather``."""
        p = _rows3("points", points)
        n = _rows3("surface_normals", surface_normals, len(p))
        if occluders is None:
            return self._field.at(p, n)
        return self._field.at(p, n, occluders._scene, occluders.offset)


def cosine_directions(normals, count: int, ids, seed: int = 0) -> np.ndarray:
    """Unit directions (M, count, 3), cosine-distributed about unit ``normals`` (M, 3).

    One rank-1 (Fibonacci) lattice, shifted per receiver by a hash of (seed, id)
    (Cranley–Patterson), mapped to the disc by Shirley's concentric map and lifted to the
    hemisphere (Malley). The gather casts exactly these.
    """
    n = _rows3("normals", normals)
    ids = np.ascontiguousarray(ids, dtype=np.int64).reshape(-1)
    if len(ids) != len(n):
        raise InputError(f"ids must have {len(n)} entries, got {len(ids)}")
    if int(count) < 1:
        raise InputError(f"count must be >= 1, got {count}")
    return _core.cosine_directions(n, int(count), ids, int(seed))


@dataclass
class ExactPart:
    """A part of the light the gather finds at its hits that is known exactly at the points
    where it tabulates its field (``gather_lattices``): typically the reflected direct light
    of lamps, evaluated there with shadow rays. The gather then interpolates ``values`` (L, 3)
    plus ``rest`` (the surfels' light less that part) instead of the whole field, so that a
    lamp's shadow edge on a hit surface is as sharp as the lattice, not blurred over the
    surfels' spacing."""

    rest: SurfelField
    values: np.ndarray


#: ``straddling_surfels`` looks for another surface among this many nearest surfels.
STRADDLE_NEIGHBOURS = 8
#: Surfaces meet when |cos| between their normals is below this (60° or more apart).
STRADDLE_MAX_COS = 0.5


def straddling_surfels(positions, normals, areas, *, k: int = STRADDLE_NEIGHBOURS) -> np.ndarray:
    """Which surfels' discs reach through another surface: one of the ``k`` nearest surfels
    lies on a plane at least 60° from theirs that passes within their disc's radius
    sqrt(A / π) of their centre. Where two surfaces meet (a floor along a wall, a box's edge,
    a scan's crease) such a disc overlaps its neighbours across the line, and the solve's
    close-pair rule, exact for a point beside a disc, counts the other surface's light
    through several overlapping discs: their solved values scatter by tens of percent where
    the light itself is smooth. Returns (N,) bool; positions and areas in m and m²."""
    p = _rows3("positions", positions)
    n = _rows3("normals", normals, len(p))
    a = np.asarray(areas, dtype=np.float64).reshape(-1)
    if len(a) != len(p):
        raise InputError(f"areas must have {len(p)} entries, got {len(a)}")
    if len(p) < 2:
        return np.zeros(len(p), dtype=bool)
    kk = min(int(k), len(p) - 1)
    radius = np.sqrt(np.maximum(a, 0.0) / np.pi)
    neighbours = np.asarray(_core.knn(p, p, kk + 1)[0])[:, 1:]
    out = np.zeros(len(p), dtype=bool)
    for lo in range(0, len(p), _STRADDLE_CHUNK):   # bounded memory at millions of surfels
        r = slice(lo, min(lo + _STRADDLE_CHUNK, len(p)))
        idx = neighbours[r]
        nb = n[idx]
        other = np.abs(np.einsum("ic,ikc->ik", n[r], nb)) < STRADDLE_MAX_COS
        height = np.abs(np.einsum("ikc,ikc->ik", nb, p[r, None, :] - p[idx]))
        out[r] = (other & (height < radius[r, None])).any(axis=1)
    return out


#: Surfels examined at once by ``straddling_surfels``.
_STRADDLE_CHUNK = 65536


#: ``sharpness`` looks at this many surfels around a point, as ``SurfelField`` does.
SHARP_NEIGHBOURS = LOOKUP_NEIGHBOURS
#: Light changes sharply around a point when its neighbours' luminance spreads over more than
#: this share of their brightest (sharpness 1), not at all below SHARP_SPREAD_FROM (0); the
#: ramp between keeps results continuous in the input.
SHARP_SPREAD = 0.6
SHARP_SPREAD_FROM = 0.3


def sharpness(positions, values, points, *, k: int = SHARP_NEIGHBOURS) -> np.ndarray:
    """How sharply the surfels' ``values`` (N, 3) change around each of ``points`` (L, 3),
    in [0, 1]: from the spread of the luminance of the ``k`` surfels nearest each, as a share
    of the brightest (0 up to ``SHARP_SPREAD_FROM``, 1 from ``SHARP_SPREAD``). Where it is 0
    the surfels' inverse-distance average is as good as an exact value. Returns (L,)."""
    p = _rows3("positions", positions)
    v = _rows3("values", values, len(p))
    q = _rows3("points", points)
    if not len(q) or not len(p):
        return np.zeros(len(q))
    idx, _ = _core.knn(p, q, min(int(k), len(p)))
    lum = (v @ LUMINANCE_WEIGHTS)[np.asarray(idx)]
    hi, lo = lum.max(axis=1), lum.min(axis=1)
    share = (hi - lo) / np.where(hi > 0, hi, 1.0)
    return np.clip((share - SHARP_SPREAD_FROM) / (SHARP_SPREAD - SHARP_SPREAD_FROM), 0.0, 1.0)


def gather_lattices(occluders: MeshOccluders, field: SurfelField, *,
                    back_field: SurfelField | None = None, two_sided=None, owners=None,
                    back_owners=None, triangles: bool = False) -> tuple:
    """The points (L, 3) and surface normals (L, 3) at which ``gather`` with the same
    arguments tabulates ``field`` and ``back_field``: ((front points, front normals), (back
    points, back normals)), each point a hair inside its triangle; about as many as the
    surfels. Values for an ``ExactPart`` are given in this order. With ``triangles``, each
    pair has a third array: the triangle (L,) each point lies in (its points come together,
    in a fixed order within it)."""
    fp, fn, bp, bn, ft, bt = _core.gather_lattices(
        occluders._scene, field._field, None if back_field is None else back_field._field,
        two_sided=_sided(occluders, two_sided), owner_front=_owner_rows(occluders, owners, "owners"),
        owner_back=_owner_rows(occluders, back_owners, "back_owners"))
    if triangles:
        return (fp, fn, ft), (bp, bn, bt)
    return (fp, fn), (bp, bn)


def _sided(occluders: MeshOccluders, two_sided):
    if two_sided is None:
        return None
    sided = np.ascontiguousarray(two_sided, dtype=bool).astype(np.int64).reshape(-1)
    if len(sided) != occluders.n:
        raise InputError(f"two_sided must have {occluders.n} entries, got {len(sided)}")
    return sided


def _owner_rows(occluders: MeshOccluders, value, name: str):
    if value is None:
        return None
    o = np.ascontiguousarray(value, dtype=np.int64).reshape(-1)
    if len(o) != occluders.n:
        raise InputError(f"{name} must have {occluders.n} entries, got {len(o)}")
    return o


@dataclass
class GatherResult:
    """Indirect incident radiance at receivers and what it cost."""

    radiance: np.ndarray      # (M, 3) mean radiance seen by the rays (incident, irradiance/π)
    stderr: np.ndarray        # (M,) standard error of the luminance of that mean
    rays: int                 # rays cast
    # (M,) m: harmonic mean distance of the rays' hits, misses infinitely far (inf: no hit)
    reach: np.ndarray | None = None
    # (M,) share of the rays that hit nothing: the background's part of ``radiance`` is
    # ``open × background``, the rest is the surfels'
    open: np.ndarray | None = None
    # (M,) half the difference of the even and the odd rays' mean luminance. The rays are a
    # lattice: ``stderr`` (independent rays) overstates the error where the light is smooth;
    # the mean of these squares over many receivers estimates the mean squared error
    halves: np.ndarray | None = None


class Gatherer:
    """A final gather prepared once for any number of receivers (``gather``'s arguments but
    the receivers, their rays and ids): the fields are tabulated on the scene's triangles
    here, not at each call, which in a scan of millions of splat triangles costs more than
    a small batch of receivers' rays."""

    def __init__(self, occluders: MeshOccluders, field: SurfelField, *, background=None,
                 back_field: SurfelField | None = None, two_sided=None, owners=None,
                 back_owners=None, exact: ExactPart | None = None,
                 back_exact: ExactPart | None = None, tabulate: bool = True, threads: int = 0,
                 progress: Progress | None = None):
        bg = np.zeros(3) if background is None else np.ascontiguousarray(background, dtype=np.float64).reshape(3)
        if not np.isfinite(bg).all() or (bg < 0).any():
            raise InputError(f"background must be 3 finite values >= 0, got {bg}")

        def exact_rows(part):
            if part is None:
                return None, None
            return part.rest._field, np.ascontiguousarray(part.values, dtype=np.float64)

        front_rest, front_lattice = exact_rows(exact)
        back_rest, back_lattice = exact_rows(back_exact)
        self._gatherer = _core.Gatherer(
            occluders._scene, field._field, None if back_field is None else back_field._field,
            offset=occluders.offset, background=bg, two_sided=_sided(occluders, two_sided),
            owner_front=_owner_rows(occluders, owners, "owners"),
            owner_back=_owner_rows(occluders, back_owners, "back_owners"),
            front_rest=front_rest, front_lattice=front_lattice, back_rest=back_rest,
            back_lattice=back_lattice, tabulate=bool(tabulate), threads=threads,
            progress=progress)

    def gather(self, positions, normals, *, rays, ids: np.ndarray | None = None, seed: int = 0,
               threads: int = 0, progress: Progress | None = None) -> GatherResult:
        """Indirect incident radiance at receivers (``positions``, unit ``normals``, (M, 3)),
        as ``gather``."""
        p = _rows3("positions", positions)
        n = _rows3("normals", normals, len(p))
        per = None
        if np.ndim(rays) == 0:
            if int(rays) < 1:
                raise InputError(f"rays must be >= 1, got {rays}")
            count = len(p) * int(rays)
        else:
            per = np.ascontiguousarray(rays, dtype=np.int64).reshape(-1)
            if len(per) != len(p) or (per < 1).any():
                raise InputError(f"rays must be an int >= 1 or {len(p)} counts >= 1")
            count = int(per.sum())
            rays = int(per.max()) if len(per) else 1
        ids = (np.arange(len(p), dtype=np.int64) if ids is None
               else np.ascontiguousarray(ids, dtype=np.int64).reshape(-1))
        if len(ids) != len(p):
            raise InputError(f"ids must have {len(p)} entries, got {len(ids)}")
        radiance, stderr, reach, open_, halves = self._gatherer.gather(
            p, n, ids, rays=int(rays), seed=int(seed), rays_per=per, threads=threads,
            progress=progress)
        return GatherResult(radiance=radiance, stderr=stderr, rays=count, reach=reach, open=open_,
                            halves=halves)

    def hit_values(self, triangles, front, points, *, threads: int = 0) -> np.ndarray:
        """What a gather ray takes (M, 3: outgoing radiance, W/(m² sr)) where it meets
        ``triangles`` (M,) int on their ``front`` (M,) bool face at ``points`` (M, 3, m, on
        those triangles): the tables' interpolation where they cover the point, else the
        field looked up there; a splat's own surfel; black for a back face without a back
        field."""
        t = np.ascontiguousarray(triangles, dtype=np.int64).reshape(-1)
        f = np.ascontiguousarray(front, dtype=bool).reshape(-1)
        p = _rows3("points", points, len(t))
        if len(f) != len(t):
            raise InputError(f"front must have {len(t)} entries, got {len(f)}")
        return self._gatherer.hit_values(t, f.view(np.uint8), p, threads=threads)


def gather(occluders: MeshOccluders, field: SurfelField, positions, normals, *, rays,
           ids: np.ndarray | None = None, seed: int = 0, background=None,
           back_field: SurfelField | None = None, two_sided=None, owners=None,
           back_owners=None, exact: ExactPart | None = None,
           back_exact: ExactPart | None = None, tabulate: bool = True, threads: int = 0,
           progress: Progress | None = None) -> GatherResult:
    """Indirect incident radiance at receivers (``positions``, unit ``normals``, (M, 3)).

    ``rays`` cosine-distributed rays per receiver (an int, or an int array (M,) of counts
    per receiver; ``cosine_directions``) start
    ``occluders.offset`` off the surface and meet the triangles; a front hit takes
    ``field.at`` there, a back hit ``back_field.at`` (None: black, one-sided surfaces), and a
    miss the ``background`` radiance (3,) (None: black). ``two_sided`` (T,) bool says which
    triangles' back faces take ``back_field`` (None: all); the others' are black.
    ``owners`` / ``back_owners`` (T,) int name, per triangle, the surfel of ``field`` /
    ``back_field`` it stands for (a point's splat, ``illumap.splats``) or -1: a hit on it takes
    that surfel's value instead of a lookup. ``exact`` / ``back_exact`` give a part of
    the field / back field known at ``gather_lattices``' points (``ExactPart``).
    ``tabulate``: the field is tabulated on the triangles that are not splats, a lattice
    looked up once per point (False: each hit looks it up itself, cheaper where few rays meet
    many such triangles; an exact part keeps its lattice). ``ids`` (M,) name the receivers
    for their random streams (default: their rows). Runs natively on ``threads`` (0: all), the GIL
    released; ``progress`` returning False cancels (``illumap.Cancelled``). Many calls over
    one scene and field: ``Gatherer``, which tabulates once.
    """
    return Gatherer(occluders, field, background=background, back_field=back_field,
                    two_sided=two_sided, owners=owners, back_owners=back_owners, exact=exact,
                    back_exact=back_exact, tabulate=tabulate, threads=threads,
                    progress=progress).gather(positions, normals, rays=rays, ids=ids, seed=seed,
                                              threads=threads, progress=progress)


#: Neighbours a point's light is compared with by ``remove_specks``.
SPECK_NEIGHBOURS = 8
#: Neighbours count as the same surface when |cos| between the normals is at least this.
SPECK_MIN_COS = 0.5
#: A speck lies below (1 − SPECK_RATIO) × the darkest, or above the brightest ÷ (1 −
#: SPECK_RATIO), of its same-surface neighbours (by luminance), beyond SPECK_FLOOR × the
#: cloud's median luminance.
SPECK_RATIO = 0.25
SPECK_FLOOR = 0.02


def remove_specks(points, normals, values, *, k: int = SPECK_NEIGHBOURS,
                  neighbours: np.ndarray | None = None) -> tuple[np.ndarray, int]:
    """Values at scan points with isolated specks replaced: (values (P, 3), specks replaced).

    A point evaluated on a splat model can come out far darker than everything around it (a
    neighbour's splat, tilted by scan noise, shadows it) or far brighter (light through a
    hole in the splats reaches a side that faces into the object). Light varies smoothly
    along a surface except across shadow edges, and a point on a shadow edge has neighbours
    on both sides of it. So a point whose luminance lies outside the range of all its
    same-surface neighbours (``k`` nearest with |n·n'| ≥ ``SPECK_MIN_COS``, at least four of
    them) by ``SPECK_RATIO`` is a speck and takes the value of its median neighbour; points on
    shadow edges, gradients and extremes of smooth light keep theirs. Positions in metres,
    values in any radiance unit. ``neighbours`` (P, k + 1): the points' own k + 1 nearest
    (``_core.knn(points, points, k + 1)``, as ``ScanPatches.neighbours`` holds them), not
    searched again.
    """
    p = _rows3("points", points)
    n = _rows3("normals", normals, len(p))
    v = _rows3("values", values, len(p))
    if len(p) <= 4:
        return v.copy(), 0
    kk = int(min(k, len(p) - 1))
    if neighbours is not None and np.shape(neighbours) == (len(p), kk + 1):
        idx = np.asarray(neighbours)[:, 1:]
    else:
        idx, _ = _core.knn(p, p, kk + 1)
        idx = np.asarray(idx)[:, 1:]
    lum = v @ LUMINANCE_WEIGHTS
    same = np.abs(np.einsum("pc,pkc->pk", n, n[idx])) >= SPECK_MIN_COS
    neighbour = np.where(same, lum[idx], np.nan)
    count = same.sum(axis=1)
    with np.errstate(all="ignore"):
        lo = np.nanmin(np.where(count[:, None] > 0, neighbour, 0.0), axis=1)
        hi = np.nanmax(np.where(count[:, None] > 0, neighbour, 0.0), axis=1)
    floor = SPECK_FLOOR * float(np.median(lum))
    speck = (count >= 4) & ((lum < (1 - SPECK_RATIO) * lo - floor) |
                            (lum > hi / (1 - SPECK_RATIO) + floor))
    out = v.copy()
    rows = np.flatnonzero(speck)
    if len(rows):
        # The same-surface neighbour of median luminance (others sort last).
        keyed = np.where(same[rows], neighbour[rows], np.inf)
        order = np.argsort(keyed, axis=1)
        pick = order[np.arange(len(rows)), (count[rows] - 1) // 2]
        out[rows] = v[idx[rows, pick]]
    return out, int(len(rows))


#: Neighbours that join a smooth patch: k nearest with |n·n'| at least PATCH_MIN_COS (~25°).
PATCH_NEIGHBOURS = 8
PATCH_MIN_COS = 0.9


def outward_sides(points, normals, front, back, *, k: int = PATCH_NEIGHBOURS) -> np.ndarray:
    """Which side of each two-sided scan point faces out: (P,) bool, True where ``normals``
    do (``front``, the light seen along them, is kept), False where ``back`` is.

    A scan without normals cannot tell the inside of a room from the outside of a statue, so
    both sides are evaluated. Choosing point by point lets one stray ray decide: light seeping
    through a hole in the splats makes the inward side of a few points brighter than their
    shadowed outer side, which then read lit. A patch (``ScanPatches``) has one outside: the
    side that receives more light over the whole patch. A wall of a room, a face of a box,
    the smooth body of a scanned object each decide as one; a lone point decides for itself.
    """
    return ScanPatches(points, normals, k=k).sides(front, back)[0]


#: A patch's side is settled by a probe when the light of its two sides differs by this
#: many standard errors of the probe's gather ...
SIDE_SETTLED_SIGMAS = 4.0
#: ... and by this share of the two together (a gather that found no spread can still be off).
SIDE_SETTLED_SHARE = 0.05


class ScanPatches:
    """The smooth patches of a scan's points: points joined through ``k``-nearest neighbours
    whose normals agree to ``PATCH_MIN_COS``, oriented consistently along those links (where
    orientation carries reliably). Each patch has one outside (``outward_sides``)."""

    def __init__(self, points, normals, *, k: int = PATCH_NEIGHBOURS):
        p = _rows3("points", points)
        n = _rows3("normals", normals, len(p))
        if len(p) < 2:
            self.part = np.zeros(len(p), dtype=np.int64)
            self.along_front = np.ones(len(p), dtype=bool)
            self.neighbours = None
            return
        kk = int(min(k, len(p) - 1))
        idx, _ = _core.knn(p, p, kk + 1)
        idx = np.asarray(idx, dtype=np.int64)
        #: (P, k + 1) each point's nearest, itself among them: ``remove_specks`` takes them
        #: too, rather than search the same neighbours again
        self.neighbours = idx
        smooth = np.abs(np.einsum("pc,pkc->pk", n, n[idx])) >= PATCH_MIN_COS
        idx = np.ascontiguousarray(np.where(smooth, idx, np.arange(len(p))[:, None]))
        oriented, part = _core.orient_normals(p, n, idx)
        #: (P,) bool: the patch's common orientation runs along the point's normal
        self.along_front = np.einsum("pc,pc->p", np.asarray(oriented), n) > 0
        #: (P,) int: the patch of each point
        self.part = np.asarray(part, dtype=np.int64)

    def sides(self, front, back, front_noise=None, back_noise=None,
              rows=None) -> tuple[np.ndarray, np.ndarray]:
        """(side, settled), (P,) bool each. ``side``: True where the point's normal faces out
        (see ``outward_sides``), from the radiance ``front`` and ``back`` (P, 3) seen along
        and against the normals. ``settled``: where the patch's two sides differ by
        ``SIDE_SETTLED_SIGMAS`` standard errors and ``SIDE_SETTLED_SHARE`` of their sum, given
        each value's standard error ``front_noise``, ``back_noise`` (P,) in luminance; all
        False without them. ``rows`` (M,): the values are those of these points only (a
        patch none of them lies in is neither side's and not settled)."""
        part = self.part if rows is None else self.part[rows]
        along_front = self.along_front if rows is None else self.along_front[rows]
        parts = int(self.part.max()) + 1 if len(self.part) else 0
        lum_f = _rows3("front", front, len(part)) @ LUMINANCE_WEIGHTS
        lum_b = _rows3("back", back, len(part)) @ LUMINANCE_WEIGHTS
        along = np.bincount(part, np.where(along_front, lum_f, lum_b), minlength=parts)
        against = np.bincount(part, np.where(along_front, lum_b, lum_f), minlength=parts)
        side = (along >= against)[self.part] == self.along_front
        if front_noise is None or back_noise is None:
            return side, np.zeros(len(side), dtype=bool)
        var = np.bincount(part, np.asarray(front_noise, dtype=np.float64) ** 2
                          + np.asarray(back_noise, dtype=np.float64) ** 2, minlength=parts)
        gap = np.abs(along - against)
        settled = (gap > SIDE_SETTLED_SIGMAS * np.sqrt(var)) & \
            (gap > SIDE_SETTLED_SHARE * (along + against))
        return side, settled[self.part]

    def sample(self, share: float, whole: int, most: int | None = None) -> np.ndarray:
        """Points (ascending rows) that stand for their patches: every point of a patch of at
        most ``whole`` points, about ``share`` of a larger one's (every 1/share-th in row
        order), at least ``whole`` of each; with ``most``, about that many at most of each
        (every ceil(size / most)-th): a wall of a dense scan decides its side on its sums as
        well from thousands of points as from hundreds of thousands."""
        order = np.argsort(self.part, kind="stable")
        sizes = np.bincount(self.part)
        starts = np.concatenate([[0], np.cumsum(sizes)[:-1]])
        rank = np.empty(len(order), dtype=np.int64)
        rank[order] = np.arange(len(order)) - starts[self.part[order]]
        size = sizes[self.part]
        stride = np.maximum(1, np.minimum(np.rint(1.0 / share), size // max(whole, 1))).astype(np.int64)
        if most is not None:
            stride = np.maximum(stride, -(-size // max(int(most), 1)))
        return np.flatnonzero(rank % stride == 0)


#: Neighbours searched for the surfaces that meet at a scan point.
CREASE_NEIGHBOURS = 12
#: The point lies on a neighbour's surface when within CREASE_ON_PLANE × the median
#: neighbour distance of the neighbour's tangent plane.
CREASE_ON_PLANE = 0.2
#: Normals that agree to this cosine (~25°) are one surface ...
CREASE_SAME_COS = 0.9
#: ... which needs this many neighbours (one stray normal is noise; the point's own counts).
CREASE_MIN_VOTES = 2
#: Groups of normals looked for around a point: a box corner has three faces and three edges.
CREASE_MAX_SURFACES = 6
#: A face's value is taken this far (× the median neighbour distance) into the face, and as
#: far off it.
CREASE_INSET = 0.03
#: An edge lies in a face when the sine of the angle between them is below this (~10°).
CREASE_EDGE_SIN = 0.17


@dataclass
class Creases:
    """The surfaces that meet at scan points, for :func:`crease_surfaces`."""

    rows: np.ndarray          # (E,) int64 points with a face to evaluate, ascending
    normals: np.ndarray       # (E, 3) that surface's unit outward normal
    points: np.ndarray        # (E, 3) m, where to evaluate it: a hair into and off the face
    own: np.ndarray           # (P,) bool: the point is lit by its own normal (not a crease)

    def mean(self, own_values: np.ndarray, values: np.ndarray) -> np.ndarray:
        """Each point's light (P, C): the mean over its surfaces of ``own_values`` (P, C), lit
        along its own normal, and ``values`` (E, C), lit along ``normals``."""
        out = np.where(self.own[:, None], own_values, 0.0)
        np.add.at(out, self.rows, values)
        count = self.own + np.bincount(self.rows, minlength=len(own_values))
        return out / np.maximum(count, 1)[:, None]


def crease_surfaces(points, normals, *, k: int = CREASE_NEIGHBOURS) -> Creases:
    """The faces that meet at each scan point on a crease, to light it by instead of the
    point's own outward ``normals`` (P, 3). Positions in metres.

    A point on the edge of a box lies on two faces (three at a corner), while its fitted
    normal is one face's, or a tilt between them. What a scanner records there, like what a
    mesh vertex shared by those faces shows, is the mean of the faces' light; so the point is
    evaluated once per face, with that face's normal, a hair into and off the face (as a
    mesh corner is lit a hair inside its face): from the crease line itself, rays along one
    face would start on the other's plane and pass through it. The faces are the groups of
    agreeing normals (``CREASE_SAME_COS``, at least ``CREASE_MIN_VOTES`` each) among the
    neighbours whose tangent plane the point lies on, each face's normal that of the plane
    through the point and the group's points; a group whose points lie on a line through the
    point (the edge's own points, their fits tilted between the faces) is no face. A point
    near an edge but not on it lies on one face's planes only and keeps its own value.
    Concave creases count as convex ones do; so do twins (points at the same position, where
    two scanned objects touch), which cannot be told apart and both take the faces' mean.
    """
    p = _rows3("points", points)
    n = _rows3("normals", normals, len(p))
    P = len(p)
    nothing = Creases(np.zeros(0, dtype=np.int64), np.zeros((0, 3)), np.zeros((0, 3)),
                      np.ones(P, dtype=bool))
    if P <= CREASE_MIN_VOTES:
        return nothing
    kk = int(min(k, P - 1))
    idx, dist = _core.knn(p, p, kk + 1)
    idx, dist = np.asarray(idx, dtype=np.int64), np.asarray(dist)
    crease = np.zeros(P, dtype=bool)
    found = []
    for lo in range(0, P, _CREASE_CHUNK):
        rows = np.arange(lo, min(lo + _CREASE_CHUNK, P))
        rows = rows[_may_crease(p, n, rows, idx[rows], dist[rows])]
        if len(rows):
            found.append(_crease_faces(p, n, rows, idx[rows], dist[rows], crease))
    r = np.concatenate([f[0] for f in found]) if found else np.zeros(0, dtype=np.int64)
    if len(r) == 0:
        return nothing
    return Creases(r, np.concatenate([f[1] for f in found]),
                   np.concatenate([f[2] for f in found]), ~crease)


#: Points grouped at once by ``crease_surfaces`` (~60 MB of neighbour offsets at k = 12).
_CREASE_CHUNK = 32768


def _may_crease(p, n, rows, idx, dist) -> np.ndarray:
    """Which of the points ``rows`` ``_crease_faces`` can find on a crease: a second face
    needs a neighbour whose tangent plane the point lies on and whose normal the point's own
    does not share (its first group is the point's own normal's). Points missing from their
    own neighbours (twins) are always looked at. The rest, most of a scan, lie on one face."""
    me = idx == rows[:, None]
    scale = np.median(dist[:, 1:], axis=1)
    nb_n = n[idx]
    offsets = p[idx] - p[rows, None, :]
    free = me | (np.abs(np.einsum("pkc,pkc->pk", offsets, nb_n)) <= CREASE_ON_PLANE * scale[:, None])
    # a hair of margin: a neighbour on the boundary is looked at, whichever way it rounds
    differ = np.einsum("pkc,pc->pk", nb_n, n[rows]) < CREASE_SAME_COS + 1e-9
    return ~me.any(axis=1) | (free & differ).any(axis=1)


def _crease_faces(p, n, rows, idx, dist, crease) -> tuple:
    """``crease_surfaces`` for the points ``rows`` (their ``idx``, ``dist``: k + 1 nearest,
    themselves included): marks ``crease[rows]`` and returns (point, face normal, where to
    evaluate) per face of a crease point."""
    me = idx == rows[:, None]
    scale = np.median(dist[:, 1:], axis=1)
    nb_n = n[idx]                                                        # (R, k + 1, 3)
    offsets = p[idx] - p[rows, None, :]
    free = me | (np.abs(np.einsum("pkc,pkc->pk", offsets, nb_n)) <= CREASE_ON_PLANE * scale[:, None])
    # Group the normals: the point's own first, then the nearest left.
    G = CREASE_MAX_SURFACES
    R = len(rows)
    local = np.arange(R)
    mean_normal = np.zeros((R, G, 3))
    members = np.zeros((R, G, idx.shape[1], 3))          # each group's offsets, 0 elsewhere
    found = np.zeros((R, G), dtype=bool)
    key = np.where(me, -1.0, dist)
    for g in range(G):
        left = free.any(axis=1)
        seed = np.argmin(np.where(free, key, np.inf), axis=1)
        member = free & (np.einsum("pc,pkc->pk", nb_n[local, seed], nb_n) >= CREASE_SAME_COS)
        total = (member[..., None] * nb_n).sum(axis=1)
        length = np.linalg.norm(total, axis=1)
        found[:, g] = left & (member.sum(axis=1) >= CREASE_MIN_VOTES) & (length > 0)
        mean_normal[:, g] = total / np.maximum(length, 1e-300)[:, None]
        members[:, g] = member[..., None] * offsets
        free &= ~member
    faces, on_line = plane_through(members)
    faces *= np.where(np.einsum("pgc,pgc->pg", faces, mean_normal) < 0, -1.0, 1.0)[..., None]
    face = found & ~on_line
    er, en, eat = _corner_faces(p, rows, face.any(axis=1), face, faces, found & on_line,
                                mean_normal, members, scale)
    mine = face.sum(axis=1) + np.bincount(er, minlength=len(rows)) >= 2
    crease[rows] = mine
    keep = mine[er]
    er, en, eat = er[keep], en[keep], eat[keep]
    r, g = np.nonzero(face & mine[:, None])
    centre = members[r, g].sum(axis=1)
    length = np.linalg.norm(centre, axis=1)
    inward = centre / np.maximum(length, 1e-300)[:, None]
    # A face whose points lie all around the point (twins where scans meet, a room's corner)
    # gives no direction. Where the corner's faces are known in full (one was found through
    # its edge), into it is away from the others: behind their planes at a convex crease (the
    # neighbours lie behind the point's own normal), in front of them at a concave one.
    short = np.flatnonzero((length < 0.5 * scale[r]) & np.isin(r, er))
    if short.size:
        others = np.zeros((len(rows), 3))
        np.add.at(others, np.concatenate([r, er]), np.concatenate([faces[r, g], en]))
        side = np.where(np.einsum("pkc,pc->p", offsets, n[rows]) > 0, 1.0, -1.0)
        rs = r[short]
        v = side[rs, None] * (others[rs] - faces[rs, g[short]])
        v -= np.einsum("ec,ec->e", v, faces[rs, g[short]])[:, None] * faces[rs, g[short]]
        norm = np.linalg.norm(v, axis=1, keepdims=True)
        inward[short] = np.where(norm > 1e-12, v / np.maximum(norm, 1e-300), inward[short])
    # A hair off the face too: near an edge the neighbours' splats tilt a little, and from
    # the face's exact plane a receiver would start behind them.
    at = p[rows[r]] + CREASE_INSET * scale[r, None] * (inward + faces[r, g])
    out = np.concatenate([rows[r], rows[er]]).astype(np.int64)
    order = np.argsort(out, kind="stable")
    return out[order], np.concatenate([faces[r, g], en])[order], np.concatenate([at, eat])[order]


def _corner_faces(p, rows, mine, face, faces, line, line_normal, members, scale) -> tuple:
    """Faces of an edge or corner that ``_crease_faces`` missed (looked for at the rows
    ``mine``): a face's own points may all lie beyond the nearest neighbours, but the edge
    it shares with a face found there does not (a group of points on a line through the
    point, their fitted normals halfway between the two faces). The missing face's normal
    is the found one's mirrored about that edge's normal. Returns (row index into ``rows``,
    normal, where to evaluate)."""
    G = face.shape[1]
    out_r, out_n, out_at = [], [], []
    known = np.where(face[..., None], faces, 0.0)                      # (R, G, 3)
    for l in range(G):
        for f in range(G):
            c = np.einsum("rc,rc->r", line_normal[:, l], faces[:, f])
            ok = mine & line[:, l] & face[:, f] & (c > 0.5) & (c < CREASE_SAME_COS)
            if not ok.any():
                continue
            other = 2.0 * c[:, None] * line_normal[:, l] - faces[:, f]
            other /= np.maximum(np.linalg.norm(other, axis=1, keepdims=True), 1e-300)
            # The edge: its points' offsets, all on one side of the point (not twins at it),
            # and in both faces' planes.
            edge = members[:, l].sum(axis=1)
            length = np.linalg.norm(edge, axis=1)
            along = edge / np.maximum(length, 1e-300)[:, None]
            ok &= length > 0.5 * scale
            ok &= (np.abs(np.einsum("rc,rc->r", along, other)) < CREASE_EDGE_SIN) & \
                  (np.abs(np.einsum("rc,rc->r", along, faces[:, f])) < CREASE_EDGE_SIN)
            new = ok & (np.einsum("rgc,rc->rg", known, other).max(axis=1) < CREASE_SAME_COS)
            i = np.flatnonzero(new)
            if not i.size:
                continue
            # Into the new face: along the edge, and behind the found face's plane where the
            # faces meet convexly (in front of it where concavely).
            along = along[i]
            convex = np.einsum("rkc,rc->r", members[i, f], other[i]) < 0
            inward = along + np.where(convex, -1.0, 1.0)[:, None] * faces[i, f]
            inward -= np.einsum("rc,rc->r", inward, other[i])[:, None] * other[i]
            inward /= np.maximum(np.linalg.norm(inward, axis=1, keepdims=True), 1e-300)
            out_r.append(i)
            out_n.append(other[i])
            out_at.append(p[rows[i]] + CREASE_INSET * scale[i, None] * (inward + other[i]))
            # The inferred face counts for the next groups' check.
            slot = np.argmin(np.abs(known[i]).sum(axis=2), axis=1)
            known[i, slot] = other[i]
    if not out_r:
        return np.zeros(0, dtype=np.int64), np.zeros((0, 3)), np.zeros((0, 3))
    return np.concatenate(out_r), np.concatenate(out_n), np.concatenate(out_at)
