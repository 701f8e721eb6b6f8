"""Splats: the surface a point cloud stands for, as triangles (``splat_triangles``, for rays),
and as the Object Preview's ellipses of a scan (``splat_frames``, below).

A point model has no faces, yet shadows, visibility and the final gather need a surface to
stop rays. Each point p (normal n, area A) gets a splat: a disc of radius
``reach × sqrt(A/π)`` in its tangent plane, clipped so that neighbouring splats tile the
surface instead of overlapping, and so that nothing overhangs where the surface turns:

* by the bisector plane between p and each of its nearest neighbours q on the same surface
  (normals within acos ``EDGE_COS``; the restricted
  Voronoi cell: on a flat or gently curved surface, splats meet about half-way; they overlap
  by ``CORNER_SLACK`` so that the sampled outline leaves no holes at the cells' corners);
* by the tangent plane of each neighbour q whose normal turns away from p's by more than
  ``EDGE_COS``, keeping the side of that plane that p lies on; for a point on that plane (an
  edge's own points), the side its own surface lies on (where the centroid of its
  same-surface neighbours is, whichever way the normals were oriented). At a
  box's edge the top's splats end at the side's plane and the side's at the top's; at a
  floor–wall junction the floor's splats stop at the wall instead of poking through it; a
  floor hidden under a box stays under it. Where another surface runs on through p's plane
  on both sides (a box's side standing on a floor that continues under it), neither clips
  the other.

A splat is a fan of ``sides`` triangles about p, its rim sampled at ``sides`` directions where
the clipped outline is reached exactly (the cell is star-shaped about p). Units: metres.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from . import _core
from .pointcloud import PLANE_INLIER, PLANE_SHARE, PLANE_SPREAD, settled_normals
from .surfels import InputError

#: Radius of the unclipped splat in units of the point's own radius sqrt(A/π): large enough
#: that the clipped cells of a jittered sampling leave no holes (1.5 left 0.8% of a jittered
#: plane open, 2.0 none). Towards the scan's rim a splat reaches only its own radius.
DEFAULT_REACH = 2.0
#: Neighbours whose bisector and tangent planes clip a splat: enough that where two surfaces
#: meet, the other surface's points do not crowd out the point's own neighbours.
DEFAULT_NEIGHBOURS = 20
#: Triangles per splat (directions at which its outline is found).
DEFAULT_SIDES = 12
#: Splats reach this far past the bisectors: the fan through the outline's sampled points is
#: inscribed in the cell and would cut its corners (a square cell sampled every 30° loses 9%
#: of its area at the corners); 1.27 covers them, and coplanar overlap hides nothing.
CORNER_SLACK = 1.3
#: A neighbour's tangent plane clips only where the surface turns by more than acos(this),
#: about 25°: on flat or gently curved parts the bisectors alone shape the cells.
EDGE_COS = 0.9
#: A direction is inside the scan when a neighbour lies within acos(this) of it (60°, in the
#: tangent plane); beyond the rim a splat reaches its point's own radius sqrt(A/π) only.
RIM_COS = 0.5
#: p lies on a neighbour's tangent plane when within this fraction of their distance of it.
JUNCTION_TOLERANCE = 0.05
#: Splats reach past the tangent planes that clip them by this fraction of the distance to
#: the neighbour, so that no slit opens along an edge.
EDGE_OVERLAP = 0.02


def _basis(n: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """A tangent basis that is the same for n and −n (u × v = ±n), so a splat's outline does
    not depend on which way its point's normal was oriented."""
    lead = np.take_along_axis(n, np.argmax(np.abs(n), axis=1)[:, None], axis=1)
    m = n * np.where(lead < 0, -1.0, 1.0)
    helper = np.where((np.abs(m[:, 0]) < 0.9)[:, None], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0])
    u = np.cross(m, helper)
    u /= np.linalg.norm(u, axis=1, keepdims=True)
    return u, np.cross(m, u)


