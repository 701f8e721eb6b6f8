"""A point cloud's points as receivers (no bpy): every point, for a scan of unknown
orientation the side of each point that a probe gather finds facing out, and where each
receiver starts: clear of its neighbours' splats (``SplatClearance``)."""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from ..stages.scene import Receivers, Scene


def point_receivers(scene: Scene) -> list[tuple]:
    """Receivers at every point of each point cloud (``(receivers, back)``; ``back`` the same
    points facing the other way for clouds of unknown orientation, else None), in the order
    of their sources."""
    backs = {src.name for src in scene.sources if src.kind == "BACK"}
    out = []
    for cloud in scene.clouds:
        n = len(cloud.positions)
        make = lambda normals, c=cloud, n=n: Receivers(  # noqa: E731
            c.name, np.arange(n, dtype=np.int64), c.positions, normals, c.albedo, c.emission, n)
        out.append((make(cloud.normals), make(-cloud.normals) if cloud.name in backs else None))
    return out


#: A scan of unknown orientation is first lit on both sides with this share of the gather's
#: rays and of the shadow samples (at least SIDE_PROBE_MIN_RAYS): most patches' outside is
#: plain from that
#: (``illumap.receivers.ScanPatches.sides``), and only the other patches take the full gather
#: on both sides.
SIDE_PROBE_SHARE = 1 / 16
SIDE_PROBE_MIN_RAYS = 8
#: The probe lights this share of a patch's points (every point of a patch of at most
#: SIDE_PROBE_WHOLE_PATCH): a patch's sides are judged on its sums (``ScanPatches.sides``).
SIDE_PROBE_POINTS = 1 / 4
SIDE_PROBE_WHOLE_PATCH = 64
#: ... and at most about this many of any patch: the probe's cost then stops growing with
#: the scan's density (a 990k-point Cornell box scan probed 250k points with 16M rays; 180k
#: with 5.8M rays at 8192 per patch, 4.4 CPU-s); a patch still decides on the sums over
#: thousands of points (tens of thousands of rays). The bench scans read the same error at
#: 2048 as at 8192 (4.00% and 4.23% from Cycles).
SIDE_PROBE_MOST_POINTS = 2048


def rows_of(rec, rows: np.ndarray, normals: np.ndarray | None = None):
    """The receivers ``rows`` of ``rec`` (with other ``normals``)."""
    return replace(rec, corner_vertex=rec.corner_vertex[rows], points=rec.points[rows],
                   normals=rec.normals[rows] if normals is None else normals,
                   albedo=rec.albedo[rows], emission=rec.emission[rows],
                   inward=None if rec.inward is None else rec.inward[rows],
                   faces=None if rec.faces is None else rec.faces[rows],
                   corner_id=rec.ids[rows])


def probe_sides(front, back, incident_at, gather_rays: int, shadow_samples: int,
                 lum: np.ndarray, clearance: "SplatClearance | None" = None,
                 patches=None) -> tuple:
    """Which side of each point of a cloud of unknown orientation faces out, from a probe
    gather of both sides (``front`` and ``back``: the same points, opposite normals).
    Returns (``ScanPatches``, side (P,) bool: True where the front normal faces out,
    settled (P,) bool: whose patch the probe decided, rays cast); a gather too short to
    probe decides nothing. ``clearance``: each side's receivers start clear of the splats
    (``SplatClearance``); ``patches``: the points' ``ScanPatches`` when the caller made them."""
    from ..scan_values import ScanPatches
    n = len(front.points)
    patches = ScanPatches(front.points, front.normals) if patches is None else patches
    rays = max(SIDE_PROBE_MIN_RAYS, int(gather_rays * SIDE_PROBE_SHARE))
    if n == 0 or 2 * rays >= gather_rays:
        return patches, np.ones(n, dtype=bool), np.zeros(n, dtype=bool), 0
    ids = patches.sample(SIDE_PROBE_POINTS, SIDE_PROBE_WHOLE_PATCH, SIDE_PROBE_MOST_POINTS)
    m = len(ids)
    at = np.concatenate([front.points[ids], back.points[ids]])
    if clearance is not None:
        at = clearance.lift(np.concatenate([ids, ids]), at,
                            np.concatenate([front.normals[ids], back.normals[ids]]))
    incident, gathered, cast, _ = incident_at(
        at,
        np.concatenate([front.normals[ids], back.normals[ids]]),
        np.concatenate([ids, ids]), rays=rays,
        samples=max(SIDE_PROBE_MIN_RAYS, int(shadow_samples * SIDE_PROBE_SHARE)))
    lit_front = front.emission[ids] + front.albedo[ids] * incident[:m]
    lit_back = back.emission[ids] + back.albedo[ids] * incident[m:]
    noise_front = (front.albedo[ids] @ lum) * gathered.stderr[:m]
    noise_back = (back.albedo[ids] @ lum) * gathered.stderr[m:]
    side, settled = patches.sides(lit_front, lit_back, noise_front, noise_back, rows=ids)
    return patches, side, settled, cast


