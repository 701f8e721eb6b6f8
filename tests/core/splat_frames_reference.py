"""The preview splats' frames in numpy, as the add-on computed them before the native port
(illumap.splats.splat_frames): the reference the native frames are compared with
(test_splat_frames.py) and the baseline of bench/micro/preview_build.py. Same rules and
constants; see illumap/splats.py."""

from __future__ import annotations

import numpy as np

#: Neighbours of each point that size and clip its splat.
NEIGHBOURS = 8
#: Neighbours that tell a scan's rim: with 8, the widest angle between them exceeds 150° at
#: 18% of a random sampling's inner points; with 16 at 0.7% (measured on 20k points).
RIM_NEIGHBOURS = 16
#: Disc radius in units of the distance to the NEIGHBOURS-th nearest point (module docstring).
COVER = 1.0
#: A neighbour is on another surface when |n·m| is below this (about 25°).
EDGE_COS = 0.9
#: A point lies on a neighbour's tangent plane within this fraction of their distance.
ON_PLANE = 0.05
#: Splats reach past the line that clips them by this fraction of their radius.
EDGE_SLACK = 0.15
#: ... past a convex crease's line when the normals were given (oriented).
CONVEX_SLACK = 0.05
#: The neighbours' centroid this far off the point (in units of the neighbour distance) marks
#: a rim ...
RIM_SHIFT = 0.2
#: ... and the widest angle between neighbours seen from the point, in its plane, exceeds this
#: (radians, 150°): on a grid's edge 180°, inside a jittered grid never; inside a random
#: sampling 0.7% of points with 16 neighbours and the shift (18% with 8), before the check below.
RIM_GAP = np.radians(150.0)
#: A rim point needs a rim neighbour that faces within acos(this) of its own direction.
RIM_ALONG = 0.7
#: A rim's splats reach this fraction of their radius beyond the rim point's line.
RIM_REACH = 0.0
#: A second clipping line shrinks a cut ellipse only where it turns from the first by more
#: than acos(this) (30°).
PARALLEL_COS = np.cos(np.radians(30.0))
#: The strip along a crease that a point on it covers reaches this far into its own
#: surface (and EDGE_SLACK past the line), in units of its radius.
CREASE_WIDTH = 0.3
#: Rounds in which the neighbours' clipping planes clip a point (reach: that many rings).
PROPAGATE = 1


def _tangent(n: np.ndarray) -> np.ndarray:
    """A unit vector perpendicular to each of the unit vectors ``n`` (N, 3)."""
    helper = np.where((np.abs(n[:, 0]) < 0.9)[:, None], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0])
    u = np.cross(n, helper)
    return u / np.linalg.norm(u, axis=1, keepdims=True)


def _rims(p, n, nb, far, threads: int) -> tuple[np.ndarray, np.ndarray]:
    """Which points lie on the scan's rim, and the unit direction out of the scan there (in
    the tangent plane). Among the point's ``RIM_NEIGHBOURS`` nearest (all of them: beside a
    crease the other surface's points close the gap on their side, and at a room's open
    corner they leave the gap toward the open side) the widest angle exceeds ``RIM_GAP``, and
    their centroid lies ``RIM_SHIFT`` × the farthest one's distance off the point; the
    direction out halves the gap; and a neighbour is a rim point facing about the same way (a
    rim is a line of them: a lone one is an uneven sampling's hole in the angles). Only the
    points with such a gap among their ``NEIGHBOURS`` nearest take the wider search (a gap
    among some of the neighbours is never narrower than among all): on a regular scan the
    rows along its rims, on a random one about a fifth."""
    from illumap.neighbours import knn  # noqa: PLC0415 - native, loaded on use
    count = len(nb)
    # Single precision suffices for the screen's angles and halves its memory traffic.
    p32, n32 = p.astype(np.float32), n.astype(np.float32)
    cand = np.flatnonzero(_widest_gap(p32[nb] - p32[:, None, :], n32)[0] > RIM_GAP)
    del p32, n32
    rim = np.zeros(count, bool)
    facing = np.zeros((count, 3))
    wide = min(RIM_NEIGHBOURS, count - 1)
    if not len(cand) or wide < 2:
        return rim, facing
    idx, dist = knn(p, p[cand], wide + 1, threads=threads)
    idx, dist = idx[:, 1:], dist[:, -1]
    nc = n[cand]
    offsets = p[idx] - p[cand, None, :]
    gc = offsets.mean(axis=1)
    gc -= np.einsum("ic,ic->i", gc, nc)[:, None] * nc
    gap, out = _widest_gap(offsets, nc)
    is_rim = (np.linalg.norm(gc, axis=1) > RIM_SHIFT * dist) & (gap > RIM_GAP)
    rim[cand] = is_rim
    facing[cand[is_rim]] = out[is_rim]
    sub = np.flatnonzero(rim)
    along = (rim[nb[sub]] & (np.einsum("ic,ikc->ik", facing[sub], facing[nb[sub]])
                             > RIM_ALONG)).any(axis=1)
    rim[sub[~along]] = False
    facing[sub[~along]] = 0.0
    return rim, facing


