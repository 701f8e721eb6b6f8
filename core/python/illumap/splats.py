"""Splats: the surface a point cloud stands for, as triangles.

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

import numpy as np

from . import _core
from .pointcloud import settled_normals
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
                sides: int = DEFAULT_SIDES) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The clipped outline of every splat: (radii (N, sides) in m along the directions
    cos θ_m u + sin θ_m v, u (N, 3), v (N, 3)), the tangent basis of each point. Native
    (``illumap._core.splat_radii``, splats.cpp), both threads."""
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
    idx, _ = _core.knn(p, p, k + 1)
    radii = _core.splat_radii(p, n, np.ascontiguousarray(u), np.ascontiguousarray(v),
                              reach * own, own, np.ascontiguousarray(np.asarray(idx)[:, 1:]),
                              sides=int(sides), corner_slack=CORNER_SLACK, edge_cos=EDGE_COS,
                              rim_cos=RIM_COS, junction_tolerance=JUNCTION_TOLERANCE,
                              edge_overlap=EDGE_OVERLAP)
    return np.asarray(radii), u, v


def splat_triangles(positions, normals, areas, **options) -> np.ndarray:
    """(N × sides, 3, 3) triangles, the splats of N points as fans about them (point i's are
    rows i·sides … (i+1)·sides − 1), each in the plane of its point's surface
    (``pointcloud.settled_normals``), wound so that their normals agree with ``normals``.
    Options: see ``splat_radii``."""
    p = np.ascontiguousarray(positions, dtype=np.float64)
    facing = np.ascontiguousarray(settled_normals(p, normals), dtype=np.float64)
    radii, u, v = splat_radii(p, facing, areas, **options)
    return np.asarray(_core.splat_fans(p, np.ascontiguousarray(u), np.ascontiguousarray(v),
                                       np.ascontiguousarray(radii), facing))
