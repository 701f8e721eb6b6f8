"""The numpy formulation of the lamps' shadow-ray samples (``addon.lamps._lamp_samples``)
that the native ``illumap._core.lamp_samples`` replaced, kept as an independent reference for
it."""

import numpy as np

from illumap.lights import Lamp, _basis, _disc, mesh_lamp_triangles
from illumap.refinement import LUMINANCE_WEIGHTS


def _pattern(k: int, shifts: np.ndarray) -> np.ndarray:
    """Rows of k points in [0,1)²: one rank-1 lattice (well stratified in both axes), shifted
    per row by ``shifts`` (M, 1, 2) (Cranley-Patterson rotation)."""
    base = np.column_stack([(np.arange(k) + 0.5) / k, np.mod(np.arange(k) * 0.6180339887498949, 1.0)])
    return np.mod(base[None, :, :] + shifts, 1.0)



def lamp_samples(lamp: Lamp, p: np.ndarray, n: np.ndarray, k: int, shifts: np.ndarray,
                  far: float) -> tuple[np.ndarray, np.ndarray]:
    """Sample points (M, k, 3) on ``lamp`` seen from receivers p (M, 3) and each sample's
    unshadowed weight (M, k) (relative contribution; only ratios matter); ``shifts`` (M, 1, 2)
    place each row's pattern (``row_shifts``)."""
    uv = _pattern(k, shifts)
    if lamp.kind == "WORLD":
        # Cosine-distributed directions: every sample weighs the same.
        disc = _disc(uv)
        up = np.sqrt(np.maximum(1.0 - np.einsum("mkc,mkc->mk", disc, disc), 0.0))
        u, v = _basis(n)
        dirs = disc[..., :1] * u[:, None] + disc[..., 1:] * v[:, None] + up[..., None] * n[:, None]
        return p[:, None, :] + far * dirs, np.ones(up.shape)
    if lamp.kind == "SUN":
        cone = np.tan(lamp.angle / 2) * _disc(uv)                       # (M, k, 2)
        d = np.broadcast_to(-lamp.direction, p.shape)
        u, v = _basis(d)
        dirs = d[:, None, :] + cone[..., :1] * u[:, None] + cone[..., 1:] * v[:, None]
        dirs /= np.linalg.norm(dirs, axis=2, keepdims=True)
        weight = np.maximum(np.einsum("mkc,mc->mk", dirs, n), 0.0)
        return p[:, None, :] + far * dirs, weight
    if lamp.kind == "MESH":
        # The triangles' set-up is the add-on's; the sampling below is the reference.
        mesh = mesh_lamp_triangles(lamp)
        tri = lamp.triangles
        e1, e2, nrm, cum = mesh["edge1"], mesh["edge2"], mesh["normal"], mesh["cumulative"]
        # The first coordinate picks a triangle by area (stratified) and, rescaled inside its
        # interval, places the sample in it with the second (uniform square-root map).
        t = np.minimum(np.searchsorted(cum, uv[..., 0], side="right"), len(tri) - 1)
        lo = np.where(t > 0, cum[t - 1], 0.0)
        u = np.clip((uv[..., 0] - lo) / np.maximum(cum[t] - lo, 1e-300), 0.0, 1.0)
        s = np.sqrt(u)[..., None]
        v = uv[..., 1:]
        pts = tri[t, 0] + s * (1 - v) * e1[t] + s * v * e2[t]
        d = pts - p[:, None, :]
        r2 = np.maximum(np.einsum("mkc,mkc->mk", d, d), 1e-300)
        cos_r = np.maximum(np.einsum("mkc,mc->mk", d, n), 0.0)
        cos_l = -np.einsum("mkc,mkc->mk", d, nrm[t])
        cos_l = np.abs(cos_l) if lamp.two_sided else np.maximum(cos_l, 0.0)
        power = lamp.radiance[t] @ LUMINANCE_WEIGHTS + 1e-12
        return pts, power * cos_r * cos_l / (r2 * r2)
    if lamp.kind == "AREA":
        local = _disc(uv) if lamp.shape in ("DISK", "ELLIPSE") else 2 * uv - 1
        pts = lamp.position + local[..., :1] * lamp.axes[0] + local[..., 1:] * lamp.axes[1]
        d = pts - p[:, None, :]
        r2 = np.maximum(np.einsum("mkc,mkc->mk", d, d), 1e-300)
        cos_r = np.maximum(np.einsum("mkc,mc->mk", d, n), 0.0)
        cos_l = np.maximum(-np.einsum("mkc,c->mk", d, lamp.direction), 0.0)
        return pts, cos_r * cos_l / (r2 * r2)
    # Point and spot lamps: the sphere's silhouette disc, facing the receiver.
    d = lamp.position - p
    dist = np.maximum(np.linalg.norm(d, axis=1, keepdims=True), 1e-300)
    u, v = _basis(d / dist)
    disc = lamp.radius * _disc(uv)
    pts = lamp.position + disc[..., :1] * u[:, None] + disc[..., 1:] * v[:, None]
    d = pts - p[:, None, :]
    r2 = np.maximum(np.einsum("mkc,mkc->mk", d, d), 1e-300)
    return pts, np.maximum(np.einsum("mkc,mc->mk", d, n), 0.0) / (r2 * np.sqrt(r2))

