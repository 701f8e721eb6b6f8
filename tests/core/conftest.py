"""Shared fixtures: an independent pure-numpy reference of the transport kernel.

The reference follows docs/architecture.md ("The kernel, exactly") line by line and builds the
dense matrix F (small N only). It checks the native direct operator and lets the solver tests
run on an operator whose every entry is known. Import them as ``illumap_core_testing``.
"""

import math
import sys

import numpy as np
import pytest

import illumap

# Test modules import these helpers as ``illumap_core_testing`` (a unique name: tests/blender has
# its own conftest.py, and both are "conftest" to Python).
sys.modules.setdefault("illumap_core_testing", sys.modules[__name__])

T0 = 16.0


def panel(origin, u, v, nu, nv, normal):
    """Midpoint grid on origin + s u + t v (s, t in [0, 1]) with a constant normal."""
    origin, u, v = (np.asarray(a, float) for a in (origin, u, v))
    s = (np.arange(nu) + 0.5) / nu
    t = (np.arange(nv) + 0.5) / nv
    S, T = np.meshgrid(s, t, indexing="ij")
    P = origin + S.reshape(-1, 1) * u + T.reshape(-1, 1) * v
    A = np.full(nu * nv, np.linalg.norm(np.cross(u, v)) / (nu * nv))
    return P, np.tile(np.asarray(normal, float), (nu * nv, 1)), A


POLYGON_SIDES = 8


def _tangent_basis(m):
    """Orthonormal (u, v) per unit normal m (P×3), from the axis least aligned with m."""
    a = np.abs(m)
    e = np.zeros_like(m)
    ex = (a[:, 0] <= a[:, 1]) & (a[:, 0] <= a[:, 2])
    ey = ~ex & (a[:, 1] <= a[:, 2])
    e[ex, 0] = 1.0
    e[ey, 1] = 1.0
    e[~ex & ~ey, 2] = 1.0
    u = np.cross(m, e)
    u /= np.linalg.norm(u, axis=1, keepdims=True)
    return u, np.cross(m, u)


def point_to_polygon(x, n, c, m, area):
    """Form factor from points x (normals n) to regular octagons of area ``area`` centred at c
    with normals m, clipped to each receiver's front half-space (Lambert's formula)."""
    k = POLYGON_SIDES
    radius = np.sqrt(2.0 * area / (k * math.sin(2.0 * math.pi / k)))
    u, v = _tangent_basis(m)
    angles = 2.0 * math.pi * np.arange(k) / k
    verts = (c[:, None, :] + radius[:, None, None] * (np.cos(angles)[None, :, None] * u[:, None, :]
             + np.sin(angles)[None, :, None] * v[:, None, :])) - x[:, None, :]
    h = np.einsum("pk,pvk->pv", n, verts)
    nxt = np.roll(np.arange(k), -1)
    keep = h > 0
    cross = keep != keep[:, nxt]
    s = h / np.where(cross, h - h[:, nxt], 1.0)
    inter = verts + s[:, :, None] * (verts[:, nxt] - verts)
    # Interleave (vertex k, intersection on edge k) and compact the kept ones in order.
    cand = np.stack([verts, inter], axis=2).reshape(len(x), 2 * k, 3)
    mask = np.stack([keep, cross], axis=2).reshape(len(x), 2 * k)
    order = np.argsort(~mask, axis=1, kind="stable")
    cand = np.take_along_axis(cand, order[:, :, None], axis=1)
    count = mask.sum(axis=1)
    idx = np.arange(2 * k)[None, :]
    valid = idx < count[:, None]
    nxt_idx = np.where(idx + 1 < count[:, None], idx + 1, 0)
    b = np.take_along_axis(cand, nxt_idx[:, :, None], axis=1)
    w = np.cross(cand, b)
    lw = np.linalg.norm(w, axis=2)
    term = np.where(valid & (lw > 0), np.arctan2(lw, np.einsum("pvk,pvk->pv", cand, b))
                    * np.einsum("pk,pvk->pv", n, w) / np.where(lw > 0, lw, 1.0), 0.0)
    f = np.minimum(1.0, np.abs(term.sum(axis=1)) / (2.0 * math.pi))
    front = np.einsum("pk,pk->p", m, x - c) > 0
    return np.where(front & (count >= 3), f, 0.0)


