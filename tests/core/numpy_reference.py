"""The numpy formulation of the point clouds' plane fits and splat outlines, and of the
irradiance cache's record weights and fitted values, that the native code (``illumap._core``:
normals.cpp, splats.cpp, irradiance_cache.cpp) replaced, kept as an independent reference for
it: the same rules written as whole-array algebra, with LAPACK's eigen-solver and linear
solver instead of the native Jacobi rotations and elimination."""

from __future__ import annotations

import numpy as np

from illumap import _core, splats
from illumap import pointcloud as pc


def _neighbours(pts: np.ndarray, k: int) -> np.ndarray:
    kk = int(min(max(int(k), 2), len(pts) - 1))
    return np.asarray(_core.knn(pts, pts, kk + 1)[0])


def estimate_plane_normals(points: np.ndarray, k: int = pc.DEFAULT_K) -> np.ndarray:
    """Unoriented plane-fit normals (P, 3) over each point's k nearest neighbours."""
    pts = np.ascontiguousarray(points, dtype=np.float64)
    idx = _neighbours(pts, k)
    return _plane_normals(pts[idx] - pts[:, None, :])


def _covariance_eigen(offsets: np.ndarray, keep: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    w = keep[..., None].astype(np.float64)
    mean = (w * offsets).sum(axis=1) / w.sum(axis=1)
    centred = (offsets - mean[:, None, :]) * w
    return np.linalg.eigh(np.einsum("rka,rkb->rab", centred, centred))


def _plane_normals(offsets: np.ndarray) -> np.ndarray:
    """Unit normals (R, 3) of the planes through each point that most of its neighbours lie
    on: ``offsets`` (R, 1 + k, 3) are the neighbours minus the point (the point first).
    Where two surfaces meet (a floor along a wall), a PCA over all neighbours tilts between
    them, and a splat on such a tilted plane stands up out of the floor; here each pair of
    neighbours proposes the plane through it and the point, the plane with the most
    neighbours within ``pc.PLANE_INLIER`` of the median neighbour distance wins (the smaller
    total distance breaks ties), and a PCA over its neighbours gives the normal. On a single
    smooth surface every neighbour agrees and this is PCA."""
    nb = offsets[:, 1:, :]
    rows, k = nb.shape[:2]
    scale = np.median(np.linalg.norm(nb, axis=2), axis=1)                 # (R,)
    a, b = np.triu_indices(k, 1)
    cand = np.cross(nb[:, a], nb[:, b])                                   # (R, C, 3)
    length = np.linalg.norm(cand, axis=2)
    usable = length > 1e-6 * np.maximum(scale, 1e-300)[:, None] ** 2
    cand = cand / np.where(usable, length, 1.0)[..., None]
    dist = np.abs(np.einsum("rcx,rkx->rck", cand, nb))                    # (R, C, k)
    tol = (pc.PLANE_INLIER * scale)[:, None, None]
    inliers = np.where(usable[..., None], dist < tol, False)
    score = inliers.sum(axis=2) - np.minimum(dist, tol).sum(axis=2) / np.maximum(tol[..., 0] * k, 1e-300)
    best = np.argmax(np.where(usable, score, -np.inf), axis=1)
    keep = inliers[np.arange(rows), best]                                 # (R, k)
    weak = ~usable.any(axis=1) | (keep.sum(axis=1) < pc.PLANE_SHARE * k)
    keep = np.concatenate([np.ones((rows, 1), dtype=bool), keep], axis=1)
    # No plane stands out, or too few usable pairs (collinear neighbours): every neighbour
    # counts, as plain PCA.
    keep[weak] = True
    vals, vecs = _covariance_eigen(offsets, keep)
    # The chosen neighbours nearly on a line leave the plane free to turn about it: all count.
    thin = vals[:, 1] < pc.PLANE_SPREAD * vals[:, 2]
    if thin.any():
        vecs[thin] = _covariance_eigen(offsets[thin], np.ones(keep[thin].shape, dtype=bool))[1]
    return vecs[:, :, 0]


def pca_normals(points: np.ndarray, k: int = pc.DEFAULT_K) -> np.ndarray:
    """Unit normals (P, 3), unoriented: the smallest eigenvector of the covariance of each
    point's ``k`` nearest neighbours (itself included). Where two surfaces meet it tilts
    between them: the mean of the surfaces, which is what a vertex on a crease shows."""
    pts = np.ascontiguousarray(points, dtype=np.float64)
    nb = pts[_neighbours(pts, k)]
    centred = nb - nb.mean(axis=1, keepdims=True)
    cov = np.empty((len(pts), 3, 3))
    for a in range(3):              # six products over (P, k) beat a (P, k, 3, 3) einsum
        for b in range(a, 3):
            cov[:, a, b] = cov[:, b, a] = np.einsum("nk,nk->n", centred[:, :, a], centred[:, :, b])
    return np.linalg.eigh(cov)[1][:, :, 0]


def settled_normals(positions, normals) -> np.ndarray:
    """Each point's normal refitted as the plane through it and those of its
    ``pc.SETTLE_NEIGHBOURS`` nearest points on the same surface (normals within acos
    ``pc.SETTLE_COS``), oriented as given. A fit over all neighbours tilts beside an edge, where
    the other surface's points are among them (a block's side 6° downwards next to the floor
    it stands on): its splat, in that plane, then stands off the true surface by a tenth of
    the spacing at its far end and shadows the points along the edge. Returns (N, 3)."""
    p = np.ascontiguousarray(positions, dtype=np.float64)
    n = np.ascontiguousarray(normals, dtype=np.float64)
    if len(p) < pc.SETTLE_MIN_POINTS:
        return n
    idx, _ = _core.knn(p, p, min(pc.SETTLE_NEIGHBOURS + 1, len(p)))
    idx = np.asarray(idx)
    same = np.abs(np.einsum("ic,ikc->ik", n, n[idx])) > pc.SETTLE_COS
    plane, on_line = pc.plane_through((p[idx] - p[:, None, :]) * same[..., None])
    plane *= np.where(np.einsum("ic,ic->i", plane, n) < 0, -1.0, 1.0)[:, None]
    fit = ~on_line & (same.sum(axis=1) >= pc.SETTLE_MIN_POINTS)
    return np.where(fit[:, None], plane, n)


def splat_radii(positions, normals, areas, *, reach: float = splats.DEFAULT_REACH,
                neighbours: int = splats.DEFAULT_NEIGHBOURS, sides: int = splats.DEFAULT_SIDES,
                chunk: int = 16384) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The clipped outline of every splat: (radii (N, sides) in m along the directions
    cos θ_m u + sin θ_m v, u (N, 3), v (N, 3)), the tangent basis of each point."""
    p = np.ascontiguousarray(positions, dtype=np.float64)
    n = np.asarray(normals, dtype=np.float64)
    a = np.asarray(areas, dtype=np.float64)
    count = len(p)
    n = n / np.maximum(np.linalg.norm(n, axis=1, keepdims=True), 1e-300)
    u, v = splats._basis(n)
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
    turn = np.einsum("rc,rkc->rk", n, nq) < splats.EDGE_COS
    # Bisector with neighbours on the same surface: ρ (d·w) ≤ |w|²/2; coincident points
    # (w = 0) leave each other whole.
    limit = np.where((dw > 1e-12 * np.sqrt(half)[:, None, :] + 1e-300) & ~turn[:, None, :],
                     splats.CORNER_SLACK * half[:, None, :] / np.where(dw > 0, dw, 1.0), np.inf)
    # Directions with no neighbour within 60° lead off the scan's rim: there the splat ends at
    # the point's own radius instead of its reach. (Another surface's neighbours count: a
    # wall's splats reach down to the floor's plane, which then clips them.)
    tangential = w - np.einsum("rkc,rc->rk", w, n)[..., None] * n[:, None, :]
    length = np.linalg.norm(tangential, axis=2)
    toward = dw / np.maximum(length, 1e-300)[:, None, :]       # cos(d, neighbour), tangentially
    supported = ((toward > splats.RIM_COS) & (length > 0)[:, None, :]).any(axis=2)
    # Tangent planes where the surface turns: a splat stays on the side of each such plane
    # that its point is on, side·(x − q)·n_q ≥ 0.
    height = np.einsum("rkc,rkc->rk", -w, nq)                  # (p − q)·n_q
    on_plane = turn & (np.abs(height) <= splats.JUNCTION_TOLERANCE * np.sqrt(2.0 * half))
    # p on the plane itself (an edge's own points): the side its own surface lies on, where
    # the centroid of p and its same-surface neighbours is (whichever way either normal was
    # oriented). Unless it is a junction, where the other surface lies on both sides of p's
    # plane (a box's side on a floor that runs on under it): there nothing clips, or the
    # side's splats would lose their half above the floor.
    own = (~turn)[..., None]
    centroid = (w * own).sum(axis=1) / (own.sum(axis=1) + 1.0)             # minus p
    lean = np.einsum("rc,rkc->rk", centroid, nq) + height                 # (c − q)·n_q
    leaning = np.abs(lean) > splats.JUNCTION_TOLERANCE * np.sqrt(2.0 * half)
    # Which side of p's plane each neighbour lies on; one on the edge line itself lies on
    # neither (it would make every edge look like a junction).
    rise = np.einsum("rkc,rc->rk", w, n)
    bend = np.where(np.abs(rise) > splats.JUNCTION_TOLERANCE * np.sqrt(2.0 * half), np.sign(rise), 0.0)
    side = np.where(on_plane, np.where(leaning, np.sign(lean), 0.0), np.sign(height))
    junction = (on_plane & (bend > 0)).any(axis=1) & (on_plane & (bend < 0)).any(axis=1)
    # ... a hair beyond it: splats that end exactly on each other's planes leave a slit
    # along the edge that rays slip through (0.5% of the rays from inside a scanned box).
    g = np.maximum(side * height, 0.0) + splats.EDGE_OVERLAP * np.sqrt(2.0 * half)
    slope = side[:, None, :] * np.einsum("rmc,rkc->rmk", d, nq)
    keep = turn & (side != 0) & ~(on_plane & junction[:, None])
    applies = keep[:, None, :] & (slope < 0)
    plane = np.where(applies, g[:, None, :] / np.where(slope < 0, -slope, 1.0), np.inf)
    radius = np.minimum(limit, plane).min(axis=2)
    return np.where(supported, radius, np.minimum(radius, rim))


def splat_triangles(positions, normals, areas, **options) -> np.ndarray:
    """(N × sides, 3, 3) triangles: the splats of N points as fans about them."""
    p = np.ascontiguousarray(positions, dtype=np.float64)
    normals = settled_normals(p, normals)
    radii, u, v = splat_radii(p, normals, areas, **options)
    sides = radii.shape[1]
    theta = 2.0 * np.pi * np.arange(sides) / sides
    rim = p[:, None, :] + radii[..., None] * (np.cos(theta)[None, :, None] * u[:, None, :]
                                              + np.sin(theta)[None, :, None] * v[:, None, :])
    centre = np.broadcast_to(p[:, None, :], rim.shape)
    nxt = np.roll(rim, -1, axis=1)
    along = np.einsum("nc,nc->n", np.cross(u, v), np.asarray(normals, dtype=np.float64)) >= 0
    first = np.where(along[:, None, None], rim, nxt)
    second = np.where(along[:, None, None], nxt, rim)
    return np.stack([centre, first, second], axis=2).reshape(-1, 3, 3)


def record_weights(p, n, reach, own, rows, near, dist, accuracy, behind_slack):
    """Each receiver's records' weights (R, K) and which are valid (R, K) bool, for records
    ``near`` (R, K) at distances ``dist`` (the rule of ``_core.record_lookup``)."""
    q, nq = p[rows], n[rows]
    cos = np.einsum("rc,rkc->rk", nq, n[near])
    eps = dist / np.minimum(reach[near], own[rows, None]) + np.sqrt(np.maximum(0.0, 1.0 - cos))
    lift = np.einsum("rkc,rkc->rk", q[:, None, :] - p[near], 0.5 * (nq[:, None, :] + n[near]))
    ok = (eps < accuracy) & (lift >= -behind_slack * dist)
    return np.where(ok, 1.0 / np.maximum(eps, 1e-3 * accuracy) - 1.0 / accuracy, 0.0), ok


def record_lookup(p, n, reach, own, raw, records, rows, k, accuracy, behind_slack,
                  min_reach=0.0, far_reach=0.0):
    """``_core.record_lookup`` by brute force: each receiver's ``k`` nearest ``records`` (all
    distances sorted), their weights (zero where not valid, or where the receiver's ``raw``
    reach and the record's lie on different sides of the floor) and the count of valid ones."""
    d = np.linalg.norm(p[rows][:, None, :] - p[records][None, :, :], axis=2)
    order = np.argsort(d, axis=1, kind="stable")[:, :k]
    near, dist = records[order], np.take_along_axis(d, order, axis=1)
    w, ok = record_weights(p, n, reach, own, rows, near, dist, accuracy, behind_slack)
    if min_reach > 0:
        me, them = raw[rows][:, None], raw[near]
        ok &= ~(((me < min_reach) & (them >= far_reach)) | ((me >= far_reach) & (them < min_reach)))
        w = np.where(ok, w, 0.0)
    return near, w, ok.sum(axis=1)


def fitted_values(p, n, values, rows, near, w):
    """``_core.fitted_values``: (R, 3)."""
    q, nq, at, vals = p[rows], n[rows], p[near], values[near]
    mean = np.einsum("rk,rkc->rc", w, vals) / w.sum(axis=1)[:, None]
    helper = np.where((np.abs(nq[:, 0]) < 0.9)[:, None], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0])
    u = np.cross(nq, helper)
    u /= np.linalg.norm(u, axis=1, keepdims=True)
    v = np.cross(nq, u)
    d = at - q[:, None, :]
    scale = np.sqrt(np.einsum("rk,rkc,rkc->r", w, d, d) / w.sum(axis=1))
    scale = np.where(scale > 0, scale, 1.0)
    design = np.stack([np.ones(w.shape), np.einsum("rkc,rc->rk", d, u) / scale[:, None],
                       np.einsum("rkc,rc->rk", d, v) / scale[:, None]], axis=2)
    normal = np.einsum("rk,rki,rkj->rij", w, design, design)
    rhs = np.einsum("rk,rki,rkc->ric", w, design, vals)
    posed = (np.count_nonzero(w > 0, axis=1) >= 3) & \
        (np.linalg.eigvalsh(normal)[:, 0] > 1e-3 * w.sum(axis=1))
    out = mean.copy()
    if posed.any():
        out[posed] = np.linalg.solve(normal[posed], rhs[posed])[:, 0, :]
        valid = (w > 0)[..., None]
        low = np.where(valid, vals, np.inf).min(axis=1)
        high = np.where(valid, vals, -np.inf).max(axis=1)
        out = np.clip(out, low, high)
    return out
