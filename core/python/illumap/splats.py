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
                neighbours: int = DEFAULT_NEIGHBOURS, sides: int = DEFAULT_SIDES,
                chunk: int = 16384) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The clipped outline of every splat: (radii (N, sides) in m along the directions
    cos θ_m u + sin θ_m v, u (N, 3), v (N, 3)), the tangent basis of each point."""
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
    n = n / np.maximum(np.linalg.norm(n, axis=1, keepdims=True), 1e-300)
    u, v = _basis(n)
    theta = 2.0 * np.pi * np.arange(sides) / sides
    directions = (np.cos(theta)[None, :, None] * u[:, None, :]
                  + np.sin(theta)[None, :, None] * v[:, None, :])          # (N, M, 3)
    own = np.sqrt(a / np.pi)
    radii = np.repeat((reach * own)[:, None], sides, axis=1)
    k = min(neighbours, count - 1)
    if k < 1:
        return radii, u, v
    idx, _ = _core.knn(p, p, k + 1)
    idx = idx[:, 1:]
    for lo in range(0, count, chunk):
        rows = slice(lo, min(lo + chunk, count))
        radii[rows] = np.minimum(radii[rows], _clip(p[rows], n[rows], directions[rows],
                                                    p[idx[rows]], n[idx[rows]],
                                                    own[rows, None]))
    return radii, u, v


def _clip(p, n, d, q, nq, rim) -> np.ndarray:
    """Largest radius along each direction d (R, M, 3) inside every neighbour's half-spaces."""
    w = q - p[:, None, :]                                       # (R, k, 3)
    dw = np.einsum("rmc,rkc->rmk", d, w)
    half = 0.5 * np.einsum("rkc,rkc->rk", w, w)
    turn = np.einsum("rc,rkc->rk", n, nq) < EDGE_COS
    # Bisector with neighbours on the same surface: ρ (d·w) ≤ |w|²/2; coincident points
    # (w = 0) leave each other whole.
    limit = np.where((dw > 1e-12 * np.sqrt(half)[:, None, :] + 1e-300) & ~turn[:, None, :],
                     CORNER_SLACK * half[:, None, :] / np.where(dw > 0, dw, 1.0), np.inf)
    # Directions with no neighbour within 60° lead off the scan's rim: there the splat ends at
    # the point's own radius instead of its reach. (Another surface's neighbours count: a
    # wall's splats reach down to the floor's plane, which then clips them.)
    tangential = w - np.einsum("rkc,rc->rk", w, n)[..., None] * n[:, None, :]
    length = np.linalg.norm(tangential, axis=2)
    toward = dw / np.maximum(length, 1e-300)[:, None, :]       # cos(d, neighbour), tangentially
    supported = ((toward > RIM_COS) & (length > 0)[:, None, :]).any(axis=2)
    # Tangent planes where the surface turns: a splat stays on the side of each such plane
    # that its point is on, side·(x − q)·n_q ≥ 0.
    height = np.einsum("rkc,rkc->rk", -w, nq)                  # (p − q)·n_q
    on_plane = turn & (np.abs(height) <= JUNCTION_TOLERANCE * np.sqrt(2.0 * half))
    # p on the plane itself (an edge's own points): the side its own surface lies on, where
    # the centroid of p and its same-surface neighbours is (whichever way either normal was
    # oriented). Unless it is a junction, where the other surface lies on both sides of p's
    # plane (a box's side on a floor that runs on under it): there nothing clips, or the
    # side's splats would lose their half above the floor.
    own = (~turn)[..., None]
    centroid = (w * own).sum(axis=1) / (own.sum(axis=1) + 1.0)             # minus p
    lean = np.einsum("rc,rkc->rk", centroid, nq) + height                 # (c − q)·n_q
    leaning = np.abs(lean) > JUNCTION_TOLERANCE * np.sqrt(2.0 * half)
    # Which side of p's plane each neighbour lies on; one on the edge line itself lies on
    # neither (it would make every edge look like a junction).
    rise = np.einsum("rkc,rc->rk", w, n)
    bend = np.where(np.abs(rise) > JUNCTION_TOLERANCE * np.sqrt(2.0 * half), np.sign(rise), 0.0)
    side = np.where(on_plane, np.where(leaning, np.sign(lean), 0.0), np.sign(height))
    junction = (on_plane & (bend > 0)).any(axis=1) & (on_plane & (bend < 0)).any(axis=1)
    # ... a hair beyond it: splats that end exactly on each other's planes leave a slit
    # along the edge that rays slip through (0.5% of the rays from inside a scanned box).
    g = np.maximum(side * height, 0.0) + EDGE_OVERLAP * np.sqrt(2.0 * half)
    slope = side[:, None, :] * np.einsum("rmc,rkc->rmk", d, nq)
    keep = turn & (side != 0) & ~(on_plane & junction[:, None])
    applies = keep[:, None, :] & (slope < 0)
    plane = np.where(applies, g[:, None, :] / np.where(slope < 0, -slope, 1.0), np.inf)
    radius = np.minimum(limit, plane).min(axis=2)
    return np.where(supported, radius, np.minimum(radius, rim))


def splat_triangles(positions, normals, areas, **options) -> np.ndarray:
    """(N × sides, 3, 3) triangles, the splats of N points as fans about them (point i's are
    rows i·sides … (i+1)·sides − 1), each in the plane of its point's surface
    (``pointcloud.settled_normals``), wound so that their normals agree with ``normals``.
    Options: see ``splat_radii``."""
    p = np.ascontiguousarray(positions, dtype=np.float64)
    normals = settled_normals(p, normals)
    radii, u, v = splat_radii(p, normals, areas, **options)
    sides = radii.shape[1]
    theta = 2.0 * np.pi * np.arange(sides) / sides
    rim = p[:, None, :] + radii[..., None] * (np.cos(theta)[None, :, None] * u[:, None, :]
                                              + np.sin(theta)[None, :, None] * v[:, None, :])
    centre = np.broadcast_to(p[:, None, :], rim.shape)
    nxt = np.roll(rim, -1, axis=1)
    # The rim runs counter-clockwise about u × v: wind each fan so its normal is the point's.
    along = np.einsum("nc,nc->n", np.cross(u, v), np.asarray(normals, dtype=np.float64)) >= 0
    first = np.where(along[:, None, None], rim, nxt)
    second = np.where(along[:, None, None], nxt, rim)
    return np.stack([centre, first, second], axis=2).reshape(-1, 3, 3)
