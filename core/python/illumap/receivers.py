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
from .refinement import LUMINANCE_WEIGHTS
from .surfels import InputError

#: Ray origins move off the surface by this fraction of the scene's feature length (see above).
RAY_OFFSET = 1e-5
#: The share of a point's distance from the scene's centre that its rays skip (2^-18, as
#: ``LocalFrame::noise`` in core/src/geometry/local_frame.hpp).
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
    from .array_checks import first_nonfinite_row   # chunked: a scan's splats are 12M triangles
    bad = first_nonfinite_row(c)
    if bad >= 0:
        raise InputError(f"corners of triangle {bad} are not finite")
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
    cancels (``illumap.Cancelled``). ``splats`` (``splats.SplatOutlines``, or None): the last
    triangles are those points' splat fans, which the scene casts against as one outline
    each (a dozen times less memory); hits name the fan triangles all the same. ``offset`` (m) defaults to ``RAY_OFFSET`` × the feature
    length. ``extent`` (m) is the largest side of the triangles' box, ``feature_length`` (m) the
    size of their bulk (the largest per-axis spread between the 1st and 99th percentiles).
    """

    def __init__(self, corners, *, offset: float | None = None, threads: int = 0,
                 progress: Progress | None = None, splats=None) -> None:
        c = _corners(corners)
        if len(c) == 0:
            raise InputError("MeshOccluders needs at least one triangle")
        self.corners = c
        extra = {}
        if splats is not None and len(splats.points):
            # The last triangles are these points' splat fans (``splats.SplatOutlines``):
            # cast against as one outline each (hits still name the fan's triangles).
            f64 = lambda a: np.ascontiguousarray(a, dtype=np.float64)  # noqa: E731
            extra = dict(splat_points=f64(splats.points), splat_u=f64(splats.u),
                         splat_v=f64(splats.v), splat_radii=f64(splats.radii),
                         splat_facing=f64(splats.facing))
        self._scene = _core.MeshScene(c.reshape(-1, 9), threads=threads, progress=progress,
                                      **extra)
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
    to a box takes the floor's light, not the box's. Where none agrees (with occluders: none
    that agrees and that the point sees), the nearest of them that the point sees, whatever its
    normal; where none is seen (the point is walled off), the nearest surfel's value.
    ``light_field``: the values are light (the gather's), which walls seal off: a neighbour
    counts where it is seen along a segment lifted a quarter of its distance off both surfaces
    (an enclosed surfel under a rim that overhangs it is not seen from the lit surface beside
    it), else as above, and a walled-off point reads black.
    """

    def __init__(self, positions, normals, values, *, light_field: bool = False) -> None:
        p = _rows3("positions", positions)
        if len(p) == 0:
            raise InputError("SurfelField needs at least one surfel")
        n = _rows3("normals", normals, len(p))
        v = _rows3("values", values, len(p))
        self._field = _core.SurfelField(p, n, v, k=LOOKUP_NEIGHBOURS, min_cos=LOOKUP_MIN_COS,
                                        light_field=bool(light_field))

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
    """``two_sided`` as the core reads it: one uint8 per triangle (a bool array's own bytes)."""
    if two_sided is None:
        return None
    sided = np.ascontiguousarray(two_sided, dtype=bool).reshape(-1).view(np.uint8)
    if len(sided) != occluders.n:
        raise InputError(f"two_sided must have {occluders.n} entries, got {len(sided)}")
    return sided


def _owner_rows(occluders: MeshOccluders, value, name: str):
    """Per-triangle owner rows as the core reads them: int32 (no copy when given so)."""
    if value is None:
        return None
    o = np.asarray(value).reshape(-1)
    if len(o) and (o.min() < -1 or o.max() > np.iinfo(np.int32).max):
        raise InputError(f"{name} must be -1 or surfel rows below 2^31")
    o = np.ascontiguousarray(o, dtype=np.int32)
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
               faces=None, shares=None, threads: int = 0,
               progress: Progress | None = None) -> GatherResult:
        """Indirect incident radiance at receivers (``positions``, unit ``normals``, (M, 3)),
        as ``gather``. ``shares`` (with ``faces``): corners that take the receivers' rays in
        faces of their own, (start (M + 1,) int: receiver i's are rows start[i]:start[i + 1],
        their points (E, 3), their faces' unit normals (E, 3)); the result then has M + E
        rows, theirs after the receivers', each the mean a gather of its own would give (a
        ray below its receiver's face and above its own cast again from the corner's point;
        ``rays`` counts the receivers' rays and these)."""
        p = _rows3("positions", positions)
        n = _rows3("normals", normals, len(p))
        f = None if faces is None else _rows3("faces", faces, len(p))
        start = share_points = share_faces = None
        if shares is not None:
            if f is None:
                raise InputError("shares need the receivers' faces")
            start = np.ascontiguousarray(shares[0], dtype=np.int64).reshape(-1)
            share_points = _rows3("share positions", shares[1])
            share_faces = _rows3("share faces", shares[2], len(share_points))
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
        radiance, stderr, reach, open_, halves, recast = self._gatherer.gather(
            p, n, ids, rays=int(rays), seed=int(seed), rays_per=per, faces=f, share_start=start,
            share_positions=share_points, share_faces=share_faces, threads=threads,
            progress=progress)
        return GatherResult(radiance=radiance, stderr=stderr, rays=count + int(recast),
                            reach=reach, open=open_, halves=halves)

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
           back_exact: ExactPart | None = None, tabulate: bool = True, faces=None,
           threads: int = 0, progress: Progress | None = None) -> GatherResult:
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
    for their random streams (default: their rows). ``faces`` (M, 3) unit: the geometric
    normal of the face each receiver lies in (a mesh corner's triangle); a ray that leaves
    below it takes nothing, as a renderer's diffuse surface drops the directions of a smooth
    normal's hemisphere that lie below its face (None: every ray counts). Runs natively on ``threads`` (0: all), the GIL
    released; ``progress`` returning False cancels (``illumap.Cancelled``). Many calls over
    one scene and field: ``Gatherer``, which tabulates once.
    """
    return Gatherer(occluders, field, background=background, back_field=back_field,
                    two_sided=two_sided, owners=owners, back_owners=back_owners, exact=exact,
                    back_exact=back_exact, tabulate=tabulate, threads=threads,
                    progress=progress).gather(positions, normals, rays=rays, ids=ids, seed=seed,
                                              faces=faces, threads=threads,
                                              progress=progress)