def polygon_weight(t):
    """Blend of the "disc" rule: 1 up to t0, linear to 0 at 2 t0."""
    return np.clip(2.0 - np.asarray(t) / T0, 0.0, 1.0)


def reference_matrix(positions, normals, areas, near_field="disc", rows=None):
    """Dense F[i, j] for the receivers ``rows`` (all by default): the bare point kernel, and
    with near_field="disc", for close facing pairs (π r² ≤ 2 t0 Ā), the symmetrized
    point-to-octagon rule; where a row's close pairs sum above 1 they are scaled back to 1,
    symmetrically (docs/architecture.md)."""
    positions = np.asarray(positions, dtype=np.float64)
    normals = np.asarray(normals, dtype=np.float64)
    areas = np.asarray(areas, dtype=np.float64)
    if near_field not in ("disc", "point"):
        raise ValueError(near_field)
    d = positions[:, None, :] - positions[None, :, :]          # r_i − r_j
    r2 = np.einsum("ijk,ijk->ij", d, d)
    r = np.sqrt(r2)
    safe = np.where(r > 0, r, 1.0)
    cos_i = -np.einsum("ik,ijk->ij", normals, d) / safe
    cos_j = np.einsum("jk,ijk->ij", normals, d) / safe
    f = areas[None, :] * np.maximum(cos_i, 0) * np.maximum(cos_j, 0) / (
        math.pi * np.where(r > 0, r2, 1.0))
    f = np.where(r > 0, f, 0.0)
    if near_field == "disc":
        t = math.pi * r2 / (0.5 * (areas[:, None] + areas[None, :]))
        close = (t <= 2 * T0) & (f > 0) & (cos_i > 1e-9) & (cos_j > 1e-9)
        ii, jj = np.nonzero(close)
        p = positions
        f_ij = point_to_polygon(p[ii], normals[ii], p[jj], normals[jj], areas[jj])
        f_ji = point_to_polygon(p[jj], normals[jj], p[ii], normals[ii], areas[ii])
        g = 0.5 * (areas[ii] * f_ij + areas[jj] * f_ji)
        w = polygon_weight(t[ii, jj])
        f[ii, jj] = (1.0 - w) * f[ii, jj] + w * g / areas[ii]
        close_sums = np.where(close, f, 0.0).sum(axis=1)
        gamma = 1.0 / np.maximum(close_sums, 1.0)
        f[ii, jj] *= np.minimum(gamma[ii], gamma[jj])
    return f if rows is None else f[np.asarray(rows)]


class ReferenceOperator:
    """Dense numpy operator with TransportOperator's interface (apply, symmetric, stats)."""

    def __init__(self, surfels, near_field="disc"):
        self.surfels = surfels
        self.n = surfels.n
        self.near_field = near_field
        self.F = reference_matrix(surfels.positions, surfels.normals, surfels.areas, near_field)
        self.symmetric = True
        self.stats = {"method": "numpy-reference", "near_field": near_field, "n": self.n}
        self.calls = 0

    def apply(self, values, progress=None):
        self.calls += 1
        return self.F @ np.asarray(values, dtype=np.float64)


requires_native = pytest.mark.skipif(not illumap.native_available(),
                                     reason="illumap._core (native module) not built")


def make_operator(kind, surfels, near_field="disc", **keywords):
    """kind: "reference" (numpy), "direct" or "fmm" (native)."""
    if kind == "reference":
        return ReferenceOperator(surfels, near_field)
    if not illumap.native_available():
        pytest.skip("illumap._core (native module) not built")
    return illumap.TransportOperator(surfels, method=kind, near_field=near_field, **keywords)