#: A scan point's receivers start just above the splats of this many of its nearest points
#: (``SplatClearance``): the ones whose splats reach over it (a splat spans about two spacings).
CLEARANCE_NEIGHBOURS = 6
#: Neighbours whose splat planes count: normals within acos(this) of the receiver's direction
#: (about 25°; farther, the neighbour lies on another surface, which the ray must meet).
CLEARANCE_COS = 0.9
#: The lift never exceeds this share of the point's spacing (the median distance to those
#: neighbours): a neighbour's splat standing higher is another surface, not scan noise.
CLEARANCE_MAX = 0.5
#: ... and clears the highest splat by this share of the spacing.
CLEARANCE_MARGIN = 0.02
#: No other surface may lie within this many times the lift along the way (a receiver
#: lifted close to another surface would see past it sooner than its point does).
CLEARANCE_FREE = 2.0
#: ... nor within this many spacings (the gap under a scanned base: a receiver lifted
#: towards the floor sees less of the sky beside it than its point does).
CLEARANCE_FREE_SPACINGS = 3.0
#: The way up is followed through at most this many splats (the point's own and its
#: neighbours') ...
CLEARANCE_HOPS = 4
#: ... stepping this share of the spacing past each.
CLEARANCE_STEP = 1e-4
#: A splat lower than this share of the spacing above the receiver leaves it where it is
#: (rounding, a plane's own points).
CLEARANCE_MIN = 0.01
#: ... and no receiver moves farther than this many times its point's roughness: the largest
#: distance of its neighbours on the same surface from its own splat's plane (scan noise and
#: curvature at the splats' scale; 0 on an exact scan of planes, whose receivers stay put).
CLEARANCE_ROUGHNESS = 4.0