def _widest_gap(offsets: np.ndarray, n: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The widest angle (radians) between the directions of the neighbours ``offsets``
    (N, k, 3) seen from each point, in its tangent plane (normal ``n``), and the unit vector
    that halves it."""
    u = _tangent(n)
    v = np.cross(n, u)
    angle = np.sort(np.arctan2(np.einsum("ikc,ic->ik", offsets, v),
                               np.einsum("ikc,ic->ik", offsets, u)), axis=1)
    gaps = np.diff(angle, axis=1, append=angle[:, :1] + 2 * np.pi)
    j = np.argmax(gaps, axis=1)[:, None]
    half = (np.take_along_axis(angle, j, axis=1) + 0.5 * np.take_along_axis(gaps, j, axis=1))[:, 0]
    return gaps.max(axis=1), np.cos(half)[:, None] * u + np.sin(half)[:, None] * v


def _crease_lines(p, n, nb, sub, other):
    """For the points ``sub`` and their neighbours on other surfaces (``other``, (S, k)): the
    distance in each point's plane to the nearest line where such a neighbour's tangent plane
    cuts it (inf: none), the unit direction toward that line, and that neighbour's plane
    (normal, offset)."""
    ps, ns, q = p[sub], n[sub], p[nb[sub]]
    m = n[nb[sub]]
    offsets = q - ps[:, None, :]
    cos = np.einsum("ic,ikc->ik", ns, m)
    h = -np.einsum("ikc,ikc->ik", m, offsets)                 # m·(p − q)
    near = np.linalg.norm(offsets, axis=2)
    same = ~other
    centroid = (offsets * same[..., None]).sum(1) / np.maximum(same.sum(1), 1)[:, None]
    # No neighbour on its own surface (a corner whose normal is its faces' mean): the side
    # where its neighbours are.
    centroid = np.where(same.any(1)[:, None], centroid, offsets.mean(1))
    on_plane = np.abs(h) <= ON_PLANE * near
    # A point on the neighbour's plane keeps the side its own surface's neighbours are on.
    side = np.where(on_plane, ON_PLANE * near * np.sign(np.einsum("ikc,ic->ik", m, centroid)), h)
    t_len = np.sqrt(np.maximum(1.0 - cos ** 2, 1e-12))
    c = np.where(other & (side != 0), np.where(on_plane, 0.0, np.abs(h)) / t_len, np.inf)
    j = np.argmin(c, axis=1)
    rows = np.arange(len(sub))
    mj, cj = m[rows, j], cos[rows, j]
    w = -np.sign(side[rows, j])[:, None] * (mj - cj[:, None] * ns) / t_len[rows, j][:, None]
    return c[rows, j], w, mj, np.einsum("ic,ic->i", mj, q[rows, j])


def _neighbours_planes(p, n, nb, sub, has, plane_n, plane_d):
    """For the points ``sub``: the nearest line where a clipped neighbour's clipping plane
    cuts the point's plane (distance, inf: none; unit direction toward it; that plane's
    normal and offset)."""
    ps, ns, nbs = p[sub], n[sub], nb[sub]
    pm = plane_n[nbs]
    cos = np.einsum("ic,ikc->ik", ns, pm)
    h = np.einsum("ikc,ic->ik", pm, ps) - plane_d[nbs]
    t_len = np.sqrt(np.maximum(1.0 - cos ** 2, 1e-12))
    near = np.linalg.norm(p[nbs] - ps[:, None, :], axis=2)
    usable = has[nbs] & (np.abs(cos) < EDGE_COS) & (np.abs(h) > ON_PLANE * near)
    c = np.where(usable, np.abs(h) / t_len, np.inf)
    j = np.argmin(c, axis=1)
    rows = np.arange(len(sub))
    w = -np.sign(h[rows, j])[:, None] * (pm[rows, j] - cos[rows, j][:, None] * ns) \
        / t_len[rows, j][:, None]
    return c[rows, j], w, pm[rows, j], plane_d[nbs][rows, j], j


def _slack(oriented, rim_plane, plane_n, w):
    """EDGE_SLACK, or CONVEX_SLACK past a convex crease where normals are oriented."""
    convex = oriented & ~rim_plane & (np.einsum("...c,...c->...", plane_n, w) > 0)
    return np.where(convex, CONVEX_SLACK, EDGE_SLACK)


def splat_frames(positions, normals=None, radius=None, *, threads: int = 0) -> dict:
    """Each point's splat (module docstring) as float32 arrays: ``normal`` (N, 3, unit),
    ``axis`` (N, 3: the in-plane direction of the ellipse's first axis), ``scale`` (N, 3: the
    semi-axes along ``axis`` and across it, and 1) and ``offset`` (N, 3: from the point to
    the ellipse's centre), and ``clipped`` (N,) bool: the splats a crease or rim shaped."""
    from illumap.neighbours import knn  # noqa: PLC0415 - native, loaded on use
    from illumap.pointcloud import plane_normals  # noqa: PLC0415
    p = np.ascontiguousarray(positions, dtype=np.float64)
    count = len(p)
    k = min(NEIGHBOURS, count - 1)
    if k < 2:
        n = np.tile([0.0, 0.0, 1.0], (count, 1)) if normals is None else np.asarray(normals)
        r = np.full(count, 0.01) if radius is None else np.asarray(radius, np.float64)
        return _pack(n, _tangent(n), np.stack([r, r, r], 1), np.zeros((count, 3)),
                     np.zeros(count, bool))
    idx, dist = knn(p, p, k + 1, threads=threads)
    far = dist[:, k]
    if normals is None:
        n = np.asarray(plane_normals(p, idx, threads=threads), dtype=np.float64)
    else:
        n = np.asarray(normals, dtype=np.float64)
        length = np.linalg.norm(n, axis=1, keepdims=True)
        n = np.where(length > 0, n / np.maximum(length, 1e-300), [0.0, 0.0, 1.0])
    if radius is None:
        r = COVER * far[idx].mean(axis=1)
    else:
        r = np.asarray(radius, dtype=np.float64)
    r = np.where(r > 0, r, np.maximum(far, 1e-6))
    nb = idx[:, 1:]
    cos = np.einsum("ic,ikc->ik", n, n[nb])
    other = np.abs(cos) < EDGE_COS
    # Only the points with a neighbour on another surface (those by an edge) and then those
    # whose neighbours were clipped do the per-neighbour work below.
    c_min = np.full(count, np.inf)
    w = np.zeros((count, 3))
    plane_n = np.zeros((count, 3))
    plane_d = np.zeros(count)
    sub = np.flatnonzero(other.any(axis=1))
    if len(sub):
        c_min[sub], w[sub], plane_n[sub], plane_d[sub] = _crease_lines(p, n, nb, sub, other[sub])
    # A point on the crease itself belongs to both surfaces (a scan of two walls has one on
    # each, at the same place, with the same plane and each its own colour): its splat would
    # lay one surface's colour over the other's, so it keeps only a strip along the crease
    # on its own side (CREASE_WIDTH × r into it, EDGE_SLACK × r past the line: across the
    # line it would stand out of the other surface), and its neighbours on either side, which
    # reach the crease, cover the surface up to it. With the scan's own normals each point there lies in
    # its own surface's plane: its splat is that surface's and stays whole.
    on_crease = (c_min == 0) & (normals is None)
    # Rims (``_rims``): the scan ends there; the splat reaches RIM_REACH × r beyond the
    # point, and so does its clipping plane (perpendicular to the surface, facing out) for
    # the points around it.
    rim, facing = _rims(p, n, nb, far, threads)
    rim &= RIM_REACH * r < c_min
    out = facing[rim]
    # The line sits EDGE_SLACK × r inside the reach, which every cut adds back: a splat ends
    # RIM_REACH × r past the rim, where an edge's splats overlap the other face by the slack.
    c_min[rim] = (RIM_REACH - EDGE_SLACK) * r[rim]
    w[rim] = out
    plane_n[rim] = out
    plane_d[rim] = np.einsum("ic,ic->i", out, p[rim] + c_min[rim][:, None] * out)
    rim_plane = rim.copy()    # which planes are rims' (no convex crease there)
    # The planes that clipped the neighbours clip the point too: one a few spacings from an
    # edge or a rim may have no point of the other surface (or no rim point) among its own
    # neighbours, yet its splat reaches over. Each neighbour's clipping plane is tried as a
    # line of the point's own, twice (so the plane reaches the neighbours' neighbours).
    for _ in range(PROPAGATE):
        has = np.isfinite(c_min)
        sub = np.flatnonzero(has[nb].any(axis=1))
        if not len(sub):
            break
        c2, w2, n2, d2, j2 = _neighbours_planes(p, n, nb, sub, has, plane_n, plane_d)
        better = c2 < c_min[sub]
        moved = sub[better]
        from_rim = rim_plane[nb[sub, j2]][better]
        c_min[moved], w[moved] = c2[better], w2[better]
        plane_n[moved], plane_d[moved] = n2[better], d2[better]
        rim_plane[moved] = from_rim
    # Past a convex crease (the clipping surface's normal points beyond the line) splats
    # reach CONVEX_SLACK × r only, where the normals were given (oriented).
    oriented = normals is not None
    reach = c_min + _slack(oriented, rim_plane, plane_n, w) * r
    clipped = reach < r
    reach = np.where(clipped, reach, r)
    a = r
    b = np.where(clipped, 0.5 * (r + reach), r)
    shift = np.where(clipped, 0.5 * (r - reach), 0.0)
    offset = -shift[:, None] * np.where(clipped[:, None], w, 0.0)
    # The ellipse's first axis runs along the clipping line: across it, w.
    axis = np.where(clipped[:, None], np.cross(w, n), _tangent(n))
    axis /= np.maximum(np.linalg.norm(axis, axis=1, keepdims=True), 1e-300)
    # Where a second line cuts (a room's corner, a crease meeting the scan's rim), the ellipse
    # shrinks about its point until it ends there too.
    has = np.isfinite(c_min)
    sub = np.flatnonzero(clipped)
    if len(sub):
        shrink = _second_lines(p, n, nb, sub, has, plane_n, plane_d, axis, a, b, offset, r,
                               np.where(clipped[:, None], w, 0.0), oriented, rim_plane)
        a, b = a.copy(), b.copy()
        a[sub] *= shrink
        b[sub] *= shrink
        offset[sub] *= shrink[:, None]
        clipped[sub] |= shrink < 1
    b = np.where(on_crease, 0.5 * (CREASE_WIDTH + EDGE_SLACK) * r, b)
    offset[on_crease] = -0.5 * (CREASE_WIDTH - EDGE_SLACK) * r[on_crease, None] * w[on_crease]
    return _pack(n, axis, np.stack([a, b, a], 1), offset, clipped | on_crease)


def _second_lines(p, n, nb, sub, has, plane_n, plane_d, axis, a, b, offset, r, primary,
                  oriented, rim_plane):
    """For the points ``sub``: the factor (≤ 1) by which each ellipse shrinks about its point
    so that it reaches no further than ``EDGE_SLACK`` × r past any clipping plane of its own or
    of its neighbours (the line where that plane cuts the point's plane); ``primary``: the
    direction toward the line that cut the ellipse (0: none)."""
    ps, ns = p[sub], n[sub]
    near_offsets = p[nb[sub]] - ps[:, None, :]
    own = (np.abs(np.einsum("ic,ikc->ik", ns, n[nb[sub]])) >= EDGE_COS)[..., None]
    inward = (near_offsets * own).sum(axis=1) / np.maximum(own.sum(axis=1), 1)
    inward = np.where(own.any(axis=1), inward, near_offsets.mean(axis=1))
    cand = np.concatenate([sub[:, None], nb[sub]], axis=1)              # (S, k + 1)
    # ... and the neighbours' own tangent planes: near a corner of three faces the third
    # face's plane may clip none of the neighbours, yet the ellipse reaches over it.
    own_n = n[nb[sub]]
    pm = np.concatenate([plane_n[cand], own_n], axis=1)                  # (S, 2k + 1, 3)
    pd = np.concatenate([plane_d[cand], np.einsum("ikc,ikc->ik", own_n, p[nb[sub]])], axis=1)
    has_plane = np.concatenate([has[cand], np.ones(nb[sub].shape, bool)], axis=1)
    rim_of = np.concatenate([rim_plane[cand], np.zeros(nb[sub].shape, bool)], axis=1)
    cand = np.concatenate([cand, nb[sub]], axis=1)
    cos = np.einsum("ic,ikc->ik", ns, pm)
    h = np.einsum("ikc,ic->ik", pm, ps) - pd                            # signed, p off the plane
    t_len = np.sqrt(np.maximum(1.0 - cos ** 2, 1e-12))
    near = np.linalg.norm(p[cand] - ps[:, None, :], axis=2)
    near[:, 0] = 0.0
    # A point on the plane (a room's corner, where three scans' points coincide) keeps the
    # side its neighbours are on.
    side = np.where(np.abs(h) > ON_PLANE * near, np.sign(h),
                    -np.sign(np.einsum("ikc,ic->ik", pm, inward)))
    usable = has_plane & (np.abs(cos) < EDGE_COS) & (side != 0)
    dist = np.where(np.abs(h) > ON_PLANE * near, np.abs(h), 0.0) / t_len   # p to the line
    w = -side[..., None] * (pm - cos[..., None] * ns[:, None, :]) / t_len[..., None]
    bx = np.cross(ns, axis[sub])
    support = np.einsum("ic,ikc->ik", offset[sub], w) + np.sqrt(
        (a[sub, None] * np.einsum("ic,ikc->ik", axis[sub], w)) ** 2
        + (b[sub, None] * np.einsum("ic,ikc->ik", bx, w)) ** 2)
    # A line along the one the ellipse was cut at (the same edge, seen from a neighbour) is
    # that cut's business; only a line across it (a corner) shrinks the ellipse.
    # A line through the point counts only as a second one at a cut point (a corner): at an
    # uncut one it would shrink the splat to nothing where the cut itself shapes it.
    cut = np.any(primary[sub] != 0, axis=1)[:, None]
    across = np.abs(np.einsum("ic,ikc->ik", primary[sub], w)) < PARALLEL_COS
    usable &= np.where(cut, across, np.abs(h) > ON_PLANE * near)
    limit = dist + _slack(oriented, rim_of, pm, w) * r[sub, None]
    scale = np.where(usable & (support > limit), limit / np.maximum(support, 1e-300), 1.0)
    return scale.min(axis=1)


def _pack(n, axis, scale, offset, clipped) -> dict:
    f = lambda x: np.ascontiguousarray(x, dtype=np.float32)  # noqa: E731
    return {"normal": f(n), "axis": f(axis), "scale": f(scale), "offset": f(offset),
            "clipped": np.asarray(clipped, bool)}
