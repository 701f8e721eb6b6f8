"""The numpy version of the preview splats' shading (illumap.splat_shading, native since):
the reference test_splat_shading.py compares the native one to."""

from __future__ import annotations

import numpy as np

from illumap.splat_shading import EDGE_COS, RIDGE, SHADING_NEIGHBOURS


def splat_shading(positions, frames: dict, values, *, neighbours: np.ndarray | None = None,
                  threads: int = 0) -> dict:
    """Each splat's linear shading (the rules above) as float32 (N, 3) arrays: ``base`` (the
    value at the ellipse's centre), ``dx`` and ``dy`` (its change per unit of the instanced
    disc's X and Y). ``positions`` (N, 3) the scan's points, ``frames`` their
    ``splats.splat_frames``, ``values`` (N, 3) or (N, 4) their light (RGB; a fourth column is
    ignored). ``neighbours`` (N, k) int: each point's nearest others, nearest first (found
    when None; ``threads`` for that search, 0: all)."""
    p = np.asarray(positions, dtype=np.float64)
    count = len(p)
    v = np.asarray(values, dtype=np.float64)
    if p.ndim != 2 or p.shape[1] != 3:
        raise ValueError(f"splat_shading: positions must be an (N, 3) array, got {p.shape}")
    if v.ndim != 2 or v.shape[0] != count or v.shape[1] not in (3, 4):
        raise ValueError(f"splat_shading: values must be ({count}, 3) or ({count}, 4), got "
                         f"{v.shape}")
    v = v[:, :3]
    flat = {"base": v.astype(np.float32), "dx": np.zeros((count, 3), np.float32),
            "dy": np.zeros((count, 3), np.float32)}
    if count < 3:
        return flat
    if neighbours is None:
        from illumap.neighbours import knn  # noqa: PLC0415 - native, loaded on use
        k = min(SHADING_NEIGHBOURS, count - 1)
        neighbours = knn(np.ascontiguousarray(p), np.ascontiguousarray(p), k + 1,
                         threads=threads)[0][:, 1:]
    idx = np.asarray(neighbours, dtype=np.int64)
    normal = np.asarray(frames["normal"], np.float64)
    axis = np.asarray(frames["axis"], np.float64)
    across = np.cross(normal, axis)
    scale = np.asarray(frames["scale"], np.float64)
    offset = np.asarray(frames["offset"], np.float64)

    d = p[idx] - p[:, None]                                         # (N, k, 3)
    same = np.abs(np.einsum("ij,ikj->ik", normal, normal[idx])) >= EDGE_COS
    s = np.einsum("ikj,ij->ik", d, axis) * same                     # along the axis
    t = np.einsum("ikj,ij->ik", d, across) * same                   # across it
    dv = (v[idx] - v[:, None]) * same[..., None]                    # (N, k, 3)
    ss, st, tt = (s * s).sum(1), (s * t).sum(1), (t * t).sum(1)
    ridge = RIDGE * (ss + tt) / np.maximum(same.sum(1), 1) + 1e-300
    ss, tt = ss + ridge, tt + ridge
    bs, bt = np.einsum("ik,ikc->ic", s, dv), np.einsum("ik,ikc->ic", t, dv)
    det = (ss * tt - st * st)[:, None]
    fitted = (same.sum(1) >= 2) & (det[:, 0] > 0)
    det = np.where(det > 0, det, 1.0)
    gs = (tt[:, None] * bs - st[:, None] * bt) / det                # per unit length along axis
    gt = (ss[:, None] * bt - st[:, None] * bs) / det
    gs[~fitted], gt[~fitted] = 0.0, 0.0

    # The limit: the function's change half-way to each neighbour, against the room left
    # above and below the point's value by the neighbourhood's range.
    own = np.where(same[..., None], v[idx], v[:, None])
    above, below = (own.max(1) - v)[:, None], (v - own.min(1))[:, None]     # (N, 1, 3)
    half = 0.5 * (gs[:, None] * s[..., None] + gt[:, None] * t[..., None])   # (N, k, 3)
    ratio = np.where(half > 0, above / np.maximum(half, 1e-300),
                     np.where(half < 0, below / np.maximum(-half, 1e-300), 1.0))
    phi = np.clip(ratio.min(1), 0.0, 1.0)
    gs, gt = phi * gs, phi * gt
    centre = v + gs * np.einsum("ij,ij->i", offset, axis)[:, None] + \
        gt * np.einsum("ij,ij->i", offset, across)[:, None]
    return {"base": centre.astype(np.float32), "dx": (gs * scale[:, :1]).astype(np.float32),
            "dy": (gt * scale[:, 1:2]).astype(np.float32)}