class SplatClearance:
    """How far above its neighbours' splats each receiver of a scan must start.

    A scan's points scatter about the surface they sample (the bunny's by about a tenth of
    its 3 mm spacing), and each point's splat lies in its own fitted plane
    (``pointcloud.settled_normals``, as ``splats.splat_triangles`` builds them). Where the
    neighbours' splats pass above a point, a receiver at the point starts under them: its
    lamp's shadow rays and its gather's rays meet the splats of its own surface, and it
    reads dark (the bunny's points 0.09 where Cycles bakes its triangles at 0.75). Cycles'
    vertex lies on its own faces, with nothing of its own surface above it. So a receiver
    at point i facing ``d`` starts at x + h·d, h the largest height along d at which the
    planes of i's ``CLEARANCE_NEIGHBOURS`` nearest points on the same surface (normals within
    acos ``CLEARANCE_COS`` of d) pass above x, plus ``CLEARANCE_MARGIN`` of the spacing; at
    most ``CLEARANCE_MAX`` of it (a higher plane belongs to another surface) and
    ``CLEARANCE_ROUGHNESS`` × the point's roughness. On an exact scan of planes nothing
    moves; on a curved surface the neighbours' planes pass a little above the point (the
    sag of the curve over a spacing), which the lift clears too. ``occluders`` (the scene's
    ``receivers.MeshOccluders``) and ``owner`` ((T,) int: the point of this cloud whose splat
    each triangle is, −1 for other surfaces): a receiver whose way up meets another surface
    stays put (``_path_clear``). ``neighbours`` (P, SETTLE_NEIGHBOURS + 1): the points' own
    search, the point first, when the caller has it (``ScanPatches.neighbours``). Positions
    in metres."""

    def __init__(self, points, normals, occluders=None, owner: np.ndarray | None = None,
                 neighbours: np.ndarray | None = None) -> None:
        from ..pointcloud import SETTLE_NEIGHBOURS, settled_normals
        from .. import _core
        p = np.ascontiguousarray(points, dtype=np.float64)
        self.points = p
        self.count = len(p)
        #: the scene's ``receivers.MeshOccluders`` and, per triangle, the point of this cloud
        #: whose splat it is (−1: another surface's), or None: lifts are not checked
        self.occluders, self.owner = occluders, owner
        if self.count < 2:
            self.idx = np.zeros((self.count, 0), dtype=np.int64)
            self.planes = np.asarray(normals, dtype=np.float64)
            self.spacing = np.zeros(self.count)
            self.roughness = np.zeros(self.count)
            return
        k = int(min(max(SETTLE_NEIGHBOURS, CLEARANCE_NEIGHBOURS) + 1, self.count))
        if neighbours is not None and np.shape(neighbours) == (self.count, k):
            idx = np.asarray(neighbours, dtype=np.int64)
            dist = np.linalg.norm(p[idx] - p[:, None, :], axis=2)
        else:
            idx, dist = _core.knn(p, p, k)
            idx, dist = np.asarray(idx, dtype=np.int64), np.asarray(dist)
        #: (P, 3) the splats' planes' normals (sign as given)
        self.planes = settled_normals(p, normals, idx if k == SETTLE_NEIGHBOURS + 1 else None)
        m = int(min(CLEARANCE_NEIGHBOURS + 1, k))
        #: (P, m − 1) the neighbours whose splats may pass over each point, itself left out
        self.idx = idx[:, 1:m]
        #: (P,) m: the median distance to them
        self.spacing = np.median(dist[:, 1:m], axis=1)
        own = self.planes[:, None, :]
        off = np.abs(np.einsum("pkc,pkc->pk", own, p[self.idx] - p[:, None, :]))
        same = np.abs(np.einsum("pkc,pkc->pk", own, self.planes[self.idx])) >= CLEARANCE_COS
        #: (P,) m: how far its same-surface neighbours lie off each point's splat plane
        self.roughness = np.where(same, off, 0.0).max(axis=1)

    def lift(self, rows: np.ndarray, at: np.ndarray, directions: np.ndarray) -> np.ndarray:
        """Receivers of the points ``rows`` (M,), placed ``at`` (M, 3) m and facing unit
        ``directions`` (M, 3), moved along them to clear their neighbours' splats: (M, 3)."""
        rows = np.asarray(rows, dtype=np.int64)
        at = np.asarray(at, dtype=np.float64)
        d = np.asarray(directions, dtype=np.float64)
        if self.idx.shape[1] == 0 or len(rows) == 0:
            return at.copy()
        nb = self.idx[rows]                                       # (M, k)
        n_q = self.planes[nb]                                     # (M, k, 3)
        cos = np.einsum("mkc,mc->mk", n_q, d)
        above = np.einsum("mkc,mkc->mk", n_q, self.points[nb] - at[:, None, :])
        with np.errstate(divide="ignore", invalid="ignore"):
            height = np.where(np.abs(cos) >= CLEARANCE_COS, above / cos, 0.0)
        spacing = self.spacing[rows]
        h = np.clip(height.max(axis=1), 0.0, None)
        h = np.where(h > CLEARANCE_MIN * spacing, h + CLEARANCE_MARGIN * spacing, 0.0)
        h = np.minimum(h, np.minimum(CLEARANCE_MAX * spacing,
                                     CLEARANCE_ROUGHNESS * self.roughness[rows]))
        h[~self._path_clear(rows, at, d, h)] = 0.0
        return at + h[:, None] * d

    def _path_clear(self, rows, at, d, h) -> np.ndarray:
        """bool (M,): whether the way from ``at`` along ``d`` (``CLEARANCE_FREE`` × ``h``, at
        least ``CLEARANCE_FREE_SPACINGS`` spacings) meets only the splats of the point and
        its neighbours (looked for over ``CLEARANCE_HOPS`` hits);
        False where it meets another surface (a floor 1.5 mm under a scanned base: lifted
        past it, the receiver would see under the floor) or more splats than that."""
        clear = np.ones(len(rows), dtype=bool)
        if self.occluders is None or self.owner is None:
            return clear
        todo = np.flatnonzero(h > 0)
        h = np.maximum(CLEARANCE_FREE * h, CLEARANCE_FREE_SPACINGS * self.spacing[rows])
        start = np.zeros(len(todo))
        allowed = np.concatenate([rows[:, None], self.idx[rows]], axis=1)
        for _ in range(CLEARANCE_HOPS):
            if not len(todo):
                return clear
            tri, dist, _ = self.occluders.intersect(at[todo] + start[:, None] * d[todo],
                                                    d[todo], tmax=float(h[todo].max()))
            reached = start + np.where(tri >= 0, dist, np.inf)
            beyond = reached >= h[todo]
            owner = np.where(tri >= 0, self.owner[np.maximum(tri, 0)], -1)
            own = (owner[:, None] == allowed[todo]).any(axis=1) & (owner >= 0)
            clear[todo[~beyond & ~own]] = False
            go = ~beyond & own
            todo = todo[go]
            start = reached[go] + CLEARANCE_STEP * self.spacing[rows[todo]]
        clear[todo] = False
        return clear

    def lifted(self, rec):
        """Receivers ``rec`` of this cloud (``rows_of``: its points are ``corner_vertex``)
        moved clear of the splats along their normals."""
        return replace(rec, points=self.lift(rec.corner_vertex, rec.points, rec.normals))