def splat_radii(positions, normals, areas, *, reach: float = DEFAULT_REACH,
                neighbours: int = DEFAULT_NEIGHBOURS,
                sides: int = DEFAULT_SIDES,
                nearest: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The clipped outline of every splat: (radii (N, sides) in m along the directions
    cos θ_m u + sin θ_m v, u (N, 3), v (N, 3)), the tangent basis of each point. Native
    (``illumap._core.splat_radii``, splats.cpp), both threads. ``nearest``: the points' own
    search (N, ≥ neighbours + 1 columns, the point first, ``pointcloud.nearest``), read
    instead of searching again (knn keeps ties to the lower index: its first columns are
    this search's)."""
    p = np.ascontiguousarray(positions, dtype=np.float64)
    n = np.asarray(normals, dtype=np.float64)
    a = np.asarray(areas, dtype=np.float64)
    if p.ndim != 2 or p.shape[1] != 3 or n.shape != p.shape or a.shape != (len(p),):
        raise InputError(f"splats need positions and normals (N, 3) and areas (N,), got "
                         f"{p.shape}, {n.shape}, {a.shape}")
    if not (np.isfinite(p).all() and np.isfinite(n).all() and np.isfinite(a).all()):
        raise InputError("splats need finite positions, normals and areas")
    if (a <= 0).any():
        raise InputError(f"splat area {int(np.flatnonzero(a <= 0)[0])} is not positive")
    count = len(p)
    n = np.ascontiguousarray(n / np.maximum(np.linalg.norm(n, axis=1, keepdims=True), 1e-300))
    u, v = _basis(n)
    own = np.sqrt(a / np.pi)
    k = min(neighbours, count - 1)
    if k < 1:
        return np.repeat((reach * own)[:, None], sides, axis=1), u, v
    shape = np.shape(nearest) if nearest is not None else ()
    if len(shape) == 2 and shape[0] == count and shape[1] >= k + 1:
        idx = nearest[:, :k + 1]
    else:
        idx, _ = _core.knn(p, p, k + 1)
    radii = _core.splat_radii(p, n, np.ascontiguousarray(u), np.ascontiguousarray(v),
                              reach * own, own, np.ascontiguousarray(np.asarray(idx)[:, 1:]),
                              sides=int(sides), corner_slack=CORNER_SLACK, edge_cos=EDGE_COS,
                              rim_cos=RIM_COS, junction_tolerance=JUNCTION_TOLERANCE,
                              edge_overlap=EDGE_OVERLAP)
    return np.asarray(radii), u, v


#: Ray scenes cast against each splat as one outline (``SplatOutlines``, a rectangle whose
#: hits a filter keeps inside the fan: ~0.2 KB a point) instead of its fan of ``DEFAULT_SIDES``
#: triangles (~1.1 KB a point); the hits are the same (tests/core/test_splat_outlines.py).
OUTLINE_RAYS = True

#: Points whose fans are built at once: the fans go into the caller's array a chunk at a time
#: (a scan of 1M points has 0.86 GB of splat corners; built whole, then copied, twice that).
FAN_CHUNK = 1 << 16


@dataclass
class SplatOutlines:
    """The splats of N points as outlines: ``points`` (N, 3) m, the tangent basis ``u``, ``v``
    (N, 3), ``radii`` (N, sides) m along cos θ_m u + sin θ_m v (``splat_radii``) and
    ``facing`` (N, 3), the way their fans are wound to face. What a ray scene needs to cast
    against each splat as one primitive (``receivers.MeshOccluders``) instead of its fan of
    ``sides`` triangles."""

    points: np.ndarray
    u: np.ndarray
    v: np.ndarray
    radii: np.ndarray
    facing: np.ndarray

    @staticmethod
    def joined(parts: list["SplatOutlines"]) -> "SplatOutlines | None":
        """The outlines of several clouds, in order (None for none)."""
        parts = [p for p in parts if p is not None and len(p.points)]
        if not parts:
            return None
        if len(parts) == 1:
            return parts[0]
        return SplatOutlines(*(np.concatenate([getattr(p, k) for p in parts])
                               for k in ("points", "u", "v", "radii", "facing")))


def splat_triangles(positions, normals, areas, *, out: np.ndarray | None = None,
                    nearest: np.ndarray | None = None, outlines: bool = False,
                    **options):
    """(N × sides, 3, 3) triangles, the splats of N points as fans about them (point i's are
    rows i·sides … (i+1)·sides − 1), each in the plane of its point's surface
    (``pointcloud.settled_normals``), wound so that their normals agree with ``normals``.
    ``out``: a C-contiguous float64 array of that shape to write them into (returned), so a
    caller assembling all of a scene's triangles holds them once. ``nearest``: the points' own
    search, passed on to ``settled_normals`` and ``splat_radii``. ``outlines``: return
    (triangles, ``SplatOutlines``) instead. Options: see ``splat_radii``."""
    p = np.ascontiguousarray(positions, dtype=np.float64)
    facing = np.ascontiguousarray(settled_normals(p, normals, nearest), dtype=np.float64)
    radii, u, v = splat_radii(p, facing, areas, nearest=nearest, **options)
    sides = radii.shape[1]
    shape = (len(p) * sides, 3, 3)
    if out is None:
        out = np.empty(shape)
    elif out.shape != shape or out.dtype != np.float64 or not out.flags.c_contiguous:
        raise InputError(f"splat_triangles: out must be C-contiguous float64 {shape}, got "
                         f"{out.dtype} {out.shape}")
    for lo in range(0, len(p), FAN_CHUNK):
        hi = min(lo + FAN_CHUNK, len(p))
        out[lo * sides:hi * sides] = _core.splat_fans(
            p[lo:hi], np.ascontiguousarray(u[lo:hi]), np.ascontiguousarray(v[lo:hi]),
            np.ascontiguousarray(radii[lo:hi]), facing[lo:hi])
    if outlines:
        return out, SplatOutlines(p, np.ascontiguousarray(u), np.ascontiguousarray(v),
                                  np.ascontiguousarray(radii), facing)
    return out


# --- The Object Preview's splats of a scan (``splat_frames``) --------------------------------
#
# A scan's points are drawn as oriented ellipses, one instance per point (the add-on's
# mesh_preview reads what ``splat_frames`` returns from hidden point attributes):
#
# * Plane. Each splat lies in its point's tangent plane: the scan's own normals where given,
#   else the plane that most of its ``PREVIEW_NEIGHBOURS`` nearest points lie on
#   (``pointcloud.plane_normals``: on a smooth surface PCA; beside an edge the point's own
#   surface, not a tilt between the two).
# * Size. A disc of radius ``PREVIEW_COVER`` × the mean, over the point and its neighbours, of
#   the distance to the ``PREVIEW_NEIGHBOURS``-th nearest point (π ρ d² ≈ PREVIEW_NEIGHBOURS,
#   ρ the density): discs of that radius about randomly placed points leave about
#   exp(−COVER² × NEIGHBOURS) ≈ 0.03% of a flat surface open, a regular scan none. A given
#   radius is used as it is.
# * Creases. A neighbour whose normal turns from the point's by more than acos
#   ``PREVIEW_EDGE_COS`` lies on another surface: its tangent plane cuts the point's plane
#   along a line, and the splat keeps the point's side of that line (for a point on the line,
#   the side its own surface's neighbours are on). The nearest such line clips: the disc
#   becomes the ellipse that touches it (``EDGE_SLACK`` of the radius past it, so no slit
#   opens along the edge) and the disc's far side, a = r along the line and b = (r + c) / 2
#   across, its centre moved (r − c) / 2 away from the line. A point on the crease itself
#   keeps only a strip along it on its own surface's side, ``CREASE_WIDTH`` × r into it and
#   ``EDGE_SLACK`` × r past the line, when the normals were estimated (a scan of two walls has a point of
#   each there, each with its own wall's colour, and its plane may be either wall's): a strip
#   across the line would stand out of the other surface with this one's light (the top
#   edge of a lit box's front face drew a bright rim).
# * Rims. Where the scan ends (among the ``RIM_NEIGHBOURS`` nearest points the widest angle
#   exceeds ``RIM_GAP`` and their centroid lies ``RIM_SHIFT`` × the farthest one's distance
#   off the point; a neighbour is a rim point facing about the same way), a line through the
#   point, across the gap's middle, clips the splat there (``RIM_REACH`` × r past it). Only
#   points whose ``PREVIEW_NEIGHBOURS`` nearest already leave such a gap take the wider search
#   (a gap among some of the neighbours is never narrower than among all).
# * Neighbours' lines. Each point also tries the lines that clipped its neighbours
#   (``PROPAGATE`` rounds); where a second line crosses the one that shaped the ellipse (a
#   room's corner, a crease meeting the rim), the ellipse shrinks about its point until it
#   ends there as well. The neighbours' own tangent planes count as such lines too: near a
#   corner of three faces the third face's plane may have clipped no neighbour.
#
# Native (``_core.splat_widest_gaps``, ``_core.splat_frames``, splat_frames.cpp), both threads;
# positions in the object's own coordinates, lengths in its units.

#: Neighbours of each point that size and clip its preview splat.
PREVIEW_NEIGHBOURS = 8
#: Neighbours that tell a scan's rim: with 8, the widest angle between them exceeds 150° at
#: 18% of a random sampling's inner points; with 16 at 0.7% (measured on 20k points).
RIM_NEIGHBOURS = 16
#: Disc radius in units of the distance to the PREVIEW_NEIGHBOURS-th nearest point.
PREVIEW_COVER = 1.0
#: A neighbour is on another surface when |n·m| is below this (about 25°).
PREVIEW_EDGE_COS = 0.9
#: A point lies on a neighbour's tangent plane within this fraction of their distance.
ON_PLANE = 0.05
#: Splats reach past the line that clips them by this fraction of their radius.
EDGE_SLACK = 0.15
#: ... past a convex crease's line (the clipping surface's normal points beyond it) where the
#: normals were given: those are oriented (a scanner's face out of the surfaces), and what
#: reaches past a convex edge stands out of the surface and, where the other face is seen at
#: a grazing angle, hides a strip of it (the top of a box seen from a little above). Estimated
#: normals are unoriented: convex and concave creases look alike, and EDGE_SLACK holds.
CONVEX_SLACK = 0.05
#: The neighbours' centroid this far off the point (in units of the farthest one's distance)
#: marks a rim ...
RIM_SHIFT = 0.2
#: ... with a gap wider than this between them (radians, 150°).
RIM_GAP = float(np.radians(150.0))
#: A rim point needs a rim neighbour that faces within acos(this) of its own direction.
RIM_ALONG = 0.7
#: A rim's splats reach this fraction of their radius beyond the rim point's line.
RIM_REACH = 0.0
#: A second clipping line shrinks a cut ellipse only where it turns from the first by more
#: than acos(this) (30°).
PARALLEL_COS = float(np.cos(np.radians(30.0)))
#: How far into its own surface the strip of a point on a crease reaches (× r).
CREASE_WIDTH = 0.3
#: Rounds in which the neighbours' clipping planes clip a point.
PROPAGATE = 1


def _tangent(n: np.ndarray) -> np.ndarray:
    """A unit vector perpendicular to each of the unit vectors ``n`` (N, 3)."""
    helper = np.where((np.abs(n[:, 0]) < 0.9)[:, None], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0])
    u = np.cross(n, helper)
    return u / np.linalg.norm(u, axis=1, keepdims=True)


def _pack(n, axis, scale, offset, clipped) -> dict:
    f = lambda x: np.ascontiguousarray(x, dtype=np.float32)  # noqa: E731
    return {"normal": f(n), "axis": f(axis), "scale": f(scale), "offset": f(offset),
            "clipped": np.asarray(clipped, bool)}


def splat_frames(positions, normals=None, radius=None, *, threads: int = 0,
                 progress=None, with_neighbours: bool = False) -> dict:
    """Each scan point's preview splat (the rules above) as float32 arrays: ``normal`` (N, 3,
    unit), ``axis`` (N, 3: the in-plane direction of the ellipse's first axis), ``scale``
    (N, 3: the semi-axes along ``axis`` and across it, and the first again; in the positions'
    unit) and ``offset`` (N, 3: from the point to the ellipse's centre), and ``clipped`` (N,)
    bool: the splats a crease or rim shaped. ``normals`` (N, 3) and ``radius`` (N,) are the
    scan's own where it has them. ``threads``: worker threads (0: all); ``progress(fraction,
    phase)`` may cancel (``illumap.Cancelled``)."""
    p = np.ascontiguousarray(positions, dtype=np.float64)
    if p.ndim != 2 or p.shape[1] != 3:
        raise InputError(f"splat_frames: positions must be an (N, 3) array, got {p.shape}")
    count = len(p)
    if normals is not None and np.shape(normals) != p.shape:
        raise InputError(f"splat_frames: normals must have the positions' shape {p.shape}, "
                         f"got {np.shape(normals)}")
    if radius is not None and np.shape(radius) != (count,):
        raise InputError(f"splat_frames: radius must have shape ({count},), got "
                         f"{np.shape(radius)}")
    k = min(PREVIEW_NEIGHBOURS, count - 1)
    if k < 2:
        n = np.tile([0.0, 0.0, 1.0], (count, 1)) if normals is None else np.asarray(normals)
        r = np.full(count, 0.01) if radius is None else np.asarray(radius, np.float64)
        small = _pack(n, _tangent(n), np.stack([r, r, r], 1), np.zeros((count, 3)),
                      np.zeros(count, bool))
        return {**small, "order": None, "neighbours": None} if with_neighbours else small

    if not np.isfinite(p).all():
        bad = int(np.flatnonzero(~np.isfinite(p).all(axis=1))[0])
        raise InputError(f"splat_frames: position {bad} is not finite")
    n = None
    if normals is not None:
        n = np.asarray(normals, dtype=np.float64)
        length = np.linalg.norm(n, axis=1, keepdims=True)
        n = np.ascontiguousarray(np.where(length > 0, n / np.maximum(length, 1e-300),
                                          [0.0, 0.0, 1.0]))
    if radius is not None:
        radius = np.ascontiguousarray(radius, dtype=np.float64)
    result = _core.splat_frames(
        p, n, radius, k=k, inlier=PLANE_INLIER, share=PLANE_SHARE, spread=PLANE_SPREAD,
        cover=PREVIEW_COVER, edge_cos=PREVIEW_EDGE_COS, on_plane=ON_PLANE, edge_slack=EDGE_SLACK,
        rim_shift=RIM_SHIFT, rim_gap=RIM_GAP, rim_along=RIM_ALONG, rim_reach=RIM_REACH,
        parallel_cos=PARALLEL_COS, crease_width=CREASE_WIDTH, propagate=PROPAGATE,
        rim_neighbours=RIM_NEIGHBOURS, crease_strips=normals is None,
        convex_slack=CONVEX_SLACK if normals is not None else -1.0,
        with_neighbours=with_neighbours, threads=threads, progress=progress)
    frames = np.asarray(result[0] if with_neighbours else result)
    packed = _pack(frames[:, 0:3], frames[:, 3:6], frames[:, 6:9], frames[:, 9:12],
                   frames[:, 12] > 0.5)
    if with_neighbours:
        packed["order"] = np.asarray(result[1])[:, 0]
        packed["neighbours"] = np.asarray(result[2])
    return packed
