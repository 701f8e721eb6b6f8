"""A point cloud's points as receivers (no bpy): every point, and for a scan of unknown
orientation the side of each point that a probe gather finds facing out."""

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
                 lum: np.ndarray) -> tuple:
    """Which side of each point of a cloud of unknown orientation faces out, from a probe
    gather of both sides (``front`` and ``back``: the same points, opposite normals).
    Returns (``ScanPatches``, side (P,) bool: True where the front normal faces out,
    settled (P,) bool: whose patch the probe decided, rays cast); a gather too short to
    probe decides nothing."""
    from ..scan_values import ScanPatches
    n = len(front.points)
    patches = ScanPatches(front.points, front.normals)
    rays = max(SIDE_PROBE_MIN_RAYS, int(gather_rays * SIDE_PROBE_SHARE))
    if n == 0 or 2 * rays >= gather_rays:
        return patches, np.ones(n, dtype=bool), np.zeros(n, dtype=bool), 0
    ids = patches.sample(SIDE_PROBE_POINTS, SIDE_PROBE_WHOLE_PATCH, SIDE_PROBE_MOST_POINTS)
    m = len(ids)
    incident, gathered, cast, _ = incident_at(
        np.concatenate([front.points[ids], back.points[ids]]),
        np.concatenate([front.normals[ids], back.normals[ids]]),
        np.concatenate([ids, ids]), rays=rays,
        samples=max(SIDE_PROBE_MIN_RAYS, int(shadow_samples * SIDE_PROBE_SHARE)))
    lit_front = front.emission[ids] + front.albedo[ids] * incident[:m]
    lit_back = back.emission[ids] + back.albedo[ids] * incident[m:]
    noise_front = (front.albedo[ids] @ lum) * gathered.stderr[:m]
    noise_back = (back.albedo[ids] @ lum) * gathered.stderr[m:]
    side, settled = patches.sides(lit_front, lit_back, noise_front, noise_back, rows=ids)
    return patches, side, settled, cast
